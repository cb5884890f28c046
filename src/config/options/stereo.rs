//! `multiview` and `two-pass`: both eyes in one multiview scope or one
//! scope per eye (the renderer's scopes in [`crate::render`]).

use super::{flag, Entry, Technique};
use crate::config::{RenderConfig, StereoMode};
use crate::error::Result;

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "Multiview / two-pass",
    page: "multiview",
    summary: "both eyes in one multiview rendering scope (the default), or one scope per eye",
    options: &[flag("multiview"), flag("two-pass")],
    parse,
    print,
    rules: &[],
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    c.frame.stereo = match e.name {
        "two-pass" => StereoMode::TwoPass,
        _ => StereoMode::Multiview,
    };
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    out.push(c.frame.stereo.name().into());
}
