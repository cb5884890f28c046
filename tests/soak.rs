//! Shortened soaks (the long runs' figures are in docs/testing.md): memory stays
//! flat over a headless run, and a Monado session stays free of validation
//! messages over many frames.

mod common;

use serde_json::Value;
use std::process::Command;

fn run_stats(cmd: &mut Command, stats: &std::path::Path) -> Value {
    let out = cmd.output().expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    serde_json::from_str(&std::fs::read_to_string(stats).unwrap()).unwrap()
}

#[test]
fn headless_rss_and_gpu_memory_stay_flat() {
    let dir = common::scratch("soak", "headless");
    let stats = dir.join("stats.json");
    let frames = 1500;
    let s = run_stats(
        Command::new(env!("CARGO_BIN_EXE_vergence"))
            .args([
                "run",
                "--xr",
                "headless",
                "--scene",
                "factory:500",
                "--hmd-fallback",
                "monado-sim",
                "--width",
                "64",
                "--height",
                "48",
                "--opt",
                "superfrustum,stencil-mask",
                "--frames",
                &frames.to_string(),
                "--stats-out",
            ])
            .arg(&stats),
        &stats,
    );
    assert_eq!(s["frames_submitted"], frames);
    // Every frame is in the file although none was kept in memory.
    assert_eq!(s["frames"].as_array().unwrap().len(), frames as usize);
    assert!(!dir.join("stats.frames.tmp").exists(), "spool removed");
    let rss = &s["rss"];
    assert!(rss["samples"].as_u64().unwrap() >= 20, "{rss}");
    let growth = rss["growth_bytes"].as_i64().unwrap();
    assert!(
        growth <= 1 << 20,
        "RSS grew {growth} bytes after warm-up: {rss}"
    );
    let gpu = s["gpu_allocated_bytes"].as_array().unwrap();
    assert!(gpu[0].as_u64().unwrap() > 0);
    assert_eq!(gpu[0], gpu[1], "GPU allocations flat");
}

#[test]
fn monado_session_of_many_frames_has_no_validation_messages() {
    let dir = common::scratch("soak", "monado");
    let stats = dir.join("stats.json");
    let s = run_stats(
        Command::new(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/with-monado"))
            .arg(env!("CARGO_BIN_EXE_vergence"))
            .args([
                "run",
                "--xr",
                "openxr",
                "--scene",
                "factory:500",
                "--width",
                "64",
                "--height",
                "48",
                "--opt",
                "superfrustum,stencil-mask",
                "--frames",
                "600",
                "--stats-out",
            ])
            .arg(&stats)
            .env("VERGENCE_XR_RUNDIR", dir.join("run")),
        &stats,
    );
    assert_eq!(s["mode"], "openxr");
    assert_eq!(s["frames_submitted"], 600);
    assert_eq!(s["validation_messages"], 0);
    assert_eq!(s["xr_validation_messages"], 0);
    let gpu = s["gpu_allocated_bytes"].as_array().unwrap();
    assert_eq!(gpu[0], gpu[1], "GPU allocations flat");
}
