//! The interaction overlay: controller models, pointing rays, the teleport
//! arc and its landing marker, measure points and the distance label, all
//! as shaded boxes that `overlay.vert` builds from the frame uniforms'
//! overlay list (36 vertices per box, one instance per box; no vertex
//! buffers). Drawn in the forward views' scope after the scene, depth
//! tested and written like the scene, in both eyes (multiview or each
//! two-pass scope).

use super::{destroy_pipelines, PipelineSetup, Recorder};
use crate::error::Result;
use crate::gpu::pipeline::GraphicsPipelineDesc;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::interact::overlay::MAX_BOXES;
use ash::vk;

/// Vertices of one box: six faces of two triangles.
const BOX_VERTICES: u32 = 36;

/// The overlay's pipeline.
#[derive(Default)]
pub struct Overlay {
    pipeline: vk::Pipeline,
}

impl Overlay {
    /// Builds the pipeline: no vertex input, no face culling (the shader
    /// does not order its corners), reverse-Z depth test and write.
    pub fn new(setup: &PipelineSetup) -> Result<Overlay> {
        let (vs, fs) = (shaders::OVERLAY_VERT.words(), shaders::OVERLAY_FRAG.words());
        let desc = GraphicsPipelineDesc {
            name: "interaction overlay",
            bindings: Vec::new(),
            attributes: Vec::new(),
            cull_mode: vk::CullModeFlags::NONE,
            ..setup.scene_desc(&vs, &fs)
        };
        Ok(Overlay {
            pipeline: desc.build(setup.ctx)?,
        })
    }

    /// Draws the first `boxes` overlay boxes of the frame uniforms for view
    /// `eye` inside the open scope. Returns the draw calls (0 or 1).
    pub fn record(&self, rec: &Recorder, boxes: usize, eye: u32) -> u64 {
        let n = boxes.min(MAX_BOXES) as u32;
        if n == 0 {
            return 0;
        }
        rec.bind(self.pipeline);
        rec.push_draw(0, eye);
        // SAFETY: inside a rendering scope with the pipeline bound; the
        // shader reads only the frame uniforms.
        unsafe { rec.ctx.device.cmd_draw(rec.cmd, BOX_VERTICES, n, 0, 0) };
        1
    }

    /// Destroys the pipeline; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, [&self.pipeline]);
    }
}
