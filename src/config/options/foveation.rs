//! `foveation[=LEVEL]` and `gaze=X:Y`: the shading-rate pattern of
//! [`crate::view::foveation`] and where it is centred.

use super::{optional, required, Entry, Technique};
use crate::config::RenderConfig;
use crate::error::{Error, Result};
use crate::view::foveation::Level;

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "Foveated shading",
    page: "foveation",
    summary: "coarser shading rate away from the gaze (VK_KHR_fragment_shading_rate)",
    options: &[
        optional("foveation", "off|low|medium|high|auto", "high"),
        required("gaze", "X:Y", "0.25:-0.5"),
    ],
    parse,
    print,
    rules: &[],
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    match (e.name, e.value) {
        ("foveation", None) => c.effort.foveation = Level::Medium,
        ("foveation", Some(v)) => {
            c.effort.foveation = v.parse().map_err(|m: String| Error::config("--opt", m))?
        }
        (_, v) => c.effort.gaze = gaze(e.item, v.unwrap_or_default())?,
    }
    Ok(())
}

/// `gaze=X:Y`'s two NDC coordinates, each within -1..1.
fn gaze(item: &str, v: &str) -> Result<[f32; 2]> {
    let xy: Vec<f32> = v
        .split(':')
        .map(|x| x.trim().parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| {
            Error::config(
                "--opt",
                format!("'{item}': expected gaze=X:Y in NDC (-1..1)"),
            )
        })?;
    match xy.as_slice() {
        [x, y] if x.abs() <= 1.0 && y.abs() <= 1.0 => Ok([*x, *y]),
        _ => Err(Error::config(
            "--opt",
            format!("'{item}': expected gaze=X:Y with both within -1..1"),
        )),
    }
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    let level = match c.effort.foveation {
        Level::Off => None,
        Level::Low => Some("low"),
        Level::Medium => Some("medium"),
        Level::High => Some("high"),
        Level::Lens(_) => Some("auto"),
    };
    if let Some(l) = level {
        out.push(format!("foveation={l}"));
    }
    if c.effort.gaze != [0.0, 0.0] {
        out.push(format!("gaze={}:{}", c.effort.gaze[0], c.effort.gaze[1]));
    }
}
