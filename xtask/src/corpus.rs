//! The bad-input corpus stays what its generator writes: `cargo xtask
//! test` runs `scripts/make-bad-inputs.py` into a scratch folder and
//! compares every file it writes with the committed `tests/bad_inputs/`.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Files the generator indexes but leaves to others (written by vergence's
/// own writers in tests, kept as committed).
const WRITTEN_ELSEWHERE: &[&str] = &["points/e57-nan.e57"];

/// Regenerates the corpus under `target/tmp/corpus-check` and compares it
/// with the committed one; without python3 it says so and skips.
pub fn check(repo: &Path) -> Result<(), String> {
    if Command::new("python3").arg("--version").output().is_err() {
        eprintln!("xtask: corpus check skipped: python3 is not installed");
        return Ok(());
    }
    let scratch = repo.join("target/tmp/corpus-check");
    let _ = std::fs::remove_dir_all(&scratch);
    std::fs::create_dir_all(scratch.join("tests"))
        .map_err(|e| format!("{}: {e}", scratch.display()))?;
    // The generator reads the vendored assets and links one case to
    // Cargo.toml, both relative to where it runs.
    for name in ["assets", "Cargo.toml"] {
        std::os::unix::fs::symlink(repo.join(name), scratch.join(name))
            .map_err(|e| format!("linking {name}: {e}"))?;
    }
    crate::run(
        Command::new("python3")
            .arg(repo.join("scripts/make-bad-inputs.py"))
            .current_dir(&scratch),
    )?;
    let (made, kept) = (
        scratch.join("tests/bad_inputs"),
        repo.join("tests/bad_inputs"),
    );
    let mut drift = Vec::new();
    for rel in files(&made, &made)?
        .iter()
        .chain(files(&kept, &kept)?.iter())
    {
        if WRITTEN_ELSEWHERE.contains(&rel.to_string_lossy().as_ref()) {
            continue;
        }
        if !same(&made.join(rel), &kept.join(rel)) {
            drift.push(rel.display().to_string());
        }
    }
    drift.sort();
    drift.dedup();
    if drift.is_empty() {
        return Ok(());
    }
    Err(format!(
        "tests/bad_inputs differs from what scripts/make-bad-inputs.py writes (add the case to the script, then run it from the repository root): {}",
        drift.join(", ")
    ))
}

/// Every file and link under `dir`, relative to `base`.
fn files(dir: &Path, base: &Path) -> Result<Vec<PathBuf>, String> {
    let mut out = Vec::new();
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for entry in entries {
        let path = entry.map_err(|e| e.to_string())?.path();
        let meta = std::fs::symlink_metadata(&path).map_err(|e| e.to_string())?;
        if meta.is_dir() {
            out.extend(files(&path, base)?);
        } else {
            out.push(path.strip_prefix(base).expect("under base").to_path_buf());
        }
    }
    Ok(out)
}

/// Whether `a` and `b` are the same file content, or links to the same
/// target.
fn same(a: &Path, b: &Path) -> bool {
    match (std::fs::read_link(a), std::fs::read_link(b)) {
        (Ok(x), Ok(y)) => x == y,
        (Err(_), Err(_)) => {
            matches!((std::fs::read(a), std::fs::read(b)), (Ok(x), Ok(y)) if x == y)
        }
        _ => false,
    }
}
