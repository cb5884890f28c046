//! Draws a laid-out egui frame (the desk overlay) into a window image inside
//! the window's own command buffer: egui-ash-renderer records into it with
//! dynamic rendering, loading what the blit put there. Only the window's
//! image is touched; the eye images the headset gets never see the overlay.

use super::barrier::{self, Use};
use super::Context;
use crate::error::{Error, Result, VkContext};
use ash::vk;

/// A colour attachment loaded (read) and written: what the overlay's
/// scope does to the window image.
pub const LOADED: Use = Use {
    layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
    stage: vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
    access: vk::AccessFlags2::from_raw(
        vk::AccessFlags2::COLOR_ATTACHMENT_READ.as_raw()
            | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw(),
    ),
};

/// One frame of the overlay, laid out and tessellated on the CPU.
pub struct UiFrame {
    /// What to draw.
    pub primitives: Vec<egui::ClippedPrimitive>,
    /// Texture changes (the font atlas on the first frame).
    pub textures: egui::TexturesDelta,
    /// Physical pixels per egui point.
    pub pixels_per_point: f32,
}

/// The egui renderer of one window.
pub struct UiLayer {
    renderer: egui_ash_renderer::Renderer,
    pool: vk::CommandPool,
    format: vk::Format,
}

fn ui_error(what: &str, e: egui_ash_renderer::RendererError) -> Error {
    Error::Gpu(format!("{what}: {e}"))
}

impl UiLayer {
    /// A renderer for images of `format`, with `frames` frames in flight
    /// (its vertex buffers rotate over them).
    pub fn new(ctx: &Context, format: vk::Format, frames: usize) -> Result<UiLayer> {
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: plain object creation on a live device; destroyed by
        // `destroy`.
        let pool = unsafe { ctx.device.create_command_pool(&info, None) }
            .vk("creating the overlay's upload pool")?;
        let srgb = matches!(
            format,
            vk::Format::B8G8R8A8_SRGB | vk::Format::R8G8B8A8_SRGB
        );
        let renderer = egui_ash_renderer::Renderer::with_default_allocator(
            &ctx.instance,
            ctx.physical_device,
            ctx.device.clone(),
            egui_ash_renderer::DynamicRendering {
                color_attachment_format: format,
                depth_attachment_format: None,
            },
            egui_ash_renderer::Options {
                in_flight_frames: frames.max(1),
                enable_depth_test: false,
                enable_depth_write: false,
                srgb_framebuffer: srgb,
            },
        );
        match renderer {
            Ok(renderer) => Ok(UiLayer {
                renderer,
                pool,
                format,
            }),
            Err(e) => {
                // SAFETY: the pool was created above and holds nothing.
                unsafe { ctx.device.destroy_command_pool(pool, None) };
                Err(ui_error("creating the overlay renderer", e))
            }
        }
    }

    /// The image format it draws into.
    pub fn format(&self) -> vk::Format {
        self.format
    }

    /// Uploads `frame`'s new textures (a submission of its own, waited
    /// for); call before recording the frame.
    pub fn upload(&mut self, ctx: &Context, frame: &UiFrame) -> Result<()> {
        if frame.textures.set.is_empty() {
            return Ok(());
        }
        self.renderer
            .set_textures(ctx.queue, self.pool, &frame.textures.set)
            .map_err(|e| ui_error("uploading the overlay's textures", e))
    }

    /// Records `frame` over `image` (through `view`, `extent` pixels), which
    /// is in `from` use, first cleared to `clear` (linear RGBA) when given,
    /// else drawn over what it holds; leaves it in [`LOADED`] use.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        (image, view): (vk::Image, vk::ImageView),
        extent: vk::Extent2D,
        from: Use,
        clear: Option<[f32; 4]>,
        frame: &UiFrame,
    ) -> Result<()> {
        let d = &ctx.device;
        let to_draw = [barrier::image(
            image,
            vk::ImageAspectFlags::COLOR,
            1,
            from,
            LOADED,
        )];
        let load = match clear {
            Some(c) => super::rendering::Load::Clear(c),
            None => super::rendering::Load::Keep,
        };
        // SAFETY: recording into the window's open command buffer outside
        // any rendering scope; the image and view belong to the swapchain.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&to_draw),
            );
            super::rendering::begin_color(d, cmd, view, extent, load, 0);
        }
        let drawn = self
            .renderer
            .cmd_draw(cmd, extent, frame.pixels_per_point, &frame.primitives);
        // SAFETY: ends the scope begun above.
        unsafe { d.cmd_end_rendering(cmd) };
        drawn.map_err(|e| ui_error("drawing the overlay", e))
    }

    /// Frees the textures `frame` retires once nothing uses them (waits
    /// for the device; egui retires textures rarely).
    pub fn retire(&mut self, ctx: &Context, frame: &UiFrame) -> Result<()> {
        if frame.textures.free.is_empty() {
            return Ok(());
        }
        // SAFETY: waiting for the device so no submission samples them.
        unsafe { ctx.device.device_wait_idle() }.vk("waiting before freeing overlay textures")?;
        self.renderer
            .free_textures(&frame.textures.free)
            .map_err(|e| ui_error("freeing the overlay's textures", e))
    }

    /// Destroys the renderer and its pool; the device must be idle.
    pub fn destroy(self, ctx: &Context) {
        drop(self.renderer);
        // SAFETY: the device is idle; the pool's buffers are done.
        unsafe { ctx.device.destroy_command_pool(self.pool, None) };
    }
}
