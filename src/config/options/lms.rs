//! `lms[=K]` and `lms-emulated`: lens-matched shading
//! ([`crate::view::lms`]).

use super::{flag, optional, Entry, Rule, Technique};
use crate::config::RenderConfig;
use crate::error::Result;

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "Lens-matched shading",
    page: "lms",
    summary: "renders each quadrant with a clip-space w scaling that matches the lens's falling pixel density",
    options: &[optional("lms", "K", "0.25"), flag("lms-emulated")],
    parse,
    print,
    rules: &[Rule {
        when: |c| c.effort.lms.is_some(),
        with: &[
            ("mffr", |c| c.effort.mffr.is_some()),
            ("occlusion", |c| c.culling.occlusion),
            ("inset", |c| c.effort.inset.is_some()),
            ("timewarp", |c| c.simulator.timewarp.is_some()),
            ("--record-threads", |c| c.submission.record_threads.is_some()),
        ],
        message: "lms draws each eye per quadrant into a smaller, non-rectilinear image and resamples it; {} works on the rectilinear eye image: leave it out with lms",
    }],
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    let mut l = c.effort.lms.unwrap_or_default();
    if e.name == "lms-emulated" {
        l.emulated = true;
    } else if e.value.is_some() {
        let range = (0.0, crate::view::lms::MAX_COEFFICIENT);
        let what = "the clip-space w scaling coefficient of every side";
        l.coefficient = Some(e.number(range, "K", what)?);
    }
    c.effort.lms = Some(l);
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    let Some(l) = c.effort.lms else { return };
    out.push(match l.coefficient {
        Some(k) => format!("lms={k}"),
        None => "lms".into(),
    });
    if l.emulated {
        out.push("lms-emulated".into());
    }
}
