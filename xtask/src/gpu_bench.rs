//! `cargo xtask gpu-bench`: prepares `target/gpu-bench/` for a GPU machine
//! that has a driver but no Rust and no Vulkan loader: the release binary
//! (stripped), the loader package and the run script. One command there
//! (`bash target/gpu-bench/run.sh default`) writes the report.

use super::{apt_install, repo, run};
use std::path::Path;
use std::process::Command;

/// Packages the GPU machine lacks: the Vulkan loader, and the GL vendor
/// neutral dispatch libraries the NVIDIA Vulkan driver links against.
const LOADER_DEBS: &[&str] = &[
    "libvulkan1",
    "libglvnd0",
    "libegl1",
    "libgl1",
    "libglx0",
    "libgles2",
    "libopengl0",
];

/// Builds the release binary (installing `glslc` first where neither
/// `$GLSLC` nor `glslc` runs), strips it and puts it, the loader packages
/// and the run script into `target/gpu-bench/`; `args` may name the plan
/// the hint prints.
pub fn gpu_bench(args: &[String]) -> Result<(), String> {
    let dir = repo().join("target/gpu-bench");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    // The build compiles the shaders with glslc (build.rs runs $GLSLC or
    // the one on PATH); only where neither runs is the package installed.
    let glslc = std::env::var("GLSLC").unwrap_or_else(|_| "glslc".into());
    if Command::new(&glslc).arg("--version").output().is_err() {
        apt_install(&["glslc"], "the shader compiler glslc is missing")?;
    }
    run(Command::new(env!("CARGO")).current_dir(repo()).args([
        "build",
        "--release",
        "-j2",
        "-p",
        "vergence",
        "--bin",
        "vergence",
    ]))?;
    let bin = dir.join("vergence");
    std::fs::copy(repo().join("target/release/vergence"), &bin)
        .map_err(|e| format!("copying the release binary: {e}"))?;
    run(Command::new("strip").arg(&bin))?;
    std::fs::copy(repo().join("scripts/gpu-bench"), dir.join("run.sh"))
        .map_err(|e| format!("copying scripts/gpu-bench: {e}"))?;
    fetch_loader(&dir)?;
    let plan = args.first().map_or("default", String::as_str);
    eprintln!(
        "xtask: gpu-bench: ready in {dir}\n\
         On the GPU machine, from the repository root (with target/gpu-bench carried):\n    \
         bash target/gpu-bench/run.sh {plan}\n\
         It writes bench.tgz (report.md, report.html, results.json, results.csv, images/), \
         report.md, results.json and device.txt into $OUT (or ./gpu-bench-out).\n\
         Commit report.md as bench/results/<date>-<gpu>.md.",
        dir = dir.display()
    );
    Ok(())
}

/// Downloads the amd64 packages of [`LOADER_DEBS`] into `dir` unless they
/// are there.
fn fetch_loader(dir: &Path) -> Result<(), String> {
    let names: Vec<String> = std::fs::read_dir(dir)
        .map_err(|e| e.to_string())?
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    let missing: Vec<&str> = LOADER_DEBS
        .iter()
        .copied()
        .filter(|p| !names.iter().any(|n| n.starts_with(&format!("{p}_"))))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    let lists = std::env::temp_dir().join("vergence-apt-amd64");
    std::fs::create_dir_all(lists.join("partial")).map_err(|e| e.to_string())?;
    let opts = [
        "-oAPT::Architecture=amd64".to_string(),
        "-oAPT::Architectures=amd64".to_string(),
        format!("-oDir::State::Lists={}", lists.display()),
    ];
    let fetch = |verb: &[&str]| {
        run(Command::new("apt-get")
            .current_dir(dir)
            .args(&opts)
            .args(verb))
    };
    let download: Vec<&str> = std::iter::once("download")
        .chain(missing.iter().copied())
        .collect();
    fetch(&["update"])
        .and_then(|()| fetch(&download))
        .map_err(|e| {
            format!(
                "{e}\nfetching the Vulkan loader packages failed; download them (amd64) by hand: \
                 cd {} && apt-get download {}",
                dir.display(),
                missing.join(" ")
            )
        })
}
