//! Radial density masking's fill in place (`rdm` with `inset` or `lms`).
//! With the inset the checkerboard goes in the wide views (the periphery;
//! the inset itself is drawn whole), with lens-matched shading in the LMS
//! image; the passes after them (the inset's accumulation and composite,
//! LMS's resample) read those images as they are, so the skipped quads are
//! filled in the resolved image itself, after every scope and before those
//! passes, by `shaders/rdm_fill_in_place.comp`: each skipped pixel takes
//! the mean of the pixels two to its left, right, top and bottom — the
//! fill of [`super::rdm`], which writes a separate image — averaged in
//! linear light. Those neighbours lie in rendered quads, which no
//! invocation writes, so reading and writing one image is race-free.

use crate::error::Result;
use crate::gpu::barrier::{self, Use};
use crate::gpu::pipeline::{compute_pipeline, DescriptorSets};
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::attachments::AttachmentSet;
use ash::vk;

/// Bytes of the push constants: size, radius, set, unused.
const PUSH_BYTES: u32 = 16;

/// The fill's pipeline and its one descriptor set (the images do not
/// change between frame slots).
pub struct RdmInPlace {
    radius: f32,
    sets: DescriptorSets,
    pipeline: vk::Pipeline,
}

impl RdmInPlace {
    /// The fill of `targets`' resolved images (made with storage use) for
    /// NDC radius `radius`; on failure, destroys what it made.
    pub fn new(ctx: &Context, targets: &[AttachmentSet], radius: f32) -> Result<RdmInPlace> {
        let views: Vec<vk::ImageView> = targets.iter().filter_map(|s| s.resolve_storage).collect();
        if views.len() != targets.len() {
            return Err(crate::error::Error::Gpu(
                "RDM's fill in place needs resolve images made with storage use".into(),
            ));
        }
        let stage = vk::ShaderStageFlags::COMPUTE;
        let sets = DescriptorSets::new(
            ctx,
            &[(vk::DescriptorType::STORAGE_IMAGE, 2, stage)],
            stage,
            PUSH_BYTES,
            1,
            "rdm fill in place",
        )?;
        let storage = super::sampled::pair(&views, vk::Sampler::null(), vk::ImageLayout::GENERAL);
        // No frame has used the set yet.
        sets.write_images(ctx, 0, &[(0, vk::DescriptorType::STORAGE_IMAGE, &storage)]);
        let code = shaders::RDM_FILL_IN_PLACE_COMP.words();
        match compute_pipeline(ctx, sets.layout, &code, "rdm fill in place") {
            Ok(pipeline) => Ok(RdmInPlace {
                radius,
                sets,
                pipeline,
            }),
            Err(e) => {
                sets.destroy(ctx);
                Err(e)
            }
        }
    }

    /// After every scope (and the sky after the resolve): fills the
    /// skipped quads of `targets`' resolved images over `extent` (the size
    /// drawn this frame), timed as `rdm-fill`, and hands the images on as
    /// written colour attachments, as the scopes left them.
    pub fn record(
        &self,
        rec: &super::Recorder,
        q: &mut Queries,
        targets: &[AttachmentSet],
        extent: vk::Extent2D,
    ) {
        let colour = vk::ImageAspectFlags::COLOR;
        let transition = |from: Use, to: Use| -> Vec<vk::ImageMemoryBarrier2<'static>> {
            targets
                .iter()
                .map(|s| barrier::image(s.resolve.image, colour, s.resolve.layers, from, to))
                .collect()
        };
        let size = extent.width | extent.height << 16;
        q.begin_pass(rec.ctx, rec.cmd, "rdm-fill");
        rec.barriers(&transition(Use::COLOR_ATTACHMENT, Use::COMPUTE_STORAGE_RW));
        rec.bind_compute(self.pipeline, &self.sets);
        for (i, set) in targets.iter().enumerate() {
            let push = [size, self.radius.to_bits(), i as u32, 0];
            let groups = [
                extent.width.div_ceil(8),
                extent.height.div_ceil(8),
                set.resolve.layers,
            ];
            rec.dispatch(self.sets.layout, &push, groups);
        }
        rec.barriers(&transition(Use::COMPUTE_STORAGE_RW, Use::COLOR_ATTACHMENT));
        q.end_pass(rec.ctx, rec.cmd);
    }

    /// Destroys the pipeline and set; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        // SAFETY: the device is idle; the pipeline belongs to `self`.
        unsafe { ctx.device.destroy_pipeline(self.pipeline, None) };
        self.sets.destroy(ctx);
    }
}
