//! `aq` and `aq-scale-only`: adaptive quality ([`crate::targets`]'s
//! controller moves the render scale).

use super::{flag, Entry, Rule, Technique};
use crate::config::RenderConfig;
use crate::error::Result;

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "Adaptive quality",
    page: "aq",
    summary: "moves the render scale (and the inset's periphery) to hold the frame budget",
    options: &[flag("aq"), flag("aq-scale-only")],
    parse,
    print,
    rules: &[
        Rule {
            when: |c| c.effort.aq,
            with: &[("timewarp", |c| c.simulator.timewarp.is_some())],
            message: "aq changes the rendered size every frame; {} sizes its images once for the full size: leave it out with aq",
        },
        Rule::always(
            |c| c.effort.aq_scale_only && !(c.effort.aq && c.effort.inset.is_some()),
            "aq-scale-only leaves out aq's inset rung, which only aq with inset has: give aq and inset with it, or leave it out",
        ),
    ],
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    match e.name {
        "aq" => c.effort.aq = true,
        _ => c.effort.aq_scale_only = true,
    }
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    if c.effort.aq {
        out.push("aq".into());
    }
    if c.effort.aq_scale_only {
        out.push("aq-scale-only".into());
    }
}
