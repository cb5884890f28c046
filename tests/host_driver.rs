//! On a host whose lavapipe is older than Mesa 23 (Debian 12 ships Mesa
//! 22.3, which crashes inside the driver on vergence's frames), `vergence`
//! refuses with one `error:` line naming the driver version and the way
//! that works, and exit status 1, instead of dying with SIGSEGV.
//!
//! The host's own Vulkan stack is the point, so this test must run on the
//! host: a process it spawns runs wherever the test runs, and under
//! `scripts/in-root` (cargo's runner in `cargo xtask test`) that is the
//! Debian 13 root with Mesa 25. `cargo xtask test` therefore runs this test
//! a second time without the runner. Where there is no old lavapipe (inside
//! the root, or another host) it prints why it skipped.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// The lavapipe ICD manifest and the upstream Mesa version of the package
/// that installed it (Debian's package database), or why they are unknown.
fn lavapipe() -> Result<(PathBuf, String), String> {
    let dir = Path::new("/usr/share/vulkan/icd.d");
    let icd = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("lvp_icd") && n.ends_with(".json"))
        })
        .ok_or_else(|| format!("no lavapipe ICD (lvp_icd*.json) in {}", dir.display()))?;
    let text = |cmd: &mut Command| -> Result<String, String> {
        let out = cmd.output().map_err(|e| format!("{cmd:?}: {e}"))?;
        if !out.status.success() {
            return Err(format!("{cmd:?} failed ({})", out.status));
        }
        Ok(String::from_utf8_lossy(&out.stdout).into_owned())
    };
    // "mesa-vulkan-drivers:amd64: /usr/share/vulkan/icd.d/lvp_icd.x86_64.json"
    let owner = text(Command::new("dpkg-query").arg("-S").arg(&icd))?;
    let package = owner
        .split(": ")
        .next()
        .filter(|p| !p.is_empty())
        .ok_or_else(|| format!("no package owns {}", icd.display()))?
        .to_string();
    // "22.3.6-1+deb12u2" (maybe with an epoch "1:"): upstream "22.3.6".
    let version = text(Command::new("dpkg-query").args(["-W", "-f=${Version}", &package]))?;
    let upstream = version.rsplit(':').next().unwrap_or_default();
    let upstream = upstream.split(['-', '+', '~']).next().unwrap_or_default();
    Ok((icd, upstream.to_string()))
}

#[test]
fn old_host_lavapipe_is_refused_with_one_error_line() {
    let (icd, mesa) = match lavapipe() {
        Ok(found) => found,
        Err(why) => {
            eprintln!("skipped: cannot tell this machine's lavapipe version ({why})");
            return;
        }
    };
    let major: u32 = match mesa.split('.').next().and_then(|m| m.parse().ok()) {
        Some(m) => m,
        None => {
            eprintln!(
                "skipped: unreadable Mesa version {mesa:?} for {}",
                icd.display()
            );
            return;
        }
    };
    if major >= 23 {
        eprintln!(
            "skipped: lavapipe here is Mesa {mesa} (not older than 23, nothing to refuse; inside the Debian 13 root this is expected)"
        );
        return;
    }
    let out_dir = common::scratch("host-driver", "render");
    let out = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args(["render", "--scene", "factory:1", "--out"])
        .arg(&out_dir)
        // Only the host's lavapipe, so it is the device vergence picks.
        .env("VK_DRIVER_FILES", &icd)
        .env("VK_ICD_FILENAMES", &icd)
        .env("VERGENCE_VALIDATION", "0")
        .env_remove("VERGENCE_DEVICE")
        .output()
        .expect("vergence runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{}: {stderr}", out.status);
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "one error line expected: {stderr}");
    let line = errors[0];
    assert!(
        line.contains(&format!("lavapipe from Mesa {mesa}")),
        "names Mesa {mesa}: {line}"
    );
    assert!(
        line.contains("scripts/in-root") && line.contains("cargo xtask xr"),
        "{line}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}
