//! `resolved-sky`: the sky drawn once per pixel after the resolve
//! ([`crate::render::passes`]).

use super::{flag, Entry, Technique};
use crate::config::RenderConfig;
use crate::error::Result;

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "Sky after the resolve",
    page: "resolved-sky",
    summary: "draws the sky once per pixel under the resolved 4× image",
    options: &[flag("resolved-sky")],
    parse,
    print,
};

fn parse(c: &mut RenderConfig, _: &Entry) -> Result<()> {
    c.resolved_sky = true;
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    if c.resolved_sky {
        out.push("resolved-sky".into());
    }
}
