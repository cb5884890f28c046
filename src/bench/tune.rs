//! `vergence tune`: measures candidate optimization stacks on one scene and
//! headset and picks the one that fits the frame budget with the least
//! image error (or, under an error cap, the fastest), then writes it as a
//! config file `run --config` and `render --config` accept.

use super::plan::{Plan, PlanConfig};
use super::runner::{BenchResults, ConfigResult};
use crate::error::{Error, Result};
use std::fmt::Write as _;

/// Candidate stacks, from the naive baseline to the full stack. Each names
/// its stereo mode and MSAA explicitly so the written file is complete.
pub const CANDIDATES: &[(&str, &str)] = &[
    ("baseline", "two-pass,msaa4,per-eye"),
    ("multiview", "multiview,msaa4,superfrustum"),
    ("stencil", "multiview,msaa4,superfrustum,stencil-mask"),
    (
        "stencil-fov-low",
        "multiview,msaa4,superfrustum,stencil-mask,foveation=low",
    ),
    (
        "stencil-fov-medium",
        "multiview,msaa4,superfrustum,stencil-mask,foveation=medium",
    ),
    (
        "stencil-fov-high",
        "multiview,msaa4,superfrustum,stencil-mask,foveation=high",
    ),
    (
        "stencil-mffr",
        "multiview,msaa4,superfrustum,stencil-mask,mffr",
    ),
    (
        "stencil-fov-medium-mffr",
        "multiview,msaa4,superfrustum,stencil-mask,foveation=medium,mffr",
    ),
    (
        "full-stack",
        "multiview,msaa4,superfrustum,stencil-mask,foveation=high,mffr",
    ),
    (
        "full-stack-rdm",
        "multiview,msaa4,superfrustum,stencil-mask,foveation=high,mffr,rdm",
    ),
    (
        "full-stack-1x",
        "multiview,no-msaa,superfrustum,stencil-mask,foveation=high,mffr",
    ),
];

/// What to tune for.
#[derive(Clone, Debug)]
pub struct TuneGoal {
    /// Frame budget in ms: the measured wall-clock frame interval p95 of
    /// the loop `run` uses (frames in flight as configured) must not exceed
    /// it.
    pub budget_ms: f64,
    /// Error cap: FLIP mean must not exceed it; then the fastest wins.
    pub max_flip: Option<f64>,
}

/// The bench plan `tune` measures.
pub fn plan(scene: &str, hmd: &str, scale: f64, frames: u32) -> Plan {
    Plan {
        name: "tune".into(),
        scenes: vec![scene.to_string()],
        hmds: vec![hmd.to_string()],
        scales: vec![scale],
        // GPUs ramp their clocks and drivers finish pipelines over the first
        // frames: p95 needs a real warm-up.
        warmup: (frames / 2).clamp(10, 60),
        frames,
        error_frames: frames.min(2),
        path_seed: 1,
        reference: "two-pass,msaa4".into(),
        baseline: Some("baseline".into()),
        frames_in_flight: crate::config::RenderConfig::default().frames_in_flight,
        configs: CANDIDATES
            .iter()
            .map(|(n, o)| PlanConfig {
                name: n.to_string(),
                opt: o.to_string(),
                frames_in_flight: None,
            })
            .collect(),
    }
}

/// The choice and the reasoning, as lines for the user.
#[derive(Clone, Debug)]
pub struct Choice {
    /// The chosen candidate.
    pub chosen: ConfigResult,
    /// Why, one line per candidate.
    pub why: Vec<String>,
}

fn flip(r: &ConfigResult) -> f64 {
    r.error.map_or(0.0, |e| e.flip_mean)
}

/// Picks from measured candidates (the reference excluded). Errors when
/// none qualifies, naming the closest.
pub fn choose(results: &BenchResults, goal: &TuneGoal) -> Result<Choice> {
    let group = results
        .groups
        .first()
        .ok_or_else(|| Error::config("tune", "nothing was measured"))?;
    let cands: Vec<&ConfigResult> = group
        .results
        .iter()
        .filter(|r| r.name != "reference")
        .collect();
    // vergence's loop waits for each frame, so the wall-clock time is what
    // `run` sustains.
    let fits = |r: &ConfigResult| r.wall_frame_ms.p95 <= goal.budget_ms;
    let capped = |r: &ConfigResult| goal.max_flip.is_none_or(|m| flip(r) <= m);
    let mut why = Vec::new();
    for r in &cands {
        why.push(format!(
            "{:24} wall frame p95 {:8.3} ms {} budget {:.3}; FLIP mean {:.4}{}",
            r.name,
            r.wall_frame_ms.p95,
            if fits(r) { "within" } else { "over  " },
            goal.budget_ms,
            flip(r),
            match goal.max_flip {
                Some(m) if flip(r) > m => format!(" over the cap {m}"),
                _ => String::new(),
            }
        ));
    }
    let ok: Vec<&ConfigResult> = cands
        .iter()
        .copied()
        .filter(|r| fits(r) && capped(r))
        .collect();
    let chosen = if goal.max_flip.is_some() {
        ok.iter()
            .min_by(|a, b| a.wall_frame_ms.p95.total_cmp(&b.wall_frame_ms.p95))
    } else {
        ok.iter().min_by(|a, b| {
            flip(a)
                .total_cmp(&flip(b))
                .then(a.wall_frame_ms.p95.total_cmp(&b.wall_frame_ms.p95))
        })
    };
    match chosen {
        Some(c) => Ok(Choice {
            chosen: (*c).clone(),
            why,
        }),
        None => {
            let fastest = cands
                .iter()
                .min_by(|a, b| a.wall_frame_ms.p95.total_cmp(&b.wall_frame_ms.p95))
                .map(|r| {
                    format!(
                        "{} at {:.3} ms, FLIP {:.4}",
                        r.name,
                        r.wall_frame_ms.p95,
                        flip(r)
                    )
                })
                .unwrap_or_default();
            Err(Error::config(
                "tune",
                format!(
                    "no candidate meets a {:.3} ms budget{} (fastest: {fastest})\n{}",
                    goal.budget_ms,
                    goal.max_flip
                        .map(|m| format!(" with FLIP mean ≤ {m}"))
                        .unwrap_or_default(),
                    why.join("\n")
                ),
            ))
        }
    }
}

/// The config file text for `choice`: `opt` plus the measurements as
/// comments.
pub fn config_file(choice: &Choice, goal: &TuneGoal, results: &BenchResults) -> String {
    let c = &choice.chosen;
    let mut s = String::new();
    let _ = writeln!(s, "# Written by vergence tune on {}.", results.device);
    let _ = writeln!(
        s,
        "# Budget {:.3} ms{}; chosen '{}': wall-clock frame p95 {:.3} ms, GPU p50 {:.3} ms, FLIP mean {:.4}.",
        goal.budget_ms,
        goal.max_flip
            .map(|m| format!(", FLIP cap {m}"))
            .unwrap_or_default(),
        c.name,
        c.wall_frame_ms.p95,
        c.gpu_frame_ms.p50,
        flip(c)
    );
    let _ = writeln!(s, "# Use: vergence run --config THIS_FILE");
    let _ = writeln!(s, "opt = {:?}", c.opt);
    s
}

/// A config file as `tune` writes it.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConfigFile {
    /// The `--opt` list.
    pub opt: String,
}

impl ConfigFile {
    /// Reads and checks a config file.
    pub fn load(path: &std::path::Path) -> Result<ConfigFile> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::config("--config", format!("{}: {e}", path.display())))?;
        let file: ConfigFile = toml::from_str(&text).map_err(|e| {
            Error::config("--config", format!("{}: {}", path.display(), e.message()))
        })?;
        super::plan::config_from_opt(&file.opt)
            .map_err(|e| Error::config("--config", format!("{}: {e}", path.display())))?;
        Ok(file)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::runner::{Group, ImageError};
    use crate::stats::Summary;

    fn result(name: &str, p95: f64, flip: Option<f64>) -> ConfigResult {
        ConfigResult {
            name: name.into(),
            opt: format!("opt-{name}"),
            wall_frame_ms: Summary {
                p95,
                ..Summary::default()
            },
            error: flip.map(|f| ImageError {
                flip_mean: f,
                ..ImageError::default()
            }),
            ..ConfigResult::default()
        }
    }

    fn results() -> BenchResults {
        BenchResults {
            groups: vec![Group {
                results: vec![
                    result("reference", 1.0, None),
                    result("slow-exact", 20.0, Some(0.0)),
                    result("mid", 9.0, Some(0.01)),
                    result("fast", 5.0, Some(0.04)),
                    result("fastest", 3.0, Some(0.2)),
                ],
                ..Group::default()
            }],
            ..BenchResults::default()
        }
    }

    #[test]
    fn budget_picks_least_error_that_fits() {
        let goal = TuneGoal {
            budget_ms: 10.0,
            max_flip: None,
        };
        assert_eq!(choose(&results(), &goal).unwrap().chosen.name, "mid");
    }

    #[test]
    fn cap_picks_fastest_under_it() {
        let goal = TuneGoal {
            budget_ms: 10.0,
            max_flip: Some(0.05),
        };
        let c = choose(&results(), &goal).unwrap();
        assert_eq!(c.chosen.name, "fast");
        assert!(config_file(&c, &goal, &results()).contains("opt = \"opt-fast\""));
    }

    #[test]
    fn impossible_budget_is_an_error_naming_the_fastest() {
        let goal = TuneGoal {
            budget_ms: 1.0,
            max_flip: None,
        };
        let e = choose(&results(), &goal).unwrap_err().to_string();
        assert!(
            e.contains("no candidate meets") && e.contains("fastest: fastest"),
            "{e}"
        );
    }
}
