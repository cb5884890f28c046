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
            c.effort.rdm = Some(c.effort.rdm.unwrap_or(DEFAULT_RDM_RADIUS));
            c.effort.rdm_fill = false;
        }
        (_, None) => c.effort.rdm = Some(c.effort.rdm.unwrap_or(DEFAULT_RDM_RADIUS)),
        (_, Some("auto")) => {
            c.effort.rdm = Some(DEFAULT_RDM_RADIUS);
            c.effort.rdm_auto = true;
        }
        (_, Some(v)) => match v.parse::<f32>() {
            Ok(r) if r.is_finite() && r > 0.0 && r < 1.5 => {
                c.effort.rdm = Some(r);
                c.effort.rdm_auto = false;
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
    match (c.effort.rdm_auto, c.effort.rdm) {
        (true, _) => out.push("rdm=auto".into()),
        (false, Some(r)) => out.push(format!("rdm={r}")),
        (false, None) => return,
    }
    if !c.effort.rdm_fill {
        out.push("rdm-nofill".into());
    }
}
