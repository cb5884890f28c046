//! `aq` and `aq-scale-only`: adaptive quality ([`crate::targets`]'s
//! controller moves the render scale).

use super::{flag, Entry, Technique};
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
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    match e.name {
        "aq" => c.aq = true,
        _ => c.aq_scale_only = true,
    }
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    if c.aq {
        out.push("aq".into());
    }
    if c.aq_scale_only {
        out.push("aq-scale-only".into());
    }
}
