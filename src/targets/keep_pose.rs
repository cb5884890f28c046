//! Keeping a pose found on the desk (F8 in `view`): the fly camera's pose
//! is printed as a `--pose` value (for `render` and `view`) and the floor
//! under it as a `--spawn` value (for `run`), and appended as a named
//! `[[viewpoint]]` — the floor point and the heading, as scene manifests
//! list them — to a file beside the session (default
//! `vergence-viewpoints.toml`), from which it can be pasted into a scene
//! manifest; the `--spawn` value also works as `run --viewpoint`.

use crate::error::Result;
use crate::view::Pose;
use std::io::Write as _;
use std::path::Path;

/// The key that keeps the current pose.
pub const KEY: winit::keyboard::KeyCode = winit::keyboard::KeyCode::F8;

/// Where F8 appends by default.
pub const DEFAULT_FILE: &str = "vergence-viewpoints.toml";

/// The eyes' height above the floor point ([`crate::targets::framing::EYE_HEIGHT`]).
const EYE_HEIGHT: f64 = super::framing::EYE_HEIGHT;

/// The `--spawn` value of the floor under `head`: x,y,z of the floor
/// point and the heading (yaw) in degrees.
pub fn spawn_arg(head: &Pose) -> String {
    let (yaw, _, _) = head.to_euler_deg();
    let p = head.position;
    format!("{:.6},{:.6},{:.6},{yaw:.6}", p.x, p.y - EYE_HEIGHT, p.z)
}

/// The `[[viewpoint]]` entry of `head` named `name`.
pub fn viewpoint_entry(head: &Pose, name: &str) -> String {
    let (yaw, _, _) = head.to_euler_deg();
    let p = head.position;
    format!(
        "\n[[viewpoint]]\nname = {name:?}\nposition = [{:.6}, {:.6}, {:.6}]  # the floor under the eyes\nyaw_deg = {yaw:.6}\n# --pose {}\n",
        p.x,
        p.y - EYE_HEIGHT,
        p.z,
        head.pose_arg()
    )
}

/// Appends `head` as viewpoint `name` to `file` (through the file layer:
/// a regular file, never one of this session's inputs, never through a
/// link) and returns the line to print.
pub fn keep(head: &Pose, name: &str, file: &Path) -> Result<String> {
    let mut f = crate::fsio::open_append(file)?;
    f.write_all(viewpoint_entry(head, name).as_bytes())
        .map_err(|e| crate::error::Error::Output {
            path: file.to_path_buf(),
            message: e.to_string(),
        })?;
    Ok(format!(
        "pose: --pose {} (run: --spawn {}); appended as {name:?} to {}",
        head.pose_arg(),
        spawn_arg(head),
        file.display()
    ))
}

/// One `[[viewpoint]]` entry: the floor point under the eyes and the
/// heading.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    name: String,
    position: [f64; 3],
    #[serde(default)]
    yaw_deg: f64,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Entries {
    #[serde(default)]
    viewpoint: Vec<Entry>,
}

/// Most viewpoints one file may hold.
pub const MAX_VIEWPOINTS: usize = 10_000;

/// The viewpoints of a `[[viewpoint]]` file (as [`keep`] appends them):
/// each entry's name and the tracking origin it gives (the floor point,
/// facing its heading). A file that is not one — unreadable, over the
/// text limit, not TOML of that shape, no entries, a value out of range —
/// is one error naming what is wrong.
pub fn read_viewpoints(path: &Path) -> Result<Vec<(String, Pose)>> {
    let err =
        |m: String| crate::error::Error::config("--viewpoint", format!("{}: {m}", path.display()));
    let text = crate::fsio::read_text(path, crate::fsio::MAX_TEXT_FILE_BYTES)
        .map_err(|e| err(e.to_string()))?;
    parse_viewpoints(&text).map_err(err)
}

/// The viewpoints of `[[viewpoint]]` TOML `text` ([`read_viewpoints`]),
/// or what is wrong with it.
pub fn parse_viewpoints(text: &str) -> std::result::Result<Vec<(String, Pose)>, String> {
    let entries: Entries = toml::from_str(text).map_err(|e| e.message().to_string())?;
    if entries.viewpoint.is_empty() || entries.viewpoint.len() > MAX_VIEWPOINTS {
        return Err(format!(
            "{} viewpoints (1 to {MAX_VIEWPOINTS} [[viewpoint]] entries)",
            entries.viewpoint.len()
        ));
    }
    entries
        .viewpoint
        .into_iter()
        .map(|e| {
            let ok = e
                .position
                .iter()
                .all(|v| v.is_finite() && v.abs() <= crate::cli::MAX_DISTANCE_M)
                && e.yaw_deg.is_finite()
                && e.yaw_deg.abs() <= 1e6;
            if !ok {
                return Err(format!(
                    "viewpoint '{}': position or yaw_deg out of range",
                    e.name.escape_debug()
                ));
            }
            let pose = Pose::from_euler_deg(glam::DVec3::from(e.position), e.yaw_deg, 0.0, 0.0);
            Ok((e.name, pose))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[derive(serde::Deserialize)]
    struct Entry {
        name: String,
        position: [f64; 3],
        yaw_deg: f64,
    }

    #[derive(serde::Deserialize)]
    struct File {
        viewpoint: Vec<Entry>,
    }

    #[test]
    fn kept_poses_append_as_viewpoints_that_give_the_pose_back() {
        let dir = std::env::temp_dir().join(format!("vergence-keep-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join(DEFAULT_FILE);
        let a = Pose::from_euler_deg(DVec3::new(512_000.25, 31.6, -4_100_000.5), 37.5, 0.0, 0.0);
        let b = Pose::from_euler_deg(DVec3::new(-3.0, 1.6, 2.0), -120.0, -10.0, 0.0);
        let line = keep(&a, "entrance", &file).unwrap();
        keep(&b, "gallery", &file).unwrap();
        assert!(line.contains(&format!("--pose {}", a.pose_arg())), "{line}");
        assert!(
            line.contains("--spawn 512000.250000,30.000000,-4100000.500000,37.5"),
            "{line}"
        );
        let text = crate::fsio::read_cache(&file, 1 << 20).unwrap();
        let parsed: File = toml::from_str(std::str::from_utf8(&text).unwrap()).unwrap();
        assert_eq!(parsed.viewpoint.len(), 2);
        assert_eq!(parsed.viewpoint[0].name, "entrance");
        let p = parsed.viewpoint[0].position;
        assert!((DVec3::from(p) - DVec3::new(512_000.25, 30.0, -4_100_000.5)).length() < 1e-5);
        assert!((parsed.viewpoint[0].yaw_deg - 37.5).abs() < 1e-6);
        assert!((parsed.viewpoint[1].yaw_deg + 120.0).abs() < 1e-6);
        // The spawn string parses as run's --spawn.
        let spawn: Vec<f64> = spawn_arg(&b)
            .split(',')
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(spawn.len(), 4);
        assert!((spawn[1] - 0.0).abs() < 1e-9 && (spawn[3] + 120.0).abs() < 1e-6);
        // run --viewpoint reads the file back: the origins under the eyes.
        let back = read_viewpoints(&file).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[1].0, "gallery");
        let eyes = Pose::from_euler_deg(DVec3::new(0.0, EYE_HEIGHT, 0.0), 0.0, 0.0, 0.0);
        let head = back[1].1.compose(&eyes);
        assert!((head.position - b.position).length() < 1e-5);
        // Not a viewpoints file: one error naming it.
        let bad = dir.join("bad.toml");
        std::fs::write(&bad, "[[viewpoint]]\nname = 3\n").unwrap();
        let e = read_viewpoints(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.toml") && !e.contains('\n'), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
