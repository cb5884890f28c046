//! `stencil-mask`: the hidden-area mesh in the stencil (see
//! [`crate::render::passes`]).

use super::{flag, Entry, Technique};
use crate::config::RenderConfig;
use crate::error::Result;

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "HMD stencil mask",
    page: "stencil-mask",
    summary: "never shades the pixels the lenses hide",
    options: &[flag("stencil-mask")],
    parse,
    print,
    rules: &[],
};

fn parse(c: &mut RenderConfig, _: &Entry) -> Result<()> {
    c.effort.stencil_mask = true;
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    if c.effort.stencil_mask {
        out.push("stencil-mask".into());
    }
}
