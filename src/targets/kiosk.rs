//! `run --kiosk FILE.toml`: a demo install in one file. The scenes on offer
//! (each with its spawn and viewpoints; N in the mirror window moves to the
//! next, ending the session in order and starting one on the next scene),
//! the optimizations the run starts with and which toggles may be used,
//! reconnecting when the runtime goes away, going back to the spawn after
//! a while without head motion, and a log file that rotates by size.
//! `manifests/kiosk/demo.toml` is a sample.

use super::toggles::{parse_list, Toggle};
use crate::config::{cull_names, RenderConfig};
use crate::error::{Error, Result};
use crate::view::Pose;
use glam::DVec3;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// The file as written.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKiosk {
    name: String,
    #[serde(default)]
    opt: String,
    #[serde(default)]
    toggles: Option<Vec<String>>,
    #[serde(default)]
    reconnect: bool,
    #[serde(default)]
    idle_return_s: f64,
    #[serde(default)]
    mirror: Option<String>,
    #[serde(default)]
    log: Option<RawLog>,
    scenes: Vec<RawScene>,
}

#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLog {
    file: String,
    #[serde(default = "default_max_kb")]
    max_kb: u64,
    #[serde(default = "default_keep")]
    keep: u32,
}

fn default_max_kb() -> u64 {
    1024
}

fn default_keep() -> u32 {
    3
}

#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    name: String,
    scene: String,
    #[serde(default)]
    spawn: Option<Vec<f64>>,
    #[serde(default)]
    viewpoints: Vec<Vec<f64>>,
    #[serde(default)]
    viewpoint_file: Option<String>,
}

/// One scene on offer.
#[derive(Clone, Debug, PartialEq)]
pub struct KioskScene {
    /// Its name (shown in the window title and the log).
    pub name: String,
    /// The `--scene` value (a path relative to the kiosk file's folder when
    /// such a file exists there).
    pub scene: String,
    /// Where visitors start (None: framing the scene).
    pub spawn: Option<Pose>,
    /// Further viewpoints (the right stick click cycles through them).
    pub viewpoints: Vec<Pose>,
}

/// The log file settings.
#[derive(Clone, Debug, PartialEq)]
pub struct KioskLog {
    /// The file (relative paths from the kiosk file's folder).
    pub file: PathBuf,
    /// Size at which it rotates, in bytes.
    pub max_bytes: u64,
    /// Rotated files kept (FILE.1 newest ... FILE.keep oldest).
    pub keep: u32,
}

/// A checked kiosk file.
#[derive(Clone, Debug, PartialEq)]
pub struct Kiosk {
    /// Its name.
    pub name: String,
    /// The `--opt` list the run starts with (applied after `--config` and
    /// `--opt`).
    pub opt: String,
    /// The toggles the mirror window's keys may use.
    pub toggles: Vec<Toggle>,
    /// Reconnect when the runtime is lost (as `--reconnect`).
    pub reconnect: bool,
    /// Back to the spawn after this many seconds without head motion
    /// (None: never).
    pub idle_return_s: Option<f64>,
    /// The mirror mode (None: as `--mirror` says).
    pub mirror: Option<super::mirror::MirrorMode>,
    /// The log file (None: no log file).
    pub log: Option<KioskLog>,
    /// The scenes on offer, the first shown first.
    pub scenes: Vec<KioskScene>,
}

/// Most scenes a kiosk offers.
pub const MAX_SCENES: usize = 64;
/// Most viewpoints per scene.
pub const MAX_VIEWPOINTS: usize = 64;
/// Longest idle time accepted (seconds).
pub const MAX_IDLE_S: f64 = 86_400.0;

fn pose_of(what: &str, v: &[f64]) -> std::result::Result<Pose, String> {
    if v.len() != 4 {
        return Err(format!(
            "{what}: expected [x, y, z, yaw] (4 numbers), got {}",
            v.len()
        ));
    }
    if v.iter().any(|x| !x.is_finite() || x.abs() > 1e7) {
        return Err(format!("{what}: values must be finite and within ±1e7"));
    }
    let p = Pose::from_euler_deg(DVec3::new(v[0], v[1], v[2]), v[3], 0.0, 0.0);
    p.validate().map_err(|m| format!("{what}: {m}"))?;
    Ok(p)
}

fn printable(what: &str, s: &str) -> std::result::Result<(), String> {
    if s.trim().is_empty() {
        return Err(format!("{what} is empty"));
    }
    if s.chars().any(char::is_control) || s.len() > 256 {
        return Err(format!(
            "{what} must be at most 256 bytes without control characters"
        ));
    }
    Ok(())
}

impl Kiosk {
    /// Reads and checks a kiosk file (size-bounded, known keys only, every
    /// value in range); errors name the file and the problem.
    pub fn load(path: &Path) -> Result<Kiosk> {
        let err = |m: String| Error::config("--kiosk", format!("{}: {m}", path.display()));
        let text = crate::fsio::read_text(path, crate::fsio::MAX_TEXT_FILE_BYTES)
            .map_err(|e| err(e.to_string()))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        Kiosk::parse(&text, dir).map_err(err)
    }

    /// Loads every scene once, in order, so a scene that cannot be shown
    /// stops the kiosk at its start (naming the kiosk file, the scene's
    /// key and the problem) rather than when a visitor reaches it. Their
    /// files become this command's inputs, so no log or output replaces
    /// them.
    pub fn check_scenes(&self, path: &Path) -> Result<()> {
        for (i, s) in self.scenes.iter().enumerate() {
            crate::scene::Scene::load(&s.scene).map_err(|e| {
                Error::config(
                    "--kiosk",
                    format!(
                        "{}: scenes[{i}] ({}): scene {}: {e}",
                        path.display(),
                        s.name,
                        s.scene
                    ),
                )
            })?;
        }
        Ok(())
    }

    /// Parses kiosk text; relative paths resolve against `dir`.
    pub fn parse(text: &str, dir: &Path) -> std::result::Result<Kiosk, String> {
        let raw: RawKiosk = toml::from_str(text).map_err(|e| e.message().to_string())?;
        printable("name", &raw.name)?;
        let names = cull_names();
        let mut c = RenderConfig::default();
        c.apply_opts(&raw.opt, &names)
            .and_then(|()| c.validate())
            .and_then(|()| c.refuse_timewarp("run --kiosk"))
            .map_err(|e| format!("opt: {e}"))?;
        let toggles = match &raw.toggles {
            None => Toggle::ALL.to_vec(),
            Some(list) => parse_list(list).map_err(|m| format!("toggles: {m}"))?,
        };
        let s = raw.idle_return_s;
        let idle_return_s = if s == 0.0 {
            None
        } else if s.is_finite() && s > 0.0 && s <= MAX_IDLE_S {
            Some(s)
        } else {
            return Err(format!(
                "idle_return_s = {s}: expected 0 (never) or up to {MAX_IDLE_S} seconds"
            ));
        };
        let mirror = match raw.mirror.as_deref() {
            None => None,
            Some(m) => Some(
                <super::mirror::MirrorMode as clap::ValueEnum>::from_str(m, false).map_err(
                    |_| format!("mirror = \"{m}\": expected left, right, both, cropped or off"),
                )?,
            ),
        };
        let log = raw.log.map(|l| parse_log(l, dir)).transpose()?;
        if raw.scenes.is_empty() || raw.scenes.len() > MAX_SCENES {
            return Err(format!(
                "needs 1 to {MAX_SCENES} [[scenes]], found {}",
                raw.scenes.len()
            ));
        }
        let mut scenes: Vec<KioskScene> = Vec::new();
        for (i, s) in raw.scenes.iter().enumerate() {
            let scene = parse_scene(&format!("scenes[{i}]"), s, dir)?;
            if scenes.iter().any(|o| o.name == scene.name) {
                return Err(format!("scenes[{i}]: the name '{}' is used twice", s.name));
            }
            scenes.push(scene);
        }
        Ok(Kiosk {
            name: raw.name,
            opt: raw.opt,
            toggles,
            reconnect: raw.reconnect,
            idle_return_s,
            mirror,
            log,
            scenes,
        })
    }
}

/// The `[log]` table: a printable file name (relative to `dir`), 1 to
/// 1,000,000 kB before rotating, 1 to 100 files kept.
fn parse_log(l: RawLog, dir: &Path) -> std::result::Result<KioskLog, String> {
    printable("log.file", &l.file)?;
    if !(1..=1_000_000).contains(&l.max_kb) {
        return Err(format!("log.max_kb = {}: expected 1 to 1000000", l.max_kb));
    }
    if !(1..=100).contains(&l.keep) {
        return Err(format!("log.keep = {}: expected 1 to 100", l.keep));
    }
    Ok(KioskLog {
        file: dir.join(&l.file),
        max_bytes: l.max_kb * 1024,
        keep: l.keep,
    })
}

/// One `[[scenes]]` entry (`at` names it in errors): printable name and
/// scene, at most [`MAX_VIEWPOINTS`] viewpoints (those listed, then a
/// `viewpoint_file`'s `[[viewpoint]]` entries, as F8 in `view` appends
/// them), poses checked; the scene
/// resolves against `dir` where a file is there, else stays as written (a
/// generated scene such as `factory:1000`).
fn parse_scene(at: &str, s: &RawScene, dir: &Path) -> std::result::Result<KioskScene, String> {
    printable(&format!("{at}.name"), &s.name)?;
    printable(&format!("{at}.scene"), &s.scene)?;
    if s.viewpoints.len() > MAX_VIEWPOINTS {
        return Err(format!(
            "{at}: at most {MAX_VIEWPOINTS} viewpoints, found {}",
            s.viewpoints.len()
        ));
    }
    let spawn = s
        .spawn
        .as_deref()
        .map(|v| pose_of(&format!("{at}.spawn"), v))
        .transpose()?;
    let viewpoints = s
        .viewpoints
        .iter()
        .enumerate()
        .map(|(k, v)| pose_of(&format!("{at}.viewpoints[{k}]"), v))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let mut viewpoints = viewpoints;
    if let Some(file) = &s.viewpoint_file {
        printable(&format!("{at}.viewpoint_file"), file)?;
        let kept = super::keep_pose::read_viewpoints(&dir.join(file))
            .map_err(|e| format!("{at}.viewpoint_file: {e}"))?;
        viewpoints.extend(kept.into_iter().map(|(_, pose)| pose));
        if viewpoints.len() > MAX_VIEWPOINTS {
            return Err(format!(
                "{at}: at most {MAX_VIEWPOINTS} viewpoints with the file's, found {}",
                viewpoints.len()
            ));
        }
    }
    let local = dir.join(&s.scene);
    let scene = if local.exists() {
        local.to_string_lossy().into_owned()
    } else {
        s.scene.clone()
    };
    Ok(KioskScene {
        name: s.name.clone(),
        scene,
        spawn,
        viewpoints,
    })
}

/// Watches the head for motion: [`IdleWatch::observe`] says when it has
/// stayed within 2 cm and 3° for the whole idle time (once per still spell).
#[derive(Clone, Debug)]
pub struct IdleWatch {
    limit_s: f64,
    anchor: Option<Pose>,
    still_s: f64,
    fired: bool,
}

/// Head movement that counts as motion (metres).
pub const IDLE_MOVE_M: f64 = 0.02;
/// Head rotation that counts as motion (degrees).
pub const IDLE_TURN_DEG: f64 = 3.0;

impl IdleWatch {
    /// After `limit_s` seconds without motion.
    pub fn new(limit_s: f64) -> IdleWatch {
        IdleWatch {
            limit_s,
            anchor: None,
            still_s: 0.0,
            fired: false,
        }
    }

    /// The head (tracking space) `dt` seconds after the last call; true
    /// once the head has been still for the idle time.
    pub fn observe(&mut self, head: &Pose, dt: f64) -> bool {
        let Some(a) = self.anchor else {
            self.anchor = Some(*head);
            return false;
        };
        let moved = a.position.distance(head.position) > IDLE_MOVE_M
            || a.orientation.angle_between(head.orientation).to_degrees() > IDLE_TURN_DEG;
        if moved {
            self.anchor = Some(*head);
            self.still_s = 0.0;
            self.fired = false;
            return false;
        }
        self.still_s += dt.max(0.0);
        if self.still_s >= self.limit_s && !self.fired {
            self.fired = true;
            return true;
        }
        false
    }
}

/// A log file rotated by size: FILE, then FILE.1 (newest) ... FILE.keep.
#[derive(Debug)]
pub struct RotatingLog {
    path: PathBuf,
    max_bytes: u64,
    keep: u32,
    file: std::fs::File,
    size: u64,
    /// Why rotation stopped (reported once; the log then only grows).
    stuck: Option<String>,
}

/// The first line of every log file vergence creates: rotation renames
/// and removes only files that begin with it.
const LOG_MARK: &[u8] = b"# vergence kiosk log\n";

impl RotatingLog {
    /// Opens (appends to) `settings.file` through the file layer (never
    /// through a link, never a FIFO or device, never one of this command's
    /// inputs such as the kiosk file or a scene); a file that exists but
    /// is not a vergence log is refused rather than appended to.
    pub fn open(settings: &KioskLog) -> Result<RotatingLog> {
        let path = settings.file.clone();
        let err = |message: String| Error::Output {
            path: path.clone(),
            message,
        };
        let mut file = crate::fsio::open_append(&path)?;
        let mut size = file.metadata().map(|m| m.len()).unwrap_or(0);
        if size > 0 && !is_ours(&path) {
            return Err(err(format!(
                "exists and is not a vergence kiosk log (it does not begin with {:?}; logs of older vergence versions do not either: move them aside); name another file",
                String::from_utf8_lossy(LOG_MARK).trim_end()
            )));
        }
        if size == 0 {
            file.write_all(LOG_MARK)
                .map_err(|e| err(format!("cannot write the kiosk log: {e}")))?;
            size = LOG_MARK.len() as u64;
        }
        Ok(RotatingLog {
            path,
            max_bytes: settings.max_bytes,
            keep: settings.keep,
            file,
            size,
            stuck: None,
        })
    }

    fn rotated(&self, k: u32) -> PathBuf {
        let mut s = self.path.clone().into_os_string();
        s.push(format!(".{k}"));
        PathBuf::from(s)
    }

    /// Shifts FILE.k to FILE.k+1 (dropping FILE.keep) and FILE to FILE.1,
    /// then starts a new FILE; refused, touching nothing, when any of
    /// those files exists and is not a log vergence made.
    fn rotate(&mut self) -> std::io::Result<()> {
        // The file at the path must still be the one being written.
        if !crate::fsio::is_same_file(&self.file, &self.path) {
            return Err(std::io::Error::other(format!(
                "{} is no longer the log being written; the log is not rotated",
                self.path.display()
            )));
        }
        for k in 1..=self.keep {
            let f = self.rotated(k);
            if std::fs::symlink_metadata(&f).is_ok() && !is_ours(&f) {
                return Err(std::io::Error::other(format!(
                    "{} is not a vergence kiosk log; the log is not rotated over it",
                    f.display()
                )));
            }
        }
        let _ = std::fs::remove_file(self.rotated(self.keep));
        for k in (1..self.keep).rev() {
            let from = self.rotated(k);
            if from.exists() {
                std::fs::rename(&from, self.rotated(k + 1))?;
            }
        }
        std::fs::rename(&self.path, self.rotated(1))?;
        let mut file = crate::fsio::open_append(&self.path)
            .map_err(|e| std::io::Error::other(e.to_string()))?;
        file.write_all(LOG_MARK)?;
        self.file = file;
        self.size = LOG_MARK.len() as u64;
        Ok(())
    }

    /// Appends `bytes` (one or more whole lines), rotating first when they
    /// would take the file past its size.
    pub fn write_lines(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        let full =
            self.size > LOG_MARK.len() as u64 && self.size + bytes.len() as u64 > self.max_bytes;
        // When rotation fails or is refused, the lines still go to the log
        // (longer than its size), the reason is returned once and rotation
        // is not tried again: a half-done rotation retried could remove
        // the file being written.
        let mut rotated = Ok(());
        if full && self.stuck.is_none() {
            if let Err(e) = self.rotate() {
                self.stuck = Some(e.to_string());
                rotated = Err(e);
            }
        }
        self.file.write_all(bytes)?;
        self.size += bytes.len() as u64;
        rotated
    }
}

/// Whether `path` is a regular file (not a link) that begins with
/// [`LOG_MARK`].
fn is_ours(path: &Path) -> bool {
    !crate::fsio::is_link(path)
        && crate::fsio::read_prefix(path, LOG_MARK.len()).is_ok_and(|b| b == LOG_MARK)
}

static LOG: OnceLock<Mutex<RotatingLog>> = OnceLock::new();

/// Starts the process's kiosk log (the tracing events of vergence at info
/// and above go there from now on; see [`LogWriter`]).
pub fn start_log(settings: &KioskLog) -> Result<()> {
    let log = RotatingLog::open(settings)?;
    let _ = LOG.set(Mutex::new(log));
    Ok(())
}

/// Whether a kiosk log is open.
pub fn logging() -> bool {
    LOG.get().is_some()
}

/// A `tracing_subscriber` writer into the kiosk log (nothing when none is
/// open): each event is buffered and written whole.
#[derive(Default)]
pub struct LogWriter {
    buf: Vec<u8>,
}

impl std::io::Write for LogWriter {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.buf.extend_from_slice(b);
        Ok(b.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Drop for LogWriter {
    fn drop(&mut self) {
        if self.buf.is_empty() {
            return;
        }
        if let Some(log) = LOG.get() {
            if let Ok(mut l) = log.lock() {
                // A full disk must not end the demo: the line is dropped.
                // A refused rotation is said once on stderr (not through
                // tracing, which would come back here).
                if let Err(e) = l.write_lines(&self.buf) {
                    eprintln!("vergence: kiosk log: {e}");
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = include_str!("../../manifests/kiosk/demo.toml");

    #[test]
    fn the_sample_kiosk_parses() {
        let k = Kiosk::parse(SAMPLE, Path::new("manifests/kiosk")).unwrap();
        assert!(k.scenes.len() >= 2);
        assert!(k.reconnect);
        assert!(k.idle_return_s.is_some());
        assert!(k.toggles.contains(&Toggle::StencilMask));
        assert!(k.log.is_some());
    }

    #[test]
    fn bad_kiosks_say_what_is_wrong() {
        let base = "name = \"k\"\n[[scenes]]\nname = \"a\"\nscene = \"factory:10\"\n";
        assert!(Kiosk::parse(base, Path::new(".")).is_ok());
        for (text, says) in [
            ("name = \"k\"\n", "scenes"),
            ("name = \"k\"\nscenes = []\n", "needs 1 to"),
            (&format!("{base}colour = 1\n"), "unknown field"),
            (&format!("opt = \"warp\"\n{base}"), "warp"),
            (&format!("toggles = [\"warp\"]\n{base}"), "unknown toggle"),
            (&format!("idle_return_s = -1\n{base}"), "idle_return_s"),
            (&format!("mirror = \"up\"\n{base}"), "mirror"),
            (
                &format!("{base}spawn = [1, 2]\n"),
                "scenes[0].spawn: expected [x, y, z, yaw]",
            ),
            (
                &format!("{base}[[scenes]]\nname = \"a\"\nscene = \"factory\"\n"),
                "used twice",
            ),
            (
                "name = \"k\"\n[log]\nfile = \"k.log\"\nkeep = 0\n[[scenes]]\nname = \"a\"\nscene = \"f\"\n",
                "log.keep",
            ),
        ] {
            let e = Kiosk::parse(text, Path::new(".")).unwrap_err();
            assert!(e.contains(says), "{text}: {e}");
        }
    }

    #[test]
    fn a_scene_takes_the_viewpoints_f8_kept() {
        let dir = std::env::temp_dir().join(format!("vergence-kiosk-vp-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("kept.toml");
        let _ = std::fs::remove_file(&file);
        let head =
            |x: f64, yaw: f64| Pose::from_euler_deg(glam::DVec3::new(x, 1.6, -2.0), yaw, 0.0, 0.0);
        super::super::keep_pose::keep(&head(3.0, 90.0), "door", &file).unwrap();
        super::super::keep_pose::keep(&head(-1.5, -30.0), "stairs", &file).unwrap();
        let text = "name = \"k\"\n[[scenes]]\nname = \"a\"\nscene = \"factory:10\"\nviewpoints = [[0, 0, 0, 0]]\nviewpoint_file = \"kept.toml\"\n";
        let k = Kiosk::parse(text, &dir).unwrap();
        let v = &k.scenes[0].viewpoints;
        assert_eq!(v.len(), 3);
        // The floor under each kept head, with its heading.
        assert!((v[1].position - glam::DVec3::new(3.0, 0.0, -2.0)).length() < 1e-5);
        assert!((v[2].position - glam::DVec3::new(-1.5, 0.0, -2.0)).length() < 1e-5);
        assert!((v[1].to_euler_deg().0 - 90.0).abs() < 1e-4);
        let missing = text.replace("kept.toml", "nowhere.toml");
        let e = Kiosk::parse(&missing, &dir).unwrap_err();
        assert!(
            e.contains("scenes[0].viewpoint_file") && e.contains("nowhere.toml"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_idle_watch_fires_once_per_still_spell() {
        let mut w = IdleWatch::new(1.0);
        let p = Pose::from_euler_deg(DVec3::new(0.0, 1.6, 0.0), 0.0, 0.0, 0.0);
        assert!(!w.observe(&p, 0.0));
        assert!(!w.observe(&p, 0.6));
        assert!(w.observe(&p, 0.6), "still for 1.2 s");
        assert!(!w.observe(&p, 5.0), "once");
        let turned = Pose::from_euler_deg(p.position, 10.0, 0.0, 0.0);
        assert!(!w.observe(&turned, 0.1), "motion resets");
        assert!(!w.observe(&turned, 0.5));
        assert!(w.observe(&turned, 0.6));
        // Tiny wobble is not motion.
        let wobble = Pose::from_euler_deg(turned.position + DVec3::X * 0.005, 10.5, 0.0, 0.0);
        assert!(!w.observe(&wobble, 0.1));
    }

    #[test]
    fn the_log_rotates_by_size() {
        let dir = std::env::temp_dir().join(format!("vergence-kiosk-log-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let settings = KioskLog {
            file: dir.join("k.log"),
            max_bytes: 100,
            keep: 2,
        };
        let mut log = RotatingLog::open(&settings).unwrap();
        for i in 0..20 {
            log.write_lines(format!("line {i:02} of the kiosk log\n").as_bytes())
                .unwrap();
        }
        // Read as caches are (not made inputs: a later test's file could
        // reuse the inode).
        let read = |p: &str| {
            crate::fsio::read_cache(&dir.join(p), 1 << 20)
                .map(|b| String::from_utf8_lossy(&b).into_owned())
                .unwrap_or_default()
        };
        assert!(read("k.log").contains("line 19"));
        assert!(!read("k.log.1").is_empty() && !read("k.log.2").is_empty());
        assert!(!dir.join("k.log.3").exists(), "keeps 2");
        for f in ["k.log", "k.log.1", "k.log.2"] {
            assert!(read(f).len() <= 100, "{f}");
            assert!(read(f).starts_with("# vergence kiosk log\n"), "{f}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[cfg(unix)]
    #[test]
    fn the_log_refuses_links_fifos_and_files_it_did_not_make() {
        let dir = std::env::temp_dir().join(format!("vergence-kiosk-bad-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let at = |name: &str| KioskLog {
            file: dir.join(name),
            max_bytes: 60,
            keep: 2,
        };
        let victim = dir.join("victim.txt");
        std::fs::write(&victim, "keep me").unwrap();
        std::os::unix::fs::symlink(&victim, dir.join("link.log")).unwrap();
        let e = RotatingLog::open(&at("link.log")).unwrap_err().to_string();
        assert!(e.contains("symbolic link"), "{e}");
        let fifo = std::ffi::CString::new(dir.join("fifo.log").to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o600) }, 0);
        let e = RotatingLog::open(&at("fifo.log")).unwrap_err().to_string();
        assert!(e.contains("FIFO"), "{e}");
        let e = RotatingLog::open(&at("victim.txt"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a vergence kiosk log"), "{e}");
        // A user's own FILE.2 is never removed or overwritten by rotation.
        std::fs::write(dir.join("k.log.2"), "the user's notes").unwrap();
        let mut log = RotatingLog::open(&at("k.log")).unwrap();
        for i in 0..10 {
            let _ = log.write_lines(format!("line {i:02} of the kiosk log\n").as_bytes());
        }
        assert_eq!(
            String::from_utf8(crate::fsio::read_cache(&dir.join("k.log.2"), 1 << 20).unwrap())
                .unwrap(),
            "the user's notes"
        );
        assert_eq!(
            crate::fsio::read_cache(&victim, 1 << 20).unwrap(),
            b"keep me"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
