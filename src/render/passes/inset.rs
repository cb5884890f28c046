//! Multi-resolution foveated rendering (`inset[=F]`, `inset-fov=DEG`): each
//! eye is rendered twice, as a wide view over its whole FOV into targets
//! of F × the eye size per axis (`forward-wide`), and as the eye itself at
//! full size but only inside the inset rectangle around the gaze — render
//! area and scissor limited to it, so only its pixels are rasterized,
//! cleared and resolved (`forward-inset`). The composite (`inset-composite`,
//! `shaders/inset_composite.frag`) then writes the eye image: the wide view
//! upsampled bilinearly, the inset over it with a feathered seam
//! ([`crate::view::inset`] has the rectangle and the weight). Culling tests
//! each eye once: the wide views draw the eye's visible list, the inset
//! views the part of it inside the eyes' volumes through the rectangle
//! (`Batcher::build_inset`; with `gpu-cull`, the GPU's list).
//!
//! The inset keeps the eye's own projection and viewport, so its pixels are
//! the full-resolution render's own; the wide view keeps the eye's
//! projection with a smaller viewport, so it is the same image at a lower
//! resolution.

use super::sampled::SampledSets;
use super::{destroy_pipelines, PipelineSetup, Recorder};
use crate::error::Result;
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::attachments::Attachments;
use crate::view::inset::PixelRect;
use ash::vk;

/// The wide view's targets, the composite pipeline and its sampler.
pub struct InsetPass {
    /// The wide view's attachment sets at F × the eye size (as the eye's:
    /// one 2-layer set under multiview, one per eye in two-pass), resolved
    /// images sampled.
    pub wide: SampledSets,
    composite: vk::Pipeline,
}

impl InsetPass {
    /// The wide targets at `scale` × `extent` (`samples` per pixel) and the
    /// composite; on failure, destroys what it made.
    pub fn new(
        setup: &PipelineSetup,
        extent: vk::Extent2D,
        scale: f64,
        samples: u32,
        multiview: bool,
    ) -> Result<InsetPass> {
        let ctx = setup.ctx;
        let wide_extent = crate::render::scaled(extent, scale);
        let wide = SampledSets::new(
            ctx,
            wide_extent,
            samples,
            multiview,
            setup.depth_format,
            "inset composite",
        )?;
        let (vs, fs) = (
            shaders::FLOOR_VERT.words(),
            shaders::INSET_COMPOSITE_FRAG.words(),
        );
        let desc = setup.composed_desc("inset composite", &vs, &fs);
        match desc.build(ctx) {
            Ok(composite) => Ok(InsetPass { wide, composite }),
            Err(e) => {
                wide.destroy(ctx);
                Err(e)
            }
        }
    }

    /// What the composite samples: per attachment set the eye's resolved
    /// frame (binding 6) and the wide view's (binding 7), the second
    /// repeating the first under multiview.
    pub fn images(
        &self,
        targets: &Attachments,
    ) -> Option<([vk::DescriptorImageInfo; 2], [vk::DescriptorImageInfo; 2])> {
        let eye: Vec<vk::ImageView> = targets
            .sets
            .iter()
            .filter_map(|s| s.filled.as_ref().map(|f| f.1))
            .collect();
        let e0 = *eye.first()?;
        let e1 = eye.get(1).copied().unwrap_or(e0);
        Some(([self.wide.info(e0), self.wide.info(e1)], self.wide.infos()?))
    }

    /// After both views of every set: their resolved frames are made
    /// readable and each set's output image is written from them. Returns
    /// the draw calls.
    pub fn record_composite(
        &self,
        rec: &Recorder,
        q: &mut Queries,
        targets: &Attachments,
        extent: vk::Extent2D,
        view_mask: u32,
        rect: PixelRect,
    ) -> u64 {
        let lo = rect.x0 | rect.y0 << 16;
        let hi = rect.x1 | rect.y1 << 16;
        let feather = crate::view::inset::FEATHER_PX.to_bits();
        super::record_composed(
            rec,
            q,
            "inset-composite",
            targets,
            targets.sets.iter().chain(&self.wide.sets),
            (extent, view_mask),
            self.composite,
            |eye| [lo, eye, hi, feather],
        )
    }

    /// Destroys the targets and pipeline; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, [&self.composite]);
        self.wide.destroy(ctx);
    }
}
