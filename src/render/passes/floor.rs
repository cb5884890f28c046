//! The raster floors: what a frame costs with no scene at all, measured in
//! the forward views' own scopes (same attachments, clears, resolves, masks
//! and shading rate). `Clear` only starts the attachments as the frame's
//! scopes do (depth cleared; colour cleared only where the frame clears
//! it, else don't-care, so its image is undefined: only its time is read)
//! and resolves; `FullscreenTriangle` adds one full-screen triangle with a
//! trivial fragment shader (the fill rate floor).

use super::{destroy_pipelines, PipelineSetup, Recorder};
use crate::error::Result;
use crate::gpu::pipeline::GraphicsPipelineDesc;
use crate::gpu::shaders;
use crate::gpu::Context;
use ash::vk;

/// What the floor measurements draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FloorKind {
    /// Clear the attachments only.
    Clear,
    /// One full-screen triangle with a trivial fragment shader.
    FullscreenTriangle,
}

/// The full-screen triangle's pipeline.
#[derive(Default)]
pub struct Floor {
    flat: vk::Pipeline,
}

impl Floor {
    /// Builds the pipeline (constant colour; the depth test off, but on
    /// where the stencil mask is marked in depth, so that the triangle
    /// stays out of the hidden area as the stencil test keeps it out
    /// otherwise: at depth 0 it passes against the clear and fails against
    /// the mask).
    pub fn new(setup: &PipelineSetup) -> Result<Floor> {
        let (vs, fs) = (shaders::FLOOR_VERT.words(), shaders::FLAT_FRAG.words());
        let flat = GraphicsPipelineDesc {
            depth_test: setup.mask_in_depth,
            ..setup.fullscreen_desc("raster floor", &vs, &fs)
        };
        Ok(Floor {
            flat: flat.build(setup.ctx)?,
        })
    }

    /// Draws floor `kind` for view `eye` inside the open scope. Returns the
    /// draw calls.
    pub fn record(&self, rec: &Recorder, kind: FloorKind, eye: u32) -> u64 {
        match kind {
            FloorKind::Clear => 0,
            FloorKind::FullscreenTriangle => {
                rec.bind_indices();
                rec.draw_fullscreen(self.flat, eye);
                1
            }
        }
    }

    /// Destroys the pipeline; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, [&self.flat]);
    }
}
