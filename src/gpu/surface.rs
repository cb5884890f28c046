//! A window's Vulkan side: the surface, its swapchain (recreated on resize
//! or when the driver reports it out of date) and the [`Presenter`], which
//! blits already rendered eye images into the acquired swapchain image —
//! side by side and letterboxed to keep their aspect — presents it, and on
//! request reads the presented image back. Nothing is rendered here: the
//! sources are images some earlier submission on the same queue wrote.

use super::barrier::{self, Use};
use super::memory::{Buffer, BufferDesc};
use super::Context;
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::MemoryLocation;
use raw_window_handle::{RawDisplayHandle, RawWindowHandle};
use std::ffi::CStr;

/// The instance extensions a surface on `display` needs (VK_KHR_surface
/// and the platform's surface extension), or why there are none.
pub fn instance_extensions(display: RawDisplayHandle) -> Result<Vec<&'static CStr>> {
    let platform = match display {
        RawDisplayHandle::Xlib(_) => ash::khr::xlib_surface::NAME,
        RawDisplayHandle::Xcb(_) => ash::khr::xcb_surface::NAME,
        RawDisplayHandle::Wayland(_) => ash::khr::wayland_surface::NAME,
        RawDisplayHandle::Windows(_) => ash::khr::win32_surface::NAME,
        other => {
            return Err(Error::Gpu(format!(
                "no Vulkan surface extension for the display {other:?}"
            )))
        }
    };
    Ok(vec![ash::khr::surface::NAME, platform])
}

/// The device extensions a swapchain needs.
pub fn device_extensions() -> Vec<&'static CStr> {
    vec![ash::khr::swapchain::NAME]
}

/// Where content of `content` pixels goes in a `window`-pixel image so that
/// it is as large as fits with its aspect kept, centred (bars on the two
/// other sides): the offset and size of the destination rectangle.
pub fn letterbox(content: vk::Extent2D, window: vk::Extent2D) -> (vk::Offset2D, vk::Extent2D) {
    if content.width == 0 || content.height == 0 || window.width == 0 || window.height == 0 {
        return (vk::Offset2D::default(), vk::Extent2D::default());
    }
    let (cw, ch) = (content.width as u64, content.height as u64);
    let (ww, wh) = (window.width as u64, window.height as u64);
    // Compare aspects exactly in integers: cw/ch against ww/wh.
    let (w, h) = if cw * wh >= ww * ch {
        (ww, (ww * ch + cw / 2) / cw)
    } else {
        ((wh * cw + ch / 2) / ch, wh)
    };
    let (w, h) = (w.clamp(1, ww), h.clamp(1, wh));
    (
        vk::Offset2D {
            x: ((ww - w) / 2) as i32,
            y: ((wh - h) / 2) as i32,
        },
        vk::Extent2D {
            width: w as u32,
            height: h as u32,
        },
    )
}

/// How presentation may pace the caller.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pacing {
    /// FIFO: the window's refresh paces the loop (a desktop preview).
    Vsync,
    /// MAILBOX or IMMEDIATE when offered, so presenting never waits for the
    /// display (a mirror beside a headset's own frame loop); FIFO otherwise.
    NeverBlock,
}

impl Pacing {
    /// The present mode for this pacing among the surface's `modes`:
    /// FIFO for vsync; mailbox, else immediate, else FIFO never to block.
    fn present_mode(self, modes: &[vk::PresentModeKHR]) -> vk::PresentModeKHR {
        let wanted: &[vk::PresentModeKHR] = match self {
            Pacing::Vsync => &[vk::PresentModeKHR::FIFO],
            Pacing::NeverBlock => &[
                vk::PresentModeKHR::MAILBOX,
                vk::PresentModeKHR::IMMEDIATE,
                vk::PresentModeKHR::FIFO,
            ],
        };
        wanted
            .iter()
            .copied()
            .find(|m| modes.contains(m))
            .unwrap_or(vk::PresentModeKHR::FIFO)
    }
}

/// What a [`Source`] image is in between presents (the contract of
/// [`Presenter::present`]): COLOR_ATTACHMENT_OPTIMAL, last written by a
/// transfer or as an attachment, last read by the window's blit (a
/// transfer).
pub const SHOWN: Use = Use {
    layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
    stage: vk::PipelineStageFlags2::from_raw(
        vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT.as_raw()
            | vk::PipelineStageFlags2::ALL_TRANSFER.as_raw(),
    ),
    access: vk::AccessFlags2::from_raw(
        vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw()
            | vk::AccessFlags2::TRANSFER_WRITE.as_raw(),
    ),
};

/// One image region shown in the window: a layer of an image in
/// COLOR_ATTACHMENT_OPTIMAL, last written by a transfer or as a colour
/// attachment; it is left in that layout.
#[derive(Clone, Copy, Debug)]
pub struct Source {
    /// The image.
    pub image: vk::Image,
    /// Its array layer.
    pub layer: u32,
    /// Its size in pixels.
    pub extent: vk::Extent2D,
}

/// A swapchain image as acquired: contents undefined, first written by
/// transfers.
const ACQUIRED: Use = Use {
    layout: vk::ImageLayout::UNDEFINED,
    stage: vk::PipelineStageFlags2::ALL_TRANSFER,
    access: vk::AccessFlags2::NONE,
};

/// The swapchain's size: the surface's, or the window's `size` within
/// the surface's limits where the surface leaves it to the swapchain.
fn swap_extent(caps: &vk::SurfaceCapabilitiesKHR, size: vk::Extent2D) -> vk::Extent2D {
    if caps.current_extent.width != u32::MAX {
        return caps.current_extent;
    }
    vk::Extent2D {
        width: size
            .width
            .clamp(caps.min_image_extent.width, caps.max_image_extent.width),
        height: size
            .height
            .clamp(caps.min_image_extent.height, caps.max_image_extent.height),
    }
}

/// The first composite alpha the surface supports, opaque first.
fn composite_alpha(caps: &vk::SurfaceCapabilitiesKHR) -> vk::CompositeAlphaFlagsKHR {
    [
        vk::CompositeAlphaFlagsKHR::OPAQUE,
        vk::CompositeAlphaFlagsKHR::INHERIT,
        vk::CompositeAlphaFlagsKHR::PRE_MULTIPLIED,
        vk::CompositeAlphaFlagsKHR::POST_MULTIPLIED,
    ]
    .into_iter()
    .find(|a| caps.supported_composite_alpha.contains(*a))
    .unwrap_or(vk::CompositeAlphaFlagsKHR::OPAQUE)
}

/// The blit of `s` (content columns from `x0`) into the letterboxed
/// rectangle `(origin, size)` of the window, which shows `content`
/// proportionally.
fn blit_region(
    s: &Source,
    x0: u32,
    content: vk::Extent2D,
    (origin, size): (vk::Offset2D, vk::Extent2D),
) -> vk::ImageBlit {
    let map_x =
        |x: u32| origin.x + (x as u64 * size.width as u64 / content.width.max(1) as u64) as i32;
    let map_y =
        |y: u32| origin.y + (y as u64 * size.height as u64 / content.height.max(1) as u64) as i32;
    let layer = |base_array_layer| vk::ImageSubresourceLayers {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        mip_level: 0,
        base_array_layer,
        layer_count: 1,
    };
    let corner = |x, y, z| vk::Offset3D { x, y, z };
    vk::ImageBlit::default()
        .src_subresource(layer(s.layer))
        .src_offsets([
            vk::Offset3D::default(),
            corner(s.extent.width as i32, s.extent.height as i32, 1),
        ])
        .dst_subresource(layer(0))
        .dst_offsets([
            corner(map_x(x0), map_y(0), 0),
            corner(map_x(x0 + s.extent.width), map_y(s.extent.height), 1),
        ])
}

/// What one [`Presenter::present`] did.
#[derive(Debug)]
pub enum Presented {
    /// The image was presented (with its read-back pixels when asked for).
    Shown(Option<image::RgbaImage>),
    /// The swapchain was out of date (resize); it was recreated and nothing
    /// was shown this time.
    Skipped,
    /// [`Pacing::NeverBlock`]: no swapchain image was free, or the previous
    /// blit of this slot still ran; nothing was shown, nothing waited.
    Busy,
}

struct Slot {
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    acquired: vk::Semaphore,
}

/// A surface, its swapchain and the per-frame objects to blit into it and
/// present.
pub struct Presenter {
    surface_fn: ash::khr::surface::Instance,
    swapchain_fn: ash::khr::swapchain::Device,
    surface: vk::SurfaceKHR,
    swapchain: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    /// A view of each image (empty when the surface cannot render into
    /// its images: no overlay then).
    views: Vec<vk::ImageView>,
    /// The overlay's renderer (made on the first frame that has one).
    ui: Option<super::ui_layer::UiLayer>,
    /// Signalled by the blit of image i, waited on by its present.
    ready: Vec<vk::Semaphore>,
    format: vk::SurfaceFormatKHR,
    extent: vk::Extent2D,
    present_mode: vk::PresentModeKHR,
    pacing: Pacing,
    slots: Vec<Slot>,
    next: usize,
    stale: bool,
    readback: Option<Buffer>,
}

impl Presenter {
    /// Creates the surface of a window (`display`, `window`) and its
    /// swapchain at `size` pixels (used when the surface does not fix its
    /// own size). `ctx` must have been created with
    /// [`instance_extensions`] and [`device_extensions`].
    pub fn new(
        ctx: &Context,
        display: RawDisplayHandle,
        window: RawWindowHandle,
        size: vk::Extent2D,
        pacing: Pacing,
    ) -> Result<Presenter> {
        // SAFETY: the handles come from a live window that the caller keeps
        // open until this presenter is destroyed; the instance has the
        // surface extensions enabled.
        let surface =
            unsafe { ash_window::create_surface(&ctx.entry, &ctx.instance, display, window, None) }
                .vk("creating the window surface")?;
        let surface_fn = ash::khr::surface::Instance::new(&ctx.entry, &ctx.instance);
        let swapchain_fn = ash::khr::swapchain::Device::new(&ctx.instance, &ctx.device);
        let mut p = Presenter {
            surface_fn,
            swapchain_fn,
            surface,
            swapchain: vk::SwapchainKHR::null(),
            images: Vec::new(),
            views: Vec::new(),
            ui: None,
            ready: Vec::new(),
            format: vk::SurfaceFormatKHR::default(),
            extent: vk::Extent2D::default(),
            present_mode: vk::PresentModeKHR::FIFO,
            pacing,
            slots: Vec::new(),
            next: 0,
            stale: false,
            readback: None,
        };
        match p.init(ctx, size) {
            Ok(()) => Ok(p),
            Err(e) => {
                p.destroy(ctx);
                Err(e)
            }
        }
    }

    fn init(&mut self, ctx: &Context, size: vk::Extent2D) -> Result<()> {
        // SAFETY: the surface and physical device are valid.
        let supported = unsafe {
            self.surface_fn.get_physical_device_surface_support(
                ctx.physical_device,
                ctx.queue_family,
                self.surface,
            )
        }
        .vk("querying presentation support")?;
        if !supported {
            return Err(Error::Gpu(format!(
                "{} cannot present to this window from its graphics queue",
                ctx.device_name
            )));
        }
        for i in 0..2 {
            let (pool, cmd) = ctx.command_pool("window")?;
            let mut slot = Slot {
                pool,
                cmd,
                fence: vk::Fence::null(),
                acquired: vk::Semaphore::null(),
            };
            // SAFETY: plain object creation on a live device; stored in
            // the slot, which `destroy` cleans up.
            unsafe {
                slot.fence = ctx
                    .device
                    .create_fence(
                        &vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED),
                        None,
                    )
                    .vk("creating a window fence")?;
                slot.acquired = ctx
                    .device
                    .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
                    .vk("creating a window semaphore")?;
            }
            ctx.set_name(slot.cmd, &format!("window blit {i}"));
            self.slots.push(slot);
        }
        self.create_swapchain(ctx, size)
    }

    /// The swapchain's size in pixels.
    pub fn extent(&self) -> vk::Extent2D {
        self.extent
    }

    /// The present mode in use.
    pub fn present_mode(&self) -> vk::PresentModeKHR {
        self.present_mode
    }

    /// The swapchain images' format.
    pub fn format(&self) -> vk::Format {
        self.format.format
    }

    /// Marks the swapchain for recreation before the next present (the
    /// window was resized).
    pub fn resized(&mut self) {
        self.stale = true;
    }

    /// Swapchain image `i`'s name, its present semaphore and, where the
    /// overlay draws into it (`view_format`), its view.
    fn add_image_objects(
        &mut self,
        ctx: &Context,
        i: usize,
        view_format: Option<vk::Format>,
    ) -> Result<()> {
        let img = self.images[i];
        ctx.set_name(img, &format!("window image {i}"));
        // SAFETY: plain object creation; destroyed with the swapchain.
        let s = unsafe {
            ctx.device
                .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
        }
        .vk("creating a present semaphore")?;
        self.ready.push(s);
        let Some(format) = view_format else {
            return Ok(());
        };
        let info = vk::ImageViewCreateInfo::default()
            .image(img)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(barrier::color_range(0, 1));
        // SAFETY: a view of a live swapchain image; destroyed with the
        // swapchain.
        let v = unsafe { ctx.device.create_image_view(&info, None) }
            .vk("creating a window image view")?;
        self.views.push(v);
        Ok(())
    }

    fn create_swapchain(&mut self, ctx: &Context, size: vk::Extent2D) -> Result<()> {
        let pd = ctx.physical_device;
        let sf = &self.surface_fn;
        // SAFETY: queries on a valid surface and physical device.
        let (caps, formats, modes) = unsafe {
            (
                sf.get_physical_device_surface_capabilities(pd, self.surface)
                    .vk("querying the surface capabilities")?,
                sf.get_physical_device_surface_formats(pd, self.surface)
                    .vk("querying the surface formats")?,
                sf.get_physical_device_surface_present_modes(pd, self.surface)
                    .vk("querying the present modes")?,
            )
        };
        let extent = swap_extent(&caps, size);
        if extent.width == 0 || extent.height == 0 {
            // Minimized: keep the old swapchain (if any) and try again later.
            self.stale = true;
            return Ok(());
        }
        let format = [vk::Format::B8G8R8A8_SRGB, vk::Format::R8G8B8A8_SRGB]
            .into_iter()
            .find_map(|f| formats.iter().find(|s| s.format == f).copied())
            .or_else(|| formats.first().copied())
            .ok_or_else(|| Error::Gpu("the window surface offers no formats".into()))?;
        let present_mode = self.pacing.present_mode(&modes);
        let mut needed = vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC;
        if !caps.supported_usage_flags.contains(needed) {
            return Err(Error::Gpu(format!(
                "the window surface's images cannot be blitted into and read back (usage {:?})",
                caps.supported_usage_flags
            )));
        }
        // The overlay draws into the images where the surface allows it.
        let drawable = caps
            .supported_usage_flags
            .contains(vk::ImageUsageFlags::COLOR_ATTACHMENT);
        if drawable {
            needed |= vk::ImageUsageFlags::COLOR_ATTACHMENT;
        }
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let alpha = composite_alpha(&caps);
        let old = self.swapchain;
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(needed)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(alpha)
            .present_mode(present_mode)
            .clipped(true)
            .old_swapchain(old);
        // SAFETY: valid create info on a live device; the old swapchain
        // (retired by this call) is idle (the device was waited on).
        let swapchain = unsafe { self.swapchain_fn.create_swapchain(&info, None) }
            .vk("creating the window swapchain")?;
        self.destroy_swapchain(ctx);
        self.swapchain = swapchain;
        // SAFETY: the swapchain was just created on this device.
        self.images = unsafe { self.swapchain_fn.get_swapchain_images(swapchain) }
            .vk("getting the swapchain images")?;
        for i in 0..self.images.len() {
            self.add_image_objects(ctx, i, drawable.then_some(format.format))?;
        }
        self.format = format;
        self.extent = extent;
        self.present_mode = present_mode;
        self.stale = false;
        tracing::info!(
            "window swapchain: {}x{} {:?}, {} images, {:?}",
            extent.width,
            extent.height,
            format.format,
            self.images.len(),
            present_mode
        );
        Ok(())
    }

    /// Destroys the swapchain and its semaphores (the device must be idle
    /// as far as they are concerned).
    fn destroy_swapchain(&mut self, ctx: &Context) {
        // SAFETY: the caller waited for the device, so no submission or
        // present uses these any more.
        unsafe {
            for s in self.ready.drain(..) {
                ctx.device.destroy_semaphore(s, None);
            }
            for v in self.views.drain(..) {
                ctx.device.destroy_image_view(v, None);
            }
            if self.swapchain != vk::SwapchainKHR::null() {
                self.swapchain_fn.destroy_swapchain(self.swapchain, None);
            }
        }
        self.swapchain = vk::SwapchainKHR::null();
        self.images.clear();
    }

    fn recreate(&mut self, ctx: &Context, size: vk::Extent2D) -> Result<()> {
        // SAFETY: waiting for the device before retiring the swapchain.
        unsafe { ctx.device.device_wait_idle() }.vk("waiting before a swapchain resize")?;
        self.create_swapchain(ctx, size)
    }

    /// Blits `sources` side by side (in order, each at its own size) into
    /// the next swapchain image, letterboxed on black, and presents it;
    /// with `read_back`, the presented pixels come back as RGBA8 (this
    /// waits for the blit). `size` is the window's size, used when the
    /// swapchain must be recreated. Under [`Pacing::NeverBlock`] a present
    /// without `read_back` waits for nothing: when no image is free yet it
    /// returns [`Presented::Busy`].
    pub fn present(
        &mut self,
        ctx: &Context,
        sources: &[Source],
        size: vk::Extent2D,
        read_back: bool,
    ) -> Result<Presented> {
        self.present_with(ctx, sources, size, read_back, None)
    }

    /// Frees the textures `frame` retires (after its present).
    pub fn retire_ui(&mut self, ctx: &Context, frame: &super::ui_layer::UiFrame) -> Result<()> {
        match self.ui.as_mut() {
            Some(layer) => layer.retire(ctx, frame),
            None => Ok(()),
        }
    }

    /// Whether the overlay can be drawn into this window's images.
    pub fn draws_overlays(&self) -> bool {
        !self.views.is_empty()
    }

    /// [`Presenter::present`] with `ui` drawn over the blitted images
    /// (where the surface lets the images be rendered into).
    pub fn present_with(
        &mut self,
        ctx: &Context,
        sources: &[Source],
        size: vk::Extent2D,
        read_back: bool,
        ui: Option<&super::ui_layer::UiFrame>,
    ) -> Result<Presented> {
        if self.stale || self.swapchain == vk::SwapchainKHR::null() {
            self.recreate(ctx, size)?;
            if self.stale {
                return Ok(Presented::Skipped);
            }
        }
        self.prepare_overlay(ctx, ui)?;
        let never_block = self.pacing == Pacing::NeverBlock && !read_back;
        let slot = self.next;
        let (pool, cmd, fence, acquired) = {
            let s = &self.slots[slot];
            (s.pool, s.cmd, s.fence, s.acquired)
        };
        let index = match self.acquire(ctx, size, never_block, (fence, acquired))? {
            Ok(index) => index,
            Err(presented) => return Ok(presented),
        };
        let target = self.images[index as usize];
        let pixels = self.extent.width as u64 * self.extent.height as u64 * 4;
        if read_back {
            self.ensure_readback(ctx, pixels)?;
        }
        let readback = read_back.then(|| self.readback.as_ref().map(|b| b.buffer));
        // The overlay draws only with the renderer made for this format
        // (its textures live there; a swapchain that changed format would
        // need egui to send them again, so the overlay stops instead).
        let ui = ui.filter(|_| {
            self.draws_overlays()
                && self
                    .ui
                    .as_ref()
                    .is_some_and(|l| l.format() == self.format.format)
        });
        let view = self.views.get(index as usize).copied();
        self.record_blit(
            ctx,
            (pool, cmd),
            (target, ui.zip(view)),
            sources,
            readback.flatten(),
        )?;
        self.submit_and_present(ctx, (cmd, fence, acquired), index)?;
        if !read_back {
            return Ok(Presented::Shown(None));
        }
        // SAFETY: waiting for the submission above before mapping its copy.
        unsafe { ctx.device.wait_for_fences(&[fence], true, u64::MAX) }
            .vk("waiting for a window readback")?;
        self.read_pixels(pixels)
            .map(|img| Presented::Shown(Some(img)))
    }

    /// The overlay's texture changes go up before anything can skip a
    /// present (egui sends each change once): on the first overlay the
    /// renderer is made, and an upload waits for the device so no frame
    /// still samples what it replaces.
    fn prepare_overlay(
        &mut self,
        ctx: &Context,
        ui: Option<&super::ui_layer::UiFrame>,
    ) -> Result<()> {
        let Some(frame) = ui.filter(|_| self.draws_overlays()) else {
            return Ok(());
        };
        if self.ui.is_none() {
            self.ui = Some(super::ui_layer::UiLayer::new(
                ctx,
                self.format.format,
                self.slots.len(),
            )?);
        }
        if !frame.textures.set.is_empty() {
            // SAFETY: waiting for the device on this thread.
            unsafe { ctx.device.device_wait_idle() }.vk("waiting before an overlay upload")?;
            if let Some(layer) = self.ui.as_mut() {
                layer.upload(ctx, frame)?;
            }
        }
        Ok(())
    }

    /// Waits for (or, never blocking, checks) the slot's last blit and
    /// acquires an image: its index, or what the present became instead
    /// (busy, or skipped while the swapchain is made again).
    fn acquire(
        &mut self,
        ctx: &Context,
        size: vk::Extent2D,
        never_block: bool,
        (fence, acquired): (vk::Fence, vk::Semaphore),
    ) -> Result<std::result::Result<u32, Presented>> {
        let d = &ctx.device;
        if never_block {
            // SAFETY: the fence belongs to this device.
            let done = unsafe { d.get_fence_status(fence) }.vk("querying a window blit")?;
            if !done {
                return Ok(Err(Presented::Busy));
            }
        } else {
            // SAFETY: the fence belongs to this device; waiting makes the
            // slot's command buffer and semaphore free for reuse.
            unsafe { d.wait_for_fences(&[fence], true, u64::MAX) }
                .vk("waiting for a window blit")?;
        }
        // SAFETY: valid swapchain; the semaphore is unsignalled (its last
        // wait completed with the fence above, and a failed acquire leaves
        // it untouched).
        let acquire = unsafe {
            self.swapchain_fn.acquire_next_image(
                self.swapchain,
                if never_block { 0 } else { u64::MAX },
                acquired,
                vk::Fence::null(),
            )
        };
        let not_yet = matches!(acquire, Err(vk::Result::NOT_READY | vk::Result::TIMEOUT));
        if never_block && not_yet {
            return Ok(Err(Presented::Busy));
        }
        self.next = (self.next + 1) % self.slots.len();
        match acquire {
            Ok((i, suboptimal)) => {
                self.stale |= suboptimal;
                Ok(Ok(i))
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.recreate(ctx, size)?;
                Ok(Err(Presented::Skipped))
            }
            Err(e) => Err(e).vk("acquiring a window image"),
        }
    }

    /// A read-back buffer of at least `pixels` bytes.
    fn ensure_readback(&mut self, ctx: &Context, pixels: u64) -> Result<()> {
        if self.readback.as_ref().is_some_and(|b| b.size >= pixels) {
            return Ok(());
        }
        if let Some(old) = self.readback.take() {
            // No submission still uses it: every read-back waits for its
            // blit before returning.
            old.destroy(ctx);
        }
        self.readback = Some(Buffer::new(
            ctx,
            &BufferDesc {
                name: "window readback",
                size: pixels,
                usage: vk::BufferUsageFlags::TRANSFER_DST,
                location: MemoryLocation::GpuToCpu,
                category: "readback",
            },
        )?);
        Ok(())
    }

    /// Submits the recorded blit (after the acquire, signalling the
    /// image's ready semaphore and the slot's fence) and presents image
    /// `index`; an out-of-date or suboptimal present marks the swapchain
    /// stale.
    fn submit_and_present(
        &mut self,
        ctx: &Context,
        (cmd, fence, acquired): (vk::CommandBuffer, vk::Fence, vk::Semaphore),
        index: u32,
    ) -> Result<()> {
        let d = &ctx.device;
        let ready = self.ready[index as usize];
        let waits = [vk::SemaphoreSubmitInfo::default()
            .semaphore(acquired)
            .stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)];
        let signals = [vk::SemaphoreSubmitInfo::default()
            .semaphore(ready)
            .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
        let submit = vk::SubmitInfo2::default()
            .wait_semaphore_infos(&waits)
            .command_buffer_infos(&cmds)
            .signal_semaphore_infos(&signals);
        // SAFETY: the command buffer is recorded; the fence is reset only
        // now that a submission will signal it.
        unsafe {
            d.reset_fences(&[fence]).vk("resetting a window fence")?;
            d.queue_submit2(ctx.queue, &[submit], fence)
                .vk("submitting a window blit")?;
        }
        let swapchains = [self.swapchain];
        let indices = [index];
        let wait = [ready];
        let info = vk::PresentInfoKHR::default()
            .wait_semaphores(&wait)
            .swapchains(&swapchains)
            .image_indices(&indices);
        // SAFETY: the image was acquired and its blit submitted with the
        // semaphore the present waits on.
        match unsafe { self.swapchain_fn.queue_present(ctx.queue, &info) } {
            Ok(false) => Ok(()),
            Ok(true) | Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.stale = true;
                Ok(())
            }
            Err(e) => Err(e).vk("presenting a window image"),
        }
    }

    /// The read-back buffer's first `pixels` bytes as an RGBA image (BGRA
    /// swapchains swizzled).
    fn read_pixels(&mut self, pixels: u64) -> Result<image::RgbaImage> {
        let extent = self.extent;
        let bgra = matches!(
            self.format.format,
            vk::Format::B8G8R8A8_SRGB | vk::Format::B8G8R8A8_UNORM
        );
        let buf = self
            .readback
            .as_mut()
            .ok_or_else(|| Error::Gpu("no window readback buffer".into()))?;
        let data = buf
            .mapped()
            .ok_or_else(|| Error::Gpu("the window readback buffer is not mapped".into()))?;
        let mut px = data[..pixels as usize].to_vec();
        if bgra {
            for p in px.chunks_exact_mut(4) {
                p.swap(0, 2);
            }
        }
        image::RgbaImage::from_raw(extent.width, extent.height, px)
            .ok_or_else(|| Error::Gpu("window readback has the wrong size".into()))
    }

    /// Records the window blit: the sources letterboxed side by side over
    /// black, the overlay over them, then the hand-over to presentation
    /// (and the copy into `readback` when given).
    fn record_blit(
        &mut self,
        ctx: &Context,
        (pool, cmd): (vk::CommandPool, vk::CommandBuffer),
        (target, ui): (
            vk::Image,
            Option<(&super::ui_layer::UiFrame, vk::ImageView)>,
        ),
        sources: &[Source],
        readback: Option<vk::Buffer>,
    ) -> Result<()> {
        let d = &ctx.device;
        let c = vk::ImageAspectFlags::COLOR;
        let written = SHOWN;
        let acquired = ACQUIRED;
        let layer_barrier =
            |s: &Source, from: Use, to: Use| barrier::color_layer(s.image, s.layer, from, to);
        let mut before: Vec<_> = sources
            .iter()
            .map(|s| layer_barrier(s, written, Use::TRANSFER_SRC))
            .collect();
        before.push(barrier::image(target, c, 1, acquired, Use::TRANSFER_DST));
        let after_src: Vec<_> = sources
            .iter()
            .map(|s| layer_barrier(s, Use::TRANSFER_SRC, written))
            .collect();
        let content = vk::Extent2D {
            width: sources.iter().map(|s| s.extent.width).sum(),
            height: sources.iter().map(|s| s.extent.height).max().unwrap_or(0),
        };
        let (origin, size) = letterbox(content, self.extent);
        let range = barrier::color_range(0, 1);
        let black = vk::ClearColorValue {
            float32: [0.0, 0.0, 0.0, 1.0],
        };
        let cleared = [barrier::image(
            target,
            c,
            1,
            Use::TRANSFER_DST,
            Use::TRANSFER_DST,
        )];
        // SAFETY: recording into this slot's command buffer, whose last
        // submission finished (its fence was waited on); every image is
        // alive and in the layouts the barriers name.
        unsafe {
            d.reset_command_pool(pool, vk::CommandPoolResetFlags::empty())
                .vk("resetting the window command pool")?;
            d.begin_command_buffer(
                cmd,
                &vk::CommandBufferBeginInfo::default()
                    .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )
            .vk("beginning the window blit")?;
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&before),
            );
            d.cmd_clear_color_image(cmd, target, Use::TRANSFER_DST.layout, &black, &[range]);
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&cleared),
            );
            let mut x0 = 0u32;
            for s in sources {
                let region = blit_region(s, x0, content, (origin, size));
                let (src, dst) = (Use::TRANSFER_SRC.layout, Use::TRANSFER_DST.layout);
                d.cmd_blit_image(
                    cmd,
                    s.image,
                    src,
                    target,
                    dst,
                    &[region],
                    vk::Filter::LINEAR,
                );
                x0 += s.extent.width;
            }
            // The overlay over the blitted images, when there is one.
            let mut written_by = Use::TRANSFER_DST;
            if let (Some((frame, view)), Some(layer)) = (ui, self.ui.as_mut()) {
                layer.record(
                    ctx,
                    cmd,
                    (target, view),
                    self.extent,
                    written_by,
                    None,
                    frame,
                )?;
                written_by = super::ui_layer::LOADED;
            }
            self.record_handover(d, cmd, target, (written_by, after_src), readback);
            d.end_command_buffer(cmd).vk("ending the window blit")?;
        }
        Ok(())
    }

    /// After the blit (and overlay, last written by `written_by`): the
    /// target copied into `readback` when asked, then the sources back to
    /// their rendered layout and the target to presentation.
    fn record_handover(
        &self,
        d: &ash::Device,
        cmd: vk::CommandBuffer,
        target: vk::Image,
        (written_by, mut after): (Use, Vec<vk::ImageMemoryBarrier2<'static>>),
        readback: Option<vk::Buffer>,
    ) {
        let c = vk::ImageAspectFlags::COLOR;
        let presented = Use {
            layout: vk::ImageLayout::PRESENT_SRC_KHR,
            stage: vk::PipelineStageFlags2::ALL_COMMANDS,
            access: vk::AccessFlags2::NONE,
        };
        let Some(buf) = readback else {
            after.push(barrier::image(target, c, 1, written_by, presented));
            // SAFETY: recording into the blit's command buffer; the images
            // are in the layouts the barriers name.
            unsafe {
                d.cmd_pipeline_barrier2(
                    cmd,
                    &vk::DependencyInfo::default().image_memory_barriers(&after),
                )
            };
            return;
        };
        let to_read = [barrier::image(target, c, 1, written_by, Use::TRANSFER_SRC)];
        let copy = barrier::color_copy(0, 1, self.extent.width, self.extent.height);
        after.push(barrier::image(target, c, 1, Use::TRANSFER_SRC, presented));
        let to_host = [barrier::buffer_to_host(buf)];
        // SAFETY: as above; the buffer holds the target's pixels.
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&to_read),
            );
            d.cmd_copy_image_to_buffer(cmd, target, Use::TRANSFER_SRC.layout, buf, &[copy]);
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default()
                    .buffer_memory_barriers(&to_host)
                    .image_memory_barriers(&after),
            );
        }
    }

    /// Waits for the device and destroys everything, the surface last. The
    /// window must still exist.
    pub fn destroy(&mut self, ctx: &Context) {
        // SAFETY: waiting for the device first, so nothing destroyed below
        // is still in use.
        unsafe {
            let _ = ctx.device.device_wait_idle();
        }
        self.destroy_swapchain(ctx);
        if let Some(b) = self.readback.take() {
            b.destroy(ctx);
        }
        if let Some(layer) = self.ui.take() {
            layer.destroy(ctx);
        }
        for s in self.slots.drain(..) {
            // SAFETY: the device is idle; each object belongs to it.
            unsafe {
                ctx.device.destroy_fence(s.fence, None);
                ctx.device.destroy_semaphore(s.acquired, None);
                ctx.device.destroy_command_pool(s.pool, None);
            }
        }
        if self.surface != vk::SurfaceKHR::null() {
            // SAFETY: the swapchain made from the surface is destroyed.
            unsafe { self.surface_fn.destroy_surface(self.surface, None) };
            self.surface = vk::SurfaceKHR::null();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(width: u32, height: u32) -> vk::Extent2D {
        vk::Extent2D { width, height }
    }

    #[test]
    fn letterbox_keeps_the_aspect_and_centres() {
        // Same aspect: fills the window.
        let (o, s) = letterbox(e(200, 100), e(400, 200));
        assert_eq!((o.x, o.y, s.width, s.height), (0, 0, 400, 200));
        // Wider window: bars left and right.
        let (o, s) = letterbox(e(200, 100), e(600, 200));
        assert_eq!((o.x, o.y, s.width, s.height), (100, 0, 400, 200));
        // Taller window: bars top and bottom.
        let (o, s) = letterbox(e(200, 100), e(400, 400));
        assert_eq!((o.x, o.y, s.width, s.height), (0, 100, 400, 200));
        // Odd sizes stay inside the window.
        for (cw, ch, ww, wh) in [(1440, 1600, 1023, 577), (7, 3, 5, 9), (1, 1000, 1000, 1)] {
            let (o, s) = letterbox(e(cw, ch), e(ww, wh));
            assert!(o.x as u32 + s.width <= ww && o.y as u32 + s.height <= wh);
            assert!(s.width == ww || s.height == wh);
        }
    }
}
