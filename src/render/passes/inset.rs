//! Multi-resolution foveated rendering (`inset[=F]`, `inset-fov=DEG`): each
//! eye is rendered twice, as a wide view over its whole FOV into targets
//! of F × the eye size per axis (`forward-wide`), and as the eye itself at
//! full size but only inside the inset rectangle around the gaze — render
//! area and scissor limited to it, so only its pixels are rasterized,
//! cleared and resolved (`forward-inset`). The composite (`inset-composite`,
//! `shaders/inset_composite.frag`) then writes the eye image: the wide view
//! upsampled bilinearly, the inset over it with a feathered seam
//! ([`crate::view::inset`] has the rectangle and the weight). Culling tests
//! each eye once: both views draw the eye's visible list.
//!
//! The inset keeps the eye's own projection and viewport, so its pixels are
//! the full-resolution render's own; the wide view keeps the eye's
//! projection with a smaller viewport, so it is the same image at a lower
//! resolution.

use super::{destroy_pipelines, PipelineSetup, Recorder};
use crate::error::{Result, VkContext};
use crate::gpu::query::Queries;
use crate::gpu::shaders;
use crate::gpu::Context;
use crate::render::attachments::{AttachmentSet, Attachments, SetOptions};
use crate::view::inset::PixelRect;
use ash::vk;

/// The wide view's targets, the composite pipeline and its sampler.
pub struct InsetPass {
    /// The wide view's attachment sets (as the eye's: one 2-layer set under
    /// multiview, one per eye in two-pass), resolved images sampled.
    pub wide: Vec<AttachmentSet>,
    /// The wide view's size per eye.
    pub wide_extent: vk::Extent2D,
    /// 2D-array views of the wide resolves (what the composite samples,
    /// whatever their layer count).
    wide_views: Vec<vk::ImageView>,
    composite: vk::Pipeline,
    sampler: vk::Sampler,
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
        let opts = SetOptions {
            sampled: true,
            ..SetOptions::default()
        };
        let wide = Attachments::new(ctx, wide_extent, samples, multiview, opts)?.sets;
        let mut wide_views = Vec::new();
        for set in &wide {
            let view = crate::gpu::memory::Image::make_view(
                ctx,
                set.resolve.image,
                crate::render::attachments::COLOR_FORMAT,
                vk::ImageAspectFlags::COLOR,
                vk::ImageViewType::TYPE_2D_ARRAY,
                0,
                set.resolve.layers,
                1,
            );
            match view {
                Ok(v) => wide_views.push(v),
                Err(e) => {
                    for v in wide_views {
                        // SAFETY: unused; made above.
                        unsafe { ctx.device.destroy_image_view(v, None) };
                    }
                    for s in wide {
                        s.destroy(ctx);
                    }
                    return Err(e);
                }
            }
        }
        let undo = |wide: Vec<AttachmentSet>, views: &[vk::ImageView]| {
            for &v in views {
                // SAFETY: unused; made above.
                unsafe { ctx.device.destroy_image_view(v, None) };
            }
            for s in wide {
                s.destroy(ctx);
            }
        };
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE);
        // SAFETY: plain object creation; destroyed by `destroy`.
        let sampler = match unsafe { ctx.device.create_sampler(&info, None) }
            .vk("creating the inset composite's sampler")
        {
            Ok(s) => s,
            Err(e) => {
                undo(wide, &wide_views);
                return Err(e);
            }
        };
        let (vs, fs) = (
            shaders::FLOOR_VERT.words(),
            shaders::INSET_COMPOSITE_FRAG.words(),
        );
        let desc = setup.composed_desc("inset composite", &vs, &fs);
        let composite = match desc.build(ctx) {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: unused; created above.
                unsafe { ctx.device.destroy_sampler(sampler, None) };
                undo(wide, &wide_views);
                return Err(e);
            }
        };
        Ok(InsetPass {
            wide,
            wide_extent,
            wide_views,
            composite,
            sampler,
        })
    }

    /// What the composite samples: per attachment set the eye's resolved
    /// frame (binding 6) and the wide view's (binding 7), the second
    /// repeating the first under multiview.
    pub fn images(
        &self,
        targets: &Attachments,
    ) -> Option<([vk::DescriptorImageInfo; 2], [vk::DescriptorImageInfo; 2])> {
        let info = |image_view| vk::DescriptorImageInfo {
            sampler: self.sampler,
            image_view,
            image_layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        };
        let eye: Vec<vk::ImageView> = targets
            .sets
            .iter()
            .filter_map(|s| s.filled.as_ref().map(|f| f.1))
            .collect();
        let wide = &self.wide_views;
        let (e0, w0) = (*eye.first()?, *wide.first()?);
        let e1 = eye.get(1).copied().unwrap_or(e0);
        let w1 = wide.get(1).copied().unwrap_or(w0);
        Some(([info(e0), info(e1)], [info(w0), info(w1)]))
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
            targets.sets.iter().chain(&self.wide),
            (extent, view_mask),
            self.composite,
            |eye| [lo, eye, hi, feather],
        )
    }

    /// Destroys the targets, pipeline and sampler; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        destroy_pipelines(ctx, [&self.composite]);
        // SAFETY: the device is idle; the sampler belongs to `self`.
        unsafe { ctx.device.destroy_sampler(self.sampler, None) };
        for v in self.wide_views {
            // SAFETY: the device is idle; the view belongs to `self`.
            unsafe { ctx.device.destroy_image_view(v, None) };
        }
        for s in self.wide {
            s.destroy(ctx);
        }
    }
}
