//! The report tables and text shared by `report.md` (the `report` module)
//! and `report.html` (the `html` module): group titles, the main and
//! per-pass tables, the target lines and the run's facts.

use super::runner::{BenchResults, ConfigResult, Group};

/// Title line of a group.
pub fn group_title(g: &Group) -> String {
    format!(
        "{} ({} instances) · {} · scale {} ({}×{} per eye, {:.2} ms budget at {} Hz) · head path seed {}",
        g.scene,
        g.instances,
        g.hmd,
        g.scale,
        g.resolution[0],
        g.resolution[1],
        1000.0 / g.refresh_hz,
        g.refresh_hz,
        g.path_seed
    )
}

/// Across head paths: per scene, profile and scale measured along several
/// path seeds, each configuration's GPU speed-up range and its worst
/// (largest) error and flicker over the paths, uniform and foveated. Empty
/// when no group has siblings on other paths.
pub fn spread_rows(results: &BenchResults) -> Vec<(String, Vec<Vec<String>>)> {
    let key = |g: &Group| (g.scene.clone(), g.hmd.clone(), g.scale.to_bits());
    let mut keys = Vec::new();
    for g in &results.groups {
        if !keys.contains(&key(g)) {
            keys.push(key(g));
        }
    }
    let mut out = Vec::new();
    for k in keys {
        let groups: Vec<&Group> = results.groups.iter().filter(|g| key(g) == k).collect();
        if groups.len() < 2 {
            continue;
        }
        let seeds: Vec<String> = groups.iter().map(|g| g.path_seed.to_string()).collect();
        let title = format!(
            "{} · {} · scale {} over head path seeds {}",
            k.0,
            k.1,
            groups[0].scale,
            seeds.join(", ")
        );
        let rows = groups[0]
            .results
            .iter()
            .filter(|r| r.name != "reference")
            .map(|r| {
                let on: Vec<&ConfigResult> = groups
                    .iter()
                    .filter_map(|g| g.results.iter().find(|x| x.name == r.name))
                    .collect();
                spread_row(&r.name, &on, groups.len())
            })
            .collect();
        out.push((title, rows));
    }
    out
}

/// Header of [`spread_rows`]' tables.
pub const SPREAD_HEAD: [&str; 7] = [
    "config",
    "paths",
    "GPU speed-up (least–most)",
    "FLIP mean (worst)",
    "FLIP foveated (worst)",
    "flicker (worst)",
    "flicker foveated (worst)",
];

/// One configuration's row of [`spread_rows`] from its results `on` the
/// paths (of `paths` measured).
fn spread_row(name: &str, on: &[&ConfigResult], paths: usize) -> Vec<String> {
    let worst = |get: &dyn Fn(&ConfigResult) -> Option<f64>| -> String {
        let v: Vec<f64> = on.iter().filter_map(|r| get(r)).collect();
        if v.is_empty() {
            "–".into()
        } else {
            let m = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if m < 0.01 {
                format!("{m:.6}")
            } else {
                format!("{m:.4}")
            }
        }
    };
    let speedups: Vec<f64> = on.iter().filter_map(|r| r.gpu_speedup).collect();
    let speed = match (
        speedups.iter().copied().reduce(f64::min),
        speedups.iter().copied().reduce(f64::max),
    ) {
        (Some(lo), Some(hi)) => format!("{lo:.2}–{hi:.2}×"),
        _ => "–".into(),
    };
    vec![
        name.to_string(),
        format!("{}/{paths}", on.len()),
        speed,
        worst(&|r| r.error.as_ref().map(|e| e.flip_mean)),
        worst(&|r| r.error.as_ref().and_then(|e| e.flip_foveated_mean)),
        worst(&|r| r.flicker),
        worst(&|r| r.flicker_foveated),
    ]
}

fn pct_change(v: f64, base: f64) -> String {
    if base > 0.0 {
        format!("{:+.1} %", (v / base - 1.0) * 100.0)
    } else {
        "–".into()
    }
}

/// The main table of a group: one row per configuration.
pub fn group_rows(g: &Group) -> (Vec<&'static str>, Vec<Vec<String>>) {
    let head = vec![
        "config",
        "GPU ms p50",
        "GPU speed-up",
        "frame ms p50 / p99",
        "over budget / 2×",
        "CPU ms cull / record / submit",
        "draws",
        "triangles",
        "fragments (vs baseline)",
        "FLIP mean",
        "FLIP foveated",
        "FLIP p99",
        "PSNR dB",
        "SSIM",
        "cull FP / FN",
    ];
    let base_frag = g
        .results
        .iter()
        .find(|r| r.name == g.baseline)
        .and_then(|r| r.fragment_invocations);
    let rows = g
        .results
        .iter()
        .map(|r| {
            let e = r.error.as_ref();
            vec![
                match r.not_applied() {
                    Some(_) => format!("{} (`{}`) — not applied", r.name, r.opt),
                    None => format!("{} (`{}`)", r.name, r.opt),
                },
                r.gpu_p50_text(),
                r.gpu_speedup_text(),
                format!(
                    "{:.3} / {:.3} ({} in flight)",
                    r.wall_frame_ms.p50, r.wall_frame_ms.p99, r.frames_in_flight
                ),
                format!("{} / {}", r.frames_over_budget, r.frames_over_2x_budget),
                format!(
                    "{:.3} / {:.3} / {:.3}",
                    r.cpu_ms.cull, r.cpu_ms.record, r.cpu_ms.submit
                ),
                format!("{:.0}", r.draw_calls),
                format!("{:.0}", r.triangles),
                match (r.fragment_invocations, base_frag) {
                    (Some(f), Some(b)) => format!("{f:.0} ({})", pct_change(f, b)),
                    (Some(f), None) => format!("{f:.0}"),
                    _ => "n/a".into(),
                },
                e.map_or("ref".into(), |e| format!("{:.4}", e.flip_mean)),
                e.map_or("ref".into(), |e| {
                    e.flip_foveated_mean
                        .map_or("–".into(), |v| format!("{v:.4}"))
                }),
                e.map_or("ref".into(), |e| format!("{:.4}", e.flip_p99)),
                e.map_or("ref".into(), |e| {
                    if e.psnr_db >= 100.0 {
                        "∞".into()
                    } else {
                        format!("{:.2}", e.psnr_db)
                    }
                }),
                e.map_or("ref".into(), |e| format!("{:.4}", e.ssim)),
                r.cull_accuracy.map_or("–".into(), |a| {
                    format!("{:.1} / {:.1}", a.false_positives, a.false_negatives)
                }),
            ]
        })
        .collect();
    (head, rows)
}

/// Per-pass GPU ms: pass names and one row per configuration.
pub fn pass_rows(g: &Group) -> (Vec<String>, Vec<Vec<String>>) {
    let mut passes: Vec<String> = Vec::new();
    for r in &g.results {
        for p in r.gpu_ms.keys() {
            if !passes.contains(p) {
                passes.push(p.clone());
            }
        }
    }
    let rows = g
        .results
        .iter()
        .map(|r| {
            std::iter::once(r.name.clone())
                .chain(
                    passes
                        .iter()
                        .map(|p| r.gpu_ms.get(p).map_or("–".into(), |v| format!("{v:.3}"))),
                )
                .collect()
        })
        .collect();
    (passes, rows)
}

/// The fixed thresholds a group is checked against its baseline (written
/// to `checks.md`, not to the reports): the
/// config named `full-stack` (≥ 2.5× lower GPU frame time at FLIP mean
/// ≤ 0.05) and the config named `inset` (≥ 2× at FLIP mean ≤ 0.01 inside
/// the inset and ≤ 0.05 over the lens-visible image), one line per config
/// present; and, where the baseline's flicker was measured, the fastest
/// configuration at FLIP mean ≤ 0.01 and flicker no worse than the
/// baseline's (≥ 3×: what `tune --max-flip 0.01 --max-flicker baseline`
/// looks for, judged here by GPU time).
pub fn target_lines(g: &Group) -> Vec<String> {
    let Some(base) = g.results.iter().find(|r| r.name == g.baseline) else {
        return Vec::new();
    };
    let speedup = |r: &ConfigResult| base.gpu_frame_ms.p50 / r.gpu_frame_ms.p50.max(1e-9);
    let verdict = |met: bool| if met { "met" } else { "not met" };
    let mut out = Vec::new();
    if let Some(full) = g.results.iter().find(|r| r.name == "full-stack") {
        let (s, flip) = (speedup(full), full.error.map_or(0.0, |e| e.flip_mean));
        out.push(format!(
            "Target (full stack vs {}: ≥ 2.5× lower GPU frame time at FLIP mean ≤ 0.05): {s:.2}× at FLIP {flip:.4} — {}",
            g.baseline,
            verdict(s >= 2.5 && flip <= 0.05)
        ));
    }
    if let Some(inset) = g.results.iter().find(|r| r.name == "inset") {
        let s = speedup(inset);
        let flip = inset.error.map_or(0.0, |e| e.flip_mean);
        let inside = inset.error.and_then(|e| e.flip_inset_mean);
        let inside_text = inside.map_or("not measured".into(), |f| format!("{f:.4}"));
        let met = s >= 2.0 && flip <= 0.05 && inside.is_some_and(|f| f <= 0.01);
        out.push(format!(
            "Target (inset vs {}: ≥ 2× lower GPU frame time at FLIP mean ≤ 0.01 inside the inset and ≤ 0.05 over the image): {s:.2}× at FLIP {inside_text} inside, {flip:.4} over the image — {}",
            g.baseline,
            verdict(met)
        ));
    }
    if let Some(cap) = base.flicker {
        let qualifies = |r: &&ConfigResult| {
            r.name != g.baseline
                && r.not_applied().is_none()
                && r.error.is_some_and(|e| e.flip_mean <= 0.01)
                && r.flicker.is_some_and(|f| f <= cap)
        };
        let best = g
            .results
            .iter()
            .filter(qualifies)
            .max_by(|a, b| speedup(a).total_cmp(&speedup(b)));
        let head = format!(
            "Target (the fastest configuration at FLIP mean ≤ 0.01 and flicker ≤ {}'s {cap:.6}: ≥ 3× lower GPU frame time)",
            g.baseline
        );
        out.push(match best {
            Some(r) => {
                let (s, flip) = (speedup(r), r.error.map_or(0.0, |e| e.flip_mean));
                format!(
                    "{head}: {} {s:.2}× at FLIP {flip:.4}, flicker {:.6} — {}",
                    r.name,
                    r.flicker.unwrap_or(0.0),
                    verdict(s >= 3.0)
                )
            }
            None => format!("{head}: no configuration qualifies — not met"),
        });
    }
    out
}

/// The FLIP mean inside the inset, per configuration that has one: rows
/// of config, FLIP inside, FLIP over the image.
pub fn inset_rows(g: &Group) -> Vec<[String; 3]> {
    g.results
        .iter()
        .filter_map(|r| {
            let e = r.error?;
            let inside = e.flip_inset_mean?;
            Some([
                r.name.clone(),
                format!("{inside:.4}"),
                format!("{:.4}", e.flip_mean),
            ])
        })
        .collect()
}

fn date(unix: u64) -> String {
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm,
    // "chrono-Compatible Low-Level Date Algorithms").
    let z = (unix / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

/// The header facts shared by the Markdown and HTML reports.
pub fn facts(results: &BenchResults) -> Vec<(String, String)> {
    let plan = results.plan.as_ref();
    vec![
        ("Plan".into(), plan.map_or("?".into(), |p| p.name.clone())),
        ("Date".into(), date(results.started_unix)),
        ("GPU".into(), results.device.clone()),
        ("Driver".into(), results.driver.clone()),
        ("CPU".into(), results.cpu.clone()),
        ("Command".into(), format!("`{}`", results.command)),
        (
            "Frames".into(),
            plan.map_or("?".into(), |p| {
                format!(
                    "{} warm-up + {} measured per configuration along head path seed {}; {} compared with the reference (`{}`{})",
                    p.warmup,
                    p.frames,
                    p.path_seed,
                    p.error_frames,
                    p.reference,
                    if p.reference_supersample > 1 {
                        format!(
                            ", rendered at {k}× the eye size per axis and box-filtered down in linear light",
                            k = p.reference_supersample
                        )
                    } else {
                        String::new()
                    }
                )
            }),
        ),
        (
            "Status".into(),
            if results.complete {
                "complete".into()
            } else {
                "INCOMPLETE (interrupted): only finished configurations are listed".into()
            },
        ),
        (
            "Validation messages".into(),
            results.validation_messages.to_string(),
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(name: &str, gpu_ms: f64, flip: f64, flicker: f64) -> ConfigResult {
        ConfigResult {
            name: name.into(),
            gpu_frame_ms: crate::stats::Summary {
                p50: gpu_ms,
                ..Default::default()
            },
            error: Some(crate::bench::runner::ImageError {
                flip_mean: flip,
                ..Default::default()
            }),
            flicker: Some(flicker),
            ..Default::default()
        }
    }

    /// The third target picks the fastest configuration under both caps
    /// (not the fastest overall, nor one over either cap) and judges it
    /// at 3×.
    #[test]
    fn the_capped_target_takes_the_fastest_under_both_caps() {
        let mut g = Group {
            baseline: "base".into(),
            results: vec![
                config("base", 12.0, 0.002, 0.0001),
                config("fast-flickers", 2.0, 0.004, 0.00011),
                config("fast-blurs", 2.5, 0.02, 0.00009),
                config("slow-good", 6.0, 0.003, 0.0001),
                config("good", 3.9, 0.003, 0.000099),
            ],
            ..Group::default()
        };
        let line = target_lines(&g).pop().unwrap();
        assert!(
            line.contains(": good 3.08× at FLIP 0.0030, flicker 0.000099 — met"),
            "{line}"
        );
        g.results.retain(|r| r.name != "good");
        let line = target_lines(&g).pop().unwrap();
        assert!(
            line.contains(": slow-good 2.00× at FLIP 0.0030, flicker 0.000100 — not met"),
            "{line}"
        );
        g.results.retain(|r| r.name != "slow-good");
        let line = target_lines(&g).pop().unwrap();
        assert!(
            line.ends_with("no configuration qualifies — not met"),
            "{line}"
        );
        // Without the baseline's flicker there is no cap and no line.
        g.results[0].flicker = None;
        assert!(target_lines(&g).is_empty());
    }

    #[test]
    fn dates() {
        assert_eq!(date(0), "1970-01-01");
        assert_eq!(date(951_782_400), "2000-02-29");
        assert_eq!(date(1_795_305_600), "2026-11-22");
    }
}
