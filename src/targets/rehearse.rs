//! Rehearsing a visit without a headset: `run --rehearse FILE` plays a
//! script of timed head and controller states into Monado's remote driver
//! (`P_OVERRIDE_ACTIVE_CONFIG=remote`, [`crate::xr::remote`]) from the
//! session's first focus, and ends the run when the script ends. Every
//! interaction (move, turn, teleport, select, measure, section, the panel)
//! can so be tried, and its events checked in `--stats-out`, before a
//! headset arrives.
//!
//! The file (TOML) is a list of `[[step]]` tables, each held for `hold_s`
//! seconds. A step may set the head (`head = { position, yaw_deg,
//! pitch_deg }`) and either hand (`[step.left]`, `[step.right]`: position,
//! yaw_deg, pitch_deg or aim_at, trigger, squeeze, stick, stick_click,
//! menu); what a step leaves out keeps the previous step's state, and a
//! hand table sets that hand whole (its omitted fields idle). `panel =
//! "tool:measure"` aims the right hand at that button of the panel as it
//! opens in front of the head (names as in the frame records'
//! `panel_button` events).

use crate::error::{Error, Result};
use crate::xr::remote::{self, RemoteController, RemoteHead, RemotePose};
use glam::{DQuat, DVec3};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The most steps a script holds.
pub const MAX_STEPS: usize = 10_000;
/// The longest a script may run, seconds.
pub const MAX_TOTAL_S: f64 = 3600.0;
/// The farthest a position may lie from the tracking origin, metres.
const MAX_POSITION_M: f64 = 1000.0;
/// How often the state is sent while a step holds.
const SEND_EVERY: Duration = Duration::from_millis(10);

/// A loaded script: each step's whole state, held for its time.
#[derive(Clone, Debug)]
pub struct Script {
    /// Where it was read from (for messages).
    pub path: PathBuf,
    /// The steps in order.
    pub steps: Vec<Step>,
}

/// One step as sent: the head, both hands, how long it holds.
#[derive(Clone, Debug)]
pub struct Step {
    /// Its name (logged when it begins).
    pub name: String,
    /// How long it holds.
    pub hold: Duration,
    /// The head in tracking space.
    pub head: RemotePose,
    /// Left and right controller.
    pub hands: [RemoteController; 2],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileScript {
    #[serde(default)]
    step: Vec<FileStep>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileStep {
    name: Option<String>,
    hold_s: f64,
    head: Option<FileHead>,
    left: Option<FileHand>,
    right: Option<FileHand>,
    panel: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileHead {
    position: [f64; 3],
    #[serde(default)]
    yaw_deg: f64,
    #[serde(default)]
    pitch_deg: f64,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileHand {
    position: Option<[f64; 3]>,
    #[serde(default)]
    yaw_deg: f64,
    #[serde(default)]
    pitch_deg: f64,
    aim_at: Option<[f64; 3]>,
    #[serde(default)]
    trigger: f64,
    #[serde(default)]
    squeeze: f64,
    #[serde(default)]
    stick: [f64; 2],
    #[serde(default)]
    stick_click: bool,
    #[serde(default)]
    menu: bool,
}

/// Where each hand rests when a script does not say: in front of the
/// hips, a little to its side.
const REST: [[f64; 3]; 2] = [[-0.2, 1.0, -0.3], [0.2, 1.0, -0.3]];
/// The head at the start: standing at the origin, looking down −Z.
const HEAD_START: [f64; 3] = [0.0, 1.6, 0.0];

impl Script {
    /// Reads and checks a script file; errors name the file and the key.
    pub fn load(path: &Path) -> Result<Script> {
        let what = format!("--rehearse {}", path.display());
        let text = crate::fsio::read_text(path, crate::fsio::MAX_TEXT_FILE_BYTES)
            .map_err(|e| Error::config(&what, e.to_string()))?;
        Script::parse(&text, path)
    }

    /// Parses and checks script text read from `path`.
    pub fn parse(text: &str, path: &Path) -> Result<Script> {
        let what = format!("--rehearse {}", path.display());
        let file: FileScript =
            toml::from_str(text).map_err(|e| Error::config(&what, e.message()))?;
        if file.step.is_empty() || file.step.len() > MAX_STEPS {
            let n = file.step.len();
            return Err(Error::config(
                &what,
                format!("needs 1 to {MAX_STEPS} [[step]] tables, found {n}"),
            ));
        }
        let mut head = pose(HEAD_START, 0.0, 0.0);
        let mut hands = REST.map(|p| RemoteController::at(pose(p, 0.0, 0.0)));
        let mut steps = Vec::with_capacity(file.step.len());
        let mut total = 0.0;
        for (i, s) in file.step.iter().enumerate() {
            let at = |key: &str| format!("{what}: step[{i}].{key}");
            check_hold(s.hold_s, &at("hold_s"))?;
            total += s.hold_s;
            if total > MAX_TOTAL_S {
                return Err(Error::config(
                    at("hold_s"),
                    format!("the script runs past {MAX_TOTAL_S} s"),
                ));
            }
            if let Some(h) = &s.head {
                check_position(h.position, &at("head.position"))?;
                check_angles([h.yaw_deg, h.pitch_deg], &at("head"))?;
                head = pose(h.position, h.yaw_deg, h.pitch_deg);
            }
            for (k, hand) in [(0, &s.left), (1, &s.right)] {
                if let Some(f) = hand {
                    let key = at(["left", "right"][k]);
                    hands[k] = controller(f, REST[k], &key)?;
                }
            }
            if let Some(name) = &s.panel {
                let target =
                    panel_target(name, &head).map_err(|m| Error::config(at("panel"), m))?;
                aim(&mut hands[1].pose, target);
            }
            let name = s.name.clone().unwrap_or_else(|| format!("step {i}"));
            if name.chars().count() > 64 || name.chars().any(char::is_control) {
                return Err(Error::config(at("name"), "at most 64 printable characters"));
            }
            steps.push(Step {
                name,
                hold: Duration::from_secs_f64(s.hold_s),
                head,
                hands,
            });
        }
        Ok(Script {
            path: path.to_path_buf(),
            steps,
        })
    }
}

fn check_hold(hold: f64, what: &str) -> Result<()> {
    if (0.001..=600.0).contains(&hold) {
        return Ok(());
    }
    Err(Error::config(
        what,
        format!("{hold}: expected 0.001 <= seconds <= 600"),
    ))
}

fn check_position(p: [f64; 3], what: &str) -> Result<()> {
    if p.iter().all(|v| v.is_finite() && v.abs() <= MAX_POSITION_M) {
        return Ok(());
    }
    Err(Error::config(
        what,
        format!("{p:?}: expected finite metres within {MAX_POSITION_M} of the origin"),
    ))
}

fn check_angles(a: [f64; 2], what: &str) -> Result<()> {
    if a.iter().all(|v| v.is_finite() && v.abs() <= 360.0) {
        return Ok(());
    }
    Err(Error::config(
        what,
        format!("yaw_deg/pitch_deg {a:?}: expected degrees within ±360"),
    ))
}

fn check_unit(v: f64, lo: f64, what: &str) -> Result<()> {
    if v.is_finite() && (lo..=1.0).contains(&v) {
        return Ok(());
    }
    Err(Error::config(what, format!("{v}: expected {lo} to 1")))
}

/// A hand table as a controller state (`rest`: where it is without a
/// position).
fn controller(f: &FileHand, rest: [f64; 3], what: &str) -> Result<RemoteController> {
    let position = f.position.unwrap_or(rest);
    check_position(position, &format!("{what}.position"))?;
    check_angles([f.yaw_deg, f.pitch_deg], what)?;
    check_unit(f.trigger, 0.0, &format!("{what}.trigger"))?;
    check_unit(f.squeeze, 0.0, &format!("{what}.squeeze"))?;
    for v in f.stick {
        check_unit(v, -1.0, &format!("{what}.stick"))?;
    }
    let mut pose = pose(position, f.yaw_deg, f.pitch_deg);
    if let Some(target) = f.aim_at {
        check_position(target, &format!("{what}.aim_at"))?;
        aim(&mut pose, DVec3::from(target));
    }
    Ok(RemoteController {
        pose,
        trigger: f.trigger as f32,
        squeeze: f.squeeze as f32,
        thumbstick: f.stick.map(|v| v as f32),
        thumbstick_click: f.stick_click,
        b_click: f.menu,
    })
}

/// A pose at `p` turned `yaw` degrees about +Y (positive: to the left)
/// then `pitch` about its +X (positive: up).
pub(crate) fn pose(p: [f64; 3], yaw_deg: f64, pitch_deg: f64) -> RemotePose {
    let q = DQuat::from_rotation_y(yaw_deg.to_radians())
        * DQuat::from_rotation_x(pitch_deg.to_radians());
    RemotePose {
        orientation: [q.x as f32, q.y as f32, q.z as f32, q.w as f32],
        position: p.map(|v| v as f32),
    }
}

/// Turns `pose` so its −Z points from its position at `target` (a target
/// at the position leaves it as it is).
fn aim(pose: &mut RemotePose, target: DVec3) {
    let from = DVec3::from(pose.position.map(f64::from));
    let Some(dir) = (target - from).try_normalize() else {
        return;
    };
    let q = DQuat::from_rotation_arc(DVec3::NEG_Z, dir);
    pose.orientation = [q.x as f32, q.y as f32, q.z as f32, q.w as f32];
}

/// The tracking-space centre of the panel button `name` as the panel opens
/// in front of `head`.
fn panel_target(name: &str, head: &RemotePose) -> std::result::Result<DVec3, String> {
    use super::panel::{centre_of, layout};
    let buttons = layout();
    let Some((button, _)) = buttons.iter().find(|(b, _)| b.name() == name) else {
        let known: Vec<String> = buttons.iter().map(|(b, _)| b.name()).collect();
        return Err(format!(
            "unknown panel button '{name}' (known: {})",
            known.join(", ")
        ));
    };
    let o = head.orientation.map(f64::from);
    let head = crate::view::Pose {
        position: DVec3::from(head.position.map(f64::from)),
        orientation: DQuat::from_xyzw(o[0], o[1], o[2], o[3]),
    };
    let uv = centre_of(*button).ok_or("a button without a place")?;
    Ok(crate::interact::panel::Panel::facing(&head).point(uv))
}

/// The eyes the rehearsal's head carries: 64 mm apart, a headset's field
/// of view (about 85° by 90°).
pub(crate) fn head_of(center: RemotePose) -> RemoteHead {
    let eye = |x: f32| {
        let pose = RemotePose {
            orientation: [0.0, 0.0, 0.0, 1.0],
            position: [x, 0.0, 0.0],
        };
        ([-0.74f32, 0.74, 0.78, -0.78], pose)
    };
    RemoteHead {
        center,
        views: [eye(-0.032), eye(0.032)],
    }
}

/// A script playing on its own thread.
pub struct Player {
    finished: Arc<AtomicBool>,
    failed: Arc<Mutex<Option<String>>>,
}

impl Player {
    /// Connects to the remote driver (for up to 30 s) and plays `script`
    /// step by step, sending the state every 10 ms.
    pub fn start(script: Arc<Script>) -> Player {
        let finished = Arc::new(AtomicBool::new(false));
        let failed = Arc::new(Mutex::new(None));
        let (done, fail) = (finished.clone(), failed.clone());
        std::thread::spawn(move || {
            if let Err(e) = play(&script) {
                *fail.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
            }
            done.store(true, Ordering::SeqCst);
        });
        Player { finished, failed }
    }

    /// Whether the script has ended (played out or failed).
    pub fn finished(&self) -> bool {
        self.finished.load(Ordering::SeqCst)
    }

    /// Why it stopped early, once (None while it plays or after it played
    /// out).
    pub fn take_error(&self) -> Option<Error> {
        let why = self
            .failed
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()?;
        Some(Error::config("--rehearse", why))
    }
}

/// Plays every step of `script` into the remote driver.
fn play(script: &Script) -> std::result::Result<(), String> {
    let mut stream = remote::connect(Duration::from_secs(30)).map_err(|e| {
        format!(
            "cannot reach Monado's remote driver on 127.0.0.1:{} ({e}); start monado-service with P_OVERRIDE_ACTIVE_CONFIG=remote",
            remote::PORT
        )
    })?;
    // Draining what the driver sent must not wait out the read timeout
    // (200 ms) before each packet: steps would start late.
    stream
        .set_nonblocking(true)
        .map_err(|e| format!("the remote driver's connection: {e}"))?;
    for step in &script.steps {
        tracing::info!("rehearse: {}", step.name);
        let packet = remote::encode_with(&head_of(step.head), step.hands.map(Some));
        let start = std::time::Instant::now();
        while start.elapsed() < step.hold {
            remote::send_packet(&mut stream, &packet)
                .map_err(|e| format!("the remote driver closed the connection: {e}"))?;
            std::thread::sleep(SEND_EVERY.min(step.hold.saturating_sub(start.elapsed())));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Script> {
        Script::parse(text, Path::new("visit.toml"))
    }

    #[test]
    fn steps_keep_what_they_leave_out() {
        let s = parse(
            "[[step]]\nhold_s = 1\nhead = { position = [1, 1.7, 2], yaw_deg = 90 }\n\
             [step.right]\ntrigger = 1\n\
             [[step]]\nhold_s = 0.5\n[step.left]\nstick = [0, 1]\n",
        )
        .unwrap();
        assert_eq!(s.steps.len(), 2);
        let (a, b) = (&s.steps[0], &s.steps[1]);
        assert_eq!(a.hold, Duration::from_secs(1));
        assert_eq!(b.head.position, [1.0, 1.7, 2.0], "the head stays");
        assert_eq!(b.hands[1].trigger, 1.0, "the right hand stays");
        assert_eq!(b.hands[0].thumbstick, [0.0, 1.0]);
        assert_eq!(a.hands[0].pose.position, [-0.2, 1.0, -0.3], "rest");
        // Yaw 90°: the head's −Z turns to −X.
        let o = b.head.orientation.map(f64::from);
        let fwd = DQuat::from_xyzw(o[0], o[1], o[2], o[3]) * DVec3::NEG_Z;
        assert!((fwd - DVec3::NEG_X).length() < 1e-6, "{fwd}");
    }

    #[test]
    fn aim_at_points_the_hand_at_the_target() {
        let s =
            parse("[[step]]\nhold_s = 1\n[step.right]\nposition = [0, 1, 0]\naim_at = [0, 0, 0]\n")
                .unwrap();
        let o = s.steps[0].hands[1].pose.orientation.map(f64::from);
        let dir = DQuat::from_xyzw(o[0], o[1], o[2], o[3]) * DVec3::NEG_Z;
        assert!((dir - DVec3::NEG_Y).length() < 1e-6, "{dir}");
    }

    #[test]
    fn the_panel_button_is_where_the_right_hand_points() {
        let s = parse("[[step]]\nhold_s = 1\npanel = \"tool:measure\"\n").unwrap();
        let step = &s.steps[0];
        let target = panel_target("tool:measure", &step.head).unwrap();
        let p = &step.hands[1].pose;
        let o = p.orientation.map(f64::from);
        let dir = DQuat::from_xyzw(o[0], o[1], o[2], o[3]) * DVec3::NEG_Z;
        let from = DVec3::from(p.position.map(f64::from));
        let want = (target - from).normalize();
        assert!((dir - want).length() < 1e-6);
    }

    #[test]
    fn bad_scripts_name_the_step_and_key() {
        let cases = [
            ("", "needs 1 to"),
            ("[[step]]\nhold_s = 0\n", "step[0].hold_s"),
            ("[[step]]\nhold_s = nan\n", "step[0].hold_s"),
            ("[[step]]\nhold_s = 1\n[step.right]\ntrigger = 2\n", "step[0].right.trigger"),
            ("[[step]]\nhold_s = 1\n[step.left]\nstick = [0, -3]\n", "step[0].left.stick"),
            ("[[step]]\nhold_s = 1\nhead = { position = [1e9, 0, 0] }\n", "step[0].head.position"),
            ("[[step]]\nhold_s = 1\npanel = \"tool:fly\"\n", "unknown panel button 'tool:fly'"),
            ("[[step]]\nhold_s = 1\n[[step]]\nhold_s = 1\nwarp = 1\n", "unknown field `warp`"),
            ("[[step]]\nhold_s = 600\n[[step]]\nhold_s = 600\n[[step]]\nhold_s = 600\n[[step]]\nhold_s = 600\n[[step]]\nhold_s = 600\n[[step]]\nhold_s = 600\n[[step]]\nhold_s = 1\n", "runs past"),
            ("[[step]]\nhold_s = 1\nname = \"a\\u001b[2J\"\n", "printable"),
        ];
        for (text, want) in cases {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
            assert!(e.contains("visit.toml"), "{e}");
        }
    }
}
