//! The forward pass: the frame's batches drawn with the scene pipelines (PBR
//! with one sun and hemispheric ambient, an unlit variant, one pipeline per
//! alpha mode / double-sided / unlit combination the scene uses) and the
//! procedural sky, a full-screen triangle at the far plane drawn after the
//! opaque and masked batches and before the blended ones (reverse-Z: depth 0
//! passes GREATER_OR_EQUAL only where nothing was drawn). Under multiview one
//! scope draws both eyes (view mask 0b11); in two-pass each eye has its own.

use super::gpu_cull::GpuCull;
use super::{destroy_pipelines, PipelineSetup, Recorder, ScenePipelines};
use crate::config::PerDraw;
use crate::error::Result;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::batches::{Draw, PipelineKey};
use crate::render::submission::sky_in_run;
use ash::vk;
use std::collections::HashMap;

/// The scene and sky pipelines of the forward views.
#[derive(Default)]
pub struct Forward {
    pipelines: ScenePipelines,
    sky: vk::Pipeline,
}

impl Forward {
    /// Builds the scene pipelines and the sky.
    pub fn new(setup: &PipelineSetup) -> Result<Forward> {
        let sky_vertex = if setup.lms {
            &shaders::SKY_LMS_VERT
        } else {
            &shaders::FULLSCREEN_VERT
        };
        let (full, sky) = (sky_vertex.words(), shaders::SKY_FRAG.words());
        Ok(Forward {
            pipelines: ScenePipelines::new(Self::scene_pipelines(setup, false)?),
            sky: setup.fullscreen_desc("sky", &full, &sky).build(setup.ctx)?,
        })
    }

    fn scene_pipelines(
        setup: &PipelineSetup,
        section: bool,
    ) -> Result<HashMap<PipelineKey, vk::Pipeline>> {
        let vertex = match (setup.per_draw, section) {
            (PerDraw::Push, false) => &shaders::SCENE_VERT,
            (PerDraw::Ubo, false) => &shaders::SCENE_UBO_VERT,
            (PerDraw::Ssbo, false) => &shaders::SCENE_SSBO_VERT,
            (PerDraw::Push, true) => &shaders::SCENE_CLIP_VERT,
            (PerDraw::Ubo, true) => &shaders::SCENE_UBO_CLIP_VERT,
            (PerDraw::Ssbo, true) => &shaders::SCENE_SSBO_CLIP_VERT,
        };
        let (vs, fs) = (vertex.words(), shaders::SCENE_FRAG.words());
        setup.scene_pipelines(&setup.scene_desc(&vs, &fs))
    }

    /// Builds the pipelines that clip against the section plane, unless
    /// they exist.
    pub fn ensure_clipped(&mut self, setup: &PipelineSetup) -> Result<()> {
        if !self.pipelines.has_clipped() {
            self.pipelines
                .set_clipped(Self::scene_pipelines(setup, true)?);
        }
        Ok(())
    }

    /// Draws `draws` (the frame's list from its start) for view `eye`
    /// inside the open scope, and the sky when `with_sky`. Returns the draw
    /// calls.
    pub fn record(&self, rec: &Recorder, draws: &[Draw], eye: u32, with_sky: bool) -> u64 {
        self.record_from(rec, draws, 0, eye, with_sky)
    }

    /// [`ForwardPass::record`] of `draws` whose first is draw `base` of the
    /// frame's list (its per-draw record: the inset's own list follows the
    /// wide views').
    pub fn record_from(
        &self,
        rec: &Recorder,
        draws: &[Draw],
        base: u32,
        eye: u32,
        with_sky: bool,
    ) -> u64 {
        let sky = with_sky.then(|| (self.sky, rec.sky_slot(draws)));
        rec.draw_batches(draws, base, self.pipelines.get(rec.section), sky, eye)
    }

    /// Draws the run `run` of the frame's list `draws` for view `eye` into
    /// a secondary command buffer continuing the scope, with the sky when
    /// it falls into this run (before draw `at`, the list's first blended
    /// one as [`Recorder::sky_slot`] finds it, else at the end of the
    /// `last` run). Returns the draw calls.
    pub fn record_run(
        &self,
        rec: &Recorder,
        draws: &[Draw],
        run: std::ops::Range<usize>,
        at: usize,
        last: bool,
        eye: u32,
    ) -> u64 {
        let sky = sky_in_run(at, draws.len(), &run, last).map(|i| (self.sky, i));
        let base = run.start as u32;
        rec.draw_batches(&draws[run], base, self.pipelines.get(rec.section), sky, eye)
    }

    /// Draws the primitives `gpu` culled into frame slot `slot` (its late
    /// phase's with `late`) for view `eye` inside the open scope, then the
    /// sky when `with_sky`. Returns the draw calls recorded besides the
    /// indirect ones.
    pub fn record_gpu(
        &self,
        rec: &Recorder,
        gpu: &GpuCull,
        eye: u32,
        slot: usize,
        with_sky: bool,
        late: bool,
    ) -> u64 {
        gpu.record_draws(
            rec,
            self.pipelines.get(rec.section),
            with_sky.then_some(self.sky),
            eye,
            slot,
            late,
        )
    }

    /// Destroys the pipelines; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, self.pipelines.all().chain([&self.sky]));
    }
}
