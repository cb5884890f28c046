//! `points-budget=N`, `point-size=PX`, `points-pipeline` and `edl[=S]`:
//! point-cloud rendering ([`crate::render::passes::points`]).

use super::{flag, optional, required, Entry, Rule, Technique};
use crate::config::{RenderConfig, DEFAULT_EDL_STRENGTH, DEFAULT_POINTS_BUDGET};
use crate::error::Result;

/// The declaration.
pub const TECHNIQUE: Technique = Technique {
    title: "Point-cloud rendering",
    page: "points",
    summary: "compute rasterization of an octree-chosen point budget, composited with the meshes; eye-dome lighting",
    options: &[
        required("points-budget", "N", "5000"),
        required("point-size", "PX", "3"),
        flag("points-pipeline"),
        optional("edl", "S", "1.5"),
    ],
    parse,
    print,
    rules: &[Rule::always(
        |c| c.points.edl.is_some() && c.points.points_pipeline,
        "edl shades the compute rasterizer's pixels by their neighbours' depths; points-pipeline draws points without them: leave one out",
    )],
};

fn parse(c: &mut RenderConfig, e: &Entry) -> Result<()> {
    match (e.name, e.value) {
        ("points-pipeline", _) => c.points.points_pipeline = true,
        ("edl", None) => c.points.edl = Some(DEFAULT_EDL_STRENGTH),
        ("edl", Some(_)) => {
            c.points.edl = Some(e.number((0.01, 10.0), "S", "the eye-dome lighting's strength")?)
        }
        ("point-size", _) => {
            c.points.point_size = e.number((1.0, 16.0), "PX", "a point's side in pixels at 2 m")?
        }
        _ => {
            let max = crate::scene::points::MAX_POINTS as f64;
            c.points.points_budget = e.number((1.0, max), "N", "points drawn per frame")? as u64;
        }
    }
    Ok(())
}

fn print(c: &RenderConfig, out: &mut Vec<String>) {
    if c.points.points_pipeline {
        out.push("points-pipeline".into());
    }
    if let Some(s) = c.points.edl {
        out.push(if s == DEFAULT_EDL_STRENGTH {
            "edl".into()
        } else {
            format!("edl={s}")
        });
    }
    if c.points.point_size != 1.0 {
        out.push(format!("point-size={}", c.points.point_size));
    }
    if c.points.points_budget != DEFAULT_POINTS_BUDGET {
        out.push(format!("points-budget={}", c.points.points_budget));
    }
}
