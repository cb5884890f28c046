//! The culling strategies (`none`, `superfrustum`, ...): their names come
//! from [`crate::cull::Strategy`], not from declarations here.

use super::{Entry, Technique, CULLING_PAGE};
use crate::config::RenderConfig;
use crate::error::{Error, Result};

/// The declaration (its options are the strategies' names).
pub const TECHNIQUE: Technique = Technique {
    title: "Stereo culling on the CPU",
    page: CULLING_PAGE,
    summary: "culls both eyes against one combined frustum (or the alternatives) over a BVH",
    options: &[],
    parse,
    print,
    rules: &[],
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    c.culling.cull = e
        .item
        .parse()
        .map_err(|m| Error::config("--opt", format!("{m}")))?;
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    out.push(c.culling.cull.name().into());
}
