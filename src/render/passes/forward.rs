//! The forward pass: the frame's batches drawn with the scene pipelines (PBR
//! with one sun and hemispheric ambient, an unlit variant, one pipeline per
//! alpha mode / double-sided / unlit combination the scene uses) and the
//! procedural sky, a full-screen triangle at the far plane drawn after the
//! opaque and masked batches and before the blended ones (reverse-Z: depth 0
//! passes GREATER_OR_EQUAL only where nothing was drawn). Under multiview one
//! scope draws both eyes (view mask 0b11); in two-pass each eye has its own.

use super::gpu_cull::GpuCull;
use super::{destroy_pipelines, PipelineSetup, Recorder};
use crate::error::Result;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::batches::{Draw, PipelineKey};
use ash::vk;
use std::collections::HashMap;

/// The scene and sky pipelines of the forward views.
#[derive(Default)]
pub struct Forward {
    pipelines: HashMap<PipelineKey, vk::Pipeline>,
    sky: vk::Pipeline,
}

impl Forward {
    /// Builds the scene pipelines and the sky.
    pub fn new(setup: &PipelineSetup) -> Result<Forward> {
        let (vs, fs) = (shaders::SCENE_VERT.words(), shaders::SCENE_FRAG.words());
        let (full, sky) = (shaders::FULLSCREEN_VERT.words(), shaders::SKY_FRAG.words());
        Ok(Forward {
            pipelines: setup.scene_pipelines(&setup.scene_desc(&vs, &fs))?,
            sky: setup.fullscreen_desc("sky", &full, &sky).build(setup.ctx)?,
        })
    }

    /// Draws `draws` for view `eye` inside the open scope, and the sky when
    /// `with_sky`. Returns the draw calls.
    pub fn record(&self, rec: &Recorder, draws: &[Draw], eye: u32, with_sky: bool) -> u64 {
        rec.draw_batches(draws, &self.pipelines, with_sky.then_some(self.sky), eye)
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
            &self.pipelines,
            with_sky.then_some(self.sky),
            eye,
            slot,
            late,
        )
    }

    /// Destroys the pipelines; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, self.pipelines.values().chain([&self.sky]));
    }
}
