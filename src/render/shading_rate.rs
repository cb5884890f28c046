//! Foveated rendering's set-up on the GPU: the path is chosen by
//! capability. With VK_KHR_fragment_shading_rate (attachment rates), the
//! rate image `view::foveation` computes is uploaded into one image per
//! attachment set (both layers under multiview) and attached to every
//! forward scope, its rate replacing the pipeline's — one such image set
//! per size a scope is drawn at, so that the foveal region stays centred
//! on the drawn area when adaptive quality draws a smaller one, and the
//! inset's wide views get the pattern at their own size; lens-matched
//! shading's image gets the pattern through its map, each texel at the
//! rate of the eye point it shows. Without it foveation
//! falls back to off, with a warning naming what is missing.

use crate::config::{RenderConfig, StereoMode};
use crate::error::Result;
use crate::gpu::barrier::{self, Use};
use crate::gpu::memory::{Buffer, BufferDesc, Image, ImageDesc};
use crate::gpu::Context;
use crate::view::foveation::{self, Level};
use crate::view::lms::{Coefficients, Layout};
use ash::vk;
use gpu_allocator::MemoryLocation;

/// The shading-rate images of the forward scopes, per size drawn.
pub struct ShadingRate {
    /// Per size a scope is drawn at (the eyes', the inset's wide views',
    /// adaptive quality's scales): one image per attachment set, the rate
    /// pattern centred on the drawn area.
    sizes: Vec<(vk::Extent2D, Vec<Image>)>,
    /// The device's rate texel size in pixels.
    texel: (u32, u32),
    level: Level,
    gaze: [f32; 2],
    /// Layers per image (2 under multiview) and images per size.
    layers: u32,
    sets: usize,
}

/// Rate images made per size at most; past it the nearest larger is used.
const MAX_SIZES: usize = 64;

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
        let level = config.effort.foveation;
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
            crate::error::warn_once(&format!("foveation {level:?} falls back to {path}"));
            return Ok((None, path));
        };
        let multiview = config.frame.stereo == StereoMode::Multiview;
        let mut rates = ShadingRate {
            sizes: Vec::new(),
            texel,
            level,
            gaze: config.effort.gaze,
            layers: if multiview { 2 } else { 1 },
            sets: if multiview { 1 } else { 2 },
        };
        rates.ensure(ctx, extent)?;
        let (w, h) = (extent.width, extent.height);
        let path = format!(
            "vk-khr-fragment-shading-rate ({}x{} texels, {:.0} % of full-rate shading)",
            texel.0,
            texel.1,
            100.0 * foveation::shaded_fraction(level, config.effort.gaze, w, h, texel)
        );
        Ok((Some(rates), path))
    }

    /// Makes the rate images for scopes drawn at `extent` unless they
    /// exist (a new adaptive-quality scale or wide-view size: once each,
    /// uploaded before the frame that first uses them is recorded).
    pub fn ensure(&mut self, ctx: &Context, extent: vk::Extent2D) -> Result<()> {
        if self.sizes.iter().any(|(e, _)| *e == extent) || self.sizes.len() >= MAX_SIZES {
            return Ok(());
        }
        let pattern = foveation::rate_image(
            self.level,
            self.gaze,
            extent.width,
            extent.height,
            self.texel,
        );
        let images = self.upload(ctx, pattern)?;
        self.sizes.push((extent, images));
        Ok(())
    }

    /// Makes the rate images of lens-matched shading's scopes: its image
    /// (`layout.size`) with each texel at the rate of the eye point it
    /// shows, so the rings stay where they are in the eye.
    pub fn ensure_lms(&mut self, ctx: &Context, layout: &Layout, c: &Coefficients) -> Result<()> {
        let extent = vk::Extent2D {
            width: layout.size[0],
            height: layout.size[1],
        };
        // With no scaling the LMS image is the eye's, and so is its pattern.
        if self.sizes.iter().any(|(e, _)| *e == extent) || self.sizes.len() >= MAX_SIZES {
            return Ok(());
        }
        let size = (extent.width, extent.height);
        let pattern = foveation::rate_image_mapped(self.level, self.gaze, size, self.texel, |p| {
            let q = layout.eye_ndc(c, [p[0] as f64, p[1] as f64]);
            [q[0] as f32, q[1] as f32]
        });
        let images = self.upload(ctx, pattern)?;
        self.sizes.push((extent, images));
        Ok(())
    }

    /// One image per attachment set with the rate pattern (`tw` × `th`
    /// texels).
    fn upload(&self, ctx: &Context, (tw, th, data): (u32, u32, Vec<u8>)) -> Result<Vec<Image>> {
        let layers = self.layers;
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
        let mut images = Vec::new();
        let made = (|| -> Result<()> {
            for l in 0..layers as usize {
                staging.write(l * data.len(), &data)?;
            }
            for _ in 0..self.sets {
                images.push(Image::new(
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
            record_upload(ctx, staging.buffer, &images, (tw, th, layers))
        })();
        staging.destroy(ctx);
        match made {
            Ok(()) => Ok(images),
            Err(e) => {
                for img in images {
                    img.destroy(ctx);
                }
                Err(e)
            }
        }
    }

    /// The rate attachment of attachment set `set` for a scope drawn at
    /// `extent` (the images made for it, else for the nearest larger size
    /// made, else the largest), and its texel size.
    pub fn attachment(
        &self,
        set: u32,
        extent: vk::Extent2D,
    ) -> Option<(vk::ImageView, (u32, u32))> {
        let fits = |e: &vk::Extent2D| e.width >= extent.width && e.height >= extent.height;
        let area = |e: &vk::Extent2D| e.width as u64 * e.height as u64;
        let (_, images) = self
            .sizes
            .iter()
            .find(|(e, _)| *e == extent)
            .or_else(|| {
                self.sizes
                    .iter()
                    .filter(|(e, _)| fits(e))
                    .min_by_key(|(e, _)| area(e))
            })
            .or_else(|| self.sizes.iter().max_by_key(|(e, _)| area(e)))?;
        images.get(set as usize).map(|img| (img.view, self.texel))
    }

    /// Destroys the images; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        for (_, images) in self.sizes {
            for img in images {
                img.destroy(ctx);
            }
        }
    }
}

/// Copies the rate pattern (`tw` × `th` texels, `layers` layers) from
/// `staging` into each of `images` and leaves them ready as shading-rate
/// attachments; waits for the copy.
fn record_upload(
    ctx: &Context,
    staging: vk::Buffer,
    images: &[Image],
    (tw, th, layers): (u32, u32, u32),
) -> Result<()> {
    let d = &ctx.device;
    ctx.one_shot(|cmd| {
        for img in images {
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
            // SAFETY: a one-shot command buffer; the images are new and
            // not yet in use, the staging buffer holds the pattern.
            unsafe {
                d.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().image_memory_barriers(&to_dst),
                );
                d.cmd_copy_buffer_to_image(
                    cmd,
                    staging,
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
    })
}
