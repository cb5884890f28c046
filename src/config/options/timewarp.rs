//! `timewarp=K` and its variants: frames warped to newer poses and
//! measured ([`crate::render::timewarp`]).

use super::{flag, required, Entry, Rule, Technique};
use crate::config::{RenderConfig, Timewarp, TimewarpVariant, MAX_TIMEWARP_K};
use crate::error::{Error, Result};

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "Timewarp, measured",
    page: "timewarp",
    summary: "warps frames to newer poses offline and measures the error against rendering them",
    options: &[
        required("timewarp", "K", "2"),
        flag("timewarp-rotation"),
        flag("timewarp-fill"),
    ],
    parse,
    print,
    rules: &[Rule::always(
        |c| c.simulator.timewarp.is_some() && (c.culling.occlusion || c.effort.mffr.is_some()),
        "timewarp cannot be combined with occlusion or mffr (both use the frame's depth images for their own passes)",
    )],
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    let mut t = c.simulator.timewarp.unwrap_or(Timewarp {
        k: 2,
        variant: TimewarpVariant::Depth,
    });
    match (e.name, e.value) {
        ("timewarp-rotation", _) => t.variant = TimewarpVariant::Rotation,
        ("timewarp-fill", _) => t.variant = TimewarpVariant::Fill,
        (_, v) => match v.unwrap_or_default().parse::<u32>() {
            Ok(k) if (2..=MAX_TIMEWARP_K).contains(&k) => t.k = k,
            _ => {
                return Err(Error::config(
                    "--opt",
                    format!(
                        "'{}': expected timewarp=K with 2 <= K <= {MAX_TIMEWARP_K} (render every K-th frame)",
                        e.item
                    ),
                ))
            }
        },
    }
    c.simulator.timewarp = Some(t);
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    let Some(t) = c.simulator.timewarp else {
        return;
    };
    out.push(format!("timewarp={}", t.k));
    match t.variant {
        TimewarpVariant::Rotation => out.push("timewarp-rotation".into()),
        TimewarpVariant::Fill => out.push("timewarp-fill".into()),
        TimewarpVariant::Depth => {}
    }
}
