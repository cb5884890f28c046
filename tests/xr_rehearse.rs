//! A rehearsed visit: `vergence run --rehearse manifests/rehearse/visit.toml`
//! under Monado's remote driver plays the shipped script into the runtime's
//! controllers, and the run ends by itself when the script ends. The frame
//! records must hold what the script does: the floor selected, the tools
//! picked on the panel, 35 cm measured, a section plane placed and removed,
//! a snap turn and a teleport. Runs inside the Debian 13 root like
//! tests/xr_input.rs; fails, not skips, without Monado.

mod common;

use serde_json::Value;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The kinds of `kind` events in the frame records, in order.
fn events<'a>(frames: &'a [Value], kind: &str) -> Vec<&'a Value> {
    frames
        .iter()
        .flat_map(|f| f["events"].as_array().into_iter().flatten())
        .filter(|e| e["kind"] == kind)
        .collect()
}

#[test]
fn the_shipped_visit_plays_through_the_runtime_and_ends_the_run() {
    let dir = common::root().join("target/xr-tests/rehearse");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let stats_path = dir.join("stats.json");
    let script = common::root().join("manifests/rehearse/visit.toml");
    let started = Instant::now();
    let out = Command::new(common::root().join("scripts/with-monado"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env("VERGENCE_XR_RUNDIR", dir.join("run"))
        .env("RUST_LOG", "vergence=info")
        .env("NO_COLOR", "1")
        .arg("--remote")
        .arg(env!("CARGO_BIN_EXE_vergence"))
        .args(["run", "--xr", "openxr", "--scene", "factory:2000"])
        .args(["--width", "160", "--height", "120", "--mirror", "off"])
        .args(["--opt", "superfrustum", "--seconds", "120"])
        .args([
            "--spawn",
            "1,0,-1,-90",
            "--move-speed",
            "1.5",
            "--snap-turn",
            "45",
        ])
        .arg("--rehearse")
        .arg(&script)
        .arg("--stats-out")
        .arg(&stats_path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .expect("with-monado");
    let log = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{}\n{log}", out.status);
    // The script is 18.9 s long: the run ended with it, not at --seconds.
    let took = started.elapsed();
    assert!(took < Duration::from_secs(100), "{took:?}: {log}");
    assert!(log.contains("rehearse: teleport"), "{log}");
    let s: Value = serde_json::from_str(&std::fs::read_to_string(&stats_path).unwrap()).unwrap();
    assert_eq!(
        s["exit"], "session exited after vergence asked to exit",
        "{log}"
    );
    assert_eq!(s["validation_messages"], 0, "{log}");
    assert_eq!(s["xr_validation_messages"], 0, "{log}");
    let frames = s["frames"].as_array().expect("frames").clone();

    let selects = events(&frames, "select");
    assert_eq!(selects.len(), 1, "{selects:?}");
    assert_eq!(selects[0]["mesh"], "floor", "{}", selects[0]);
    let pressed: Vec<&str> = events(&frames, "panel_button")
        .iter()
        .map(|e| e["button"].as_str().unwrap())
        .collect();
    assert_eq!(
        pressed,
        ["tool:measure", "tool:section", "tool:select", "close"]
    );
    let tools: Vec<&str> = events(&frames, "tool")
        .iter()
        .map(|e| e["tool"].as_str().unwrap())
        .collect();
    assert_eq!(tools, ["measure", "section", "select"]);
    let measures = events(&frames, "measure");
    assert_eq!(measures.len(), 1, "{measures:?}");
    let d = measures[0]["distance_m"].as_f64().unwrap();
    assert!((d - 0.35).abs() <= 0.001, "measured {d} m");
    let sections = events(&frames, "section");
    assert_eq!(sections.len(), 2, "placed and removed: {sections:?}");
    assert!(sections[1]["plane"].is_null());
    let turns = events(&frames, "turn");
    assert_eq!(turns.len(), 1, "{turns:?}");
    assert_eq!(turns[0]["degrees"].as_f64(), Some(45.0));
    assert_eq!(events(&frames, "teleport").len(), 1);
}

#[test]
fn a_rehearsal_needs_an_openxr_runtime() {
    let script = common::root().join("manifests/rehearse/visit.toml");
    let err = common::fails_with_one_error(
        Command::new(env!("CARGO_BIN_EXE_vergence"))
            .args(["run", "--xr", "headless", "--frames", "1", "--rehearse"])
            .arg(&script),
    );
    assert!(
        err.contains("--rehearse") && err.contains("--xr openxr"),
        "{err}"
    );
}
