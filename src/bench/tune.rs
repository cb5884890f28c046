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
/// The inset comes at the default wide-view scale (0.5 per axis) and at
/// 0.7, between it and the full resolution: twice the wide view's pixels
/// for less of its blur, for scenes whose fine detail puts the default
/// over an error cap over the whole image. The `-taa` stacks accumulate
/// the wide views over frames (`inset-taa`): the one-sample wide views
/// shimmer less than the plain inset's and cost one compute pass more.
/// The last adds the CPU-free culling with LOD at the 0.7 scale.
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
    ("gpu-cull", "multiview,msaa4,superfrustum,gpu-cull"),
    (
        "gpu-cull-occlusion-lod",
        "multiview,msaa4,superfrustum,gpu-cull,occlusion,lod",
    ),
    ("stencil-aq", "multiview,msaa4,superfrustum,stencil-mask,aq"),
    ("inset", "multiview,msaa4,superfrustum,inset"),
    (
        "stencil-inset",
        "multiview,msaa4,superfrustum,stencil-mask,inset",
    ),
    (
        "inset-wide-1x",
        "multiview,msaa4,superfrustum,inset,inset-wide-1x",
    ),
    ("inset-0.7", "multiview,msaa4,superfrustum,inset=0.7"),
    (
        "inset-0.7-wide-1x",
        "multiview,msaa4,superfrustum,inset=0.7,inset-wide-1x",
    ),
    ("inset-taa", "multiview,msaa4,superfrustum,inset,inset-taa"),
    (
        "inset-wide-1x-taa",
        "multiview,msaa4,superfrustum,inset,inset-wide-1x,inset-taa",
    ),
    (
        "inset-0.7-wide-1x-taa",
        "multiview,msaa4,superfrustum,inset=0.7,inset-wide-1x,inset-taa",
    ),
    (
        "inset-1.0-wide-1x-taa",
        "multiview,msaa4,superfrustum,inset=1.0,inset-wide-1x,inset-taa",
    ),
    (
        "inset-wide-1x-taau",
        "multiview,msaa4,superfrustum,inset,inset-wide-1x,inset-taau",
    ),
    (
        "inset-0.7-wide-1x-taau",
        "multiview,msaa4,superfrustum,inset=0.7,inset-wide-1x,inset-taau",
    ),
    (
        "inset-wide-1x-sharpen",
        "multiview,msaa4,superfrustum,inset,inset-wide-1x,inset-sharpen",
    ),
    (
        "inset-0.7-wide-1x-sharpen",
        "multiview,msaa4,superfrustum,inset=0.7,inset-wide-1x,inset-sharpen",
    ),
    (
        "inset-wide-1x-sharpen-lanczos",
        "multiview,msaa4,superfrustum,inset,inset-wide-1x,inset-sharpen,inset-taau-lanczos",
    ),
    (
        "inset-0.7-wide-1x-sharpen-lanczos",
        "multiview,msaa4,superfrustum,inset=0.7,inset-wide-1x,inset-sharpen,inset-taau-lanczos",
    ),
    (
        "inset-0.65-wide-1x-sharpen-lanczos",
        "multiview,msaa4,superfrustum,inset=0.65,inset-wide-1x,inset-sharpen,inset-taau-lanczos",
    ),
    (
        "inset-0.6-wide-1x-sharpen-lanczos",
        "multiview,msaa4,superfrustum,inset=0.6,inset-wide-1x,inset-sharpen,inset-taau-lanczos",
    ),
    (
        "inset-gpu-cull-lod",
        "multiview,msaa4,superfrustum,gpu-cull,lod,inset",
    ),
    (
        "inset-gpu-cull-lod-wide-1x",
        "multiview,msaa4,superfrustum,gpu-cull,lod,inset,inset-wide-1x",
    ),
    (
        "inset-0.7-gpu-cull-lod-wide-1x-taa",
        "multiview,msaa4,superfrustum,gpu-cull,lod,inset=0.7,inset-wide-1x,inset-taa",
    ),
];

/// What to tune for. A candidate whose image error was not measured
/// qualifies under neither rule: its error is unknown, not zero.
#[derive(Clone, Debug)]
pub struct TuneGoal {
    /// Frame budget in ms: the measured wall-clock frame interval p95 of
    /// the loop `run` uses (frames in flight as configured) must not exceed
    /// it.
    pub budget_ms: f64,
    /// Error cap: FLIP mean must not exceed it; then the fastest wins.
    pub max_flip: Option<f64>,
    /// Temporal error cap (`--max-flicker`): a candidate whose flicker
    /// (`bench::flicker`) exceeds it, or was not measured, is left out.
    pub max_flicker: Option<FlickerCap>,
    /// `--foveated`: the caps and the ranking use the foveated error and
    /// flicker (`flip_foveated_mean`, `flicker_foveated`) instead of the
    /// uniform ones.
    pub foveated: bool,
}

/// A temporal error cap: a number, or whatever the `baseline` candidate
/// measured (`--max-flicker baseline`: no worse than the baseline, which
/// means something against a supersampled reference, where the baseline's
/// own aliasing counts; against a reference that renders the baseline's
/// pixels, the baseline scores 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FlickerCap {
    /// At most this flicker.
    Value(f64),
    /// At most the `baseline` candidate's measured flicker.
    Baseline,
}

/// `--max-flicker`: `baseline` or a number in [0, 1e6].
pub fn parse_flicker_cap(s: &str) -> std::result::Result<FlickerCap, String> {
    if s == "baseline" {
        return Ok(FlickerCap::Baseline);
    }
    crate::cli::parse_non_negative(s)
        .map(FlickerCap::Value)
        .map_err(|e| format!("{e}, or baseline"))
}

/// The cap in numbers: `baseline` resolved against the measured
/// candidates (an error when the baseline's flicker was not measured).
fn flicker_cap(cap: Option<FlickerCap>, cands: &[&ConfigResult]) -> Result<Option<f64>> {
    match cap {
        None => Ok(None),
        Some(FlickerCap::Value(v)) => Ok(Some(v)),
        Some(FlickerCap::Baseline) => cands
            .iter()
            .find(|r| r.name == "baseline")
            .and_then(|r| r.flicker)
            .map(Some)
            .ok_or_else(|| {
                Error::config(
                    "--max-flicker",
                    "baseline: the baseline candidate's flicker was not measured",
                )
            }),
    }
}

/// The bench plan `tune` measures; `budget_ms` is the budget `aq`
/// candidates hold their frames to (None: the profile's refresh period).
/// `reference_supersample` renders the reference at that many times the
/// eye size per axis (the plan field of that name).
pub fn plan(
    scene: &str,
    hmd: &str,
    (scale, reference_supersample): (f64, u32),
    frames: u32,
    budget_ms: Option<f64>,
) -> Plan {
    Plan {
        base: None,
        name: "tune".into(),
        scenes: vec![scene.to_string()],
        hmds: vec![hmd.to_string()],
        scales: vec![scale],
        // GPUs ramp their clocks and drivers finish pipelines over the first
        // frames: p95 needs a real warm-up.
        warmup: (frames / 2).clamp(10, 60),
        spin_up_ms: 500,
        flicker_frames: 6,
        budget_ms,
        frames,
        error_frames: frames.min(2),
        path_seed: 1,
        path_seeds: Vec::new(),
        gaze: super::plan::GazeKind::Centre,
        gaze_latency_ms: 0.0,
        path: super::plan::PathKind::Walk,
        reference: "two-pass,msaa4".into(),
        reference_supersample,
        baseline: Some("baseline".into()),
        frames_in_flight: crate::config::RenderConfig::default()
            .submission
            .frames_in_flight,
        repeats: 1,
        configs: CANDIDATES
            .iter()
            .map(|(n, o)| PlanConfig {
                name: n.to_string(),
                opt: o.to_string(),
                frames_in_flight: None,
                record_threads: None,
                per_draw: None,
            })
            .collect(),
    }
}

/// The choice as the reports show it.
pub fn summary(choice: &Choice, goal: &TuneGoal) -> super::runner::TuneChoice {
    super::runner::TuneChoice {
        name: choice.chosen.name.clone(),
        opt: choice.chosen.opt.clone(),
        budget_ms: goal.budget_ms,
        max_flip: goal.max_flip,
        max_flicker: goal.max_flicker.map(|c| match c {
            FlickerCap::Value(v) => v.to_string(),
            FlickerCap::Baseline => "the baseline's".to_string(),
        }),
        rule: match (goal.max_flip.is_some(), goal.foveated) {
            (true, false) => "the fastest within the budget and the caps",
            (true, true) => {
                "the fastest within the budget and the caps on the foveated FLIP and flicker"
            }
            (false, false) => "the least FLIP error within the budget",
            (false, true) => "the least foveated FLIP error within the budget",
        }
        .to_string(),
        why: choice.why.clone(),
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

/// The measured FLIP mean; None when the error was not measured.
fn flip(r: &ConfigResult) -> Option<f64> {
    r.error.map(|e| e.flip_mean)
}

/// The FLIP mean for the user: the number, or that it is unknown.
fn flip_text(r: &ConfigResult) -> String {
    flip(r).map_or_else(|| "unknown (not measured)".into(), |f| format!("{f:.4}"))
}

/// Picks from measured candidates (the reference excluded): within the
/// budget, the least FLIP mean (ties: the faster), or under an error cap
/// the fastest. Candidates without a measured error are left out and say
/// so. Errors when none qualifies, naming the fastest.
pub fn choose(results: &BenchResults, goal: &TuneGoal) -> Result<Choice> {
    if goal.foveated {
        let mut choice = choose_in(&foveated_view(results), goal)?;
        // The chosen candidate's own figures, uniform and foveated.
        if let Some(own) = results.groups.iter().flat_map(|g| &g.results).find(|r| {
            r.name == choice.chosen.name && r.wall_frame_ms == choice.chosen.wall_frame_ms
        }) {
            choice.chosen = own.clone();
        }
        choice
            .why
            .insert(0, "errors judged where the eye looks: FLIP and flicker below are the foveated ones (flip_foveated_mean, flicker_foveated)".into());
        return Ok(choice);
    }
    choose_in(results, goal)
}

/// `results` with each candidate's FLIP mean and flicker replaced by their
/// foveated values (absent where those were not measured).
fn foveated_view(results: &BenchResults) -> BenchResults {
    let mut view = results.clone();
    for r in view.groups.iter_mut().flat_map(|g| g.results.iter_mut()) {
        r.error = r.error.and_then(|e| {
            Some(super::runner::ImageError {
                flip_mean: e.flip_foveated_mean?,
                ..e
            })
        });
        r.flicker = r.flicker_foveated;
    }
    view
}

/// [`choose`] on the figures as given.
fn choose_in(results: &BenchResults, goal: &TuneGoal) -> Result<Choice> {
    let groups = &results.groups;
    if groups.is_empty() {
        return Err(Error::config("tune", "nothing was measured"));
    }
    let per = groups
        .iter()
        .map(|g| qualify(g, goal))
        .collect::<Result<Vec<_>>>()?;
    let several = per.len() > 1;
    let mut why = Vec::new();
    for (g, q) in groups.iter().zip(&per) {
        if several {
            why.push(format!("head path seed {}:", g.path_seed));
        }
        why.extend(q.why.iter().cloned());
    }
    if several {
        why.push(format!(
            "measured on {} head paths (seeds {}); a candidate qualifies only if it does on every one, and is judged by its worst",
            per.len(),
            groups.iter().map(|g| g.path_seed.to_string()).collect::<Vec<_>>().join(", ")
        ));
    }
    // Per candidate qualifying on every path: its worst result (the
    // slowest) and its worst error.
    let worst: Vec<(&ConfigResult, f64)> = per[0]
        .ok
        .iter()
        .filter_map(|(first, _)| {
            let on: Vec<&(&ConfigResult, f64)> = per
                .iter()
                .filter_map(|q| q.ok.iter().find(|(r, _)| r.name == first.name))
                .collect();
            (on.len() == per.len()).then(|| {
                let slowest = on.iter().map(|(r, _)| *r).max_by(|a, b| faster(a, b))?;
                let flip = on.iter().map(|(_, f)| *f).fold(f64::NEG_INFINITY, f64::max);
                Some((slowest, flip))
            })?
        })
        .collect();
    let chosen = if goal.max_flip.is_some() {
        worst.iter().min_by(|a, b| faster(a.0, b.0))
    } else {
        worst
            .iter()
            .min_by(|a, b| a.1.total_cmp(&b.1).then(faster(a.0, b.0)))
    };
    match chosen {
        Some((c, _)) => Ok(Choice {
            chosen: (*c).clone(),
            why,
        }),
        None => Err(nothing_qualifies(&per[0], goal, &why)),
    }
}

/// Faster by the measured wall-clock frame interval's p95 (what `run`
/// sustains, frames in flight included).
fn faster(a: &ConfigResult, b: &ConfigResult) -> std::cmp::Ordering {
    a.wall_frame_ms.p95.total_cmp(&b.wall_frame_ms.p95)
}

/// One path's candidates judged against the goal.
struct Qualified<'a> {
    /// Every candidate but the reference.
    cands: Vec<&'a ConfigResult>,
    /// Those within the budget and the caps, with their FLIP mean.
    ok: Vec<(&'a ConfigResult, f64)>,
    /// Why, one line per candidate.
    why: Vec<String>,
    /// The flicker cap as the user reads it (None: no cap).
    cap_text: Option<String>,
}

/// `group`'s candidates against `goal`.
fn qualify<'a>(group: &'a super::runner::Group, goal: &TuneGoal) -> Result<Qualified<'a>> {
    let cands: Vec<&ConfigResult> = group
        .results
        .iter()
        .filter(|r| r.name != "reference")
        .collect();
    // The measured wall-clock interval of the loop `run` uses (frames in
    // flight included) is what `run` sustains.
    let fits = |r: &ConfigResult| r.wall_frame_ms.p95 <= goal.budget_ms;
    let max_flicker = flicker_cap(goal.max_flicker, &cands)?;
    // The cap as the user reads it, to a millionth: flicker near the
    // baseline's differs in its third significant digit.
    let cap_text = |m: f64| match goal.max_flicker {
        Some(FlickerCap::Baseline) => format!("{m:.6} (the baseline's)"),
        _ => format!("{m}"),
    };
    let why = cands
        .iter()
        .map(|r| why_line(r, goal, max_flicker, &cap_text))
        .collect();
    // Within the budget and the cap, with a measured error.
    let ok = cands
        .iter()
        .copied()
        .filter(|r| fits(r) && r.not_applied().is_none())
        .filter_map(|r| Some((r, flip(r)?)))
        .filter(|&(_, f)| goal.max_flip.is_none_or(|m| f <= m))
        .filter(|&(r, _)| max_flicker.is_none_or(|m| r.flicker.is_some_and(|f| f <= m)))
        .collect();
    Ok(Qualified {
        cands,
        ok,
        why,
        cap_text: max_flicker.map(cap_text),
    })
}

/// One candidate's line of the reasons.
fn why_line(
    r: &ConfigResult,
    goal: &TuneGoal,
    max_flicker: Option<f64>,
    cap_text: &dyn Fn(f64) -> String,
) -> String {
    let fits = r.wall_frame_ms.p95 <= goal.budget_ms;
    format!(
        "{:24} wall frame p95 {:8.3} ms {} budget {:.3}; FLIP mean {}{}",
        r.name,
        r.wall_frame_ms.p95,
        if fits { "within" } else { "over  " },
        goal.budget_ms,
        flip_text(r),
        match (r.not_applied(), flip(r), goal.max_flip) {
            (Some(why), ..) => format!(" — not applied here: {why}, so it is left out"),
            (None, None, _) => ", so it is left out".to_string(),
            (None, Some(f), Some(m)) if f > m => format!(" over the cap {m}"),
            _ => String::new(),
        } + &match (r.flicker, max_flicker) {
            (_, None) => String::new(),
            (None, Some(_)) => "; flicker not measured, so it is left out".to_string(),
            (Some(f), Some(m)) if f > m => {
                format!("; flicker {f:.6} over the cap {}", cap_text(m))
            }
            (Some(f), Some(_)) => format!("; flicker {f:.6}"),
        }
    )
}

/// The error when no candidate qualifies, naming the fastest of the first
/// path, the goal and every reason.
fn nothing_qualifies(first: &Qualified, goal: &TuneGoal, why: &[String]) -> Error {
    let fastest = first
        .cands
        .iter()
        .min_by(|a, b| faster(a, b))
        .map(|r| {
            format!(
                "{} at {:.3} ms, FLIP {}",
                r.name,
                r.wall_frame_ms.p95,
                flip_text(r)
            )
        })
        .unwrap_or_default();
    Error::config(
        "tune",
        format!(
            "no candidate meets a {:.3} ms budget{} (fastest: {fastest})\n{}",
            goal.budget_ms,
            goal.max_flip
                .map(|m| format!(" with FLIP mean ≤ {m}"))
                .unwrap_or_default()
                + &first
                    .cap_text
                    .as_ref()
                    .map(|m| format!(" and flicker ≤ {m}"))
                    .unwrap_or_default(),
            why.join("\n")
        ),
    )
}

/// The config file text for `choice`: `opt` plus the measurements as
/// comments.
pub fn config_file(choice: &Choice, goal: &TuneGoal, results: &BenchResults) -> String {
    let c = &choice.chosen;
    let mut s = String::new();
    let _ = writeln!(s, "# Written by vergence tune on {}.", results.device);
    let foveated = c.error.and_then(|e| e.flip_foveated_mean);
    let _ = writeln!(
        s,
        "# Budget {:.3} ms{}; chosen '{}': wall-clock frame p95 {:.3} ms, GPU p50 {:.3} ms, FLIP mean {}{}.",
        goal.budget_ms,
        goal.max_flip
            .map(|m| format!(", {}FLIP cap {m}", if goal.foveated { "foveated " } else { "" }))
            .unwrap_or_default(),
        c.name,
        c.wall_frame_ms.p95,
        c.gpu_frame_ms.p50,
        flip_text(c),
        foveated
            .filter(|_| goal.foveated)
            .map(|f| format!(", foveated FLIP mean {f:.4}"))
            .unwrap_or_default()
    );
    let _ = writeln!(s, "# Use: vergence run --config THIS_FILE");
    let _ = writeln!(s, "opt = {:?}", c.opt);
    s
}

pub use crate::config::ConfigFile;

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
    fn foveated_caps_judge_the_error_where_the_eye_looks() {
        let mut r = results();
        // "fast" is over a 0.02 cap uniformly (0.04) but under it foveated.
        for c in &mut r.groups[0].results {
            if let Some(e) = c.error.as_mut() {
                e.flip_foveated_mean = Some(e.flip_mean / 4.0);
            }
        }
        let mut g = goal(10.0, Some(0.02));
        assert_eq!(choose(&r, &g).unwrap().chosen.name, "mid");
        g.foveated = true;
        let c = choose(&r, &g).unwrap();
        assert_eq!(c.chosen.name, "fast");
        // The chosen candidate keeps its own uniform figure.
        assert_eq!(c.chosen.error.unwrap().flip_mean, 0.04);
        assert!(c.why[0].contains("foveated"));
        // Without a foveated error a candidate is left out.
        for c in &mut r.groups[0].results {
            if let Some(e) = c.error.as_mut() {
                e.flip_foveated_mean = None;
            }
        }
        assert!(choose(&r, &g).is_err());
    }

    #[test]
    fn on_several_paths_a_candidate_must_qualify_on_each_and_is_judged_by_its_worst() {
        let mut r = results();
        let mut second = r.groups[0].clone();
        r.groups[0].path_seed = 1;
        second.path_seed = 5;
        // On the second path "fast" shows more error than the cap allows,
        // and "mid" is slower than on the first (but within the budget).
        for c in &mut second.results {
            match c.name.as_str() {
                "fast" => c.error.as_mut().unwrap().flip_mean = 0.08,
                "mid" => c.wall_frame_ms.p95 = 9.5,
                _ => {}
            }
        }
        r.groups.push(second);
        let goal = goal(10.0, Some(0.05));
        // On the first path alone, "fast" wins.
        let one = BenchResults {
            groups: vec![r.groups[0].clone()],
            ..BenchResults::default()
        };
        assert_eq!(choose(&one, &goal).unwrap().chosen.name, "fast");
        let c = choose(&r, &goal).unwrap();
        assert_eq!(c.chosen.name, "mid");
        // Its worst path's figures.
        assert_eq!(c.chosen.wall_frame_ms.p95, 9.5);
        assert!(c
            .why
            .iter()
            .any(|w| w.starts_with("measured on 2 head paths (seeds 1, 5)")));
        assert!(c.why.iter().any(|w| w == "head path seed 5:"));
    }

    #[test]
    fn budget_picks_least_error_that_fits() {
        let goal = TuneGoal {
            budget_ms: 10.0,
            max_flip: None,
            max_flicker: None,
            foveated: false,
        };
        assert_eq!(choose(&results(), &goal).unwrap().chosen.name, "mid");
    }

    #[test]
    fn cap_picks_fastest_under_it() {
        let goal = TuneGoal {
            budget_ms: 10.0,
            max_flip: Some(0.05),
            max_flicker: None,
            foveated: false,
        };
        let c = choose(&results(), &goal).unwrap();
        assert_eq!(c.chosen.name, "fast");
        assert!(config_file(&c, &goal, &results()).contains("opt = \"opt-fast\""));
    }

    fn with(extra: Vec<ConfigResult>) -> BenchResults {
        let mut r = results();
        r.groups[0].results.extend(extra);
        r
    }

    fn goal(budget_ms: f64, max_flip: Option<f64>) -> TuneGoal {
        TuneGoal {
            budget_ms,
            max_flip,
            max_flicker: None,
            foveated: false,
        }
    }

    #[test]
    fn a_technique_that_fell_back_is_never_chosen() {
        // Foveation asked for, but the device had no shading-rate
        // attachment: it rendered as the baseline, with its error, and
        // would otherwise win on least error within the budget.
        let mut fell = result("foveation-medium", 4.0, Some(0.0));
        fell.opt = "multiview,foveation=medium".into();
        fell.renderer.foveation =
            "off: lavapipe offers no VK_KHR_fragment_shading_rate attachment".into();
        let r = with(vec![fell.clone()]);
        let c = choose(&r, &goal(10.0, None)).unwrap();
        assert_eq!(c.chosen.name, "mid");
        let line = c
            .why
            .iter()
            .find(|l| l.starts_with("foveation-medium"))
            .unwrap();
        assert!(
            line.contains("not applied here: foveation fell back"),
            "{line}"
        );
        // Where foveation ran it is a candidate like any other.
        fell.renderer.foveation = "vk-khr-fragment-shading-rate (16x16 texels)".into();
        let c = choose(&with(vec![fell]), &goal(10.0, None)).unwrap();
        assert_eq!(c.chosen.name, "foveation-medium");
    }

    #[test]
    fn unmeasured_error_passes_no_cap_and_is_reported_unknown() {
        // Fastest of all and within any budget, but its error is unknown:
        // counted as 0.0 it would win both rules.
        let r = with(vec![result("unmeasured", 2.0, None)]);
        let c = choose(&r, &goal(10.0, Some(0.05))).unwrap();
        assert_eq!(c.chosen.name, "fast");
        let line = c.why.iter().find(|l| l.starts_with("unmeasured")).unwrap();
        assert!(
            line.contains("FLIP mean unknown (not measured)") && line.contains("left out"),
            "{line}"
        );
        assert_eq!(choose(&r, &goal(10.0, None)).unwrap().chosen.name, "mid");
        // Only unmeasured candidates within the budget: nothing qualifies.
        let e = choose(&r, &goal(2.5, Some(1.0))).unwrap_err().to_string();
        assert!(
            e.contains("fastest: unmeasured at 2.000 ms, FLIP unknown (not measured)"),
            "{e}"
        );
    }

    #[test]
    fn equal_error_goes_to_the_faster() {
        let r = with(vec![result("mid-faster", 8.0, Some(0.01))]);
        assert_eq!(
            choose(&r, &goal(10.0, None)).unwrap().chosen.name,
            "mid-faster"
        );
    }

    #[test]
    fn budget_and_cap_are_inclusive() {
        // p95 exactly on the budget fits; FLIP exactly on the cap passes.
        assert_eq!(
            choose(&results(), &goal(5.0, Some(0.04)))
                .unwrap()
                .chosen
                .name,
            "fast"
        );
        assert_eq!(
            choose(&results(), &goal(9.0, None)).unwrap().chosen.name,
            "mid"
        );
    }

    #[test]
    fn the_reference_is_never_chosen() {
        // The reference is the fastest and, given an error, within every
        // limit here.
        let mut r = results();
        r.groups[0].results[0].error = Some(ImageError::default());
        let e = choose(&r, &goal(2.0, None)).unwrap_err().to_string();
        assert!(e.contains("fastest: fastest at 3.000 ms"), "{e}");
    }

    #[test]
    fn a_flicker_cap_leaves_out_what_shimmers_and_what_was_not_measured() {
        // Under the FLIP cap "fast" wins; capping flicker leaves it out
        // (too much) and "fastest" too (not measured), so "mid" wins.
        let mut r = results();
        for c in &mut r.groups[0].results {
            c.flicker = match c.name.as_str() {
                "fast" => Some(0.02),
                "mid" => Some(0.004),
                _ => None,
            };
        }
        let goal = TuneGoal {
            budget_ms: 10.0,
            max_flip: Some(0.05),
            max_flicker: Some(FlickerCap::Value(0.01)),
            foveated: false,
        };
        let c = choose(&r, &goal).unwrap();
        assert_eq!(c.chosen.name, "mid");
        let line = c.why.iter().find(|l| l.starts_with("fast ")).unwrap();
        assert!(
            line.contains("flicker 0.020000 over the cap 0.01"),
            "{line}"
        );
        let capped = TuneGoal {
            max_flicker: Some(FlickerCap::Value(0.001)),
            foveated: false,
            ..goal
        };
        let e = choose(&r, &capped).unwrap_err().to_string();
        assert!(e.contains("and flicker ≤ 0.001"), "{e}");
    }

    #[test]
    fn a_baseline_flicker_cap_is_the_baseline_candidates_measure() {
        // Candidates as results() gives them, with a "baseline" among
        // them: under the FLIP cap "fast" (flicker above the baseline's)
        // is left out and "mid" (equal to it) qualifies.
        let mut r = results();
        r.groups[0]
            .results
            .push(result("baseline", 20.0, Some(0.0)));
        for c in &mut r.groups[0].results {
            c.flicker = match c.name.as_str() {
                "fast" => Some(0.0031),
                "mid" | "baseline" => Some(0.003),
                "fastest" => Some(0.0),
                _ => None,
            };
        }
        let goal = TuneGoal {
            budget_ms: 10.0,
            max_flip: Some(0.05),
            max_flicker: Some(FlickerCap::Baseline),
            foveated: false,
        };
        let c = choose(&r, &goal).unwrap();
        assert_eq!(c.chosen.name, "mid");
        let line = c.why.iter().find(|l| l.starts_with("fast ")).unwrap();
        assert!(
            line.contains("flicker 0.003100 over the cap 0.003000 (the baseline's)"),
            "{line}"
        );
        // Unmeasured baseline flicker: an error, not a silent 0.
        for c in &mut r.groups[0].results {
            if c.name == "baseline" {
                c.flicker = None;
            }
        }
        let e = choose(&r, &goal).unwrap_err().to_string();
        assert!(
            e.contains("baseline candidate's flicker was not measured"),
            "{e}"
        );
    }

    #[test]
    fn flicker_caps_parse() {
        assert_eq!(parse_flicker_cap("baseline"), Ok(FlickerCap::Baseline));
        assert_eq!(parse_flicker_cap("0.002"), Ok(FlickerCap::Value(0.002)));
        for bad in ["-1", "nan", "base", ""] {
            let e = parse_flicker_cap(bad).unwrap_err();
            assert!(e.contains("or baseline"), "{bad}: {e}");
        }
    }

    #[test]
    fn impossible_budget_is_an_error_naming_the_fastest() {
        let goal = TuneGoal {
            budget_ms: 1.0,
            max_flip: None,
            max_flicker: None,
            foveated: false,
        };
        let e = choose(&results(), &goal).unwrap_err().to_string();
        assert!(
            e.contains("no candidate meets") && e.contains("fastest: fastest"),
            "{e}"
        );
    }
}
