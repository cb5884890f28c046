//! The stereo render targets. Multiview renders into 2-layer images; two-pass
//! renders into one single-layer set per eye (as an OpenXR session would use
//! one swapchain per view). Each set is a multisampled colour and
//! depth-stencil pair as transient attachments (lazily allocated memory where
//! the device has it; contents never stored) and a single-sample resolve
//! image that holds the frame.

use crate::error::Result;
use crate::gpu::memory::{Image, ImageDesc};
use crate::gpu::Context;
use ash::vk;

/// Colour format of the resolved frame (what an OpenXR swapchain would use).
pub const COLOR_FORMAT: vk::Format = vk::Format::R8G8B8A8_SRGB;

/// Views one rendering scope draws into.
#[derive(Clone, Copy)]
pub struct TargetViews {
    /// Multisampled colour (or the resolve image at 1 sample).
    pub color: vk::ImageView,
    /// Depth-stencil.
    pub depth: vk::ImageView,
    /// Resolve target (None at 1 sample).
    pub resolve: Option<vk::ImageView>,
}

/// One set of attachments (2 layers for multiview, 1 for an eye in two-pass).
pub struct AttachmentSet {
    /// Multisampled colour (None at 1 sample).
    pub color_msaa: Option<Image>,
    /// Depth-stencil (multisampled to match).
    pub depth: Image,
    /// Resolved (or directly rendered) colour.
    pub resolve: Image,
}

impl AttachmentSet {
    fn new(
        ctx: &Context,
        extent: vk::Extent2D,
        samples: u32,
        layers: u32,
    ) -> Result<AttachmentSet> {
        let s = vk::SampleCountFlags::from_raw(samples);
        let transient = vk::ImageUsageFlags::TRANSIENT_ATTACHMENT;
        let desc = |name, format, samples, usage, aspect| ImageDesc {
            name,
            format,
            extent,
            layers,
            mips: 1,
            samples,
            usage,
            aspect,
            category: "render target",
        };
        let color_msaa = if samples > 1 {
            let d = desc(
                "colour msaa",
                COLOR_FORMAT,
                s,
                vk::ImageUsageFlags::COLOR_ATTACHMENT | transient,
                vk::ImageAspectFlags::COLOR,
            );
            Some(Image::new(ctx, &d)?)
        } else {
            None
        };
        let ds = vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL;
        let depth = Image::new(
            ctx,
            &desc(
                "depth-stencil",
                ctx.caps.depth_format,
                s,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | transient,
                ds,
            ),
        )?;
        let usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC;
        let resolve = Image::new(
            ctx,
            &desc(
                "colour resolve",
                COLOR_FORMAT,
                vk::SampleCountFlags::TYPE_1,
                usage,
                vk::ImageAspectFlags::COLOR,
            ),
        )?;
        Ok(AttachmentSet {
            color_msaa,
            depth,
            resolve,
        })
    }

    /// The views of this set.
    pub fn views(&self) -> TargetViews {
        match &self.color_msaa {
            Some(c) => TargetViews {
                color: c.view,
                depth: self.depth.view,
                resolve: Some(self.resolve.view),
            },
            None => TargetViews {
                color: self.resolve.view,
                depth: self.depth.view,
                resolve: None,
            },
        }
    }

    fn destroy(self, ctx: &Context) {
        if let Some(c) = self.color_msaa {
            c.destroy(ctx);
        }
        self.depth.destroy(ctx);
        self.resolve.destroy(ctx);
    }
}

/// The attachments of one stereo frame.
pub struct Attachments {
    /// One 2-layer set (multiview) or one single-layer set per eye (two-pass).
    pub sets: Vec<AttachmentSet>,
}

impl Attachments {
    /// Creates the attachments for `extent` per eye with `samples` (1 or 4).
    pub fn new(
        ctx: &Context,
        extent: vk::Extent2D,
        samples: u32,
        multiview: bool,
    ) -> Result<Attachments> {
        let sets = if multiview {
            vec![AttachmentSet::new(ctx, extent, samples, 2)?]
        } else {
            vec![
                AttachmentSet::new(ctx, extent, samples, 1)?,
                AttachmentSet::new(ctx, extent, samples, 1)?,
            ]
        };
        Ok(Attachments { sets })
    }

    /// Whether the transient attachments got lazily allocated memory.
    pub fn lazily_allocated(&self) -> bool {
        self.sets[0].depth.lazy
    }

    /// Barriers that discard the previous frame's contents and make the
    /// attachments writable.
    pub fn begin_barriers(&self) -> Vec<vk::ImageMemoryBarrier2<'static>> {
        let mut out = Vec::new();
        let mut add = |img: &Image, aspect: vk::ImageAspectFlags, layout, stage, access| {
            out.push(
                vk::ImageMemoryBarrier2::default()
                    .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                    .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
                    .dst_stage_mask(stage)
                    .dst_access_mask(access)
                    .old_layout(vk::ImageLayout::UNDEFINED)
                    .new_layout(layout)
                    .image(img.image)
                    .subresource_range(vk::ImageSubresourceRange {
                        aspect_mask: aspect,
                        base_mip_level: 0,
                        level_count: 1,
                        base_array_layer: 0,
                        layer_count: img.layers,
                    }),
            );
        };
        let color_stage = vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT;
        let color_access =
            vk::AccessFlags2::COLOR_ATTACHMENT_READ | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE;
        for set in &self.sets {
            if let Some(c) = &set.color_msaa {
                add(
                    c,
                    vk::ImageAspectFlags::COLOR,
                    vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                    color_stage,
                    color_access,
                );
            }
            add(
                &set.resolve,
                vk::ImageAspectFlags::COLOR,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                color_stage,
                color_access,
            );
            add(
                &set.depth,
                vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
                vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
                vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ
                    | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
            );
        }
        out
    }

    /// Destroys all images.
    pub fn destroy(self, ctx: &Context) {
        for s in self.sets {
            s.destroy(ctx);
        }
    }
}
