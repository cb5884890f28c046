//! `vergence run`: the application. In a headset through OpenXR (see
//! [`crate::xr`]), or headless on an HMD profile when no runtime or headset
//! is there (`--xr auto`) or when asked (`--xr headless`). Both write the
//! same frame statistics (`--stats-out`).

use crate::config::RenderConfig;
use crate::cull::CullStats;
use crate::error::{Error, Result};
use crate::gpu::{Context, Validation};
use crate::render::{FrameStats, Renderer};
use crate::scene::Scene;
use crate::targets::headless::{
    eye_extent, load_scene, save_pair, write_json, CullState, Percentiles, SceneCounts,
};
use crate::view::profile::HmdProfile;
use crate::view::{frame_bounds, Fov, Pose, RigFile, StereoRig};
use glam::DVec3;
use std::path::{Path, PathBuf};
use std::sync::Arc;
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
}

impl RunArgs {
    /// Checks values before anything is loaded.
    pub fn validate(&self) -> Result<()> {
        self.config.validate()?;
        if let Some(s) = self.seconds {
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::config(
                    "--seconds",
                    format!("{s} must be a positive number"),
                ));
            }
        }
        if self.frames == Some(0) {
            return Err(Error::config("--frames", "must be at least 1"));
        }
        if self.capture.is_some() && self.frames.is_none() {
            return Err(Error::config(
                "--capture",
                "needs --frames N (the last frame, N, is captured)",
            ));
        }
        Ok(())
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
#[derive(Clone, Debug, Default, serde::Serialize)]
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
    /// Whether the session reached FOCUSED.
    pub focused: bool,
    /// Frames in the loop.
    pub frames: Vec<FrameRecord>,
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
    /// Which foveation path ran.
    pub foveation: String,
    /// Series summary.
    pub summary: RunSummary,
    /// Why the loop ended.
    pub exit: String,
    /// Wall time of the loop in seconds.
    pub duration_s: f64,
}

impl RunStats {
    /// Adds a frame, counting missed display periods from the change in
    /// predicted display time: a step of k periods means k - 1 were missed.
    pub fn push_frame(&mut self, mut f: FrameRecord) {
        if let Some(prev) = self.frames.last() {
            let period = f.predicted_display_period_ns.max(1) as f64;
            let step = (f.predicted_display_time_ns - prev.predicted_display_time_ns) as f64;
            let periods = (step / period).round();
            f.missed_periods = if periods > 1.0 { periods as u64 - 1 } else { 0 };
        }
        self.missed_display_periods += f.missed_periods;
        self.frames.push(f);
    }

    /// Fills the summary from the frames.
    pub fn summarize(&mut self) {
        let rendered: Vec<&FrameRecord> = self.frames.iter().filter(|f| f.should_render).collect();
        self.summary = RunSummary {
            wait_ms: Percentiles::of(&self.frames.iter().map(|f| f.wait_ms).collect::<Vec<_>>()),
            cpu_frame_ms: Percentiles::of(&rendered.iter().map(|f| f.cpu_ms).collect::<Vec<_>>()),
            gpu_frame_ms: Percentiles::of(&rendered.iter().map(|f| f.gpu_ms).collect::<Vec<_>>()),
        };
    }

    /// Writes the JSON file.
    pub fn write(&self, path: &Path) -> Result<()> {
        write_json(path, self)
    }
}

/// Where the tracking origin sits in the scene: at the hall entrance for
/// large scenes, else where a standing viewer (eyes 1.6 m above the
/// origin) sees the whole scene.
pub fn spawn_pose(scene: &Scene, fov: &Fov) -> Pose {
    let (lo, hi) = scene.bounds();
    let radius = (hi - lo).length() * 0.5;
    if !radius.is_finite() || radius > 50.0 {
        return Pose::from_euler_deg(DVec3::new(3.0, 0.0, 2.0), -25.0, 0.0, 0.0);
    }
    let framed = frame_bounds(lo, hi, fov, 0.0);
    Pose {
        position: framed.position - DVec3::new(0.0, 1.6, 0.0),
        orientation: framed.orientation,
    }
}

/// Runs `args`: OpenXR or headless as `--xr` says, writing `--stats-out`.
pub fn run(args: &RunArgs) -> Result<RunStats> {
    args.validate()?;
    crate::quit::install();
    let mut stats = RunStats::default();
    let result = match args.xr {
        XrMode::Headless => run_headless(args, &mut stats),
        XrMode::Openxr => crate::xr::run_session(args, &mut stats),
        XrMode::Auto => match crate::xr::run_session(args, &mut stats) {
            Err(Error::XrUnavailable(reason)) => {
                eprintln!(
                    "vergence: no OpenXR headset ({reason}); running headless on the {} profile",
                    args.hmd_fallback
                );
                stats = RunStats {
                    fallback_reason: Some(reason),
                    ..RunStats::default()
                };
                run_headless(args, &mut stats)
            }
            other => other,
        },
    };
    stats.summarize();
    if let Some(path) = &args.stats_out {
        if !stats.mode.is_empty() {
            stats.write(path)?;
        }
    }
    result.map(|()| stats)
}

/// Writes the captured frame: left.png, right.png and rig.json.
pub fn write_capture(dir: &Path, images: &[image::RgbaImage; 2], rig: &StereoRig) -> Result<()> {
    save_pair(dir, images)?;
    write_json(&dir.join("rig.json"), &RigFile::of(rig))
}

fn gpu_total(f: &FrameStats) -> f64 {
    f.gpu_ms.values().sum()
}

/// The headless loop: the fallback profile's rig at the spawn pose, the
/// head turning slowly (±20° yaw over 10 s) so culling and batching see
/// motion; paced by nothing (frames run back to back).
fn run_headless(args: &RunArgs, stats: &mut RunStats) -> Result<()> {
    let profile = HmdProfile::load(&args.hmd_fallback)?;
    if profile.views.len() != 2 {
        return Err(Error::Profile {
            name: args.hmd_fallback.clone(),
            message: "the renderer needs exactly 2 views".into(),
        });
    }
    let (scene, _) = load_scene(&args.scene)?;
    let ctx = Arc::new(Context::new_headless(Validation::from_env())?);
    let extent = eye_extent(&profile, args.size);
    let mut renderer = Renderer::new(ctx.clone(), &scene, &args.config, extent)?;
    let mut culling = CullState::new(&args.config, &scene)?;
    let spawn = spawn_pose(&scene, &profile.views[0].fov);
    stats.mode = "headless".into();
    stats.scene = Some(SceneCounts::of(&scene));
    stats.config = renderer.config.clone();
    stats.foveation = renderer.foveation_path.clone();
    stats.device = ctx.device_name.clone();
    stats.driver = ctx.driver.clone();
    stats.system = format!("HMD profile {}", profile.name);
    stats.image_size = [extent.width, extent.height];
    stats.views = profile
        .views
        .iter()
        .map(|v| ViewInfo {
            recommended: v.resolution,
            max: v.resolution,
            fov: Some(v.fov),
        })
        .collect();
    let period_ns = (1e9 / profile.refresh_hz.max(1.0)) as i64;
    let started = Instant::now();
    let mut index = 0u64;
    stats.exit = loop {
        if crate::quit::requested() {
            break "quit requested (signal)".into();
        }
        if args.limit_reached(stats.frames_submitted, started) {
            break "frame or time limit reached".into();
        }
        let t = started.elapsed().as_secs_f64();
        let yaw = 20.0 * (t * std::f64::consts::TAU / 10.0).sin();
        let head = spawn.compose(&Pose::from_euler_deg(
            DVec3::new(0.0, 1.6, 0.0),
            yaw,
            0.0,
            0.0,
        ));
        let rig = profile.rig(head);
        let t0 = Instant::now();
        let visible = culling.as_mut().map(|c| c.cull(&rig, index)).transpose()?;
        let cull_ms = t0.elapsed().as_secs_f64() * 1e3;
        let capture = args.capture.is_some() && args.frames == Some(stats.frames_submitted + 1);
        let f = renderer.render(&rig, visible.as_ref().map(|(v, _)| *v), capture)?;
        stats.cull = visible.map(|(_, s)| s);
        if capture {
            let images = renderer.read_images()?;
            write_capture(args.capture.as_deref().expect("checked"), &images, &rig)?;
        }
        stats.push_frame(FrameRecord {
            index,
            should_render: true,
            wait_ms: 0.0,
            cpu_ms: cull_ms + f.cpu_ms.batch + f.cpu_ms.record + f.cpu_ms.submit,
            gpu_ms: gpu_total(&f),
            cull_ms,
            predicted_display_time_ns: (t * 1e9) as i64,
            predicted_display_period_ns: period_ns,
            missed_periods: 0,
            instances_drawn: f.instances_drawn,
            fov: rig.views.iter().map(|v| v.fov).collect(),
        });
        stats.frames_submitted += 1;
        stats.frames_rendered += 1;
        index += 1;
    };
    stats.duration_s = started.elapsed().as_secs_f64();
    stats.validation_messages = ctx.validation_messages();
    drop(renderer);
    Ok(())
}
