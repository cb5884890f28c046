//! The Windows binary runs: `vergence.exe` (cross-built by `cargo xtask
//! test` for x86_64-pc-windows-gnu, named by `VERGENCE_WINDOWS_EXE`) renders
//! a scene under Wine, with lavapipe reached through Wine's Vulkan, and its
//! images match the Linux binary's. Without the executable or without Wine
//! the test says why on stderr and checks nothing else.
//!
//! Wine's Vulkan hides the host's layers from the application, so the
//! Windows binary cannot ask for validation itself; the host's Vulkan
//! loader, which Wine's Vulkan calls, inserts the validation layer (with
//! synchronization validation) by its own environment variables instead,
//! and any message the layer prints fails the test.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// The scene and view both binaries render: a small factory from a fixed
/// pose, multiview at 4× MSAA.
const ARGS: &[&str] = &[
    "--scene",
    "factory:300",
    "--hmd",
    "valve-index",
    "--pose",
    "0,1.6,12,0,-10,0",
    "--width",
    "192",
    "--height",
    "160",
];

/// The Windows executable to run, or why there is none.
fn windows_exe() -> Result<PathBuf, String> {
    let exe = std::env::var_os("VERGENCE_WINDOWS_EXE")
        .ok_or("VERGENCE_WINDOWS_EXE is not set (cargo xtask test sets it when it could cross-build the Windows binary)")?;
    let exe = PathBuf::from(exe);
    if !exe.is_file() {
        return Err(format!("{} does not exist", exe.display()));
    }
    if !common::on_path("wine") {
        return Err("Wine is not installed (the test root's `wine` package)".into());
    }
    Ok(exe)
}

/// `wine EXE render ARGS --out OUT` in a Wine prefix of its own under
/// `dir`, without a display, the host loader inserting the validation
/// layer; panics with Wine's output when it fails, when the layer did not
/// load, or when it reported anything.
fn render_under_wine(exe: &Path, dir: &Path, out: &Path) {
    let output = Command::new("wine")
        .arg(exe)
        .arg("render")
        .args(ARGS)
        .arg("--out")
        .arg(out)
        .env("WINEPREFIX", dir.join("prefix"))
        .env("WINEDEBUG", "-all")
        .env("WINEDLLOVERRIDES", "mscoree,mshtml=")
        .env("VERGENCE_VALIDATION", "off")
        .env("VK_LOADER_LAYERS_ENABLE", "*validation")
        .env(
            "VK_LAYER_ENABLES",
            "VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT",
        )
        .env("VK_LOADER_DEBUG", "layer")
        .env_remove("DISPLAY")
        .output()
        .expect("wine starts");
    let text = format!(
        "{}\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        output.status.success(),
        "vergence.exe under Wine failed ({}):\n{text}",
        output.status
    );
    assert!(
        text.contains("Insert instance layer \"VK_LAYER_KHRONOS_validation\""),
        "the validation layer did not load under Wine:\n{text}"
    );
    let messages: Vec<&str> = text
        .lines()
        .filter(|l| {
            l.contains("VUID-")
                || l.contains("Validation Error")
                || l.contains("Validation Warning")
        })
        .collect();
    assert!(messages.is_empty(), "validation under Wine: {messages:#?}");
}

#[test]
fn the_windows_binary_renders_the_linux_binarys_images() {
    let exe = match windows_exe() {
        Ok(e) => e,
        Err(why) => {
            eprintln!("skipped: the Windows binary under Wine: {why}");
            return;
        }
    };
    let dir = common::scratch("windows", "wine");
    let (win, linux) = (dir.join("windows"), dir.join("linux"));
    render_under_wine(&exe, &dir, &win);
    let stats = common::render_cli(ARGS, &linux);
    let text = std::fs::read_to_string(win.join("stats.json")).expect("stats.json from Windows");
    let win_stats: serde_json::Value = serde_json::from_str(&text).expect("stats.json is JSON");
    // The same scene, the same draws.
    for key in ["draw_calls", "instances_drawn", "triangles"] {
        assert_eq!(win_stats[key], stats[key], "{key}");
    }
    for eye in ["left", "right"] {
        let read = |d: &Path| {
            image::open(d.join(format!("{eye}.png")))
                .unwrap()
                .to_rgba8()
        };
        let (w, l) = (read(&win), read(&linux));
        let flip = vergence::bench::metrics::flip(&l, &w, 30.0).unwrap();
        assert!(flip.mean <= 0.01, "{eye}: FLIP {} against Linux", flip.mean);
        // Not an empty frame that trivially matches another empty one.
        let distinct: std::collections::HashSet<_> = l.pixels().map(|p| p.0).collect();
        assert!(distinct.len() > 50, "{eye}: the scene is in view");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
