//! Device faults: a lost GPU and a scene that does not fit in GPU memory
//! each give one error line naming what happened, and a non-zero exit.

mod common;

use std::process::Command;

/// The one `error:` line of a failing run.
fn failing(cmd: &mut Command) -> String {
    let stderr = common::fails_with_one_error(cmd);
    let line = stderr.lines().find(|l| l.starts_with("error:"));
    line.expect("checked").to_string()
}

#[test]
fn device_lost_names_the_last_pass_and_fails() {
    let out = common::scratch("faults", "lost");
    for (opt, pass) in [("", "forward"), ("rdm", "rdm-fill")] {
        let err = failing(
            Command::new(env!("CARGO_BIN_EXE_vergence"))
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
                    "10",
                    "--opt",
                    opt,
                    "--stats-out",
                ])
                .arg(out.join("stats.json"))
                .env("VERGENCE_INJECT_FAULT", "device-lost@3"),
        );
        assert!(err.contains("GPU device was lost"), "{err}");
        assert!(
            err.contains(&format!("'{pass}'")),
            "names the last pass {pass}: {err}"
        );
    }
}

#[test]
fn a_scene_over_the_gpu_memory_budget_is_refused_with_the_need_and_the_budget() {
    let out = common::scratch("faults", "oom");
    let err = failing(
        Command::new(env!("CARGO_BIN_EXE_vergence"))
            .args([
                "render",
                "--scene",
                "factory:100000",
                "--hmd",
                "monado-sim",
                "--out",
            ])
            .arg(&out)
            .env("VERGENCE_GPU_MEMORY_BUDGET_MB", "4"),
    );
    assert!(
        err.contains("not enough GPU memory for scene factory:100000"),
        "{err}"
    );
    assert!(err.contains("of the 4.0 MiB budget"), "{err}");
    let need: f64 = err
        .split("it needs ")
        .nth(1)
        .and_then(|s| s.split(" MiB").next())
        .and_then(|s| s.parse().ok())
        .expect("need in MiB");
    // 100,000 instances are 6.1 MiB of matrices alone.
    assert!(need >= 6.1, "{err}");
    // A budget that fits renders.
    let ok = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args([
            "render",
            "--scene",
            "factory:200",
            "--hmd",
            "monado-sim",
            "--width",
            "32",
            "--height",
            "32",
            "--out",
        ])
        .arg(&out)
        .env("VERGENCE_GPU_MEMORY_BUDGET_MB", "256")
        .output()
        .unwrap();
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
}

/// Every image and every buffer `render` makes, failed in turn
/// (`VERGENCE_INJECT_FAULT=image@N`, `buffer@N`, N = 1, 2, … until the
/// render succeeds): each failure is one `error:` line naming the injected
/// fault and a non-zero exit, never a panic, and everything made before it
/// is destroyed: no allocation left behind (gpu-allocator's leak report)
/// and no object left at device destruction (the validation layer's
/// VUIDs). Over the paths that make the most: the inset in multiview and
/// in two-pass with aq and the stencil mask, RDM, LMS, occlusion culling.
#[test]
fn every_allocation_failure_is_one_error_and_leaves_nothing_behind() {
    let out = common::scratch("faults", "sweep");
    for kind in ["image", "buffer"] {
        for opt in [
            "multiview",
            "inset",
            "two-pass,stencil-mask,inset,aq",
            "rdm",
            "two-pass,lms",
            "superfrustum,gpu-cull,occlusion",
        ] {
            let mut n = 1;
            loop {
                assert!(n <= 150, "{kind}@{n} with {opt}: still failing");
                let o = Command::new(env!("CARGO_BIN_EXE_vergence"))
                    .args(["render", "--scene", "factory:200", "--hmd", "monado-sim"])
                    .args(["--width", "64", "--height", "48", "--opt", opt, "--out"])
                    .arg(&out)
                    .env("VERGENCE_INJECT_FAULT", format!("{kind}@{n}"))
                    // The leak report is a warning; objects left at device
                    // destruction are validation errors.
                    .env("RUST_LOG", "warn")
                    .env("VERGENCE_VALIDATION", "required")
                    .output()
                    .expect("vergence runs");
                let stderr = String::from_utf8_lossy(&o.stderr);
                for bad in ["leak detected", "VUID", "panicked"] {
                    assert!(
                        !stderr.contains(bad),
                        "{kind}@{n} with {opt}: {bad}:\n{stderr}"
                    );
                }
                if o.status.success() {
                    // The sweep has passed every allocation the render makes.
                    assert!(n > 3, "{kind} with {opt}: only {} made", n - 1);
                    break;
                }
                assert_ne!(o.status.code(), Some(101), "{kind}@{n} with {opt}");
                let errors: Vec<&str> =
                    stderr.lines().filter(|l| l.starts_with("error:")).collect();
                assert_eq!(errors.len(), 1, "{kind}@{n} with {opt}:\n{stderr}");
                assert!(
                    errors[0].contains("injected by VERGENCE_INJECT_FAULT"),
                    "{kind}@{n} with {opt}: {}",
                    errors[0]
                );
                n += 1;
            }
        }
    }
}
