//! `vergence run`: the application. In a headset through OpenXR (see
//! [`crate::xr`]), or headless on an HMD profile when no runtime or headset
//! is there (`--xr auto`) or when asked (`--xr headless`). Both write the
//! same frame statistics (`--stats-out`).

use super::headless::{eye_extent, load_scene, load_stereo_profile, SceneCounts};
use super::session::{write_capture, FrameRecord, ViewInfo, WARMUP_FRAMES};
pub use super::session::{RunArgs, RunStats, XrMode};
use crate::error::{Error, Result};
use crate::gpu::{Context, Validation};
use crate::render::driver::{FrameDriver, FrameResult};
use crate::view::{Pose, PoseFile};
use glam::DVec3;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Runs `args`: OpenXR or headless as `--xr` says, writing `--stats-out`.
pub fn run(args: &RunArgs) -> Result<RunStats> {
    args.validate()?;
    crate::quit::install();
    let mut stats = RunStats::new(args.stats_out.as_deref())?;
    let result = match args.xr {
        XrMode::Headless => run_headless(args, &mut stats),
        XrMode::Openxr => xr_with_reconnect(args, &mut stats),
        XrMode::Auto => match super::xr_session::run_session(args, &mut stats) {
            Err(Error::XrUnavailable(reason)) => {
                eprintln!(
                    "vergence: no OpenXR headset ({reason}); running headless on the {} profile",
                    args.hmd_fallback
                );
                stats.fall_back(reason);
                run_headless(args, &mut stats)
            }
            Err(e) if args.reconnect && e.is_runtime_loss() => {
                reconnect_after(&e, args, &mut stats)
                    .and_then(|()| xr_with_reconnect(args, &mut stats))
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

/// An OpenXR run that, with `--reconnect`, outlives losing the runtime:
/// each loss is reported on one line and retried every second until a
/// session runs again, a quit is requested or the frame limit is reached.
fn xr_with_reconnect(args: &RunArgs, stats: &mut RunStats) -> Result<()> {
    loop {
        match super::xr_session::run_session(args, stats) {
            Err(e) if args.reconnect && e.is_runtime_loss() => reconnect_after(&e, args, stats)?,
            other => return other,
        }
        let started = stats.run_started();
        if crate::quit::requested() || args.limit_reached(stats.frames_submitted, started) {
            return Ok(());
        }
    }
}

/// Reports the loss `e` and waits a second (in small steps, so Ctrl-C is
/// prompt) before the next attempt.
fn reconnect_after(e: &Error, args: &RunArgs, stats: &mut RunStats) -> Result<()> {
    debug_assert!(args.reconnect);
    eprintln!("vergence: {e}; reconnecting in 1 s (--reconnect; Ctrl-C to stop)");
    stats.reconnects += 1;
    for _ in 0..20 {
        if crate::quit::requested() {
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok(())
}

/// The headless loop: the fallback profile's rig at the spawn pose, the
/// head turning slowly (±20° yaw over 10 s) so culling and batching see
/// motion; paced by nothing (frames run back to back).
fn run_headless(args: &RunArgs, stats: &mut RunStats) -> Result<()> {
    let profile = load_stereo_profile(&args.hmd_fallback)?;
    let (scene, _) = load_scene(&args.scene)?;
    let ctx = Arc::new(Context::new_headless(Validation::from_env())?);
    let extent = eye_extent(&profile, args.size);
    let renderer = super::headless::new_renderer(&ctx, &scene, &args.config, extent)?;
    let mut driver = FrameDriver::new(renderer, &scene)?;
    let places = super::viewpoints::plan(args, &scene, &profile.views[0].fov)?;
    stats.viewpoints = places.iter().map(|v| v.name.clone()).collect();
    let spawn = places[0].origin;
    stats.mode = "headless".into();
    stats.scene = Some(SceneCounts::of(&scene));
    stats.config = driver.renderer().config.clone();
    stats.foveation = driver.renderer().foveation_path.clone();
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
    // A finished frame's record: written when its GPU times are known.
    // Heads of the frames in flight, by frame index, for their records.
    let mut heads: std::collections::VecDeque<(u64, Pose)> = Default::default();
    let record = |r: FrameResult,
                  stats: &mut RunStats,
                  heads: &mut std::collections::VecDeque<(u64, Pose)>|
     -> Result<()> {
        stats.cull = r.cull;
        while heads.front().is_some_and(|(i, _)| *i < r.index) {
            heads.pop_front();
        }
        let head = heads
            .front()
            .filter(|(i, _)| *i == r.index)
            .map(|(_, h)| PoseFile::from(h));
        stats.push_frame(FrameRecord {
            index: r.index,
            should_render: true,
            wait_ms: 0.0,
            cpu_ms: r.cpu_ms(),
            gpu_ms: r.gpu_ms(),
            cull_ms: r.cull_ms,
            predicted_display_time_ns: (r.started - started).as_nanos() as i64,
            predicted_display_period_ns: period_ns,
            missed_periods: 0,
            instances_drawn: r.stats.instances_drawn,
            fov: r.fov.to_vec(),
            head_world: head,
            events: Vec::new(),
        })
    };
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
        heads.push_back((index, head));
        let capture = args.capture.is_some() && args.frames == Some(stats.frames_submitted + 1);
        driver.frame(&rig, index, capture)?;
        if capture {
            let images = driver.read_images()?;
            write_capture(args.capture.as_deref().expect("checked"), &images, &rig)?;
        }
        stats.frames_submitted += 1;
        stats.frames_rendered += 1;
        index += 1;
        while let Some(r) = driver.take_completed() {
            record(r, stats, &mut heads)?;
        }
        if index == WARMUP_FRAMES {
            stats.sample_memory(&ctx, false);
        }
    };
    driver.finish()?;
    while let Some(r) = driver.take_completed() {
        record(r, stats, &mut heads)?;
    }
    stats.sample_memory(&ctx, true);
    stats.duration_s = started.elapsed().as_secs_f64();
    stats.validation_messages = ctx.validation_messages();
    drop(driver);
    Ok(())
}
