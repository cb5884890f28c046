//! `vergence run`: the application. In a headset through OpenXR (see
//! [`crate::xr`]), or headless on an HMD profile when no runtime or headset
//! is there (`--xr auto`) or when asked (`--xr headless`). Both write the
//! same frame statistics (`--stats-out`).

use super::headless::{eye_extent, load_scene, load_stereo_profile, SceneCounts};
use super::mirror::{Desk, Mirror};
use super::session::{write_capture, FrameRecord, ViewInfo, WARMUP_FRAMES};
pub use super::session::{RunArgs, RunStats, XrMode};
use super::view::EyeImages;
use crate::config::RenderConfig;
use crate::error::{Error, Result};
use crate::gpu::{Context, Direct, Validation};
use crate::render::attachments::COLOR_FORMAT;
use crate::render::driver::{FrameDriver, FrameResult};
use crate::render::{OutputSpec, Renderer};
use crate::scene::Scene;
use crate::view::{Pose, PoseFile};
use glam::DVec3;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Runs `args`: OpenXR or headless as `--xr` says, writing `--stats-out`.
pub fn run(args: &RunArgs) -> Result<RunStats> {
    args.validate()?;
    crate::quit::install();
    let mut stats = RunStats::new(args.stats_out.as_deref())?;
    let mut desk = Desk::new(args.mirror, args.config.clone(), args.save_config.clone());
    desk.overlay = args.overlay;
    if let Some(k) = &args.kiosk {
        desk.live.allowed = k.toggles.clone();
        desk.scenes = k.scenes.len();
        if k.scenes.len() > 1 {
            desk.live.extra_help = Some("  N        the next scene".into());
        }
        tracing::info!(
            "kiosk {}: {} scenes, starting with {}",
            k.name,
            k.scenes.len(),
            k.scenes[0].name
        );
    }
    // A kiosk's N ends a session in order and starts one on the next scene.
    let mut mode = args.xr;
    let mut at = 0;
    let result = loop {
        let a = args.for_scene(at);
        let name = args.kiosk.as_ref().map_or(&a.scene, |k| &k.scenes[at].name);
        desk.live.frame_base = stats.begin_scene(name, &a.scene);
        if args.kiosk.is_some() {
            tracing::info!("kiosk: scene {name} from frame {}", desk.live.frame_base);
        }
        let r = run_once(&a, mode, &mut stats, &mut desk);
        stats.end_scene();
        let started = stats.run_started();
        let go_on = r.is_ok()
            && desk.next_scene
            && !desk.closed
            && !crate::quit::requested()
            && !args.limit_reached(stats.frames_submitted, started);
        if !go_on {
            break r;
        }
        desk.next_scene = false;
        if stats.mode == "headless" {
            // The fallback is not tried again for every scene.
            mode = XrMode::Headless;
        }
        let n = args.kiosk.as_ref().map_or(1, |k| k.scenes.len());
        at = (at + 1) % n;
        if let Some(k) = &args.kiosk {
            tracing::info!("kiosk: next scene {}", k.scenes[at].name);
            println!("next scene: {}", k.scenes[at].name);
        }
    };
    stats.mirror = desk.stats.clone();
    stats.toggles = desk.live.events.clone();
    stats.refused_toggles = desk.live.refused.clone();
    stats.summarize();
    if let Some(path) = &args.stats_out {
        if !stats.mode.is_empty() {
            stats.write(path)?;
        }
    }
    result.map(|()| stats)
}

/// One run of `args` as `mode` says: OpenXR, headless, or OpenXR with the
/// headless fallback.
fn run_once(args: &RunArgs, mode: XrMode, stats: &mut RunStats, desk: &mut Desk) -> Result<()> {
    match mode {
        XrMode::Headless => run_headless(args, stats, desk),
        XrMode::Openxr => xr_with_reconnect(args, stats, desk),
        XrMode::Auto => match super::xr_session::run_session(args, stats, desk) {
            Err(Error::XrUnavailable(reason)) => {
                eprintln!(
                    "vergence: no OpenXR headset ({reason}); running headless on the {} profile",
                    args.hmd_fallback
                );
                stats.fall_back(reason);
                run_headless(args, stats, desk)
            }
            Err(e) if args.reconnect && e.is_runtime_loss() => {
                reconnect_after(&e, args, stats).and_then(|()| xr_with_reconnect(args, stats, desk))
            }
            other => other,
        },
    }
}

/// An OpenXR run that, with `--reconnect`, outlives losing the runtime:
/// each loss is reported on one line and retried every second until a
/// session runs again, a quit is requested or the frame limit is reached.
fn xr_with_reconnect(args: &RunArgs, stats: &mut RunStats, desk: &mut Desk) -> Result<()> {
    loop {
        match super::xr_session::run_session(args, stats, desk) {
            Err(e) if args.reconnect && e.is_runtime_loss() => reconnect_after(&e, args, stats)?,
            other => return other,
        }
        let started = stats.run_started();
        if crate::quit::requested()
            || desk.ending()
            || args.limit_reached(stats.frames_submitted, started)
        {
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
/// motion; paced by nothing (frames run back to back). With a mirror each
/// frame is copied into eye images (as a session's swapchains) that the
/// mirror shows, and the window's keys switch optimizations.
fn run_headless(args: &RunArgs, stats: &mut RunStats, desk: &mut Desk) -> Result<()> {
    let profile = load_stereo_profile(&args.hmd_fallback)?;
    let (scene, _) = load_scene(&args.scene)?;
    let extent = eye_extent(&profile, args.size);
    desk.set_lenses(super::mirror::MirrorLenses::of(&profile));
    let extra = desk.prepare(
        &format!("vergence run: {} ({})", scene.name, profile.name),
        extent,
    );
    let ctx = Arc::new(Context::with_extensions(
        Validation::from_env(),
        &Direct,
        &extra,
    )?);
    let mut mirror = desk.mirror(&ctx, COLOR_FORMAT);
    let config = desk.live.config.clone();
    let mut frames = HeadlessFrames::new(&ctx, &scene, &config, extent, mirror.is_some())?;
    let places = super::viewpoints::plan(args, &scene, &profile.views[0].fov)?;
    stats.viewpoints = places.iter().map(|v| v.name.clone()).collect();
    let spawn = places[0].origin;
    describe_session(stats, &frames, &ctx, (&scene, &profile), extent);
    if let Some(m) = &mut mirror {
        m.set_title(&format!(
            "vergence run: {} [{}]",
            scene.name,
            config.opt_string()
        ));
    }
    let period_ns = (1e9 / profile.refresh_hz.max(1.0)) as i64;
    // --seconds counts from the run's start (across a kiosk's scenes).
    let started = stats.run_started();
    let mut turn_start: Option<Instant> = None;
    let mut index = 0u64;
    // A finished frame's record: written when its GPU times are known.
    // Heads and `--opt` strings of the frames in flight, by frame index.
    let mut heads = Heads::default();
    let record = |r: FrameResult, stats: &mut RunStats, heads: &mut Heads| {
        stats.cull = r.cull;
        stats.push_frame(frame_record(&r, heads, started, period_ns))
    };
    let mut opt = config.opt_string();
    // The last recorded frame's rig and scene time (F4 measures it).
    let mut last_shown: Option<(crate::view::StereoRig, f64)> = None;
    let looped = (|| -> Result<String> {
        loop {
            if crate::quit::requested() {
                return Ok("quit requested (signal)".into());
            }
            if args.limit_reached(stats.frames_submitted, started) {
                return Ok("frame or time limit reached".into());
            }
            if let Some(m) = mirror.as_mut() {
                if let Some(new) = desk.handle(m, index) {
                    let finished = frames.drain(m);
                    while let Some(r) = frames.driver.take_completed() {
                        let (i, t) = record(r, stats, &mut heads)?;
                        m.push_record(i, t);
                    }
                    finished?;
                    frames.switch(&ctx, &scene, new, extent, &mut desk.live)?;
                    opt = desk.live.config.opt_string();
                    m.set_title(&format!("vergence run: {} [{opt}]", scene.name));
                }
                let section = frames.driver.renderer().config.frame.section;
                let shown = last_shown.as_ref().map(|(r, t)| (r, *t));
                desk.measure_error(m, &ctx, &scene, shown, extent, section);
                desk.keep_pose(last_shown.as_ref().map(|(r, _)| r));
                if let Some(why) = desk.leaving() {
                    return Ok(why.into());
                }
            }
            // The turn starts at this loop's first frame (which looks
            // exactly from the spawn), not at the run's start.
            let t = turn_start.get_or_insert_with(Instant::now).elapsed();
            let head = turning_head(&spawn, t.as_secs_f64());
            let rig = profile.rig(head);
            heads.push_back((index, head, opt.clone()));
            if let Some(m) = mirror.as_mut() {
                m.set_overlay_text(&opt, 1000.0 / profile.refresh_hz.max(1.0));
            }
            let last = args.frames == Some(stats.frames_submitted + 1);
            let capture = args.capture.as_deref().filter(|_| last);
            // aq's budget: the profile's refresh period (unless --budget-ms).
            let budget_ms = 1000.0 / profile.refresh_hz.max(1.0);
            frames.render_one(&rig, index, budget_ms, mirror.as_mut(), capture)?;
            let time = index as f64 / crate::render::driver::DEFAULT_FRAME_RATE;
            last_shown = Some((rig, time));
            stats.frames_submitted += 1;
            stats.frames_rendered += 1;
            index += 1;
            while let Some(r) = frames.driver.take_completed() {
                if let Some(m) = mirror.as_mut() {
                    m.push_frame(&r);
                }
                let (i, t) = record(r, stats, &mut heads)?;
                // The overlay shows the records' own times.
                if let Some(m) = mirror.as_mut() {
                    m.push_record(i, t);
                }
            }
            if index == WARMUP_FRAMES {
                stats.sample_memory(&ctx, false);
            }
        }
    })();
    let finished = frames.driver.finish();
    while let Some(r) = frames.driver.take_completed() {
        record(r, stats, &mut heads)?;
    }
    let shot = match (mirror.as_mut(), &args.screenshot, &looped) {
        (Some(m), Some(path), Ok(_)) => m.write_screenshot(path),
        _ => Ok(()),
    };
    stats.sample_memory(&ctx, true);
    stats.duration_s = started.elapsed().as_secs_f64();
    // The mirror goes first (it waits for the device, so nothing still
    // reads the eye images), then the frames.
    if let Some(m) = mirror.take() {
        desk.put_back(m);
    }
    frames.destroy(&ctx);
    stats.validation_messages = ctx.validation_messages();
    stats.exit = looped?;
    finished.and(shot)
}

/// Heads and `--opt` strings of the frames in flight, by frame index.
type Heads = std::collections::VecDeque<(u64, Pose, String)>;

/// The headless run's head: the spawn turning 20° left and right of it
/// every 10 s, `t` seconds into the turn, at standing height.
fn turning_head(spawn: &Pose, t: f64) -> Pose {
    let yaw = 20.0 * (t * std::f64::consts::TAU / 10.0).sin();
    spawn.compose(&Pose::from_euler_deg(
        DVec3::new(0.0, 1.6, 0.0),
        yaw,
        0.0,
        0.0,
    ))
}

/// The session's description in `stats`: mode, scene, configuration and
/// the paths it runs, device, profile, image size and views.
fn describe_session(
    stats: &mut RunStats,
    frames: &HeadlessFrames,
    ctx: &Context,
    (scene, profile): (&crate::scene::Scene, &crate::view::profile::HmdProfile),
    extent: ash::vk::Extent2D,
) {
    stats.mode = "headless".into();
    stats.scene = Some(SceneCounts::of(scene));
    stats.config = frames.driver.renderer().config.clone();
    stats.renderer = frames.driver.renderer().report();
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
}

/// The record of finished frame `r`: its times and counts, and the head
/// and `--opt` string it was recorded with (from `heads`, the frames in
/// flight by index, older ones dropped); display times from `started`.
fn frame_record(
    r: &FrameResult,
    heads: &mut Heads,
    started: Instant,
    period_ns: i64,
) -> FrameRecord {
    while heads.front().is_some_and(|(i, ..)| *i < r.index) {
        heads.pop_front();
    }
    let this = heads.front().filter(|(i, ..)| *i == r.index);
    FrameRecord {
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
        head_world: this.map(|(_, h, _)| PoseFile::from(h)),
        events: Vec::new(),
        opt: this.map(|(.., o)| o.clone()).unwrap_or_default(),
        layers: 0,
        aq: r.aq,
    }
}

/// The headless loop's renderer, driver and (with a mirror) the eye images
/// each frame is copied into.
struct HeadlessFrames {
    driver: FrameDriver,
    eyes: Option<EyeImages>,
    with_eyes: bool,
}

impl HeadlessFrames {
    fn new(
        ctx: &Arc<Context>,
        scene: &Scene,
        config: &RenderConfig,
        extent: ash::vk::Extent2D,
        with_eyes: bool,
    ) -> Result<HeadlessFrames> {
        let renderer = if with_eyes {
            let spec = OutputSpec {
                color_format: COLOR_FORMAT,
                depth: false,
                quad: false,
            };
            Renderer::with_output(ctx.clone(), scene, config, extent, Some(spec))?
        } else {
            super::headless::new_renderer(ctx, scene, config, extent)?
        };
        let driver = FrameDriver::new(renderer, scene)?;
        // With aq the eye images hold the largest scale's frames.
        let held = driver.renderer().allocated_extent();
        let eyes = if with_eyes {
            Some(EyeImages::new(ctx, config.frame.stereo, held, 1)?)
        } else {
            None
        };
        Ok(HeadlessFrames {
            driver,
            eyes,
            with_eyes,
        })
    }

    /// Waits for the frames in flight and the mirror's copies (their
    /// results stay in the driver).
    fn drain(&mut self, mirror: &mut Mirror) -> Result<()> {
        self.driver.finish()?;
        mirror.finish()
    }

    /// A new renderer (and eye images when the stereo mode changed) for
    /// `config`; the frames in flight must have been drained.
    fn rebuild(
        &mut self,
        ctx: &Arc<Context>,
        scene: &Scene,
        config: &RenderConfig,
        extent: ash::vk::Extent2D,
    ) -> Result<()> {
        let with_eyes = self.with_eyes;
        if let Some(eyes) = self.eyes.take() {
            eyes.destroy(ctx);
        }
        let renderer = if with_eyes {
            let spec = OutputSpec {
                color_format: COLOR_FORMAT,
                depth: false,
                quad: false,
            };
            Renderer::with_output(ctx.clone(), scene, config, extent, Some(spec))?
        } else {
            super::headless::new_renderer(ctx, scene, config, extent)?
        };
        self.driver = FrameDriver::new(renderer, scene)?;
        if with_eyes {
            let held = self.driver.renderer().allocated_extent();
            self.eyes = Some(EyeImages::new(ctx, config.frame.stereo, held, 1)?);
        }
        Ok(())
    }

    /// A live switch to `new` (the frames in flight drained): a renderer
    /// that cannot be made is reverted to the one before.
    fn switch(
        &mut self,
        ctx: &Arc<Context>,
        scene: &Scene,
        new: RenderConfig,
        extent: ash::vk::Extent2D,
        live: &mut super::toggles::LiveConfig,
    ) -> Result<()> {
        let old = self.driver.renderer().config.clone();
        if let Err(e) = self.rebuild(ctx, scene, &new, extent) {
            live.revert(old.clone(), &e);
            self.rebuild(ctx, scene, &old, extent)?;
        }
        Ok(())
    }

    /// Records and submits frame `index` for `rig` (aq's budget
    /// `budget_ms`), shows it in the mirror, and with `capture` writes its
    /// images and rig there.
    fn render_one(
        &mut self,
        rig: &crate::view::StereoRig,
        index: u64,
        budget_ms: f64,
        mirror: Option<&mut Mirror>,
        capture: Option<&std::path::Path>,
    ) -> Result<()> {
        self.driver.set_display_budget(budget_ms);
        self.driver.record(rig, index)?;
        let output = self.eyes.as_ref().map(|e| e.output(0));
        self.driver.submit(output.as_ref(), capture.is_some())?;
        if let Some(m) = mirror {
            self.show(m, rig)?;
        }
        if let Some(path) = capture {
            let images = self.driver.read_images()?;
            write_capture(path, &images, rig)?;
        }
        Ok(())
    }

    /// Copies the frame just submitted into the mirror (its rendered part,
    /// smaller than the images with aq, with the rig's hidden area) and
    /// presents it.
    fn show(&self, m: &mut Mirror, rig: &crate::view::StereoRig) -> Result<()> {
        let Some(eyes) = self.eyes.as_ref() else {
            return Ok(());
        };
        let fovs: Vec<_> = rig.views.iter().map(|v| v.fov).collect();
        let shown = self.driver.renderer().extent();
        let sources = [0, 1].map(|eye| crate::gpu::surface::Source {
            extent: shown,
            ..eyes.source(0, eye)
        });
        m.copy(
            &sources,
            rig.hidden_area.as_deref().map(Vec::as_slice),
            &fovs,
        )?;
        m.present()
    }

    fn destroy(self, ctx: &Context) {
        drop(self.driver);
        if let Some(e) = self.eyes {
            e.destroy(ctx);
        }
    }
}
