//! Bench outputs: `results.json`, `results.csv` and `report.md` (the HTML
//! report with plots is in [`super::html`]).

use super::runner::{BenchResults, ConfigResult, Group};
use super::tables::{facts, group_rows, group_title, inset_rows, pass_rows, target_lines};
use crate::error::Result;
use std::fmt::Write as _;
use std::path::Path;

/// Writes results.json, results.csv, report.md and report.html into `dir`,
/// and `checks.md` (fixed thresholds some plans are checked against, kept
/// out of the reports) when a group has any.
pub fn write_all(dir: &Path, results: &BenchResults) -> Result<()> {
    crate::targets::headless::write_json(&dir.join("results.json"), results)?;
    write_text(&dir.join("results.csv"), &csv(results))?;
    write_text(&dir.join("report.md"), &markdown(results))?;
    write_text(&dir.join("report.html"), &super::html::html(results))?;
    match checks(results) {
        Some(text) => write_text(&dir.join("checks.md"), &text),
        None => Ok(()),
    }
}

/// The threshold checks of every group ([`target_lines`]), or None when
/// no group has one.
pub fn checks(results: &BenchResults) -> Option<String> {
    let mut s = String::new();
    for g in &results.groups {
        let lines = target_lines(g);
        if lines.is_empty() {
            continue;
        }
        let _ = writeln!(
            s,
            "## {}
",
            group_title(g)
        );
        for t in lines {
            let _ = writeln!(s, "- {t}");
        }
        let _ = writeln!(s);
    }
    (!s.is_empty()).then(|| {
        format!(
            "# Threshold checks

Fixed thresholds this plan's results are checked against (the report itself states results only).

{s}"
        )
    })
}

/// Writes `text` to `path` ([`crate::fsio::write_output`]).
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    crate::fsio::write_bytes(path, text.as_bytes())
}

/// CSV header of [`csv`].
pub const CSV_HEADER: &str = "scene,instances,hmd,scale,width,height,config,opt,stereo,msaa,cull,foveation_path,\
gpu_p50_ms,gpu_p95_ms,gpu_p99_ms,gpu_max_ms,gpu_std_ms,frames_in_flight,wall_frame_p50_ms,wall_frame_p95_ms,wall_frame_p99_ms,wall_frame_max_ms,wall_frame_std_ms,\
model_frame_p50_ms,cpu_cull_ms,cpu_batch_ms,cpu_record_ms,cpu_submit_ms,cpu_frame_p50_ms,frames,frames_over_budget,frames_over_2x_budget,\
draw_calls,instances_drawn,triangles,fragment_invocations,gpu_allocated_bytes,gpu_usage_bytes,gpu_budget_bytes,rss_bytes,\
flip_mean,flip_p99,psnr_db,ssim,cull_false_positives,cull_false_negatives,gpu_speedup,frame_speedup,flip_inset_mean,\
flip_foveated_mean,flicker,flicker_foveated,path_seed,gpu_speedup_low,gpu_speedup_high";

fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn opt_num(v: Option<f64>) -> String {
    v.map(|x| format!("{x}")).unwrap_or_default()
}

/// One row per group and configuration.
pub fn csv(results: &BenchResults) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for g in &results.groups {
        for r in &g.results {
            let e = r.error.as_ref();
            let a = r.cull_accuracy.as_ref();
            let fields = [
                quote(&g.scene),
                g.instances.to_string(),
                quote(&g.hmd),
                g.scale.to_string(),
                g.resolution[0].to_string(),
                g.resolution[1].to_string(),
                quote(&r.name),
                quote(&r.opt),
                r.stereo.clone(),
                r.msaa.to_string(),
                r.cull.clone(),
                quote(&r.renderer.foveation),
                r.gpu_frame_ms.p50.to_string(),
                r.gpu_frame_ms.p95.to_string(),
                r.gpu_frame_ms.p99.to_string(),
                r.gpu_frame_ms.max.to_string(),
                r.gpu_frame_ms.std.to_string(),
                r.frames_in_flight.to_string(),
                r.wall_frame_ms.p50.to_string(),
                r.wall_frame_ms.p95.to_string(),
                r.wall_frame_ms.p99.to_string(),
                r.wall_frame_ms.max.to_string(),
                r.wall_frame_ms.std.to_string(),
                r.model_frame_ms.p50.to_string(),
                r.cpu_ms.cull.to_string(),
                r.cpu_ms.batch.to_string(),
                r.cpu_ms.record.to_string(),
                r.cpu_ms.submit.to_string(),
                r.cpu_frame_ms.p50.to_string(),
                r.frames.to_string(),
                r.frames_over_budget.to_string(),
                r.frames_over_2x_budget.to_string(),
                r.draw_calls.to_string(),
                r.instances_drawn.to_string(),
                r.triangles.to_string(),
                opt_num(r.fragment_invocations),
                r.gpu_memory.allocated.to_string(),
                opt_num(r.gpu_memory.usage.map(|v| v as f64)),
                opt_num(r.gpu_memory.budget.map(|v| v as f64)),
                opt_num(r.rss_bytes.map(|v| v as f64)),
                opt_num(e.map(|e| e.flip_mean)),
                opt_num(e.map(|e| e.flip_p99)),
                opt_num(e.map(|e| e.psnr_db)),
                opt_num(e.map(|e| e.ssim)),
                opt_num(a.map(|a| a.false_positives)),
                opt_num(a.map(|a| a.false_negatives)),
                opt_num(r.gpu_speedup),
                opt_num(r.frame_speedup),
                opt_num(e.and_then(|e| e.flip_inset_mean)),
                opt_num(e.and_then(|e| e.flip_foveated_mean)),
                opt_num(r.flicker),
                opt_num(r.flicker_foveated),
                g.path_seed.to_string(),
                opt_num(r.gpu_speedup_range.map(|[lo, _]| lo)),
                opt_num(r.gpu_speedup_range.map(|[_, hi]| hi)),
            ];
            s.push_str(&fields.join(","));
            s.push('\n');
        }
    }
    s
}

fn md_table(s: &mut String, head: &[String], rows: &[Vec<String>]) {
    let _ = writeln!(s, "| {} |", head.join(" | "));
    let _ = writeln!(s, "|{}", "---|".repeat(head.len()));
    for r in rows {
        let _ = writeln!(s, "| {} |", r.join(" | "));
    }
}

/// What tune chose and under which limits, as markdown lines (the HTML
/// report shows the same lines).
pub fn choice_lines(c: &super::runner::TuneChoice) -> Vec<String> {
    let mut out = vec![
        "\n## Choice\n".to_string(),
        format!("**{}** (`{}`): {}.\n", c.name, c.opt, c.rule),
        format!(
            "- Frame budget: {:.3} ms (the measured wall-clock frame interval's p95, frames in flight as `run` renders them)",
            c.budget_ms
        ),
        match c.max_flip {
            Some(m) => format!("- FLIP mean cap: {m}"),
            None => "- FLIP mean cap: none (the least error within the budget wins)".to_string(),
        },
        match &c.max_flicker {
            Some(m) => format!("- Flicker cap: {m}"),
            None => "- Flicker cap: none".to_string(),
        },
        "\nEvery candidate against the limits:\n".to_string(),
    ];
    out.extend(c.why.iter().map(|w| format!("- `{}`", w.trim())));
    out
}

/// `report.md`.
pub fn markdown(results: &BenchResults) -> String {
    let mut s = String::from(match results.choice {
        Some(_) => "# vergence tune report\n\n",
        None => "# vergence bench report\n\n",
    });
    for (k, v) in facts(results) {
        let _ = writeln!(s, "- **{k}:** {v}");
    }
    if let Some(c) = &results.choice {
        for line in choice_lines(c) {
            let _ = writeln!(s, "{line}");
        }
    }
    s.push_str(
        "\nGPU ms: sum of the frame's pass timestamps. Frame time: the measured wall-clock \
         interval from one frame's start to the next's, frames back to back with the \
         configuration's frames in flight (`wall_frame_ms`); results.json and results.csv \
         also give `model_frame_ms`, a model (per frame the larger of CPU and GPU time). \
         Speed-up: baseline GPU p50 over the configuration's. Image error: against the reference on the same frames, both eyes \
         averaged; hidden-area pixels are blacked out in both images, FLIP mean and p99 \
         (per image, averaged) leave them out, PSNR and SSIM run over the whole image. FLIP at \
         the profile's pixels per degree (at least 10).\n",
    );
    md_spread(&mut s, results);
    for g in &results.groups {
        md_group(&mut s, g);
    }
    s
}

/// The figures' spread over head paths, where the plan measured several.
fn md_spread(s: &mut String, results: &BenchResults) {
    for (title, rows) in super::tables::spread_rows(results) {
        let _ = writeln!(
            s,
            "\n## Across head paths: {title}\n\nEach configuration's GPU speed-up range and its worst error and flicker over the paths (a choice that holds must hold on every one).\n"
        );
        let head: Vec<String> = super::tables::SPREAD_HEAD.map(String::from).to_vec();
        md_table(s, &head, &rows);
    }
}

/// One group's section of `report.md`: its floors, results and per-pass
/// tables, then the tables only some configurations fill.
fn md_group(s: &mut String, g: &Group) {
    let _ = writeln!(s, "\n## {}\n", group_title(g));
    if let Some(f) = &g.floors {
        let _ = writeln!(
            s,
            "Floors ({}'s stereo mode and MSAA), GPU ms p50: empty frame {:.3}, clear only {:.3}, one full-screen triangle {:.3}.\n",
            g.baseline, f.empty_frame.p50, f.clear.p50, f.fullscreen_triangle.p50
        );
    }
    let (head, rows) = group_rows(g);
    let head: Vec<String> = head.iter().map(|h| h.to_string()).collect();
    md_table(s, &head, &rows);
    md_sample_notes(s, g);
    let (passes, rows) = pass_rows(g);
    let _ = writeln!(s, "\nGPU ms per pass (p50):\n");
    let head: Vec<String> = std::iter::once("config".to_string())
        .chain(passes)
        .collect();
    md_table(s, &head, &rows);
    let inset: Vec<Vec<String>> = inset_rows(g).into_iter().map(Vec::from).collect();
    if !inset.is_empty() {
        let _ = writeln!(
            s,
            "\nInside the inset (FLIP mean over the lens-visible pixels of the full-density rectangle around the gaze, where the eye looks; both eyes and the compared frames averaged; a configuration without an inset over the plan's first inset configuration's rectangle):\n"
        );
        let head = ["config", "FLIP inside the inset", "FLIP over the image"].map(String::from);
        md_table(s, &head, &inset);
    }
    md_flicker(s, g);
    md_aq(s, g);
    md_moving(s, g);
    let paths: Vec<&ConfigResult> = g
        .results
        .iter()
        .filter(|r| r.renderer.foveation != "off")
        .collect();
    if !paths.is_empty() {
        let _ = writeln!(s, "\nFoveation paths:\n");
        for r in paths {
            let _ = writeln!(s, "- {}: {}", r.name, r.renderer.foveation);
        }
    }
}

/// Under the main table: how many frames the figures rest on (with the
/// spread where they are few), and the configurations whose technique did
/// not run here (never ranked).
fn md_sample_notes(s: &mut String, g: &Group) {
    let mut counts: Vec<usize> = g.results.iter().map(|r| r.gpu_frame_ms.n).collect();
    counts.sort_unstable();
    counts.dedup();
    let counts: Vec<String> = counts.iter().map(usize::to_string).collect();
    let few = g
        .results
        .iter()
        .any(|r| r.gpu_frame_ms.n < super::runner::FEW_FRAMES);
    let _ = writeln!(
        s,
        "\nGPU and frame times are over {} measured frames per configuration{}.",
        counts.join(" or "),
        if few {
            "; with so few, a time differs from run to run by about its standard deviation (sd), shown beside it, and a speed-up near 1 is no evidence either way"
        } else {
            ""
        }
    );
    for r in &g.results {
        if let Some(why) = r.not_applied() {
            let _ = writeln!(
                s,
                "\nNot applied: {} — {why}. Its figures are those of the configuration without it; it is not ranked.",
                r.name
            );
        }
    }
}

/// The temporal error table, split by the inset's regions where a
/// configuration has them.
fn md_flicker(s: &mut String, g: &Group) {
    let split = g.results.iter().any(|r| r.flicker_regions.is_some());
    let region = |f: &crate::bench::runner::RegionFlicker| {
        format!("{:.5} ({:.0} %)", f.mean, 100.0 * f.share)
    };
    let flicker: Vec<Vec<String>> = g
        .results
        .iter()
        .filter_map(|r| {
            let mut row = vec![
                r.name.clone(),
                format!("{:.5}", r.flicker?),
                r.flicker_foveated
                    .map_or(String::new(), |v| format!("{v:.5}")),
                r.error
                    .as_ref()
                    .map_or(String::new(), |e| format!("{:.4}", e.flip_mean)),
            ];
            if split {
                row.extend(match &r.flicker_regions {
                    Some(f) => [region(&f.inset), region(&f.seam), region(&f.periphery)],
                    None => Default::default(),
                });
                row.push(r.flicker_floor.map_or(String::new(), |v| format!("{v:.5}")));
            }
            Some(row)
        })
        .collect();
    if flicker.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "\nTemporal error (flicker: mean per-pixel frame-to-frame luma change beyond the reference's, along the first view turning a third of a pixel a frame; 0 = as stable as the reference):\n"
    );
    let mut head: Vec<String> = ["config", "flicker", "flicker foveated", "FLIP mean"]
        .map(String::from)
        .to_vec();
    if split {
        let _ = writeln!(
            s,
            "With an inset, its flicker split by where the composite takes each pixel from: mean over the region (its share of the visible pixels); the shares weight the means into the whole (a configuration without an inset over the plan's first inset configuration's regions). Floor: the flicker of the reference sequence put through a perfect wide view of the configuration's size and filter (each wide pixel the reference's mean over its area, read back as the composite reads it), the least any wide view of that size could add.\n"
        );
        head.extend(
            [
                "inside the inset",
                "feathered seam",
                "wide view alone",
                "floor (perfect wide view)",
            ]
            .map(String::from),
        );
    }
    md_table(s, &head, &flicker);
}

/// The adaptive-quality table (configurations with `aq`).
fn md_aq(s: &mut String, g: &Group) {
    let aq: Vec<Vec<String>> = g
        .results
        .iter()
        .filter_map(|r| {
            let a = r.aq.as_ref()?;
            Some(vec![
                r.name.clone(),
                format!("{:.3}", a.mean_scale),
                format!("{:.3}–{:.3}", a.min_scale, a.max_scale),
                a.level_changes.to_string(),
                a.wide_one_sample_frames.to_string(),
                if a.wide_rung_frames > 0 {
                    format!("{} (×{:.3})", a.wide_rung_frames, a.min_wide_factor)
                } else {
                    "0".into()
                },
                format!("{:.2}", a.budget_ms),
                format!("{} / {}", r.gpu_frames_over_budget, r.frames),
            ])
        })
        .collect();
    if aq.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "\nAdaptive quality (render scale per axis the controller chose over the measured frames; GPU frames over the budget; the other configurations' GPU frames over budget are in results.json):\n"
    );
    let head = [
        "config",
        "mean scale",
        "range",
        "level changes",
        "wide at 1 sample (MSAA rung)",
        "inset rung frames (least wide factor)",
        "budget ms",
        "GPU over budget",
    ]
    .map(String::from);
    md_table(s, &head, &aq);
}

/// The moving-instances table (scenes with motion).
fn md_moving(s: &mut String, g: &Group) {
    let moving: Vec<Vec<String>> = g
        .results
        .iter()
        .filter_map(|r| {
            Some(vec![
                r.name.clone(),
                format!("{:.0}", r.moved_instances?),
                format!("{:.1}", r.motion_upload_bytes? / 1024.0),
                format!("{:.3}", r.cpu_ms.motion?),
            ])
        })
        .collect();
    if moving.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "\nMoving instances per frame (p50; only these are uploaded):\n"
    );
    let head = ["config", "moved", "uploaded KiB", "CPU ms to move"].map(String::from);
    md_table(s, &head, &moving);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn result(name: &str, opt: &str, n: usize, foveation: &str) -> ConfigResult {
        let mut r = ConfigResult {
            name: name.into(),
            opt: opt.into(),
            ..ConfigResult::default()
        };
        r.gpu_frame_ms.n = n;
        r.gpu_frame_ms.p50 = 4.0;
        r.gpu_frame_ms.std = 0.25;
        r.renderer.foveation = foveation.into();
        r
    }

    #[test]
    fn few_frames_show_their_spread_and_a_fallback_is_marked() {
        let off = "off: lavapipe offers no VK_KHR_fragment_shading_rate attachment";
        let g = Group {
            baseline: "base".into(),
            results: vec![
                result("base", "multiview", 3, "off"),
                result("foveation-medium", "multiview,foveation", 3, off),
            ],
            ..Group::default()
        };
        let mut s = String::new();
        md_group(&mut s, &g);
        assert!(s.contains("4.000 (n=3, sd 0.250)"), "{s}");
        assert!(
            s.contains("over 3 measured frames per configuration; with so few"),
            "{s}"
        );
        assert!(
            s.contains("foveation-medium (`multiview,foveation`) — not applied"),
            "{s}"
        );
        assert!(
            s.contains("Not applied: foveation-medium — foveation fell back"),
            "{s}"
        );
        assert!(!s.contains("Not applied: base"), "{s}");
        // With enough frames: the plain time, no caveat.
        let g = Group {
            baseline: "base".into(),
            results: vec![result("base", "multiview", 30, "off")],
            ..Group::default()
        };
        let mut s = String::new();
        md_group(&mut s, &g);
        assert!(s.contains("| 4.000 |"), "{s}");
        assert!(!s.contains("with so few"), "{s}");
    }

    #[test]
    fn csv_quotes_opt_lists() {
        assert_eq!(quote("a,b"), "\"a,b\"");
        assert_eq!(quote("x\"y"), "\"x\"\"y\"");
        assert_eq!(quote("say \"hi\", ok"), "\"say \"\"hi\"\", ok\"");
    }
}
