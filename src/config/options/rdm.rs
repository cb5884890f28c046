//! `rdm[=R|auto]` and `rdm-nofill`: radial density masking's radius and
//! its fill ([`crate::view::rdm`]).

use super::{flag, optional, Entry, Technique};
use crate::config::{RenderConfig, DEFAULT_RDM_RADIUS};
use crate::error::{Error, Result};

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "Radial density masking",
    page: "rdm",
    summary: "skips every other 2×2 quad in the periphery and fills it from its neighbours",
    options: &[optional("rdm", "R|auto", "0.4"), flag("rdm-nofill")],
    parse,
    print,
    rules: &[],
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    match (e.name, e.value) {
        ("rdm-nofill", _) => {
            c.rdm = Some(c.rdm.unwrap_or(DEFAULT_RDM_RADIUS));
            c.rdm_fill = false;
        }
        (_, None) => c.rdm = Some(c.rdm.unwrap_or(DEFAULT_RDM_RADIUS)),
        (_, Some("auto")) => {
            c.rdm = Some(DEFAULT_RDM_RADIUS);
            c.rdm_auto = true;
        }
        (_, Some(v)) => match v.parse::<f32>() {
            Ok(r) if r.is_finite() && r > 0.0 && r < 1.5 => {
                c.rdm = Some(r);
                c.rdm_auto = false;
            }
            _ => {
                return Err(Error::config(
                    "--opt",
                    format!(
                        "'{}': expected rdm=R with 0 < R < 1.5 (NDC radius) or rdm=auto",
                        e.item
                    ),
                ))
            }
        },
    }
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    match (c.rdm_auto, c.rdm) {
        (true, _) => out.push("rdm=auto".into()),
        (false, Some(r)) => out.push(format!("rdm={r}")),
        (false, None) => return,
    }
    if !c.rdm_fill {
        out.push("rdm-nofill".into());
    }
}
