//! The frame driver: the one loop body every frame goes through — `render`,
//! `run` (headless and OpenXR) and `bench` alike. Rig in → cull → batch →
//! record → submit → results out, so a technique is wired once.
//!
//! Frames are pipelined: [`FrameDriver::submit`] does not wait for the GPU.
//! With N frames in flight, frame n starts (before culling) by waiting for
//! frame n − N only, so culling, batching and recording of one frame overlap
//! the GPU work of the previous N − 1; with N = 1 nothing overlaps. A frame's [`FrameResult`]
//! (with its GPU timestamps) comes out of [`FrameDriver::take_completed`]
//! once its fence has signalled, in submission order.

use super::culling::CullState;
use super::{FrameOutput, FrameStats, Renderer};
use crate::cull::CullStats;
use crate::error::{Error, Result};
use crate::interact::overlay::OverlayBox;
use crate::interact::section::SectionPlane;
use crate::scene::motion::{transforms_at, Moved, MovingGroup};
use crate::scene::{Scene, WorldBounds};
use crate::view::{Fov, StereoRig};
use rayon::prelude::*;
use std::collections::VecDeque;
use std::time::Instant;

/// Everything measured about one frame, available once the GPU finished it.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// The caller's frame number (as given to [`FrameDriver::record`]).
    pub index: u64,
    /// When the frame's work began (before culling).
    pub started: Instant,
    /// Wall-clock milliseconds since the previous frame began (None for the
    /// first frame): the loop's measured frame interval.
    pub interval_ms: Option<f64>,
    /// CPU milliseconds spent culling.
    pub cull_ms: f64,
    /// CPU milliseconds spent moving instances (their transforms and
    /// bounds, the culling hierarchy's refit, staging their records).
    pub motion_ms: f64,
    /// Culling counters (None without a culling strategy).
    pub cull: Option<CullStats>,
    /// The field of view of each eye it was rendered with.
    pub fov: [Fov; 2],
    /// The renderer's statistics (CPU phases, GPU passes, counts).
    pub stats: FrameStats,
    /// With `aq`: the level, render scale (per axis) and inset wide factor
    /// the frame was rendered at, and the rendered size per eye.
    pub aq: Option<AqFrame>,
}

/// Adaptive quality's part of a frame's record.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct AqFrame {
    /// The controller's level (0: the smallest scale, and with the inset's
    /// rung its smallest wide factor).
    pub level: usize,
    /// Render scale per axis.
    pub scale: f64,
    /// The factor on the inset's wide-view scale (1 unless the controller
    /// is on the inset's rung, below the lowest render scale).
    pub wide_factor: f64,
    /// Whether the inset's wide view was drawn at one sample (`aq`'s MSAA
    /// rung and the levels below it).
    pub wide_one_sample: bool,
    /// The rendered size per eye, pixels.
    pub size: [u32; 2],
    /// The budget the controller held the frame to, milliseconds.
    pub budget_ms: f64,
}

impl FrameResult {
    /// CPU milliseconds of the frame's own work: cull, batch, record and
    /// submit (not the waits for the GPU).
    pub fn cpu_ms(&self) -> f64 {
        self.cull_ms
            + self.motion_ms
            + self.stats.cpu_ms.batch
            + self.stats.cpu_ms.record
            + self.stats.cpu_ms.submit
    }

    /// GPU milliseconds of the frame (the sum of its passes' timestamps).
    pub fn gpu_ms(&self) -> f64 {
        self.stats.gpu_ms.values().sum()
    }
}

/// Drives a [`Renderer`] (and the configuration's culling) frame by frame.
pub struct FrameDriver {
    renderer: Renderer,
    culling: Option<CullState>,
    /// The frame between `record` and `submit`.
    recorded: Option<FrameResult>,
    /// Submitted frames by the renderer's frame number, oldest first.
    in_flight: VecDeque<(u64, FrameResult)>,
    /// Finished frames not yet taken, oldest first.
    done: VecDeque<FrameResult>,
    last_start: Option<Instant>,
    /// The scene's moving instances (None: it has none).
    motion: Option<MotionState>,
    /// The scene time of the next frame, when the caller set it.
    time: Option<f64>,
    /// Adaptive quality's controller (`aq`), fed each finished frame's
    /// GPU time.
    aq: Option<crate::adaptive::AdaptiveQuality>,
}

/// The frame budget of `aq` when neither `--budget-ms` nor the runtime
/// gives one: 90 Hz.
pub const DEFAULT_BUDGET_MS: f64 = 1000.0 / DEFAULT_FRAME_RATE;

/// Scene time per frame number when the caller gives none: 90 frames a
/// second (headless renders and the bench are then reproducible).
pub const DEFAULT_FRAME_RATE: f64 = 90.0;

/// What the driver keeps to move a scene's instances each frame.
struct MotionState {
    groups: Vec<MovingGroup>,
    /// Object-space bounds per mesh.
    mesh_bounds: Vec<(glam::Vec3, glam::Vec3)>,
    moved: Vec<Moved>,
    bounds: Vec<WorldBounds>,
    boxes: Vec<(u32, (glam::DVec3, glam::DVec3))>,
}

impl MotionState {
    /// The instances at time `t`: transforms and bounds into the buffers.
    /// The instances at time `t`: transforms and bounds into the buffers,
    /// in parallel; with `boxes` also the (index, box) pairs CPU culling
    /// takes.
    fn at(&mut self, t: f64, boxes: bool) {
        transforms_at(&self.groups, t, &mut self.moved);
        let mesh_bounds = &self.mesh_bounds;
        self.moved
            .par_iter()
            .with_min_len(256)
            .map(|m| WorldBounds::of(mesh_bounds[m.mesh as usize], &m.transform))
            .collect_into_vec(&mut self.bounds);
        self.boxes.clear();
        if boxes {
            self.moved
                .par_iter()
                .zip(self.bounds.par_iter())
                .with_min_len(256)
                .map(|(m, b)| (m.index, (b.min, b.max)))
                .collect_into_vec(&mut self.boxes);
        }
    }
}

impl FrameDriver {
    /// Drives `renderer`, culling `scene` as the renderer's configuration
    /// says (builds the BVH when a strategy is set).
    pub fn new(renderer: Renderer, scene: &Scene) -> Result<FrameDriver> {
        let culling = CullState::new(&renderer.config, scene)?;
        let slots = renderer.frames_in_flight();
        let aq = aq_controller(&renderer);
        let motion = (!scene.moving.is_empty()).then(|| MotionState {
            groups: scene.moving.clone(),
            mesh_bounds: (0..scene.meshes.len() as u32)
                .map(|m| scene.mesh_bounds(m))
                .collect(),
            moved: Vec::new(),
            bounds: Vec::new(),
            boxes: Vec::new(),
        });
        Ok(FrameDriver {
            renderer,
            culling,
            recorded: None,
            aq,
            in_flight: VecDeque::with_capacity(slots + 1),
            done: VecDeque::with_capacity(slots + 1),
            last_start: None,
            motion,
            time: None,
        })
    }

    /// Sets the scene time (seconds) of the next recorded frame: where
    /// moving instances stand. Without it frame `n` is at
    /// `n /` [`DEFAULT_FRAME_RATE`].
    pub fn set_time(&mut self, seconds: f64) {
        self.time = Some(seconds);
    }

    /// The moving instances where the last recorded frame placed them
    /// (empty in a scene without motion): what ray casts follow.
    pub fn moved(&self) -> &[Moved] {
        self.motion.as_ref().map_or(&[], |m| &m.moved)
    }

    /// The renderer.
    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// The renderer, for the one-frame calls (floors, readback).
    pub fn renderer_mut(&mut self) -> &mut Renderer {
        &mut self.renderer
    }

    /// The culling state (None without a strategy).
    pub fn culling(&self) -> Option<&CullState> {
        self.culling.as_ref()
    }

    /// Sets the section plane of the following frames: the scene shaders
    /// clip beyond it and CPU culling skips instances wholly beyond it
    /// (GPU culling, `gpu-cull`, does not: its instances beyond the plane
    /// are drawn and clipped).
    pub fn set_section(&mut self, plane: Option<SectionPlane>) {
        self.renderer.extras.section = plane;
        if let Some(c) = self.culling.as_mut() {
            c.set_section(plane);
        }
    }

    /// Sets the overlay boxes (controllers, rays, arcs, labels) of the
    /// following frames.
    pub fn set_overlay(&mut self, boxes: &[OverlayBox]) {
        let o = &mut self.renderer.extras.overlay;
        o.clear();
        o.extend_from_slice(boxes);
    }

    /// Culls `rig` and records frame `index` (the command buffer stays open
    /// for [`FrameDriver::submit`]); waits first for the frame that last
    /// used this frame's slot.
    pub fn record(&mut self, rig: &StereoRig, index: u64) -> Result<()> {
        if self.recorded.is_some() {
            return Err(Error::Gpu(
                "a frame was recorded but never submitted".into(),
            ));
        }
        let started = Instant::now();
        let interval_ms = self.last_start.map(|p| ms_between(p, started));
        self.last_start = Some(started);
        // Frame n - N first: with 1 in flight nothing of this frame, not
        // even culling, overlaps the previous frame's GPU work.
        self.renderer.wait_for_slot()?;
        let aq = self.aq.as_ref().map(|a| {
            let l = a.current();
            self.renderer.set_aq_level(&l);
            let e = self.renderer.extent();
            AqFrame {
                level: a.level(),
                scale: l.scale,
                wide_factor: l.wide_factor,
                wide_one_sample: l.wide_one_sample,
                size: [e.width, e.height],
                budget_ms: a.budget_ms(),
            }
        });
        let motion_start = Instant::now();
        let time = self
            .time
            .take()
            .unwrap_or(index as f64 / DEFAULT_FRAME_RATE);
        if let Some(m) = self.motion.as_mut() {
            m.at(time, self.culling.is_some());
            if let Some(c) = self.culling.as_mut() {
                c.move_instances(&m.boxes)?;
            }
            self.renderer.move_instances(&m.moved, &m.bounds)?;
        }
        let motion_ms = ms_between(motion_start, Instant::now());
        let cull_start = Instant::now();
        let (visible, cull) = match self.culling.as_mut() {
            Some(c) => {
                let (v, s) = c.cull(rig, index)?;
                (Some(v), Some(s))
            }
            None => (None, None),
        };
        let cull_ms = ms_between(cull_start, Instant::now());
        self.renderer.record_frame(rig, visible)?;
        self.recorded = Some(FrameResult {
            index,
            started,
            interval_ms,
            cull_ms,
            motion_ms,
            cull,
            // The renderer checked above that the rig has two views.
            fov: [rig.views[0].fov, rig.views[1].fov],
            stats: FrameStats::default(),
            aq,
        });
        Ok(())
    }

    /// Submits the recorded frame (copied into `output` when given, read
    /// back when `readback`) without waiting for it.
    pub fn submit(&mut self, output: Option<&FrameOutput>, readback: bool) -> Result<()> {
        let result = self
            .recorded
            .take()
            .ok_or_else(|| Error::Gpu("submit without a recorded frame".into()))?;
        let frame = self.renderer.submit_frame(output, readback)?;
        self.in_flight.push_back((frame, result));
        self.gather();
        Ok(())
    }

    /// Records and submits frame `index` of `rig` (no output images).
    pub fn frame(&mut self, rig: &StereoRig, index: u64, readback: bool) -> Result<()> {
        self.record(rig, index)?;
        self.submit(None, readback)
    }

    /// The oldest finished frame not taken yet.
    pub fn take_completed(&mut self) -> Option<FrameResult> {
        self.gather();
        self.done.pop_front()
    }

    /// Waits for every submitted frame; their results join
    /// [`FrameDriver::take_completed`].
    pub fn finish(&mut self) -> Result<()> {
        self.renderer.finish()?;
        self.gather();
        Ok(())
    }

    /// The last read-back frame, left and right (waits for the frames in
    /// flight; their results stay available).
    pub fn read_images(&mut self) -> Result<[image::RgbaImage; 2]> {
        let images = self.renderer.read_images();
        self.gather();
        images
    }

    /// Moves the renderer's finished frames to `done`, joined with what was
    /// known when they were recorded.
    fn gather(&mut self) {
        while let Some(stats) = self.renderer.take_completed() {
            // Frames finish in submission order; a frame rendered outside
            // the driver (e.g. `Renderer::render`) has no entry and is
            // skipped.
            while let Some((frame, _)) = self.in_flight.front() {
                if *frame > stats.frame {
                    break;
                }
                let (frame, mut result) = self.in_flight.pop_front().expect("front exists");
                if frame == stats.frame {
                    result.stats = stats;
                    if let Some(a) = self.aq.as_mut() {
                        if let Some(c) = a.update(result.gpu_ms()) {
                            tracing::debug!(
                                "aq: level {} → {} (scale {:.3}, wide factor {:.3}, wide at one sample {}; {:?})",
                                c.from,
                                c.to,
                                c.scale,
                                a.wide_factor(),
                                a.wide_one_sample(),
                                c.reason
                            );
                        }
                    }
                    self.done.push_back(result);
                    break;
                }
            }
        }
    }
}

impl FrameDriver {
    /// The frame budget of `aq` from the runtime's display period (or the
    /// profile's refresh rate), unless `--budget-ms` set one.
    pub fn set_display_budget(&mut self, ms: f64) {
        if self.renderer.config.effort.budget_ms.is_none() && ms.is_finite() && ms > 0.0 {
            if let Some(a) = self.aq.as_mut() {
                a.set_budget_ms(ms);
            }
        }
    }
}

impl FrameDriver {
    /// Starts adaptive quality again from its default level with no
    /// history (the bench, after its unmeasured spin-up frames), keeping
    /// the budget.
    pub fn reset_aq(&mut self) {
        if let Some(old) = self.aq.take() {
            let mut fresh = aq_controller(&self.renderer);
            if let Some(a) = fresh.as_mut() {
                a.set_budget_ms(old.budget_ms());
            }
            self.aq = fresh;
        }
    }
}

/// The controller of `renderer`'s `aq`: The Lab's levels from
/// [`crate::adaptive::MIN_SCALE`] to [`crate::adaptive::MAX_SCALE`], with
/// `inset` (unless `aq-scale-only`) the inset's rungs below them: the MSAA
/// rung where the renderer made its wide targets for it, then the wide
/// view's scale.
fn aq_controller(renderer: &Renderer) -> Option<crate::adaptive::AdaptiveQuality> {
    let config = &renderer.config;
    use crate::adaptive::{
        levels, wide_rung_factors, AdaptiveQuality, MAX_SCALE, MIN_SCALE, MIN_WIDE_FACTOR, STEP_PCT,
    };
    if !config.effort.aq {
        return None;
    }
    let budget = config.effort.budget_ms.unwrap_or(DEFAULT_BUDGET_MS);
    let aq = AdaptiveQuality::new(budget, levels(MIN_SCALE, MAX_SCALE, STEP_PCT)?)?;
    if config.effort.inset.is_none() || config.effort.aq_scale_only {
        return Some(aq);
    }
    let factors = wide_rung_factors(MIN_WIDE_FACTOR, STEP_PCT)?;
    Some(aq.with_wide_rungs(&factors, renderer.has_inset_msaa_rung()))
}

fn ms_between(a: Instant, b: Instant) -> f64 {
    (b - a).as_secs_f64() * 1e3
}
