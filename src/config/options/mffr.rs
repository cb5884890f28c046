//! `mffr[=D]` and its variants: the monoscopic far field
//! ([`crate::view::mffr`]).

use super::{flag, optional, Entry, Technique};
use crate::config::{Mffr, RenderConfig, MAX_MFFR_SPLIT_M, MIN_MFFR_SPLIT_M};
use crate::error::{Error, Result};

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "Monoscopic far field",
    page: "mffr",
    summary: "renders what lies beyond a disparity of one pixel once, for both eyes",
    options: &[
        optional("mffr", "D", "12.5"),
        flag("mffr-depth-shift"),
        flag("mffr-alternate-eye"),
        flag("mffr-no-split"),
    ],
    parse,
    print,
    rules: &[],
};

/// The variants' flags, each with its name.
fn flags(m: &mut Mffr) -> [(&'static str, &mut bool); 3] {
    [
        ("mffr-depth-shift", &mut m.depth_shift),
        ("mffr-alternate-eye", &mut m.alternate_eye),
        ("mffr-no-split", &mut m.no_split),
    ]
}

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    let m = c.effort.mffr.get_or_insert_with(Mffr::default);
    if let Some(v) = e.value {
        match v.parse::<f64>() {
            Ok(d) if d.is_finite() && (MIN_MFFR_SPLIT_M..=MAX_MFFR_SPLIT_M).contains(&d) => {
                m.split = Some(d)
            }
            _ => {
                return Err(Error::config(
                    "--opt",
                    format!(
                        "'{}': expected mffr=D with D in [{MIN_MFFR_SPLIT_M}, {MAX_MFFR_SPLIT_M}] metres",
                        e.item
                    ),
                ))
            }
        }
    }
    for (name, on) in flags(m) {
        *on |= name == e.name;
    }
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    let Some(mut m) = c.effort.mffr else { return };
    out.push(match m.split {
        Some(d) => format!("mffr={d}"),
        None => "mffr".into(),
    });
    for (name, on) in flags(&mut m) {
        if *on {
            out.push(name.into());
        }
    }
}
