//! `msaa4` (the default) and `no-msaa`: the sample count of every scope.

use super::{flag, Entry, Technique};
use crate::config::RenderConfig;
use crate::error::Result;

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "MSAA and the raster floor",
    page: "msaa",
    summary:
        "4× (the default) or one sample; what an empty frame costs and the parts vergence skips",
    options: &[flag("msaa4"), flag("msaa"), flag("no-msaa")],
    parse,
    print,
    rules: &[],
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    c.frame.msaa = if e.name == "no-msaa" { 1 } else { 4 };
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    out.push(
        if c.frame.msaa == 1 {
            "no-msaa"
        } else {
            "msaa4"
        }
        .into(),
    );
}
