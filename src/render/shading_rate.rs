//! Foveated rendering's set-up on the GPU: the path is chosen by
//! capability. With VK_KHR_fragment_shading_rate (attachment rates), the
//! rate image `view::foveation` computes is uploaded once into one image per
//! attachment set (both layers under multiview) and attached to every
//! forward scope, its rate replacing the pipeline's. Without it foveation
//! falls back to off, with a warning naming what is missing.

use crate::config::{RenderConfig, StereoMode};
use crate::error::Result;
use crate::gpu::barrier::{self, Use};
use crate::gpu::memory::{Buffer, BufferDesc, Image, ImageDesc};
use crate::gpu::Context;
use crate::view::foveation::{self, Level};
use ash::vk;
use gpu_allocator::MemoryLocation;

/// The shading-rate images of the forward scopes.
pub struct ShadingRate {
    /// One per attachment set.
    images: Vec<Image>,
    /// The device's rate texel size in pixels.
    texel: (u32, u32),
}

impl ShadingRate {
    /// Sets up foveation `config.foveation` for eyes of `extent`. Returns
    /// the rate images (None: foveation is off, asked for or fallen back
    /// to) and the path that runs, for stats: "off", why it fell back to
    /// off, or the Vulkan path with its estimated shading.
    pub fn new(
        ctx: &Context,
        config: &RenderConfig,
        extent: vk::Extent2D,
    ) -> Result<(Option<ShadingRate>, String)> {
        let level = config.foveation;
        if level == Level::Off {
            return Ok((None, "off".into()));
        }
        let Some(texel) = ctx.caps.shading_rate_texel else {
            let path = format!(
                "off: {} offers no VK_KHR_fragment_shading_rate attachment{}, and XR_FB_foveation is not in use",
                ctx.device_name,
                if ctx.caps.fragment_density_map {
                    " (VK_EXT_fragment_density_map is offered but not implemented yet)"
                } else {
                    " nor VK_EXT_fragment_density_map"
                }
            );
            tracing::warn!("foveation {level:?} requested; {path}");
            eprintln!("warning: foveation {level:?} falls back to {path}");
            return Ok((None, path));
        };
        let (w, h) = (extent.width, extent.height);
        let (tw, th, data) = foveation::rate_image(level, config.gaze, w, h, texel);
        let layers = if config.stereo == StereoMode::Multiview {
            2
        } else {
            1
        };
        let sets = if layers == 2 { 1 } else { 2 };
        let mut staging = Buffer::new(
            ctx,
            &BufferDesc {
                name: "shading rate staging",
                size: (data.len() * layers as usize) as u64,
                usage: vk::BufferUsageFlags::TRANSFER_SRC,
                location: MemoryLocation::CpuToGpu,
                category: "staging",
            },
        )?;
        for l in 0..layers as usize {
            staging.write(l * data.len(), &data)?;
        }
        let mut rates = ShadingRate {
            images: Vec::new(),
            texel,
        };
        for _ in 0..sets {
            rates.images.push(Image::new(
                ctx,
                &ImageDesc {
                    name: "shading rate",
                    format: vk::Format::R8_UINT,
                    extent: vk::Extent2D {
                        width: tw,
                        height: th,
                    },
                    layers,
                    mips: 1,
                    samples: vk::SampleCountFlags::TYPE_1,
                    usage: vk::ImageUsageFlags::FRAGMENT_SHADING_RATE_ATTACHMENT_KHR
                        | vk::ImageUsageFlags::TRANSFER_DST,
                    aspect: vk::ImageAspectFlags::COLOR,
                    category: "render target",
                    flags: vk::ImageCreateFlags::empty(),
                },
            )?);
        }
        let d = &ctx.device;
        let buf = staging.buffer;
        let upload = ctx.one_shot(|cmd| {
            for img in &rates.images {
                let color = vk::ImageAspectFlags::COLOR;
                let to_dst = [barrier::image(
                    img.image,
                    color,
                    layers,
                    Use::TRANSFER_DST.discarded(),
                    Use::TRANSFER_DST,
                )];
                let copy = barrier::color_copy(0, layers, tw, th);
                let to_rate = [barrier::image(
                    img.image,
                    color,
                    layers,
                    Use::TRANSFER_DST,
                    Use::SHADING_RATE,
                )];
                // SAFETY: recording into the one-shot command buffer; the
                // staging buffer holds `layers` copies of the rate image.
                unsafe {
                    d.cmd_pipeline_barrier2(
                        cmd,
                        &vk::DependencyInfo::default().image_memory_barriers(&to_dst),
                    );
                    d.cmd_copy_buffer_to_image(
                        cmd,
                        buf,
                        img.image,
                        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                        &[copy],
                    );
                    d.cmd_pipeline_barrier2(
                        cmd,
                        &vk::DependencyInfo::default().image_memory_barriers(&to_rate),
                    );
                }
            }
        });
        staging.destroy(ctx);
        if let Err(e) = upload {
            rates.destroy(ctx);
            return Err(e);
        }
        let path = format!(
            "vk-khr-fragment-shading-rate ({}x{} texels, {:.0} % of full-rate shading)",
            texel.0,
            texel.1,
            100.0 * foveation::shaded_fraction(level, config.gaze, w, h, texel)
        );
        Ok((Some(rates), path))
    }

    /// The rate attachment of attachment set `set` and its texel size.
    pub fn attachment(&self, set: u32) -> Option<(vk::ImageView, (u32, u32))> {
        self.images
            .get(set as usize)
            .map(|img| (img.view, self.texel))
    }

    /// Destroys the images; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        for img in self.images {
            img.destroy(ctx);
        }
    }
}
