//! The in-headset panel's OpenXR side: its own colour swapchain, the egui
//! frame of [`super::panel`] drawn into it each frame the panel is open
//! (one small submission of its own on the renderer's queue), and the
//! `XrCompositionLayerQuad` that shows it where
//! [`crate::interact::panel::Panel`] placed it in tracking space. Made the
//! first time the menu button opens the panel, kept for the session.

use super::panel::{PanelUi, BACKGROUND, SIZE_PX};
use crate::error::{Result, VkContext};
use crate::gpu::barrier::Use;
use crate::gpu::memory::Image;
use crate::gpu::ring::FrameRing;
use crate::gpu::ui_layer::{UiFrame, UiLayer};
use crate::gpu::Context;
use crate::interact::panel::Panel;
use crate::xr::watchdog::Watchdog;
use crate::xr::{Chain, XrCall};
use ash::vk;
use openxr as xr;
use openxr::sys;
use std::sync::Arc;

/// The panel as `--stats-out` reports it (`panel`).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct PanelStats {
    /// Its image, pixels.
    pub size_px: [u32; 2],
    /// Its quad, metres.
    pub size_m: [f64; 2],
    /// Times the menu button opened it.
    pub opened: u64,
    /// Frames submitted with it (two composition layers).
    pub frames_shown: u64,
    /// Buttons pressed on it.
    pub buttons_pressed: u64,
    /// Why it could not be shown, if it could not (the session goes on
    /// without it).
    pub error: Option<String>,
}

/// The panel's swapchain and renderer.
pub struct XrPanel {
    ctx: Arc<Context>,
    chain: Chain,
    views: Vec<vk::ImageView>,
    layer: Option<UiLayer>,
    ring: Option<FrameRing>,
    extent: vk::Extent2D,
    /// Its egui context.
    pub ui: PanelUi,
}

/// Frames of the panel in flight.
const FRAMES: usize = 2;

impl XrPanel {
    /// A swapchain of [`SIZE_PX`] images of `format` (an sRGB format the
    /// runtime offers) and the egui renderer for it.
    pub fn new(
        ctx: &Arc<Context>,
        session: &xr::Session<xr::Vulkan>,
        format: vk::Format,
    ) -> Result<XrPanel> {
        let extent = vk::Extent2D {
            width: SIZE_PX[0],
            height: SIZE_PX[1],
        };
        let chain = Chain::new(
            session,
            format,
            xr::SwapchainUsageFlags::COLOR_ATTACHMENT | xr::SwapchainUsageFlags::SAMPLED,
            extent,
            1,
        )?;
        let mut panel = XrPanel {
            ctx: ctx.clone(),
            chain,
            views: Vec::new(),
            layer: None,
            ring: None,
            extent,
            ui: PanelUi::new(),
        };
        for &image in &panel.chain.images {
            let view = Image::make_view(
                ctx,
                image,
                format,
                vk::ImageAspectFlags::COLOR,
                vk::ImageViewType::TYPE_2D,
                0,
                1,
                1,
            )?;
            panel.views.push(view);
        }
        panel.ring = Some(FrameRing::new(ctx, FRAMES)?);
        panel.layer = Some(UiLayer::new(ctx, format, FRAMES)?);
        Ok(panel)
    }

    /// Draws `frame` into the next swapchain image: acquire, wait, record
    /// and submit on the renderer's queue, release (the runtime reads it
    /// after the submission, in queue order).
    pub fn draw(&mut self, frame: &UiFrame, watchdog: &Watchdog) -> Result<()> {
        let ctx = self.ctx.clone();
        let (Some(layer), Some(ring)) = (self.layer.as_mut(), self.ring.as_mut()) else {
            return Ok(());
        };
        if !frame.textures.set.is_empty() {
            // A texture change may rewrite a texture an earlier panel frame
            // still samples: let the device finish first (rare: the font
            // atlas, on the first frame).
            // SAFETY: waiting on this device.
            unsafe { ctx.device.device_wait_idle() }.vk("waiting before a panel upload")?;
            layer.upload(&ctx, frame)?;
        }
        let cmd = ring.begin(&ctx)?;
        let index = {
            let _w = watchdog.watch("xrAcquireSwapchainImage");
            self.chain
                .swapchain
                .acquire_image()
                .call("xrAcquireSwapchainImage")? as usize
        };
        {
            let _w = watchdog.watch("xrWaitSwapchainImage");
            self.chain
                .swapchain
                .wait_image(xr::Duration::INFINITE)
                .call("xrWaitSwapchainImage")?;
        }
        let target = (self.chain.images[index], self.views[index]);
        // The whole image is cleared: what it held does not matter.
        let recorded = layer.record(
            &ctx,
            cmd,
            target,
            self.extent,
            Use::COLOR_ATTACHMENT.discarded(),
            Some(BACKGROUND),
            frame,
        );
        // The command buffer is submitted even when recording failed, so
        // the ring's slot stays consistent; the error is reported after.
        let submitted = ring.submit(&ctx);
        {
            let _w = watchdog.watch("xrReleaseSwapchainImage");
            self.chain
                .swapchain
                .release_image()
                .call("xrReleaseSwapchainImage")?;
        }
        recorded?;
        submitted?;
        if !frame.textures.free.is_empty() {
            layer.retire(&ctx, frame)?;
        }
        Ok(())
    }

    /// The quad layer showing the last drawn image at `panel` (tracking
    /// space `space`), blended by the image's (premultiplied) alpha.
    pub fn layer(&self, panel: &Panel, space: &xr::Space) -> sys::CompositionLayerQuad {
        let p = panel.pose;
        sys::CompositionLayerQuad {
            ty: sys::CompositionLayerQuad::TYPE,
            next: std::ptr::null(),
            layer_flags: xr::CompositionLayerFlags::BLEND_TEXTURE_SOURCE_ALPHA,
            space: space.as_raw(),
            eye_visibility: xr::EyeVisibility::BOTH,
            sub_image: sys::SwapchainSubImage {
                swapchain: self.chain.swapchain.as_raw(),
                image_rect: sys::Rect2Di {
                    offset: sys::Offset2Di { x: 0, y: 0 },
                    extent: sys::Extent2Di {
                        width: self.extent.width as i32,
                        height: self.extent.height as i32,
                    },
                },
                image_array_index: 0,
            },
            pose: sys::Posef {
                orientation: sys::Quaternionf {
                    x: p.orientation.x as f32,
                    y: p.orientation.y as f32,
                    z: p.orientation.z as f32,
                    w: p.orientation.w as f32,
                },
                position: sys::Vector3f {
                    x: p.position.x as f32,
                    y: p.position.y as f32,
                    z: p.position.z as f32,
                },
            },
            size: sys::Extent2Df {
                width: panel.size_m[0] as f32,
                height: panel.size_m[1] as f32,
            },
        }
    }
}

/// Draws `frame` (a panel frame of [`SIZE_PX`]) as [`XrPanel::draw`] does,
/// into an offscreen R8G8B8A8_SRGB image, and reads it back: what the quad
/// layer shows, for tests and docs/headset.md's picture (alpha premultiplied).
pub fn snapshot(ctx: &Context, frame: &UiFrame) -> Result<image::RgbaImage> {
    use crate::gpu::memory::{Buffer, BufferDesc, ImageDesc};
    let extent = vk::Extent2D {
        width: SIZE_PX[0],
        height: SIZE_PX[1],
    };
    let format = vk::Format::R8G8B8A8_SRGB;
    let mut layer = UiLayer::new(ctx, format, 1)?;
    let target = Image::new(
        ctx,
        &ImageDesc::eye_copy("panel snapshot", format, extent, 1, "panel"),
    )?;
    let size = u64::from(extent.width) * u64::from(extent.height) * 4;
    let mut readback = Buffer::new(
        ctx,
        &BufferDesc {
            name: "panel snapshot readback",
            size,
            usage: vk::BufferUsageFlags::TRANSFER_DST,
            location: gpu_allocator::MemoryLocation::GpuToCpu,
            category: "panel",
        },
    )?;
    let drawn = (|| -> Result<image::RgbaImage> {
        layer.upload(ctx, frame)?;
        let mut recorded = Ok(());
        ctx.one_shot(|cmd| {
            recorded = layer.record(
                ctx,
                cmd,
                (target.image, target.view),
                extent,
                Use::COLOR_ATTACHMENT.discarded(),
                Some(BACKGROUND),
                frame,
            );
            let to_copy = [crate::gpu::barrier::image(
                target.image,
                vk::ImageAspectFlags::COLOR,
                1,
                crate::gpu::ui_layer::LOADED,
                Use::TRANSFER_SRC,
            )];
            let copy = crate::gpu::barrier::color_copy(0, 1, extent.width, extent.height);
            let to_host = [crate::gpu::barrier::copies_to_host()];
            // SAFETY: recording into the one-shot command buffer; the image
            // and buffer are live and sized for the copy.
            unsafe {
                ctx.device.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().image_memory_barriers(&to_copy),
                );
                ctx.device.cmd_copy_image_to_buffer(
                    cmd,
                    target.image,
                    Use::TRANSFER_SRC.layout,
                    readback.buffer,
                    &[copy],
                );
                ctx.device.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().memory_barriers(&to_host),
                );
            }
        })?;
        recorded?;
        let bytes = readback
            .mapped()
            .ok_or_else(|| crate::error::Error::Gpu("the readback is not mapped".into()))?
            .get(..size as usize)
            .ok_or_else(|| crate::error::Error::Gpu("the readback is too small".into()))?
            .to_vec();
        image::RgbaImage::from_raw(extent.width, extent.height, bytes)
            .ok_or_else(|| crate::error::Error::Gpu("panel snapshot size".into()))
    })();
    // SAFETY: one_shot waited for its submission (or failed before it).
    unsafe { ctx.device.device_wait_idle() }.vk("waiting after the panel snapshot")?;
    layer.destroy(ctx);
    target.destroy(ctx);
    readback.destroy(ctx);
    drawn
}

impl Drop for XrPanel {
    fn drop(&mut self) {
        // The ring waits for the device; then nothing uses the views or
        // the egui renderer. The swapchain goes with `chain`.
        if let Some(ring) = self.ring.take() {
            ring.destroy(&self.ctx);
        }
        if let Some(layer) = self.layer.take() {
            layer.destroy(&self.ctx);
        }
        for v in self.views.drain(..) {
            // SAFETY: the device is idle (above); the view is ours.
            unsafe { self.ctx.device.destroy_image_view(v, None) };
        }
    }
}
