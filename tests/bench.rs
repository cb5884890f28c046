//! `vergence bench` on the shipped smoke plan, `vergence tune` and
//! `--config`: the outputs' content, not only their existence.

mod common;

use std::path::Path;
use std::process::Command;
use vergence::bench::plan::Plan;
use vergence::bench::report::CSV_HEADER;
use vergence::bench::runner::{BenchResults, ConfigResult};
use vergence::bench::tune::{self, TuneGoal};

fn vergence(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args(args)
        .output()
        .expect("vergence runs")
}

fn ok(args: &[&str]) -> String {
    let out = vergence(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "{args:?} failed ({}): {stderr}",
        out.status
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs `vergence bench --plan PLAN --out OUT` (asserting success) and
/// reads the results it wrote.
fn run_plan(plan: &Path, out: &Path) -> BenchResults {
    ok(&[
        "bench",
        "--plan",
        plan.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap()
}

/// Splits a CSV line, honouring double quotes.
fn csv_fields(line: &str) -> Vec<String> {
    let (mut out, mut cur, mut quoted) = (Vec::new(), String::new(), false);
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(std::mem::take(&mut cur)),
            _ => cur.push(c),
        }
    }
    out.push(cur);
    out
}

fn get<'a>(results: &'a BenchResults, name: &str) -> &'a ConfigResult {
    results.groups[0]
        .results
        .iter()
        .find(|r| r.name == name)
        .unwrap_or_else(|| panic!("no result for {name}"))
}

#[test]
fn smoke_plan_measures_and_reports() {
    let out = common::scratch("bench", "smoke");
    let run = vergence(&["bench", "--plan", "smoke", "--out", out.to_str().unwrap()]);
    assert!(run.status.success(), "{:?}", run);
    let stdout = String::from_utf8_lossy(&run.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    // Without a terminal: one progress line per finished step, and a
    // fallback warning once however many renderers meet it.
    let plan_steps = Plan::resolve("smoke").unwrap().configs.len() + 1;
    let progress = stderr.lines().filter(|l| l.starts_with("bench: ")).count();
    assert_eq!(progress, plan_steps, "{stderr}");
    for line in stderr.lines().filter(|l| l.starts_with("warning: ")) {
        assert_eq!(stderr.matches(line).count(), 1, "{stderr}");
    }
    let checks = std::fs::read_to_string(out.join("checks.md")).unwrap();
    assert!(checks.contains("Target (full stack"), "{checks}");
    for report in ["report.md", "report.html"] {
        let text = std::fs::read_to_string(out.join(report)).unwrap();
        assert!(
            !text.contains("Target ("),
            "{report} holds a threshold line"
        );
    }
    assert!(!stdout.contains("Target ("), "{stdout}");
    let plan = Plan::resolve("smoke").unwrap();

    let json = std::fs::read_to_string(out.join("results.json")).unwrap();
    let results: BenchResults = serde_json::from_str(&json).unwrap();
    assert!(results.complete);
    assert_eq!(results.validation_messages, 0);
    assert_eq!(results.groups.len(), 1);
    let g = &results.groups[0];
    assert_eq!(g.resolution, [160, 120]);
    let names: Vec<&str> = g.results.iter().map(|r| r.name.as_str()).collect();
    let mut want = vec!["reference"];
    want.extend(plan.configs.iter().map(|c| c.name.as_str()));
    assert_eq!(names, want);
    // Repeated runs: each configuration's medians per run, and the
    // speed-up's range over them holds the first run's speed-up.
    assert!(plan.repeats > 1);
    for r in g.results.iter().filter(|r| r.name != "reference") {
        assert_eq!(r.runs.len(), plan.repeats as usize, "{}", r.name);
        assert_eq!(r.runs[0].gpu_p50, r.gpu_frame_ms.p50, "{}", r.name);
        assert!(r.runs.iter().all(|run| run.gpu_p50 > 0.0), "{}", r.name);
        let [lo, hi] = r.gpu_speedup_range.expect("a speed-up range");
        let s = r.gpu_speedup.unwrap();
        assert!(
            lo <= s + 1e-12 && s <= hi + 1e-12,
            "{}: {s} not in {lo}..{hi}",
            r.name
        );
    }
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains(&format!("over {} runs", plan.repeats)),
        "{report}"
    );
    // The foveated error beside the uniform one, never above it.
    assert!(report.contains("FLIP foveated"), "{report}");
    for r in g.results.iter().filter(|r| r.name != "reference") {
        let e = r.error.as_ref().expect("an error");
        let foveated = e.flip_foveated_mean.expect("a foveated FLIP");
        assert!(
            foveated <= e.flip_mean + 1e-9,
            "{}: {foveated} > {}",
            r.name,
            e.flip_mean
        );
        if let (Some(f), Some(ff)) = (r.flicker, r.flicker_foveated) {
            assert!(ff <= f + 1e-9, "{}: {ff} > {f}", r.name);
        }
    }
    let mut lossy = g.results.iter().filter_map(|r| r.error.as_ref());
    assert!(
        lossy.any(|e| e.flip_mean > 0.0 && e.flip_foveated_mean.unwrap() < e.flip_mean),
        "some configuration's periphery error is discounted"
    );
    for r in &g.results {
        assert_eq!(r.frames, plan.frames, "{}", r.name);
        assert_eq!(r.frame_times_ms.len(), plan.frames as usize);
        assert!(
            r.gpu_frame_ms.p50 > 0.0 && r.cpu_frame_ms.p50 > 0.0,
            "{}",
            r.name
        );
        // The frame-time model is the per-frame max of CPU and GPU time.
        assert!(r.model_frame_ms.p50 >= r.gpu_frame_ms.p50.max(r.cpu_frame_ms.p50));
        // The measured intervals cover the GPU's serial work: over the
        // measured frames, their sum reaches the GPU time of those frames
        // less what may still be in flight (and one frame of window slack).
        assert_eq!(r.frames_in_flight, plan.frames_in_flight, "{}", r.name);
        let wall_total = r.wall_frame_ms.mean * r.wall_frame_ms.n as f64;
        let gpu_total = r.gpu_frame_ms.mean * r.gpu_frame_ms.n as f64;
        let slack = (r.frames_in_flight + 1) as f64 * r.gpu_frame_ms.max;
        assert!(
            wall_total >= gpu_total - slack,
            "{}: wall {:?} gpu {:?}",
            r.name,
            r.wall_frame_ms,
            r.gpu_frame_ms
        );
        assert!(r.draw_calls > 0.0 && r.triangles > 0.0, "{}", r.name);
        assert!(r.gpu_memory.allocated > 0, "{}", r.name);
        assert!(r.rss_bytes.unwrap_or(0) > 1 << 20, "{}", r.name);
        assert_eq!(r.error.is_none(), r.name == "reference", "{}", r.name);
        assert!(out.join(r.image.as_ref().unwrap()).is_file());
    }
    let floors = g.floors.expect("floors measured on the baseline");
    assert!(floors.clear.p50 > 0.0 && floors.fullscreen_triangle.p50 > 0.0);
    assert!(floors.empty_frame.p50 > 0.0);

    // Culling changes nothing visible; per-eye culling misses nothing.
    assert_eq!(g.baseline, "two-pass-per-eye");
    let base = get(&results, "two-pass-per-eye");
    assert!(base.error.unwrap().flip_mean < 1e-3, "{:?}", base.error);
    assert_eq!(base.cull_accuracy.unwrap().false_negatives_total, 0);
    assert!(base.instances_drawn < get(&results, "reference").instances_drawn);
    let mv = get(&results, "multiview-superfrustum");
    assert!(mv.draw_calls < base.draw_calls, "multiview halves draws");
    assert!(mv.error.unwrap().flip_mean < 1e-3);

    // The stencil mask shades fewer fragments; RDM and MFFR change pixels.
    let frag = |n: &str| get(&results, n).fragment_invocations.unwrap();
    assert!(frag("stencil-mask") < frag("two-pass-per-eye"));
    for n in ["rdm", "mffr", "full-stack"] {
        let e = get(&results, n).error.unwrap();
        assert!(e.flip_mean > 1e-4 && e.flip_mean < 0.2, "{n}: {e:?}");
        assert!(
            e.psnr_db < 100.0 && e.ssim < 1.0 && e.ssim > 0.5,
            "{n}: {e:?}"
        );
    }
    assert!(get(&results, "mffr").gpu_ms.contains_key("mffr-far"));
    // Foveation runs where the device has a fragment-shading-rate
    // attachment; elsewhere the path says it is off and why. Configurations
    // without foveation report plain "off".
    let ctx = common::context();
    let foveated = |r: &&ConfigResult| r.opt.contains("foveation=");
    assert_eq!(g.results.iter().filter(foveated).count(), 2);
    for r in &g.results {
        let path = &r.renderer.foveation;
        if !foveated(&r) {
            assert_eq!(path, "off", "{}", r.name);
        } else if ctx.caps.shading_rate_texel.is_some() {
            assert!(
                path.starts_with("vk-khr-fragment-shading-rate ("),
                "{}: {path}",
                r.name
            );
        } else {
            assert!(
                path.starts_with(&format!(
                    "off: {} offers no VK_KHR_fragment_shading_rate attachment",
                    ctx.device_name
                )),
                "{}: {path}",
                r.name
            );
        }
    }

    // The renderer's block sits at each result's top level, keyed as in
    // render's stats.json; a result written before it (the foveation path
    // as `foveation_path`) still loads.
    let raw: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let first = &raw["groups"][0]["results"][0];
    assert_eq!(first["foveation"], g.results[0].renderer.foveation.as_str());
    assert!(first["per_view_render_areas"]
        .as_str()
        .unwrap()
        .contains("unused"));
    assert!(first.get("foveation_path").is_none());
    let mut old = first.clone();
    let fov = old.as_object_mut().unwrap().remove("foveation").unwrap();
    old["foveation_path"] = fov;
    let back: ConfigResult = serde_json::from_value(old).unwrap();
    assert_eq!(back.renderer, g.results[0].renderer);

    // CSV: the header, one row per result, same field count, same numbers.
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some(CSV_HEADER));
    let head = csv_fields(CSV_HEADER);
    let rows: Vec<Vec<String>> = lines.map(csv_fields).collect();
    assert_eq!(rows.len(), g.results.len());
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    for (row, r) in rows.iter().zip(&g.results) {
        assert_eq!(row.len(), head.len());
        assert_eq!(row[col("config")], r.name);
        assert_eq!(row[col("opt")], r.opt);
        let gpu: f64 = row[col("gpu_p50_ms")].parse().unwrap();
        assert!((gpu - r.gpu_frame_ms.p50).abs() < 1e-9);
    }

    // Speed-ups, from the CSV's own columns: the baseline's p50 over each
    // configuration's p50 (the baseline's own is then 1).
    let num = |row: &[String], c: &str| -> f64 {
        row[col(c)]
            .parse()
            .unwrap_or_else(|e| panic!("{c} = {:?}: {e}", row[col(c)]))
    };
    let base_row = rows
        .iter()
        .find(|row| row[col("config")] == g.baseline)
        .expect("a baseline row");
    for (row, r) in rows.iter().zip(&g.results) {
        for (speedup, p50) in [
            ("gpu_speedup", "gpu_p50_ms"),
            ("frame_speedup", "wall_frame_p50_ms"),
        ] {
            let want = num(base_row, p50) / num(row, p50);
            let got = num(row, speedup);
            assert!(
                (got - want).abs() <= 1e-12 * want,
                "{}: {speedup} {got}, want {want}",
                r.name
            );
        }
        // results.json agrees (serde_json may read a float 1 ulp off).
        let json = r.gpu_speedup.expect("a speed-up for every configuration");
        assert!(
            (json - num(row, "gpu_speedup")).abs() <= 1e-12 * json,
            "{}",
            r.name
        );
    }

    // Markdown and HTML: every configuration, the floors, plots, images.
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for r in &g.results {
        assert!(
            md.contains(&format!("| {} (`{}`)", r.name, r.opt)),
            "{}",
            r.name
        );
        assert!(html.contains(&r.name));
    }
    assert!(md.contains("Floors") && md.contains("mffr-far"));
    assert_eq!(html.matches("<svg").count(), 1 + g.results.len());
    for src in html.split("<img src=\"").skip(1) {
        let rel = &src[..src.find('"').unwrap()];
        let img = image::open(out.join(rel)).unwrap();
        assert_eq!((img.width(), img.height()), (160, 120), "{rel}");
    }
}

#[test]
fn tune_writes_a_config_run_accepts() {
    let dir = common::scratch("bench", "tune");
    let file = dir.join("tuned.toml");
    let stdout = ok(&[
        "tune",
        "--budget-ms",
        "10000",
        "--max-flip",
        "0.2",
        "--scene",
        "factory:300",
        "--hmd",
        "monado-sim",
        "--scale",
        "0.25",
        "--frames",
        "2",
        "--out",
        file.to_str().unwrap(),
    ]);
    assert!(stdout.contains("chose "), "{stdout}");
    let text = std::fs::read_to_string(&file).unwrap();
    let opt_line = text.lines().find(|l| l.starts_with("opt = ")).unwrap();
    // The rule itself is tested on constructed inputs with known answers
    // (src/bench/tune.rs); here: what the command printed and wrote is
    // that rule's choice from the measurements it wrote.
    let results: BenchResults = serde_json::from_str(
        &std::fs::read_to_string(file.with_extension("bench").join("results.json")).unwrap(),
    )
    .unwrap();
    let goal = TuneGoal {
        budget_ms: 10000.0,
        max_flip: Some(0.2),
        max_flicker: None,
        foveated: false,
    };
    let chosen = tune::choose(&results, &goal).unwrap().chosen;
    assert_eq!(results.groups[0].results.len(), 1 + tune::CANDIDATES.len());
    assert_eq!(opt_line, format!("opt = {:?}", chosen.opt));
    assert!(
        stdout.contains(&format!("chose {} (`{}`)", chosen.name, chosen.opt)),
        "{stdout}"
    );
    // The reports name the choice and its limits; the chart marks it.
    let c = results
        .choice
        .as_ref()
        .expect("the choice is in results.json");
    assert_eq!(
        (c.name.as_str(), c.budget_ms, c.max_flip),
        (chosen.name.as_str(), 10000.0, Some(0.2))
    );
    assert_eq!(c.why.len(), tune::CANDIDATES.len());
    let bench = file.with_extension("bench");
    let md = std::fs::read_to_string(bench.join("report.md")).unwrap();
    assert!(md.starts_with("# vergence tune report"), "{md}");
    assert!(
        md.contains(&format!("**{}** (`{}`)", chosen.name, chosen.opt)),
        "{md}"
    );
    assert!(
        md.contains("Frame budget: 10000.000 ms") && md.contains("FLIP mean cap: 0.2"),
        "{md}"
    );
    let html = std::fs::read_to_string(bench.join("report.html")).unwrap();
    assert!(html.contains("<h2>Choice</h2>"));
    let svg = &html[html.find("<svg").expect("a chart")..];
    assert!(svg.contains("chosen"), "the chart marks the choice");

    let out = dir.join("render");
    ok(&[
        "render",
        "--scene",
        "factory:300",
        "--hmd",
        "monado-sim",
        "--width",
        "64",
        "--height",
        "48",
        "--config",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("stats.json")).unwrap()).unwrap();
    let want = vergence::bench::plan::config_from_opt(&chosen.opt).unwrap();
    assert_eq!(stats["config"]["stereo"], want.frame.stereo.name());
    assert_eq!(stats["config"]["cull"], want.culling.cull.name());
    assert_eq!(stats["config"]["msaa"], want.frame.msaa);
}

fn fails(args: &[&str], expect: &str) {
    let out = vergence(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && out.status.code() != Some(101),
        "{args:?}: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        stderr.contains(expect),
        "{args:?} should mention '{expect}': {stderr}"
    );
}

#[test]
fn bad_bench_and_tune_input_is_named() {
    let dir = common::scratch("bench", "bad");
    let plan = dir.join("bad-plan.toml");
    std::fs::write(
        &plan,
        "name = \"x\"\nscenes = [\"factory:10\"]\nhmds = [\"monado-sim\"]\nframes = 2\n[[configs]]\nname = \"a\"\nopt = \"hyperdrive\"\n",
    )
    .unwrap();
    fails(&["bench", "--plan", plan.to_str().unwrap()], "hyperdrive");
    fails(&["bench", "--plan", "nonesuch"], "not a shipped plan");
    fails(&["tune", "--budget-ms", "-3"], "--budget-ms");
    fails(
        &["tune", "--budget-ms", "5", "--max-flip", "NaN"],
        "--max-flip",
    );
    let cfg = dir.join("cfg.toml");
    std::fs::write(&cfg, "opt = \"multiview\"\ncolour = 3\n").unwrap();
    fails(
        &[
            "render",
            "--config",
            cfg.to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
        ],
        "colour",
    );
    assert!(Path::new(&dir).exists());
}

/// Starts `vergence bench --plan PLAN --out OUT` in the background.
fn spawn_bench(plan: &Path, out: &Path, stderr: std::process::Stdio) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_vergence"))
        .arg("bench")
        .arg("--plan")
        .arg(plan)
        .arg("--out")
        .arg(out)
        .stdout(std::process::Stdio::null())
        .stderr(stderr)
        .spawn()
        .unwrap()
}

#[test]
fn ctrl_c_writes_what_finished() {
    let dir = common::scratch("bench", "interrupt");
    let plan = dir.join("long.toml");
    let mut text = String::from(
        "name = \"long\"\nscenes = [\"factory:500\"]\nhmds = [\"monado-sim\"]\nscales = [0.25]\nwarmup = 1\nframes = 20000\nerror_frames = 1\n",
    );
    for i in 0..3 {
        text.push_str(&format!(
            "[[configs]]\nname = \"c{i}\"\nopt = \"two-pass\"\n"
        ));
    }
    std::fs::write(&plan, text).unwrap();
    let out = dir.join("out");
    let mut child = spawn_bench(&plan, &out, std::process::Stdio::piped());
    // Let it run a moment (the reference takes far longer than this), then
    // interrupt.
    std::thread::sleep(std::time::Duration::from_millis(1500));
    // SAFETY: signalling our own child.
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let started = std::time::Instant::now();
    let status = child.wait().unwrap();
    assert!(started.elapsed().as_secs() < 10, "exits promptly");
    let mut stderr = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
    assert!(!status.success(), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    let results: BenchResults =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert!(!results.complete);
    // Nothing unfinished is reported as if it were measured.
    assert!(results.groups.iter().all(|g| g.results.is_empty()));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("INCOMPLETE"));
}

#[test]
fn ctrl_c_keeps_the_finished_group_and_drops_the_unfinished_configuration() {
    let dir = common::scratch("bench", "interrupt-late");
    let plan = dir.join("two-groups.toml");
    // A small group that finishes in seconds, then a large one that would
    // take minutes.
    let mut text = String::from(
        "name = \"two\"\nscenes = [\"factory:300\"]\nhmds = [\"monado-sim\"]\nscales = [0.1, 2.0]\nwarmup = 1\nframes = 150\nerror_frames = 1\nbaseline = \"b\"\n",
    );
    for name in ["b", "c"] {
        text.push_str(&format!(
            "[[configs]]\nname = \"{name}\"\nopt = \"two-pass,per-eye\"\n"
        ));
    }
    std::fs::write(&plan, text).unwrap();
    let out = dir.join("out");
    let mut child = spawn_bench(&plan, &out, std::process::Stdio::null());
    let first_done = out.join("images/factory_300-monado-sim-0.1/c.png");
    let t = std::time::Instant::now();
    while !first_done.exists() {
        assert!(
            t.elapsed().as_secs() < 120,
            "the first group never finished"
        );
        assert!(child.try_wait().unwrap().is_none(), "exited early");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    std::thread::sleep(std::time::Duration::from_millis(300));
    // SAFETY: signalling our own child.
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let status = child.wait().unwrap();
    assert!(!status.success());
    let results: BenchResults =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert!(!results.complete);
    let first = &results.groups[0];
    let names: Vec<&str> = first.results.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(names, ["reference", "b", "c"]);
    assert!(first
        .results
        .iter()
        .all(|r| r.frames == 150 && r.gpu_speedup.is_some()));
    // The second group had started when the signal came: it is reported,
    // holding only what finished before the signal (a prefix of the plan),
    // each configuration fully measured.
    assert_eq!(results.groups.len(), 2, "the started group is reported");
    let second = &results.groups[1];
    assert_eq!(second.scale, 2.0);
    let names: Vec<&str> = second.results.iter().map(|r| r.name.as_str()).collect();
    assert!(
        names.len() < 3 && ["reference", "b", "c"].starts_with(&names),
        "{names:?}"
    );
    assert!(second.results.iter().all(|r| r.frames == 150));
}

#[test]
fn a_plan_measures_timewarp_against_rendered_frames() {
    let dir = common::scratch("bench", "timewarp");
    let plan = dir.join("tw.toml");
    let body = "name = \"tw\"\nscenes = [\"factory:2000\"]\nhmds = [\"monado-sim\"]\nscales = [0.5]\nwarmup = 3\nframes = 4\nerror_frames = 2\npath_seed = 7\nreference = \"two-pass\"\n\n[[configs]]\nname = \"plain\"\nopt = \"multiview\"\n\n[[configs]]\nname = \"tw3\"\nopt = \"multiview,timewarp=3\"\n\n[[configs]]\nname = \"tw2-rotation\"\nopt = \"multiview,timewarp=2,timewarp-rotation\"\n\n[[configs]]\nname = \"tw2\"\nopt = \"multiview,timewarp=2\"\n";
    std::fs::write(&plan, body).unwrap();
    let out = dir.join("out");
    run_plan(&plan, &out);
    let json = std::fs::read_to_string(out.join("results.json")).unwrap();
    let results: BenchResults = serde_json::from_str(&json).unwrap();
    assert_eq!(results.validation_messages, 0);
    let plain = get(&results, "plain");
    assert!(plain.timewarp.is_none());
    let plain_flip = plain.error.as_ref().unwrap().flip_mean;
    for (name, k, variant) in [
        ("tw3", 3, "depth"),
        ("tw2-rotation", 2, "rotation"),
        ("tw2", 2, "depth"),
    ] {
        let r = get(&results, name);
        let tw = r
            .timewarp
            .as_ref()
            .unwrap_or_else(|| panic!("{name}: no timewarp"));
        assert_eq!((tw.k, tw.variant.as_str()), (k, variant), "{name}");
        // Two compared frames, each warped from K - 1 earlier frames.
        assert_eq!(tw.warps, 2 * (k - 1), "{name}");
        // The head moves along the path: warps are close, not exact.
        assert!(
            tw.flip_vs_rendered > 1e-4 && tw.flip_vs_rendered < 0.5,
            "{name}: {tw:?}"
        );
        assert!(tw.warp_gpu_ms > 0.0, "{name}: {tw:?}");
        let per_frame = (r.gpu_frame_ms.p50 + (k - 1) as f64 * tw.warp_gpu_ms) / k as f64;
        assert!(
            (tw.gpu_ms_per_displayed_frame - per_frame).abs() < 1e-9,
            "{name}"
        );
        let e = r.error.as_ref().unwrap();
        assert_eq!(e.frames, 2 * (k - 1), "{name}: every warp compared");
        assert!(
            e.flip_mean > plain_flip,
            "{name}: {} vs {plain_flip}",
            e.flip_mean
        );
        assert!(out.join(r.image.as_ref().unwrap()).is_file());
    }
    // Older frames warp worse: K = 3 averages ages 1 and 2, K = 2 age 1.
    let (tw2, tw3) = (
        get(&results, "tw2").timewarp.as_ref().unwrap(),
        get(&results, "tw3").timewarp.as_ref().unwrap(),
    );
    assert!(
        tw2.flip_vs_rendered < tw3.flip_vs_rendered,
        "{tw2:?} vs {tw3:?}"
    );
    // Each compared frame needs K - 1 frames before it.
    std::fs::write(&plan, body.replace("warmup = 3", "warmup = 0")).unwrap();
    fails(
        &["bench", "--plan", plan.to_str().unwrap()],
        "raise warmup to at least 1",
    );
    // The reference is rendered, never warped.
    std::fs::write(
        &plan,
        body.replace(
            "reference = \"two-pass\"",
            "reference = \"two-pass,timewarp=2\"",
        ),
    )
    .unwrap();
    fails(
        &["bench", "--plan", plan.to_str().unwrap()],
        "`reference` does not run it",
    );
}

/// The desk overlay's on-demand error (F4 in `view`): the reference
/// configuration against itself is exact (FLIP 0, a black heat map), 1×
/// MSAA against it is not; the heat map has the eye's size.
#[test]
fn the_on_demand_error_is_zero_for_the_reference_and_not_for_1x() {
    use vergence::targets::error_probe::{measure, reference_of};
    let ctx = common::context();
    let scene = common::load("factory:1500");
    let profile = vergence::view::profile::HmdProfile::load("valve-index").unwrap();
    let rig = profile.rig(common::framing_pose(&scene, &profile));
    let extent = ash::vk::Extent2D {
        width: 96,
        height: 96,
    };
    let base = vergence::config::RenderConfig::default();
    let same = measure(&ctx, &scene, &reference_of(&base), (&rig, 0.0), extent).unwrap();
    assert_eq!(same.flip_mean, 0.0);
    assert_eq!(same.heatmap.dimensions(), (96, 96));
    let mut one = base.clone();
    one.apply_opts("multiview,no-msaa", &vergence::config::cull_names())
        .unwrap();
    let r = measure(&ctx, &scene, &one, (&rig, 0.0), extent).unwrap();
    assert!(r.flip_mean > 0.0 && r.flip_mean < 0.2, "{}", r.flip_mean);
    assert_eq!(r.opt, one.opt_string());
    assert_eq!(ctx.validation_messages(), 0, "{:#?}", ctx.validation_log());
}

/// The temporal error (`flicker`) is reported per configuration: 0 for a
/// configuration rendering exactly as the reference, more at 1× MSAA than
/// at 4× (edges shimmer as the view turns by sub-pixel steps), and off with
/// `flicker_frames = 0`.
#[test]
fn flicker_is_zero_for_the_reference_and_larger_without_msaa() {
    let dir = common::scratch("bench", "flicker");
    let plan = dir.join("flicker.toml");
    let body = "name = \"flicker\"\nscenes = [\"factory:2000\"]\nhmds = [\"valve-index\"]\nscales = [0.12]\nwarmup = 1\nframes = 2\nerror_frames = 1\nflicker_frames = 6\nspin_up_ms = 0\n\n[[configs]]\nname = \"same\"\nopt = \"two-pass,msaa4\"\n\n[[configs]]\nname = \"mv4\"\nopt = \"multiview,msaa4\"\n\n[[configs]]\nname = \"mv1\"\nopt = \"multiview,no-msaa\"\n";
    std::fs::write(&plan, body).unwrap();
    let results = run_plan(&plan, &dir.join("out"));
    let f = |name: &str| get(&results, name).flicker.expect("flicker measured");
    assert!(get(&results, "reference").flicker.is_none());
    assert_eq!(f("same"), 0.0);
    assert!(f("mv1") > f("mv4"), "1x {} vs 4x {}", f("mv1"), f("mv4"));
    let md = std::fs::read_to_string(dir.join("out").join("report.md")).unwrap();
    assert!(md.contains("Temporal error (flicker"), "{md}");
    // Off: no sequence rendered, no field.
    std::fs::write(
        &plan,
        body.replace("flicker_frames = 6", "flicker_frames = 0"),
    )
    .unwrap();
    let results = run_plan(&plan, &dir.join("off"));
    assert!(results.groups[0]
        .results
        .iter()
        .all(|r| r.flicker.is_none()));
}

#[test]
fn raster_floors_times_every_route_without_validation_messages() {
    let out = ok(&[
        "raster-floors",
        "--width",
        "64",
        "--height",
        "48",
        "--repeats",
        "3",
        // Mesa 25's lavapipe crashes executing an empty multiview scope (a
        // SIGSEGV in its queue thread, libvulkan_lvp.so); the H200 runs
        // the default two views.
        "--views",
        "1",
        "--json",
    ]);
    let report: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(report["extent"], serde_json::json!([64, 48]));
    assert_eq!(report["samples"], 4);
    assert_eq!(report["views"], 1);
    assert_eq!(report["validation_messages"], 0, "{out}");
    let timings = report["timings"].as_array().unwrap();
    let names: Vec<&str> = timings
        .iter()
        .map(|t| t["variant"]["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        vergence::bench::raster_floors::VARIANTS
            .iter()
            .map(|v| v.name)
            .collect::<Vec<_>>()
    );
    for t in timings {
        let (p50, min) = (t["p50_ms"].as_f64().unwrap(), t["min_ms"].as_f64().unwrap());
        assert!(min > 0.0 && min <= p50 && p50.is_finite(), "{t}");
    }
}

/// With `inset` the bench measures FLIP inside the inset rectangle
/// (`flip_inset_mean`): far below the whole image's there (the inset is
/// the full-density render; the error lies in the magnified periphery),
/// wherever the gaze puts it; a configuration without an inset is
/// measured over the plan's first inset's rectangle (the same pixels); in
/// the CSV's last column, the report's table and the target line.
#[test]
fn the_inset_error_is_measured_inside_the_inset() {
    let dir = common::scratch("bench", "inset-error");
    let plan = dir.join("inset.toml");
    let body = "name = \"inset-error\"\nscenes = [\"factory:2000\"]\nhmds = [\"valve-index\"]\nscales = [0.2]\nwarmup = 1\nframes = 2\nerror_frames = 1\nflicker_frames = 0\nspin_up_ms = 0\nreference = \"two-pass\"\nbaseline = \"two-pass-per-eye\"\n\n[[configs]]\nname = \"two-pass-per-eye\"\nopt = \"two-pass,per-eye\"\n\n[[configs]]\nname = \"inset\"\nopt = \"multiview,superfrustum,inset\"\n\n[[configs]]\nname = \"inset-up-left\"\nopt = \"multiview,superfrustum,inset,gaze=-0.4:-0.3\"\n";
    std::fs::write(&plan, body).unwrap();
    let out = dir.join("out");
    let results = run_plan(&plan, &out);
    let base = get(&results, "two-pass-per-eye")
        .error
        .expect("error measured");
    let base_inside = base
        .flip_inset_mean
        .expect("measured over the inset's pixels");
    assert!(base_inside >= 0.0 && base_inside.is_finite());
    for name in ["inset", "inset-up-left"] {
        let e = get(&results, name).error.expect("error measured");
        let inside = e.flip_inset_mean.expect("inset error measured");
        assert!(e.flip_mean > 0.0, "{name}: {e:?}");
        assert!(
            inside < 0.5 * e.flip_mean,
            "{name}: inside {inside} vs overall {}",
            e.flip_mean
        );
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("Inside the inset"), "{md}");
    let checks = std::fs::read_to_string(out.join("checks.md")).unwrap();
    assert!(
        checks.contains("Target (inset vs two-pass-per-eye"),
        "{checks}"
    );
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    let head = csv_fields(csv.lines().next().unwrap());
    let col = head.iter().position(|h| h == "flip_inset_mean").unwrap();
    let rows: Vec<Vec<String>> = csv.lines().skip(1).map(csv_fields).collect();
    let cell = |name: &str| {
        rows.iter()
            .find(|r| r[6] == name)
            .map(|r| r[col].clone())
            .unwrap()
    };
    let base_cell: f64 = cell("two-pass-per-eye").parse().unwrap();
    assert_eq!(base_cell, base_inside);
    let inside: f64 = cell("inset").parse().unwrap();
    assert_eq!(
        Some(inside),
        get(&results, "inset").error.unwrap().flip_inset_mean
    );
}

/// `reference_supersample = 2`: the reference is rendered at twice the
/// eye size and box-filtered down, so the configuration that renders as
/// the plain reference would (`two-pass,msaa4`) now has an image and a
/// temporal error of its own (its aliasing against a converged image),
/// and 1× MSAA still flickers more; the report says how the reference was
/// made.
#[test]
fn a_supersampled_reference_gives_the_baseline_an_error_of_its_own() {
    let dir = common::scratch("bench", "supersample");
    let plan = dir.join("ss.toml");
    let body = "name = \"ss\"\nscenes = [\"factory:2000\"]\nhmds = [\"valve-index\"]\nscales = [0.12]\nwarmup = 1\nframes = 2\nerror_frames = 1\nflicker_frames = 6\nspin_up_ms = 0\nreference = \"two-pass,msaa4\"\nreference_supersample = 2\nbaseline = \"same\"\n\n[[configs]]\nname = \"same\"\nopt = \"two-pass,msaa4\"\n\n[[configs]]\nname = \"mv1\"\nopt = \"multiview,no-msaa\"\n\n[[configs]]\nname = \"inset\"\nopt = \"multiview,superfrustum,inset,inset-wide-1x\"\n";
    std::fs::write(&plan, body).unwrap();
    let out = dir.join("out");
    let results = run_plan(&plan, &out);
    let same = get(&results, "same");
    let flip = same.error.expect("error measured").flip_mean;
    let flicker = same.flicker.expect("flicker measured");
    assert!(flip > 0.0 && flip < 0.1, "FLIP {flip}");
    assert!(flicker > 0.0, "flicker {flicker}");
    let mv1 = get(&results, "mv1");
    assert!(
        mv1.flicker.unwrap() > flicker,
        "{:?} vs {flicker}",
        mv1.flicker
    );
    assert!(mv1.error.unwrap().flip_mean > flip);
    // The inset's flicker split by region: the shares cover the visible
    // pixels, weight the means into the whole, and the one-sample
    // half-size wide view shimmers more than the 4x inset.
    let inset = get(&results, "inset");
    let r = inset.flicker_regions.expect("regions measured");
    let parts = [r.inset, r.seam, r.periphery];
    let share: f64 = parts.iter().map(|p| p.share).sum();
    let whole: f64 = parts.iter().map(|p| p.mean * p.share).sum();
    assert!((share - 1.0).abs() < 1e-9, "{r:?}");
    let total = inset.flicker.unwrap();
    assert!(
        (whole - total).abs() < 1e-6 * total.max(1e-3),
        "{whole} vs {total}"
    );
    assert!(parts.iter().all(|p| p.share > 0.0), "{r:?}");
    assert!(r.periphery.mean > r.inset.mean, "{r:?}");
    // Without an inset, over the same pixels as the plan's inset: the
    // baseline's regions compare with the inset's.
    let base = same
        .flicker_regions
        .expect("baseline regions over the inset's pixels");
    assert!(
        (base.inset.share - r.inset.share).abs() < 1e-9,
        "{base:?} {r:?}"
    );
    assert!(same.error.unwrap().flip_inset_mean.is_some());
    // A perfect wide view of that size flickers less than the one-sample
    // render, and not at all like the reference.
    let floor = inset.flicker_floor.expect("floor measured");
    assert!(
        floor > 0.0 && floor < total,
        "floor {floor}, flicker {total}"
    );
    assert!(same.flicker_floor.is_none());
    let map = image::open(out.join(inset.flicker_heatmap.as_ref().unwrap())).unwrap();
    assert_eq!(
        map.width(),
        image::open(out.join(same.image.as_ref().unwrap()))
            .unwrap()
            .width()
    );
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("rendered at 2× the eye size"), "{md}");
    assert!(md.contains("| feathered seam |"), "{md}");
    assert!(md.contains("floor (perfect wide view)"), "{md}");
    let image = image::open(out.join(get(&results, "reference").image.as_ref().unwrap())).unwrap();
    let same_image = image::open(out.join(same.image.as_ref().unwrap())).unwrap();
    assert_eq!(image.width(), same_image.width());
}

/// `tune --reference-supersample 2 --max-flicker baseline`: the reference
/// is rendered at twice the eye size, the baseline candidate measures a
/// flicker of its own against it, and the stack tune writes flickers no
/// more than that (the rule's own tests are in src/bench/tune.rs).
#[test]
fn tune_caps_flicker_at_the_baselines_against_a_supersampled_reference() {
    let dir = common::scratch("bench", "tune-ss");
    let file = dir.join("tuned.toml");
    let stdout = ok(&[
        "tune",
        "--budget-ms",
        "10000",
        "--max-flicker",
        "baseline",
        "--reference-supersample",
        "2",
        "--scene",
        "factory:300",
        "--hmd",
        "monado-sim",
        "--scale",
        "0.2",
        "--frames",
        "2",
        "--out",
        file.to_str().unwrap(),
    ]);
    let results: BenchResults = serde_json::from_str(
        &std::fs::read_to_string(file.with_extension("bench").join("results.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(results.plan.as_ref().unwrap().reference_supersample, 2);
    let base = get(&results, "baseline").flicker.expect("baseline flicker");
    assert!(base > 0.0, "the baseline against a 2x reference: {base}");
    let text = std::fs::read_to_string(&file).unwrap();
    let opt_line = text.lines().find(|l| l.starts_with("opt = ")).unwrap();
    let chosen = results.groups[0]
        .results
        .iter()
        .find(|r| opt_line == format!("opt = {:?}", r.opt))
        .expect("the written stack was measured");
    assert!(chosen.flicker.unwrap() <= base, "{stdout}");
    // Some candidate flickers more than the baseline and says so.
    assert!(
        stdout.contains(&format!("over the cap {base:.6} (the baseline's)")),
        "{stdout}"
    );
    // The checks judge the capped threshold against the same cap.
    let md = std::fs::read_to_string(file.with_extension("bench").join("checks.md")).unwrap();
    assert!(
        md.contains(&format!(
            "Target (the fastest configuration at FLIP mean ≤ 0.01 and flicker ≤ baseline's {base:.6}: ≥ 3× lower GPU frame time): "
        )),
        "{md}"
    );
}

/// From a folder outside the repository: every shipped plan resolves by
/// name and checks (its scene and profile paths resolve against the plan's
/// own folder), a plan given by its full path too, and running the smoke
/// plan twice into an output folder named like it works (the folder does
/// not hide the plan).
#[test]
fn shipped_plans_work_by_name_from_any_folder() {
    let away = common::scratch("bench", "elsewhere");
    std::fs::create_dir_all(&away).unwrap();
    let attempt = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
            .args(args)
            .current_dir(&away)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned()
            + &String::from_utf8_lossy(&out.stderr);
        (out.status.success(), text)
    };
    let run = |args: &[&str]| {
        let (ok, text) = attempt(args);
        assert!(ok, "{args:?} from {}: {text}", away.display());
        text
    };
    let names = vergence::bench::plan::shipped_names();
    assert!(
        names.len() >= 20 && names.iter().any(|n| n == "ufo-lod"),
        "{names:?}"
    );
    for name in &names {
        match attempt(&["bench", "--plan", name, "--check"]) {
            (true, said) => assert!(said.contains(": ok"), "{name}: {said}"),
            // The point-cloud plans read scans the user makes first
            // (`vergence scan`, docs/points.md) in the working folder.
            (false, said) => assert!(
                said.starts_with("error:") && said.contains("bench-data/"),
                "{name}: {said}"
            ),
        }
    }
    let full = common::root().join("manifests/bench/default.toml");
    run(&["bench", "--plan", full.to_str().unwrap(), "--check"]);
    for _ in 0..2 {
        run(&[
            "bench", "--plan", "smoke", "--frames", "2", "--out", "smoke",
        ]);
    }
    assert!(away.join("smoke/report.md").is_file());
}

/// A plan with several head paths: one group per seed, each along its
/// own path (different frames, so different times), and the reports'
/// spread over them.
#[test]
fn several_head_paths_give_a_group_each_and_their_spread() {
    let dir = common::scratch("bench", "seeds");
    let plan = dir.join("seeds.toml");
    let text = "name = \"seeds\"\nscenes = [\"factory:500\"]\nhmds = [\"monado-sim\"]\nscales = [0.25]\nwarmup = 1\nframes = 3\nerror_frames = 1\nflicker_frames = 0\npath_seeds = [3, 4]\nbaseline = \"two-pass\"\n[[configs]]\nname = \"two-pass\"\nopt = \"two-pass,per-eye\"\n[[configs]]\nname = \"no-msaa\"\nopt = \"multiview,no-msaa\"\n";
    std::fs::write(&plan, text).unwrap();
    let out = dir.join("out");
    let results = run_plan(&plan, &out);
    let seeds: Vec<u64> = results.groups.iter().map(|g| g.path_seed).collect();
    assert_eq!(seeds, [3, 4]);
    for g in &results.groups {
        assert_eq!(g.results.len(), 3, "reference and two configurations");
        let img = out.join(g.results[1].image.as_ref().unwrap());
        assert!(img
            .to_str()
            .unwrap()
            .contains(&format!("-seed{}", g.path_seed)));
        assert!(img.is_file(), "{}", img.display());
    }
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains(
            "Across head paths: factory:500 · monado-sim · scale 0.25 over head path seeds 3, 4"
        ),
        "{report}"
    );
    assert!(report.contains("| no-msaa | 2/2 |"), "{report}");
    assert!(report.contains("head path seed 4"), "{report}");
    // Duplicate seeds are refused before anything runs.
    std::fs::write(&plan, text.replace("[3, 4]", "[3, 3]")).unwrap();
    let out = vergence(&["bench", "--plan", plan.to_str().unwrap(), "--check"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("path_seeds repeats a seed"),
        "{stderr}"
    );
}

/// A plan whose gaze moves: the inset follows the tracker's report
/// (50 ms late), so its images differ from the centred plan's, and the
/// foveated error is measured at the true gaze.
#[test]
fn the_inset_follows_a_scripted_gaze() {
    let dir = common::scratch("bench", "gaze");
    let plan = dir.join("gaze.toml");
    let text = "name = \"gaze\"\nscenes = [\"factory:500\"]\nhmds = [\"monado-sim\"]\nscales = [0.25]\nwarmup = 30\nframes = 3\nerror_frames = 1\nflicker_frames = 0\npath_seed = 2\nGAZE\nbaseline = \"two-pass\"\n[[configs]]\nname = \"two-pass\"\nopt = \"two-pass,per-eye\"\n[[configs]]\nname = \"inset\"\nopt = \"multiview,inset=0.5,inset-fov=12\"\n";
    let run = |gaze: &str, name: &str| {
        std::fs::write(&plan, text.replace("GAZE", gaze)).unwrap();
        let out = dir.join(name);
        let results = run_plan(&plan, &out);
        let inset = results.groups[0].results[2].clone();
        let image = image::open(out.join(inset.image.as_ref().unwrap()))
            .unwrap()
            .to_rgba8();
        (results, inset, image)
    };
    let (_, centred, centred_image) = run("gaze = \"centre\"", "centre");
    let (results, moving, moving_image) =
        run("gaze = \"saccades\"\ngaze_latency_ms = 50", "saccades");
    let p = results.plan.as_ref().unwrap();
    assert_eq!(p.gaze, vergence::bench::plan::GazeKind::Saccades);
    assert_eq!(p.gaze_latency_ms, 50.0);
    assert_ne!(centred_image, moving_image, "the inset moved with the gaze");
    let (c, m) = (centred.error.unwrap(), moving.error.unwrap());
    assert!(m.flip_foveated_mean.unwrap() <= m.flip_mean + 1e-9);
    assert_ne!(c.flip_foveated_mean, m.flip_foveated_mean);
    // An unknown gaze path and an impossible latency are refused.
    for (bad, says) in [
        ("gaze = \"left\"", "gaze"),
        ("gaze_latency_ms = 900", "gaze_latency_ms = 900"),
    ] {
        std::fs::write(&plan, text.replace("GAZE", bad)).unwrap();
        let out = vergence(&["bench", "--plan", plan.to_str().unwrap(), "--check"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && stderr.contains(says), "{stderr}");
    }
}
