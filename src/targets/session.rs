//! What a run is asked to do and what it reports: the arguments of `run`,
//! the per-frame records and statistics of `--stats-out`, and the pieces
//! both loops (headless and OpenXR) share. Below both loops.

use super::headless::{save_pair, write_json, Percentiles, SceneCounts};
use crate::config::RenderConfig;
use crate::cull::CullStats;
use crate::error::{Error, Result};
use crate::gpu::Context;
use crate::interact::locomotion::Origin;
use crate::interact::{Event, Settings};
use crate::render::driver::FrameResult;
use crate::stats::FrameHistogram;
use crate::targets::hud::Times;
use crate::view::{Fov, Pose, PoseFile, RigFile, StereoRig};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Where `run` renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum XrMode {
    /// OpenXR when a runtime and headset are there, else headless.
    Auto,
    /// OpenXR only: no runtime or headset is an error.
    Openxr,
    /// Headless on the fallback HMD profile.
    Headless,
}

/// What `run` was asked to do.
#[derive(Clone, Debug)]
pub struct RunArgs {
    /// `--scene`.
    pub scene: String,
    /// `--hmd-fallback`: the profile used headless.
    pub hmd_fallback: String,
    /// `--xr`.
    pub xr: XrMode,
    /// `--frames`: stop after this many submitted frames.
    pub frames: Option<u64>,
    /// `--seconds`: stop after this long.
    pub seconds: Option<f64>,
    /// `--stats-out`.
    pub stats_out: Option<PathBuf>,
    /// Renderer configuration (`--opt`, `--stereo`, `--msaa`).
    pub config: RenderConfig,
    /// Per-eye size override (else the runtime's recommended size or the
    /// profile's resolution).
    pub size: Option<(u32, u32)>,
    /// `--capture DIR`: write the last frame (left.png, right.png, rig.json).
    pub capture: Option<PathBuf>,
    /// `--reconnect`: when the OpenXR runtime is lost mid-run, retry every
    /// second until it is back, instead of exiting.
    pub reconnect: bool,
    /// `--spawn x,y,z,yaw`: where the tracking origin starts (else as
    /// `framing` says, see `targets::framing`).
    pub spawn: Option<Pose>,
    /// `--frame`: how the start is placed without `--spawn` or `--camera`.
    pub framing: super::framing::Framing,
    /// `--viewpoint x,y,z,yaw` (repeatable): further places the right stick
    /// click cycles through after the spawn.
    pub viewpoints: Vec<Pose>,
    /// `--camera N|NAME`: start at this camera of the scene file (see
    /// `targets/viewpoints.rs`).
    pub camera: Option<String>,
    /// Locomotion settings (`--move-speed`, `--snap-turn`, ...).
    pub interact: Settings,
    /// `--mirror`: the desktop window showing the submitted eye images
    /// (None: `left` when a display is there, else none).
    pub mirror: Option<crate::targets::mirror::MirrorMode>,
    /// `--screenshot FILE.png`: the mirror window's last presented image.
    pub screenshot: Option<PathBuf>,
    /// `--save-config FILE`: where the live toggles' F2 writes the config
    /// file (default `vergence-live.toml`).
    pub save_config: Option<PathBuf>,
    /// `--kiosk FILE`: the demo install (scenes on offer, allowed toggles,
    /// idle return); `scene`, `spawn` and `viewpoints` are its first
    /// scene's.
    pub kiosk: Option<crate::targets::kiosk::Kiosk>,
    /// `--overlay`: whether the mirror starts with the overlay shown.
    pub overlay: bool,
    /// `--rehearse FILE`: the script played into Monado's remote driver.
    pub rehearse: Option<std::sync::Arc<super::rehearse::Script>>,
    /// `--desk-controllers`: the mirror window's keys drive the remote
    /// driver's controllers.
    pub desk_controllers: bool,
}

impl RunArgs {
    /// Checks values before anything is loaded.
    pub fn validate(&self) -> Result<()> {
        self.config.validate()?;
        self.interact
            .validate()
            .map_err(|m| Error::config("locomotion", m))?;
        if let Some(p) = &self.spawn {
            p.validate().map_err(|m| Error::config("--spawn", m))?;
        }
        for p in &self.viewpoints {
            p.validate().map_err(|m| Error::config("--viewpoint", m))?;
        }
        if let Some(s) = self.seconds {
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::config(
                    "--seconds",
                    format!("{s} must be a positive number"),
                ));
            }
        }
        if self.rehearse.is_some() && self.xr != XrMode::Openxr {
            return Err(Error::config(
                "--rehearse",
                "plays into an OpenXR runtime's controllers: it needs --xr openxr (Monado with its remote driver)",
            ));
        }
        if self.desk_controllers
            && (self.xr != XrMode::Openxr
                || self.mirror == Some(crate::targets::mirror::MirrorMode::Off))
        {
            return Err(Error::config(
                "--desk-controllers",
                "drives an OpenXR runtime's controllers from the mirror window's keys: it needs --xr openxr and a mirror window (not --mirror off)",
            ));
        }
        if self.frames == Some(0) {
            return Err(Error::config("--frames", "must be at least 1"));
        }
        if self.mirror == Some(crate::targets::mirror::MirrorMode::Off) && self.screenshot.is_some()
        {
            return Err(Error::config(
                "--screenshot",
                "writes the mirror window's image; it cannot be combined with --mirror off",
            ));
        }
        if let Some(p) = &self.screenshot {
            crate::fsio::prepare_output(p)?;
        }
        if self.capture.is_some() && self.frames.is_none() && self.rehearse.is_none() {
            return Err(Error::config(
                "--capture",
                "needs --frames N (the last frame, N, is captured) or --rehearse (the frame the script ends on)",
            ));
        }
        Ok(())
    }

    /// These arguments for the kiosk's scene `i` (its scene, spawn and
    /// viewpoints); unchanged without a kiosk.
    pub fn for_scene(&self, i: usize) -> RunArgs {
        let mut a = self.clone();
        if let Some(s) = self.kiosk.as_ref().and_then(|k| k.scenes.get(i)) {
            a.scene = s.scene.clone();
            a.spawn = s.spawn;
            a.viewpoints = s.viewpoints.clone();
        }
        a
    }

    /// Whether the frame or time limit is reached.
    pub fn limit_reached(&self, frames: u64, started: Instant) -> bool {
        self.frames.is_some_and(|n| frames >= n)
            || self
                .seconds
                .is_some_and(|s| started.elapsed() >= Duration::from_secs_f64(s))
    }
}

/// One frame of the loop.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameRecord {
    /// Frame number (from 0, counting frames not rendered too).
    pub index: u64,
    /// The runtime asked for rendering (always true headless).
    pub should_render: bool,
    /// Time blocked in xrWaitFrame (0 headless).
    pub wait_ms: f64,
    /// CPU time from the end of the wait to the end of xrEndFrame (or of
    /// the submit headless), GPU wait excluded.
    pub cpu_ms: f64,
    /// GPU time of the frame (all passes, timestamps).
    pub gpu_ms: f64,
    /// Culling time.
    pub cull_ms: f64,
    /// predictedDisplayTime in nanoseconds (headless: time since start).
    pub predicted_display_time_ns: i64,
    /// predictedDisplayPeriod in nanoseconds (headless: the profile's).
    pub predicted_display_period_ns: i64,
    /// Display periods skipped since the previous frame.
    pub missed_periods: u64,
    /// Instances drawn.
    pub instances_drawn: u64,
    /// FOV of each view used for culling and rendering (radians).
    pub fov: Vec<Fov>,
    /// The head in the world after locomotion (position, quaternion
    /// x, y, z, w); None when no view was located.
    pub head_world: Option<PoseFile>,
    /// What the user did this frame (teleport, turn, grab, select, ...).
    pub events: Vec<Event>,
    /// The `--opt` string the frame was rendered with (changes when a live
    /// toggle switched an optimization).
    pub opt: String,
    /// Composition layers submitted with the frame (OpenXR: the projection,
    /// plus the panel's quad while it is open; 0 when nothing was rendered,
    /// and headless, where nothing is composited).
    pub layers: u32,
    /// With `--opt aq`: the level, render scale, rendered size and budget
    /// of the frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub aq: Option<crate::render::driver::AqFrame>,
}

/// The interaction profile the runtime bound per hand (top-level
/// `interaction_profiles` of `--stats-out`).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct HandProfiles {
    /// `/user/hand/left`'s profile, None when nothing is bound.
    pub left: Option<String>,
    /// `/user/hand/right`'s profile.
    pub right: Option<String>,
}

/// A view configuration view as the runtime reports it.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ViewInfo {
    /// Recommended image size.
    pub recommended: [u32; 2],
    /// Maximum image size.
    pub max: [u32; 2],
    /// FOV of the first located frame.
    pub fov: Option<Fov>,
}

/// The per-frame records of `--stats-out`, spooled to a fresh temporary
/// file beside it as they come (one JSON line each; created with `O_EXCL`
/// under a unique name, [`crate::fsio::TempFile`], and removed at the end:
/// nothing vergence did not create is touched) and streamed into the JSON
/// document at the end, so memory stays flat however long the run.
/// Without `--stats-out` nothing is kept.
#[derive(Debug, Default)]
pub struct FrameLog {
    spool: Option<(crate::fsio::TempFile, std::io::BufWriter<std::fs::File>)>,
    count: u64,
}

impl FrameLog {
    /// A log spooled next to `stats_out`.
    pub fn spooled(stats_out: &Path) -> Result<FrameLog> {
        crate::fsio::prepare_output(stats_out)?;
        let out = |e: std::io::Error| Error::Output {
            path: stats_out.to_path_buf(),
            message: format!("cannot create the frame spool beside it: {e}"),
        };
        let tmp = crate::fsio::TempFile::beside(stats_out).map_err(out)?;
        let file = tmp.file().try_clone().map_err(out)?;
        Ok(FrameLog {
            spool: Some((tmp, std::io::BufWriter::new(file))),
            count: 0,
        })
    }

    fn push(&mut self, f: &FrameRecord) -> Result<()> {
        self.count += 1;
        if let Some((tmp, w)) = &mut self.spool {
            let path = tmp.path().to_path_buf();
            use std::io::Write as _;
            serde_json::to_writer(&mut *w, f)
                .map_err(std::io::Error::from)
                .and_then(|()| w.write_all(b"\n"))
                .map_err(|e| Error::Output {
                    path,
                    message: e.to_string(),
                })?;
        }
        Ok(())
    }

    /// Records logged.
    pub fn len(&self) -> u64 {
        self.count
    }

    /// Whether nothing was logged.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    fn flush(&mut self) -> Result<()> {
        if let Some((tmp, w)) = &mut self.spool {
            use std::io::Write as _;
            w.flush().map_err(|e| Error::Output {
                path: tmp.path().to_path_buf(),
                message: e.to_string(),
            })?;
        }
        Ok(())
    }

    fn remove_spool(&mut self) {
        // Dropping the TempFile removes the file vergence created.
        self.spool = None;
    }
}

impl serde::Serialize for FrameLog {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::Error as _;
        use std::io::BufRead as _;
        use std::io::Seek as _;
        let Some((tmp, _)) = &self.spool else {
            return s.collect_seq(std::iter::empty::<()>());
        };
        // The spool's own handle (not its name, which another process
        // could replace), read from the start.
        let mut file = tmp.file().try_clone().map_err(S::Error::custom)?;
        file.seek(std::io::SeekFrom::Start(0))
            .map_err(S::Error::custom)?;
        let mut failed = None;
        let records = std::io::BufReader::new(file).lines().map_while(|l| {
            match l.map_err(|e| e.to_string()).and_then(|l| {
                serde_json::from_str::<serde_json::Value>(&l).map_err(|e| e.to_string())
            }) {
                Ok(v) => Some(v),
                Err(e) => {
                    failed = Some(e);
                    None
                }
            }
        });
        let out = s.collect_seq(records)?;
        match failed {
            Some(e) => Err(S::Error::custom(e)),
            None => Ok(out),
        }
    }
}

/// Summary of the frame series.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct RunSummary {
    /// xrWaitFrame wait.
    pub wait_ms: Percentiles,
    /// CPU frame time.
    pub cpu_frame_ms: Percentiles,
    /// GPU frame time.
    pub gpu_frame_ms: Percentiles,
}

/// The contents of `--stats-out`.
#[derive(Debug, Default, serde::Serialize)]
pub struct RunStats {
    /// `openxr` or `headless`.
    pub mode: String,
    /// Why OpenXR was not used (`--xr auto` fallback), if it was not.
    pub fallback_reason: Option<String>,
    /// Scene counts.
    pub scene: Option<SceneCounts>,
    /// Configuration used.
    pub config: RenderConfig,
    /// GPU name.
    pub device: String,
    /// Driver description.
    pub driver: String,
    /// OpenXR runtime name and version.
    pub runtime: Option<String>,
    /// OpenXR system name (or the HMD profile headless).
    pub system: String,
    /// OpenXR extensions enabled.
    pub extensions_enabled: Vec<String>,
    /// OpenXR API layers enabled.
    pub api_layers: Vec<String>,
    /// Display refresh rate (XR_FB_display_refresh_rate, when offered).
    pub display_refresh_hz: Option<f32>,
    /// Refresh rates the display supports (XR_FB_display_refresh_rate).
    pub display_refresh_rates: Vec<f32>,
    /// Per view: recommended and max sizes and FOV.
    pub views: Vec<ViewInfo>,
    /// The session's view configuration: `PRIMARY_STEREO`, or with the
    /// inset on a runtime that takes quad views `PRIMARY_QUAD_VARJO` (the
    /// four views then go out as they are).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub view_configuration: Option<String>,
    /// The OpenXR API version of the instance (1.1 where offered with the
    /// inset, for its foveated-inset views; else 1.0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub api_version: Option<String>,
    /// Per-eye image size rendered.
    pub image_size: [u32; 2],
    /// Reference space (STAGE or LOCAL).
    pub reference_space: Option<String>,
    /// Swapchain colour format.
    pub color_format: Option<String>,
    /// Swapchain depth format (None: no depth layer).
    pub depth_format: Option<String>,
    /// Hidden-area mesh per view: (vertices, indices).
    pub visibility_mask: Vec<[usize; 2]>,
    /// Visibility-mask refreshes after XrEventDataVisibilityMaskChangedKHR.
    pub visibility_mask_refreshes: u64,
    /// Session states in order.
    pub states: Vec<String>,
    /// The current interaction profile per hand (updated on
    /// XrEventDataInteractionProfileChanged).
    pub interaction_profiles: HandProfiles,
    /// Interaction profiles whose suggested bindings the runtime accepted.
    pub suggested_profiles: Vec<String>,
    /// Tracking origin at the end of the run (after locomotion).
    pub origin: Option<OriginFile>,
    /// What the last select named (instance, node name and path, mesh,
    /// material, extras, point, distance), as in its `select` event.
    pub selected: Option<crate::interact::Picked>,
    /// The places the right stick click cycles through, the start first
    /// (`spawn`, `--viewpoint N`, `camera N 'NAME'`; see
    /// `targets/viewpoints.rs`).
    pub viewpoints: Vec<String>,
    /// Whether the session reached FOCUSED.
    pub focused: bool,
    /// Frames in the loop (streamed from the spool file when written).
    pub frames: FrameLog,
    /// Process resident set size (Linux), sampled every
    /// [`RSS_SAMPLE_EVERY`] frames after warm-up: the median of the first
    /// ten samples, of the last ten, and the difference (growth).
    pub rss: RssTrack,
    /// GPU memory vergence allocated after the first 300 frames and at the
    /// end, in bytes.
    pub gpu_allocated_bytes: [u64; 2],
    #[serde(skip)]
    series: Series,
    #[serde(skip)]
    started: Option<Instant>,
    /// Added to the current loop's frame numbers (see
    /// [`RunStats::begin_scene`]).
    #[serde(skip)]
    frame_base: u64,
    /// Frames ended with xrEndFrame success (headless: rendered).
    pub frames_submitted: u64,
    /// Frames rendered (shouldRender true).
    pub frames_rendered: u64,
    /// Sum of missed display periods.
    pub missed_display_periods: u64,
    /// Events the runtime dropped (XrEventDataEventsLost).
    pub events_lost: u64,
    /// Frames whose views lacked a valid pose (last valid pose reused).
    pub invalid_pose_frames: u64,
    /// Vulkan validation messages.
    pub validation_messages: usize,
    /// OpenXR debug-utils warnings and errors (core validation layer).
    pub xr_validation_messages: usize,
    /// Culling counters of the last frame.
    pub cull: Option<CullStats>,
    /// What the renderer chose per technique (the foveation, inset, LMS,
    /// LOD and point paths; per-view render areas), at the top level: the
    /// same block as `render`'s stats.json.
    #[serde(flatten)]
    pub renderer: crate::render::report::RendererReport,
    /// Series summary.
    pub summary: RunSummary,
    /// The mirror window (None: no mirror).
    pub mirror: Option<crate::targets::mirror::MirrorStats>,
    /// The in-headset panel (None: `--panel off`, or not an OpenXR run).
    pub panel: Option<crate::targets::xr_panel::PanelStats>,
    /// Optimizations switched by the live toggles, in order.
    pub toggles: Vec<crate::targets::toggles::ToggleEvent>,
    /// Live toggles refused (not allowed by the kiosk, or an invalid
    /// combination), in order.
    pub refused_toggles: Vec<crate::targets::toggles::RefusedToggle>,
    /// The scenes shown, in order (a kiosk's N starts the next one): each
    /// with its frames, numbered over the whole run.
    pub scenes: Vec<SceneSection>,
    /// Sessions re-established after the runtime was lost (`--reconnect`).
    pub reconnects: u64,
    /// Why the loop ended.
    pub exit: String,
    /// Wall time of the loop in seconds.
    pub duration_s: f64,
}

/// One scene of the run, as `--stats-out` lists it.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SceneSection {
    /// Its name (a kiosk scene's name; else the scene as given).
    pub name: String,
    /// The scene as given (file or generated scene).
    pub scene: String,
    /// Its first frame's index in `frames`.
    pub first_frame: u64,
    /// Its frames.
    pub frames: u64,
    /// Seconds from the start of the run to its first frame.
    pub started_s: f64,
    /// Its counts (None when it could not be loaded).
    pub counts: Option<SceneCounts>,
}

/// A tracking origin as written to the statistics.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct OriginFile {
    /// World position of the tracking origin.
    pub position: [f64; 3],
    /// Yaw about +Y, degrees.
    pub yaw_deg: f64,
    /// Tracking-to-world scale.
    pub scale: f64,
}

impl From<&Origin> for OriginFile {
    fn from(o: &Origin) -> OriginFile {
        OriginFile {
            position: o.position.to_array(),
            yaw_deg: o.yaw.to_degrees(),
            scale: o.scale,
        }
    }
}

/// Constant-memory summaries of the frame series.
#[derive(Clone, Debug, Default)]
struct Series {
    wait: FrameHistogram,
    cpu: FrameHistogram,
    gpu: FrameHistogram,
    last_display_time_ns: Option<i64>,
}

/// Frames after which the warm-up memory figures are taken.
pub const WARMUP_FRAMES: u64 = 300;
/// Frames between RSS samples.
pub const RSS_SAMPLE_EVERY: u64 = 50;

/// RSS over a run in constant memory: the first and the latest ten samples
/// after warm-up. Medians of ten absorb the allocator's and driver's
/// ±1 MB breathing; a leak shows as growth between them.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct RssTrack {
    /// Median of the first ten samples after warm-up, in bytes.
    pub after_warmup_bytes: Option<u64>,
    /// Median of the last ten samples, in bytes.
    pub end_bytes: Option<u64>,
    /// `end_bytes - after_warmup_bytes`.
    pub growth_bytes: Option<i64>,
    /// Samples taken.
    pub samples: u64,
    #[serde(skip)]
    first: Vec<u64>,
    #[serde(skip)]
    last: std::collections::VecDeque<u64>,
}

impl RssTrack {
    const KEEP: usize = 10;

    /// Adds a sample and updates the figures.
    pub fn sample(&mut self, bytes: u64) {
        self.samples += 1;
        if self.first.len() < Self::KEEP {
            self.first.push(bytes);
        }
        if self.last.len() == Self::KEEP {
            self.last.pop_front();
        }
        self.last.push_back(bytes);
        let median = |v: &mut Vec<u64>| {
            v.sort_unstable();
            v[v.len() / 2]
        };
        let a = median(&mut self.first.clone());
        let b = median(&mut self.last.iter().copied().collect());
        self.after_warmup_bytes = Some(a);
        self.end_bytes = Some(b);
        self.growth_bytes = Some(b as i64 - a as i64);
    }
}

/// Frame records waiting for their frames' GPU times (frames in flight),
/// written to the statistics in frame order.
#[derive(Debug, Default)]
pub struct RecordQueue {
    /// Records, oldest first, each with whether it still waits for its
    /// frame's result.
    waiting: std::collections::VecDeque<(FrameRecord, bool)>,
}

impl RecordQueue {
    /// Queues `rec`; a `rendered` frame's record waits for its result.
    pub fn push(&mut self, rec: FrameRecord, rendered: bool) {
        self.waiting.push_back((rec, rendered));
    }

    /// Completes the record of the finished frame `r`: GPU time, counts,
    /// culling, and its CPU time without the wait for a frame slot.
    pub fn complete(&mut self, r: &FrameResult, stats: &mut RunStats) {
        let found = self
            .waiting
            .iter_mut()
            .find(|(rec, waits)| *waits && rec.index == r.index);
        if let Some((rec, waits)) = found {
            rec.gpu_ms = r.gpu_ms();
            rec.cull_ms = r.cull_ms;
            rec.instances_drawn = r.stats.instances_drawn;
            rec.aq = r.aq;
            rec.cpu_ms = (rec.cpu_ms - r.stats.cpu_ms.wait).max(0.0);
            *waits = false;
            stats.cull = r.cull;
        }
    }

    /// Writes the complete records at the front, handing each one's index
    /// and times to `shown` (what the overlay shows).
    pub fn flush(&mut self, stats: &mut RunStats, mut shown: impl FnMut(u64, Times)) -> Result<()> {
        while self.waiting.front().is_some_and(|(_, waits)| !waits) {
            let (rec, _) = self.waiting.pop_front().expect("front exists");
            let (i, t) = stats.push_frame(rec)?;
            shown(i, t);
        }
        Ok(())
    }

    /// Writes every record, also those whose frame never finished (the
    /// session ended first; their GPU time stays 0).
    pub fn flush_all(&mut self, stats: &mut RunStats) -> Result<()> {
        while let Some((rec, _)) = self.waiting.pop_front() {
            stats.push_frame(rec)?;
        }
        Ok(())
    }
}

impl RunStats {
    /// Starts over for the headless fallback after OpenXR was unavailable
    /// (`reason`), keeping only the frame log: a fresh log at the same
    /// spool path would be unlinked when the old one drops.
    pub fn fall_back(&mut self, reason: String) {
        let frames = std::mem::take(&mut self.frames);
        let scenes = std::mem::take(&mut self.scenes);
        *self = RunStats {
            fallback_reason: Some(reason),
            frames,
            scenes,
            started: self.started,
            frame_base: self.frame_base,
            ..RunStats::default()
        };
    }

    /// Empty statistics whose frames spool next to `stats_out` when given.
    pub fn new(stats_out: Option<&Path>) -> Result<RunStats> {
        Ok(RunStats {
            frames: match stats_out {
                Some(p) => FrameLog::spooled(p)?,
                None => FrameLog::default(),
            },
            ..RunStats::default()
        })
    }

    /// Starts the section of scene `scene` (named `name`): frames from now
    /// on are numbered after the run's earlier ones. Returns the number
    /// the loop adds to its own frame numbers.
    pub fn begin_scene(&mut self, name: &str, scene: &str) -> u64 {
        let first = self.frames.len();
        let started_s = self.run_started().elapsed().as_secs_f64();
        self.scenes.push(SceneSection {
            name: name.into(),
            scene: scene.into(),
            first_frame: first,
            started_s,
            ..SceneSection::default()
        });
        self.frame_base = first;
        first
    }

    /// Ends the current scene's section: its frame count and counts.
    pub fn end_scene(&mut self) {
        let (total, counts) = (self.frames.len(), self.scene.clone());
        if let Some(s) = self.scenes.last_mut() {
            s.frames = total - s.first_frame;
            s.counts = counts;
        }
    }

    /// Adds a frame (its index after the run's earlier scenes'), counting
    /// missed display periods from the change in predicted display time:
    /// a step of k periods means k - 1 were missed.
    pub fn push_frame(&mut self, mut f: FrameRecord) -> Result<(u64, Times)> {
        f.index += self.frame_base;
        let shown = (
            f.index,
            Times {
                cpu: f.cpu_ms,
                gpu: f.gpu_ms,
                wait: f.wait_ms,
            },
        );
        if let Some(prev) = self.series.last_display_time_ns {
            let period = f.predicted_display_period_ns.max(1) as f64;
            let step = (f.predicted_display_time_ns - prev) as f64;
            let periods = (step / period).round();
            f.missed_periods = if periods > 1.0 { periods as u64 - 1 } else { 0 };
        }
        self.series.last_display_time_ns = Some(f.predicted_display_time_ns);
        self.missed_display_periods += f.missed_periods;
        let n = self.frames.len() + 1;
        if n >= WARMUP_FRAMES && (n - WARMUP_FRAMES).is_multiple_of(RSS_SAMPLE_EVERY) {
            if let Some(b) = crate::rss::process_rss_bytes() {
                self.rss.sample(b);
            }
        }
        self.series.wait.record(f.wait_ms);
        if f.should_render {
            self.series.cpu.record(f.cpu_ms);
            self.series.gpu.record(f.gpu_ms);
        }
        self.frames.push(&f)?;
        Ok(shown)
    }

    /// When the run began (the first call starts the clock); `--seconds`
    /// counts from here across reconnects.
    pub fn run_started(&mut self) -> Instant {
        *self.started.get_or_insert_with(Instant::now)
    }

    /// Marks the start of an OpenXR session: the next frame's predicted
    /// display time is not compared with the previous session's.
    pub fn begin_session(&mut self) {
        self.series.last_display_time_ns = None;
    }

    /// Records GPU memory after warm-up (`end` false) or at the end.
    pub fn sample_memory(&mut self, ctx: &Context, end: bool) {
        let i = usize::from(end);
        self.gpu_allocated_bytes[i] = ctx.allocated_bytes();
    }

    /// Fills the summary from the frames.
    pub fn summarize(&mut self) {
        let p = |h: &FrameHistogram| Percentiles {
            median: h.quantile(0.5),
            p95: h.quantile(0.95),
        };
        self.summary = RunSummary {
            wait_ms: p(&self.series.wait),
            cpu_frame_ms: p(&self.series.cpu),
            gpu_frame_ms: p(&self.series.gpu),
        };
    }

    /// Writes the JSON file (the frames streamed from the spool), then
    /// removes the spool.
    pub fn write(&mut self, path: &Path) -> Result<()> {
        self.frames.flush()?;
        let result = write_json(path, self);
        self.frames.remove_spool();
        result
    }
}

/// Writes the captured frame: left.png, right.png and rig.json.
pub fn write_capture(dir: &Path, images: &[image::RgbaImage; 2], rig: &StereoRig) -> Result<()> {
    save_pair(dir, images)?;
    write_json(&dir.join("rig.json"), &RigFile::of(rig))
}
