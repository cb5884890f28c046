//! `run --stats-out`: the summary's frame-time quantiles agree with the
//! frames the same file lists.

mod common;

use std::process::Command;

/// Nearest-rank median of `v`.
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[(v.len() as f64 * 0.5).ceil() as usize - 1]
}

#[test]
fn the_summary_medians_are_the_frames_medians() {
    let out = common::scratch("run-stats", "median").join("stats.json");
    let status = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args([
            "run",
            "--xr",
            "headless",
            "--scene",
            "factory:200",
            "--hmd-fallback",
            "monado-sim",
            "--width",
            "64",
            "--height",
            "48",
            "--frames",
            "41",
            "--stats-out",
        ])
        .arg(&out)
        .status()
        .expect("vergence runs");
    assert!(status.success());
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let frames = s["frames"].as_array().expect("frames");
    assert!(frames.len() >= 30, "{} frames", frames.len());
    for (key, summary) in [("cpu_ms", "cpu_frame_ms"), ("gpu_ms", "gpu_frame_ms")] {
        let v: Vec<f64> = frames
            .iter()
            .filter(|f| f["should_render"].as_bool() == Some(true))
            .filter_map(|f| f[key].as_f64())
            .collect();
        let exact = median(v);
        let got = s["summary"][summary]["median"].as_f64().unwrap();
        assert!(
            (got / exact - 1.0).abs() <= 1e-3,
            "{summary}: summary {got} against the frames' {exact}"
        );
    }
}
