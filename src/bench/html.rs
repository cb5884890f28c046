//! `report.html`: the report's tables plus the images and SVG plots drawn
//! with plotters: a Pareto chart (GPU ms against FLIP), frame-time
//! histograms and the scaling curve (cost against instance count).

use super::runner::{BenchResults, Group, TuneChoice};
use super::tables::{facts, group_rows, group_title, inset_rows, pass_rows};
use crate::stats::histogram;
use plotters::prelude::*;
use std::fmt::Write as _;

type PlotResult = std::result::Result<(), Box<dyn std::error::Error>>;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn table(s: &mut String, head: &[String], rows: &[Vec<String>]) {
    s.push_str("<table><tr>");
    for h in head {
        let _ = write!(s, "<th>{}</th>", esc(h));
    }
    s.push_str("</tr>");
    for r in rows {
        s.push_str("<tr>");
        for c in r {
            let _ = write!(s, "<td>{}</td>", esc(&c.replace('`', "")));
        }
        s.push_str("</tr>");
    }
    s.push_str("</table>\n");
}

/// Runs `draw` into an SVG string of `size`; a drawing error becomes a note.
fn svg(size: (u32, u32), draw: impl FnOnce(&mut String) -> PlotResult) -> String {
    let mut out = String::new();
    match draw(&mut out) {
        Ok(()) => out,
        Err(e) => format!("<p>(plot failed: {})</p>", esc(&e.to_string())),
    }
    .replace(
        "<svg ",
        &format!("<svg class=\"plot\" data-w=\"{}\" ", size.0),
    )
}

/// Points on the Pareto frontier of (cost, error): no other point is at
/// least as good in both and better in one. Sorted by cost.
pub fn pareto_frontier(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut out: Vec<(f64, f64)> = Vec::new();
    for q in p {
        if out.last().is_none_or(|l| q.1 < l.1) {
            out.push(q);
        }
    }
    out
}

fn pareto_svg(g: &Group, chosen: Option<&str>) -> String {
    let pts: Vec<(f64, f64, String)> = g
        .results
        .iter()
        .map(|r| {
            (
                r.gpu_frame_ms.p50,
                r.error.map_or(0.0, |e| e.flip_mean),
                r.name.clone(),
            )
        })
        .collect();
    let size = (760, 460);
    svg(size, |out| {
        let xmax = pts.iter().map(|p| p.0).fold(0.0, f64::max).max(1e-3) * 1.15;
        let ymax = pts.iter().map(|p| p.1).fold(0.0, f64::max).max(1e-4) * 1.15;
        let root = SVGBackend::with_string(out, size).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption("GPU ms (p50) vs FLIP mean", ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(0f64..xmax, 0f64..ymax)?;
        chart
            .configure_mesh()
            .x_desc("GPU ms per frame (p50)")
            .y_desc("FLIP mean vs reference")
            .draw()?;
        let frontier = pareto_frontier(&pts.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>());
        chart.draw_series(LineSeries::new(frontier, RED.stroke_width(2)))?;
        chart.draw_series(pts.iter().map(|(x, y, name)| {
            EmptyElement::at((*x, *y))
                + Circle::new((0, 0), 4, BLUE.filled())
                + Text::new(name.clone(), (6, -12), ("sans-serif", 11))
        }))?;
        // Tune's choice, ringed and labelled.
        chart.draw_series(pts.iter().filter(|p| Some(p.2.as_str()) == chosen).map(
            |(x, y, _)| {
                EmptyElement::at((*x, *y))
                    + Circle::new((0, 0), 9, GREEN.stroke_width(3))
                    + Text::new("chosen", (6, 4), ("sans-serif", 12))
            },
        ))?;
        root.present()?;
        Ok(())
    })
}

fn histogram_svg(name: &str, times: &[f64], lo: f64, hi: f64, budget: f64) -> String {
    let size = (300, 170);
    let bins = 24;
    let counts = histogram(times, lo, hi, bins);
    svg(size, |out| {
        let ymax = counts.iter().copied().max().unwrap_or(1).max(1);
        let root = SVGBackend::with_string(out, size).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(name, ("sans-serif", 13))
            .margin(6)
            .x_label_area_size(24)
            .y_label_area_size(30)
            .build_cartesian_2d(lo..hi, 0u32..ymax + 1)?;
        chart.configure_mesh().x_labels(5).y_labels(3).draw()?;
        let w = (hi - lo) / bins as f64;
        chart.draw_series(counts.iter().enumerate().map(|(i, &c)| {
            let x0 = lo + i as f64 * w;
            Rectangle::new([(x0, 0), (x0 + w, c)], BLUE.mix(0.6).filled())
        }))?;
        if budget > lo && budget < hi {
            chart.draw_series(LineSeries::new([(budget, 0), (budget, ymax + 1)], RED))?;
        }
        root.present()?;
        Ok(())
    })
}

/// Groups sharing an HMD and scale whose scenes differ in instance count,
/// as series per configuration: (instances, GPU p50, CPU p50).
type Series = std::collections::BTreeMap<String, Vec<(f64, f64, f64)>>;

/// The scene family a plan entry belongs to: `factory` for `factory:N`,
/// else the entry itself (a file does not scale).
fn family(scene: &str) -> &str {
    scene.split(':').next().unwrap_or(scene)
}

fn scaling(results: &BenchResults) -> Vec<(String, Series)> {
    let key = |g: &Group| {
        (
            g.hmd.clone(),
            g.scale.to_string(),
            family(&g.scene).to_string(),
        )
    };
    let mut keys: Vec<(String, String, String)> = Vec::new();
    for g in &results.groups {
        if !keys.contains(&key(g)) {
            keys.push(key(g));
        }
    }
    let mut out = Vec::new();
    for k in keys {
        let groups: Vec<&Group> = results.groups.iter().filter(|g| key(g) == k).collect();
        let mut counts: Vec<usize> = groups.iter().map(|g| g.instances).collect();
        counts.sort_unstable();
        counts.dedup();
        if counts.len() < 2 {
            continue;
        }
        let mut series = Series::new();
        for g in groups {
            for r in &g.results {
                series.entry(r.name.clone()).or_default().push((
                    g.instances.max(1) as f64,
                    r.gpu_frame_ms.p50,
                    r.cpu_frame_ms.p50,
                ));
            }
        }
        for v in series.values_mut() {
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        let (hmd, scale, fam) = k;
        out.push((format!("{fam}, {hmd}, scale {scale}"), series));
    }
    out
}

fn scaling_svg(title: &str, series: &Series) -> String {
    let size = (760, 460);
    svg(size, |out| {
        let all = series.values().flatten();
        let xmin = all.clone().map(|p| p.0).fold(f64::INFINITY, f64::min);
        let xmax = all.clone().map(|p| p.0).fold(0.0, f64::max);
        let ymax = all.map(|p| p.1.max(p.2)).fold(0.0, f64::max).max(1e-3) * 1.15;
        let root = SVGBackend::with_string(out, size).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("cost vs instances ({title}); solid GPU, dashed CPU"),
                ("sans-serif", 16),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d((xmin * 0.8..xmax * 1.25).log_scale(), 0f64..ymax)?;
        chart
            .configure_mesh()
            .x_desc("instances")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_desc("ms per frame (p50)")
            .draw()?;
        for (i, (name, pts)) in series.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            chart
                .draw_series(LineSeries::new(
                    pts.iter().map(|p| (p.0, p.1)),
                    color.stroke_width(2),
                ))?
                .label(name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
            chart.draw_series(DashedLineSeries::new(
                pts.iter().map(|p| (p.0, p.2)),
                6,
                4,
                color.into(),
            ))?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
        root.present()?;
        Ok(())
    })
}

/// The tune report's choice: the configuration, the rule that chose it,
/// the limits and every candidate against them.
fn html_choice(s: &mut String, c: &TuneChoice) {
    s.push_str("<h2>Choice</h2>");
    let _ = write!(
        s,
        "<p><b>{}</b> (<code>{}</code>): {}.</p><ul><li>Frame budget: {:.3} ms (the measured wall-clock frame interval's p95)</li><li>FLIP mean cap: {}</li><li>Flicker cap: {}</li></ul><p>Every candidate against the limits:</p><ul>",
        esc(&c.name),
        esc(&c.opt),
        esc(&c.rule),
        c.budget_ms,
        c.max_flip.map_or("none (the least error within the budget wins)".to_string(), |m| m.to_string()),
        esc(c.max_flicker.as_deref().unwrap_or("none")),
    );
    for w in &c.why {
        let _ = write!(s, "<li><code>{}</code></li>", esc(w.trim()));
    }
    s.push_str("</ul>");
}

/// One group's section: floors, results, per-pass and inset tables, the
/// speed/accuracy chart (the choice ringed), frame-time histograms and
/// the images.
fn html_group(s: &mut String, g: &Group, choice: Option<&str>) {
    let _ = write!(s, "<h2>{}</h2>", esc(&group_title(g)));
    if let Some(f) = &g.floors {
        let _ = write!(
            s,
            "<p>Floors ({}'s stereo mode and MSAA), GPU ms p50: empty frame {:.3}, clear only {:.3}, one full-screen triangle {:.3}.</p>",
            esc(&g.baseline),
            f.empty_frame.p50,
            f.clear.p50,
            f.fullscreen_triangle.p50
        );
    }
    let (head, rows) = group_rows(g);
    let head: Vec<String> = head.iter().map(|h| h.to_string()).collect();
    table(s, &head, &rows);
    let (passes, rows) = pass_rows(g);
    s.push_str("<h3>GPU ms per pass (p50)</h3>");
    let head: Vec<String> = std::iter::once("config".to_string())
        .chain(passes)
        .collect();
    table(s, &head, &rows);
    let inset: Vec<Vec<String>> = inset_rows(g).into_iter().map(Vec::from).collect();
    if !inset.is_empty() {
        s.push_str("<h3>Inside the inset (FLIP mean over the lens-visible pixels of the full-density rectangle)</h3>");
        let head = ["config", "FLIP inside the inset", "FLIP over the image"].map(String::from);
        table(s, &head, &inset);
    }
    s.push_str("<h3>Speed against accuracy</h3>");
    s.push_str(&pareto_svg(g, choice));
    html_histograms(s, g);
    s.push_str("<h3>Images (left eye, last compared frame), FLIP heat maps and flicker maps (white at 0.05)</h3><div class=\"grid\">");
    for r in &g.results {
        for (path, what) in [
            (&r.image, ""),
            (&r.heatmap, " FLIP"),
            (&r.flicker_heatmap, " flicker"),
        ] {
            if let Some(p) = path {
                let _ = write!(
                    s,
                    "<figure><img src=\"{}\" width=\"240\"><figcaption>{}{}</figcaption></figure>",
                    esc(p),
                    esc(&r.name),
                    what
                );
            }
        }
    }
    s.push_str("</div>");
}

/// The group's frame-time histograms on one shared axis, the refresh
/// budget marked.
fn html_histograms(s: &mut String, g: &Group) {
    s.push_str("<h3>Frame-time histograms (ms; red: refresh budget)</h3><div class=\"grid\">");
    let times = g
        .results
        .iter()
        .flat_map(|r| r.frame_times_ms.iter().copied());
    let lo = times.clone().fold(f64::INFINITY, f64::min);
    let hi = times.fold(0.0, f64::max);
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo * 0.95, hi * 1.05)
    } else {
        (0.0, 1.0)
    };
    let budget = 1000.0 / g.refresh_hz;
    for r in &g.results {
        s.push_str(&histogram_svg(&r.name, &r.frame_times_ms, lo, hi, budget));
    }
    s.push_str("</div>");
}

/// `report.html`: self-contained apart from the images under `images/`.
pub fn html(results: &BenchResults) -> String {
    let mut s = String::from(
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>vergence bench report</title>\
         <style>body{font-family:sans-serif;margin:2em;max-width:1500px}table{border-collapse:collapse;font-size:13px;margin:1em 0}\
         td,th{border:1px solid #ccc;padding:3px 6px;text-align:right}td:first-child{text-align:left}\
         .grid{display:flex;flex-wrap:wrap;gap:8px}.grid figure{margin:0;font-size:12px}img{image-rendering:pixelated}</style>\
         </head><body><h1>vergence bench report</h1><ul>",
    );
    if results.choice.is_some() {
        s = s.replace(
            "<h1>vergence bench report</h1>",
            "<h1>vergence tune report</h1>",
        );
    }
    for (k, v) in facts(results) {
        let _ = write!(
            s,
            "<li><b>{}:</b> {}</li>",
            esc(&k),
            esc(&v.replace('`', ""))
        );
    }
    s.push_str("</ul>");
    if let Some(c) = &results.choice {
        html_choice(&mut s, c);
    }
    for (title, rows) in super::tables::spread_rows(results) {
        let _ = write!(s, "<h2>Across head paths: {}</h2>", esc(&title));
        let head: Vec<String> = super::tables::SPREAD_HEAD.map(String::from).to_vec();
        table(&mut s, &head, &rows);
    }
    for g in &results.groups {
        html_group(&mut s, g, results.choice.as_ref().map(|c| c.name.as_str()));
    }
    let curves = scaling(results);
    if !curves.is_empty() {
        s.push_str("<h2>Scaling</h2>");
        for (title, series) in &curves {
            s.push_str(&scaling_svg(title, series));
        }
    }
    s.push_str("</body></html>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn scaling_curves_join_only_one_scene_family() {
        let group = |scene: &str, instances| Group {
            scene: scene.into(),
            instances,
            hmd: "h".into(),
            scale: 1.0,
            ..Group::default()
        };
        let r = BenchResults {
            groups: vec![
                group("factory:10", 10),
                group("garage.gltf", 1),
                group("factory:1000", 1000),
            ],
            ..BenchResults::default()
        };
        let curves = scaling(&r);
        assert_eq!(curves.len(), 1);
        assert!(curves[0].0.starts_with("factory,"));
        let only = BenchResults {
            groups: vec![group("factory:10", 10), group("garage.gltf", 1)],
            ..BenchResults::default()
        };
        assert!(scaling(&only).is_empty());
    }

    proptest! {
        #[test]
        fn frontier_matches_brute_force(pts in prop::collection::vec((0f64..100.0, 0f64..1.0), 1..40)) {
            let f = pareto_frontier(&pts);
            // Brute force: a point is on the frontier when no other point is
            // at least as good in both coordinates and strictly better in one.
            let mut want: Vec<(f64, f64)> = pts.iter().copied().filter(|&(x, y)| {
                !pts.iter().any(|&(a, b)| a <= x && b <= y && (a < x || b < y))
            }).collect();
            want.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
            want.dedup();
            prop_assert_eq!(f, want);
        }
    }
}
