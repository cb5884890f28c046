//! `run --mirror`: a desktop window showing the eye images a frame
//! submitted — under OpenXR the swapchain images handed to the runtime,
//! headless the images the frame was copied into. Nothing is rendered
//! again: before the images are released, one transfer copies the shown
//! eyes into the mirror's own image (with `cropped`, the hidden area is
//! then cleared to black), and after the frame is submitted
//! ([`Mirror::present`]) that image is blitted into the window's
//! swapchain, letterboxed, without waiting for anything: when no window
//! image is free the mirror skips that frame, so the headset's frame loop
//! never waits for the desktop.
//!
//! The window is opened before the Vulkan context ([`MirrorWindow`]),
//! because the surface's instance and device extensions go into the
//! context's create infos (under OpenXR those handed to the runtime
//! through XR_KHR_vulkan_enable2).

use super::headless::save_png;
use super::view::initial_window_size;
use super::window::{display_available, Input, Window};
use crate::error::{Error, Result, VkContext};
use crate::gpu::barrier::{self, Use};
use crate::gpu::memory::{Image, ImageDesc};
use crate::gpu::surface::{Pacing, Presented, Presenter, Source, SHOWN};
use crate::gpu::{Context, ExtraExtensions};
use crate::view::{Fov, HiddenArea};
use ash::vk;
use std::path::Path;
use std::sync::Arc;

/// A masked mirror layer while its mask renders: loaded (the copied
/// pixels) and partly cleared.
const MASKING: Use = Use {
    layout: Use::COLOR_ATTACHMENT.layout,
    stage: Use::COLOR_ATTACHMENT.stage,
    access: vk::AccessFlags2::from_raw(
        vk::AccessFlags2::COLOR_ATTACHMENT_READ.as_raw()
            | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE.as_raw(),
    ),
};

/// The copy of eye image `s` into mirror layer `layer` (clipped to the
/// mirror's `extent`).
fn copy_region(s: &Source, layer: u32, extent: vk::Extent2D) -> vk::ImageCopy {
    let sub = |base_array_layer| vk::ImageSubresourceLayers {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        mip_level: 0,
        base_array_layer,
        layer_count: 1,
    };
    vk::ImageCopy::default()
        .src_subresource(sub(s.layer))
        .dst_subresource(sub(layer))
        .extent(vk::Extent3D {
            width: s.extent.width.min(extent.width),
            height: s.extent.height.min(extent.height),
            depth: 1,
        })
}

/// What the mirror window shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MirrorMode {
    /// The left eye.
    Left,
    /// The right eye.
    Right,
    /// Both eyes side by side.
    Both,
    /// The left eye with the lens's hidden area masked black.
    Cropped,
    /// Both panels as the HMD shows them: each eye through its profile's
    /// lens (barrel distortion and chromatic aberration), side by side.
    Distorted,
    /// No window.
    Off,
}

impl MirrorMode {
    /// The eyes shown, left to right.
    pub fn eyes(self) -> &'static [usize] {
        match self {
            MirrorMode::Left | MirrorMode::Cropped => &[0],
            MirrorMode::Right => &[1],
            MirrorMode::Both | MirrorMode::Distorted => &[0, 1],
            MirrorMode::Off => &[],
        }
    }

    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            MirrorMode::Left => "left",
            MirrorMode::Right => "right",
            MirrorMode::Both => "both",
            MirrorMode::Cropped => "cropped",
            MirrorMode::Distorted => "distorted",
            MirrorMode::Off => "off",
        }
    }
}

/// The mirror a run gets: `asked` (None: `left` when a display is there,
/// else none, silently); an explicit mode without a display is off with
/// one line on stderr saying why.
pub fn resolve(asked: Option<MirrorMode>) -> Option<MirrorMode> {
    match asked {
        Some(MirrorMode::Off) => None,
        Some(m) => match display_available() {
            Ok(()) => Some(m),
            Err(e) => {
                eprintln!("vergence: mirror off: {e}");
                None
            }
        },
        None => display_available().ok().map(|()| MirrorMode::Left),
    }
}

/// The lenses the `distorted` mirror draws the panels through: each
/// view's lens and field of view (from the HMD profile).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MirrorLenses {
    /// Left and right lenses.
    pub lenses: [crate::view::distortion::Lens; 2],
    /// Left and right fields of view.
    pub fovs: [Fov; 2],
}

impl MirrorLenses {
    /// The lenses of `profile`'s two views (None when either has none).
    pub fn of(profile: &crate::view::profile::HmdProfile) -> Option<MirrorLenses> {
        let (l, r) = (profile.views.first()?, profile.views.get(1)?);
        Some(MirrorLenses {
            lenses: [l.lens?, r.lens?],
            fovs: [l.fov, r.fov],
        })
    }

    /// The size the left lens's panel is shown at for eye images of
    /// `eye` ([`crate::render::distortion::preview_panel`]).
    pub fn panel(&self, eye: vk::Extent2D) -> vk::Extent2D {
        crate::render::distortion::preview_panel(self.lenses[0].panel, eye)
    }
}

/// An open mirror window whose Vulkan side is not made yet.
pub struct MirrorWindow {
    window: Window,
    mode: MirrorMode,
    eye: vk::Extent2D,
}

impl MirrorWindow {
    /// Opens the window for `mode` (not `Off`) of `eye`-sized images
    /// (`distorted`: of the `panel`-sized images), titled `title`; a
    /// failure is one line on stderr and no mirror (the run goes on
    /// without it).
    pub fn open(
        mode: MirrorMode,
        title: &str,
        eye: vk::Extent2D,
        panel: Option<vk::Extent2D>,
    ) -> Option<MirrorWindow> {
        let shown = mode.eyes().len().max(1) as u32;
        let each = panel
            .filter(|_| mode == MirrorMode::Distorted)
            .unwrap_or(eye);
        let content = vk::Extent2D {
            width: each.width * shown,
            height: each.height,
        };
        match Window::open(title, initial_window_size(content)) {
            Ok(window) => Some(MirrorWindow { window, mode, eye }),
            Err(e) => {
                eprintln!("vergence: mirror off: {e}");
                None
            }
        }
    }

    /// The Vulkan extensions its surface needs.
    pub fn extensions(&self) -> Result<ExtraExtensions> {
        self.window.extensions()
    }
}

/// What the mirror did, for `--stats-out`.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct MirrorStats {
    /// The mode.
    pub mode: String,
    /// The window swapchain's present mode.
    pub present_mode: String,
    /// The window's size at the end.
    pub window_size: [u32; 2],
    /// Frames copied from the submitted images.
    pub copied: u64,
    /// Frames presented in the window.
    pub presented: u64,
    /// Frames not presented because no window image was free (the loop
    /// did not wait for one).
    pub busy: u64,
    /// Frames not presented because the swapchain was out of date (resize).
    pub resized: u64,
    /// The overlay's mean times over the frames it showed (the same as
    /// their records' means).
    pub overlay: Option<crate::targets::hud::OverlayFigures>,
}

struct CopySlot {
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

/// Rectangles of hidden pixels of one eye, cached until its mask, FOV or
/// size changes.
struct MaskRects {
    area: HiddenArea,
    fov: Fov,
    rects: Vec<vk::ClearRect>,
}

/// The mirror: window, presenter, its copy of the eye images.
pub struct Mirror {
    ctx: Arc<Context>,
    presenter: Presenter,
    /// Two layers, one per eye, in the submitted images' format (None with
    /// `distorted`, which keeps no copy, and while dropping).
    image: Option<Image>,
    layer_views: Vec<vk::ImageView>,
    slots: Vec<CopySlot>,
    next: usize,
    copied: bool,
    masks: [Option<MaskRects>; 2],
    mode: MirrorMode,
    /// `distorted`: the panels drawn through the lenses from the eyes.
    distortion: Option<crate::render::distortion::DistortionPreview>,
    /// What it did.
    pub stats: MirrorStats,
    /// The window (None only once handed back by [`Mirror::into_window`]).
    window: Option<MirrorWindow>,
    /// A title waiting for the first frame shown.
    title: Option<String>,
    /// The overlay drawn over the window's image (F3 shows and hides it).
    pub hud: crate::targets::hud::Hud,
    /// The `--opt` list and frame budget the overlay shows.
    hud_text: (String, f64),
}

impl Mirror {
    /// Makes the Vulkan side of `window` on `ctx` (created with its
    /// extensions) for eye images of `format`; `distorted` draws through
    /// `lenses` and is an error without them.
    pub fn new(
        ctx: &Arc<Context>,
        window: MirrorWindow,
        format: vk::Format,
        lenses: Option<&MirrorLenses>,
    ) -> Result<Mirror> {
        let (mode, eye) = (window.mode, window.eye);
        let distortion = match (mode, lenses) {
            (MirrorMode::Distorted, Some(l)) => {
                Some(crate::render::distortion::DistortionPreview::for_images(
                    ctx,
                    [&l.lenses[0], &l.lenses[1]],
                    [&l.fovs[0], &l.fovs[1]],
                    eye,
                    crate::render::distortion::Method::Mesh,
                )?)
            }
            (MirrorMode::Distorted, None) => {
                return Err(Error::config(
                    "--mirror distorted",
                    "it draws the panels through the HMD profile's [views.lens] tables: run headless with --hmd-fallback naming a profile with lenses (vive, rift-dk1); an OpenXR runtime gives no lens model",
                ))
            }
            _ => None,
        };
        let (display, handle) = window.window.handles()?;
        let mut presenter = Presenter::new(
            ctx,
            display,
            handle,
            window.window.size(),
            Pacing::NeverBlock,
        )?;
        // `distorted` draws from the eye images into the preview's own
        // images: no copy of the eyes is kept.
        let desc = ImageDesc::eye_copy("mirror eyes", format, eye, 2, "mirror");
        let image = if distortion.is_some() {
            None
        } else {
            match Image::new(ctx, &desc) {
                Ok(i) => Some(i),
                Err(e) => {
                    presenter.destroy(ctx);
                    return Err(e);
                }
            }
        };
        let mut m = Mirror {
            ctx: ctx.clone(),
            stats: MirrorStats {
                mode: mode.name().into(),
                present_mode: format!("{:?}", presenter.present_mode()),
                ..MirrorStats::default()
            },
            presenter,
            image,
            layer_views: Vec::new(),
            slots: Vec::new(),
            next: 0,
            copied: false,
            masks: [None, None],
            mode,
            distortion,
            window: Some(window),
            title: None,
            hud: crate::targets::hud::Hud::new(true),
            hud_text: (String::new(), 1000.0 / 90.0),
        };
        // On failure `m` drops, destroying what was made.
        m.init()?;
        Ok(m)
    }

    fn init(&mut self) -> Result<()> {
        let ctx = &self.ctx;
        let (image, format) = match &self.image {
            Some(i) => (i.image, i.format),
            None => (vk::Image::null(), vk::Format::UNDEFINED),
        };
        for layer in (0..2).filter(|_| image != vk::Image::null()) {
            let info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format)
                .subresource_range(barrier::color_range(layer, 1));
            // SAFETY: a view of a live image; destroyed in `drop`.
            let view = unsafe { ctx.device.create_image_view(&info, None) }
                .vk("creating a mirror view")?;
            self.layer_views.push(view);
        }
        for i in 0..2 {
            let (pool, cmd) = ctx.command_pool("mirror copy")?;
            // SAFETY: plain object creation; destroyed in `drop`.
            let fence = unsafe {
                ctx.device.create_fence(
                    &vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED),
                    None,
                )
            };
            let fence = match fence {
                Ok(f) => f,
                Err(e) => {
                    // SAFETY: the pool was just made and never submitted.
                    unsafe { ctx.device.destroy_command_pool(pool, None) };
                    return Err(e).vk("creating a mirror fence");
                }
            };
            ctx.set_name(cmd, &format!("mirror copy {i}"));
            self.slots.push(CopySlot { pool, cmd, fence });
        }
        Ok(())
    }

    fn win(&self) -> &Window {
        &self
            .window
            .as_ref()
            .expect("present until handed back")
            .window
    }

    fn image(&self) -> &Image {
        self.image.as_ref().expect("present until drop")
    }

    /// The mode shown.
    pub fn mode(&self) -> MirrorMode {
        self.mode
    }

    /// Handles the window's pending events (a resize marks the swapchain
    /// for recreation) and returns the input since the last call.
    pub fn pump(&mut self) -> &mut Input {
        let w = self.window.as_mut().expect("present until handed back");
        let input = w.window.pump();
        if input.resized {
            self.presenter.resized();
        }
        input
    }

    /// Sets the window's title; before the first frame is shown it waits
    /// for it (so a title with the configuration means frames are shown).
    pub fn set_title(&mut self, title: &str) {
        if self.stats.presented == 0 {
            self.title = Some(title.to_string());
        } else {
            self.win().set_title(title);
        }
    }

    /// Copies the shown eyes of a frame's submitted images (`eyes[e]` is eye
    /// e's image and layer, in COLOR_ATTACHMENT_OPTIMAL after the frame's
    /// commands, and left so) into the mirror's image, masking the hidden
    /// area (`hidden`, per eye in tangent space, with the eyes' `fovs`)
    /// with `cropped`. Submitted on the context's queue after the frame and
    /// before the images are released; waits only for this slot's copy of
    /// two frames ago.
    pub fn copy(
        &mut self,
        eyes: &[Source],
        hidden: Option<&[HiddenArea]>,
        fovs: &[Fov],
    ) -> Result<()> {
        let shown = self.mode.eyes();
        if shown.iter().any(|&e| e >= eyes.len()) {
            return Err(Error::Gpu(format!(
                "the mirror needs eye images {shown:?}, the frame has {}",
                eyes.len()
            )));
        }
        if self.mode == MirrorMode::Cropped {
            self.refresh_masks(hidden, fovs);
        }
        let ctx = self.ctx.clone();
        let d = &ctx.device;
        let slot = &self.slots[self.next];
        let (pool, cmd, fence) = (slot.pool, slot.cmd, slot.fence);
        self.next = (self.next + 1) % self.slots.len();
        // SAFETY: this slot's fence; waiting frees its command buffer (its
        // copy ran two frames ago, before the frames since).
        unsafe { d.wait_for_fences(&[fence], true, u64::MAX) }.vk("waiting for a mirror copy")?;
        if let Some(distortion) = &self.distortion {
            Self::begin(&ctx, pool, cmd)?;
            Self::record_distorted(&ctx, cmd, distortion, [eyes[0], eyes[1]])?;
            Self::submit(&ctx, cmd, fence)?;
            self.copied = true;
            self.stats.copied += 1;
            return Ok(());
        }
        Self::begin(&ctx, pool, cmd)?;
        self.record_copy(&ctx, cmd, eyes);
        Self::submit(&ctx, cmd, fence)?;
        self.copied = true;
        self.stats.copied += 1;
        Ok(())
    }

    /// The cropped mirror's mask rectangles per shown eye, made again when
    /// the eye's hidden area (the runtime's, else the lens default) or FOV
    /// changed.
    fn refresh_masks(&mut self, hidden: Option<&[HiddenArea]>, fovs: &[Fov]) {
        for &e in self.mode.eyes() {
            let Some(&fov) = fovs.get(e) else {
                continue;
            };
            let area = match hidden.and_then(|h| h.get(e)) {
                Some(a) => a.clone(),
                None => crate::view::lens::default_hidden_area(&fov),
            };
            let stale = self.masks[e]
                .as_ref()
                .is_none_or(|m| m.fov != fov || m.area != area);
            if stale {
                let rects = mask_rects(&area, &fov, self.image().extent);
                self.masks[e] = Some(MaskRects { area, fov, rects });
            }
        }
    }

    /// The shown eyes whose mask has rectangles to clear.
    fn masked_eyes(&self) -> Vec<usize> {
        match self.mode {
            MirrorMode::Cropped => self
                .mode
                .eyes()
                .iter()
                .copied()
                .filter(|&e| self.masks[e].as_ref().is_some_and(|m| !m.rects.is_empty()))
                .collect(),
            _ => Vec::new(),
        }
    }

    /// Records the copy of the shown eyes into the mirror's layers, then
    /// the masks cleared to black (loading the copied pixels).
    fn record_copy(&self, ctx: &Context, cmd: vk::CommandBuffer, eyes: &[Source]) {
        let d = &ctx.device;
        let shown = self.mode.eyes();
        let attached = Use::COLOR_ATTACHMENT;
        let masked = self.masked_eyes();
        let mirror = self.image().image;
        let mut before = Vec::new();
        let mut after = Vec::new();
        for &e in shown {
            let s = eyes[e];
            before.push(barrier::color_layer(
                s.image,
                s.layer,
                SHOWN,
                Use::TRANSFER_SRC,
            ));
            before.push(barrier::color_layer(
                mirror,
                e as u32,
                SHOWN.discarded(),
                Use::TRANSFER_DST,
            ));
            after.push(barrier::color_layer(
                s.image,
                s.layer,
                Use::TRANSFER_SRC,
                attached,
            ));
        }
        for &e in shown {
            let to = if masked.contains(&e) { MASKING } else { SHOWN };
            after.push(barrier::color_layer(
                mirror,
                e as u32,
                Use::TRANSFER_DST,
                to,
            ));
        }
        let extent = self.image().extent;
        // SAFETY: recording into this slot's command buffer, whose last
        // submission finished; the images are alive and in the layouts the
        // barriers name (the frame's commands, submitted earlier on this
        // queue, left the eye images in COLOR_ATTACHMENT_OPTIMAL).
        unsafe {
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&before),
            );
            for &e in shown {
                let region = copy_region(&eyes[e], e as u32, extent);
                let (src, dst) = (Use::TRANSFER_SRC.layout, Use::TRANSFER_DST.layout);
                d.cmd_copy_image(cmd, eyes[e].image, src, mirror, dst, &[region]);
            }
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&after),
            );
        }
        self.record_masks(d, cmd, &masked);
    }

    /// Clears the `masked` eyes' mask rectangles to black.
    fn record_masks(&self, d: &ash::Device, cmd: vk::CommandBuffer, masked: &[usize]) {
        if masked.is_empty() {
            return;
        }
        let extent = self.image().extent;
        let black = [vk::ClearAttachment {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            color_attachment: 0,
            clear_value: vk::ClearValue {
                color: vk::ClearColorValue {
                    float32: [0.0, 0.0, 0.0, 1.0],
                },
            },
        }];
        let keep = crate::gpu::rendering::Load::Keep;
        let done: Vec<_> = masked
            .iter()
            .map(|&e| barrier::color_layer(self.image().image, e as u32, MASKING, SHOWN))
            .collect();
        // SAFETY: the masked layers were moved to MASKING by the copy's
        // barriers; each scope renders into one layer's view.
        unsafe {
            for &e in masked {
                let rects = &self.masks[e]
                    .as_ref()
                    .expect("masked eyes have masks")
                    .rects;
                crate::gpu::rendering::begin_color(d, cmd, self.layer_views[e], extent, keep, 0);
                d.cmd_clear_attachments(cmd, &black, rects);
                d.cmd_end_rendering(cmd);
            }
            d.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&done),
            );
        }
    }

    /// Resets `pool` and begins `cmd` from it; the slot's last submission
    /// must be done.
    fn begin(ctx: &Context, pool: vk::CommandPool, cmd: vk::CommandBuffer) -> Result<()> {
        // SAFETY: the slot's fence was waited for, so nothing from the pool
        // is pending.
        unsafe {
            ctx.device
                .reset_command_pool(pool, vk::CommandPoolResetFlags::empty())
                .vk("resetting the mirror command pool")?;
            ctx.device
                .begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .vk("beginning the mirror copy")
        }
    }

    /// Ends `cmd` and submits it on the context's queue, signalling `fence`.
    fn submit(ctx: &Context, cmd: vk::CommandBuffer, fence: vk::Fence) -> Result<()> {
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
        let submit = vk::SubmitInfo2::default().command_buffer_infos(&cmds);
        // SAFETY: `cmd` was begun by `begin` and recorded; the fence is
        // this slot's, waited for before.
        unsafe {
            ctx.device
                .end_command_buffer(cmd)
                .vk("ending the mirror copy")?;
            ctx.device
                .reset_fences(&[fence])
                .vk("resetting a mirror fence")?;
            ctx.device
                .queue_submit2(ctx.queue, &[submit], fence)
                .vk("submitting the mirror copy")
        }
    }

    /// `distorted`: the two eye images (in COLOR_ATTACHMENT_OPTIMAL after
    /// the frame, and left so) made readable, drawn through the lenses into
    /// the preview's panel images, and handed back to the frame's layout.
    fn record_distorted(
        ctx: &Context,
        cmd: vk::CommandBuffer,
        distortion: &crate::render::distortion::DistortionPreview,
        eyes: [Source; 2],
    ) -> Result<()> {
        let attached = Use::COLOR_ATTACHMENT;
        let layer_barrier =
            |s: &Source, from: Use, to: Use| barrier::color_layer(s.image, s.layer, from, to);
        let before: Vec<_> = eyes
            .iter()
            .map(|s| layer_barrier(s, SHOWN, Use::TRANSFER_SRC))
            .collect();
        let after: Vec<_> = eyes
            .iter()
            .map(|s| layer_barrier(s, Use::TRANSFER_SRC, attached))
            .collect();
        // SAFETY: recording into the slot's begun command buffer; the frame's
        // commands, submitted earlier on this queue, left the eye images in
        // COLOR_ATTACHMENT_OPTIMAL.
        unsafe {
            ctx.device.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&before),
            )
        };
        distortion.record_from(cmd, eyes)?;
        // SAFETY: as above.
        unsafe {
            ctx.device.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&after),
            )
        };
        Ok(())
    }

    fn sources(&self) -> Vec<Source> {
        if let Some(d) = &self.distortion {
            let (image, extent) = d.panels();
            return (0..2)
                .map(|layer| Source {
                    image,
                    layer,
                    extent,
                })
                .collect();
        }
        self.mode
            .eyes()
            .iter()
            .map(|&e| Source {
                image: self.image().image,
                layer: e as u32,
                extent: self.image().extent,
            })
            .collect()
    }

    /// Shows a finished frame's counts and passes in the overlay.
    pub fn push_frame(&mut self, r: &crate::render::driver::FrameResult) {
        self.hud.set_last(r);
    }

    /// Adds frame `index`'s times, as its `--stats-out` record has them,
    /// to the overlay's graph and means.
    pub fn push_record(&mut self, index: u64, t: crate::targets::hud::Times) {
        self.hud.push_times(index, t);
    }

    /// Sets the `--opt` list and the frame budget (ms) the overlay shows.
    pub fn set_overlay_text(&mut self, opt: &str, budget_ms: f64) {
        if self.hud_text.0 != opt {
            self.hud_text.0 = opt.to_string();
        }
        self.hud_text.1 = budget_ms;
    }

    /// The overlay of a window of `size` (None when hidden).
    fn overlay(&mut self, size: vk::Extent2D) -> Option<crate::gpu::ui_layer::UiFrame> {
        let info = crate::targets::hud::HudInfo {
            opt: &self.hud_text.0,
            budget_ms: self.hud_text.1,
            keys: crate::targets::hud::KEYS_MIRROR,
        };
        self.hud.frame([size.width, size.height], &info)
    }

    /// Presents with the overlay, then frees the textures it retires.
    fn present_overlaid(
        &mut self,
        sources: &[Source],
        size: vk::Extent2D,
        read_back: bool,
    ) -> Result<Presented> {
        let ui = self.overlay(size);
        let shown = self
            .presenter
            .present_with(&self.ctx, sources, size, read_back, ui.as_ref());
        if let Some(f) = &ui {
            self.presenter.retire_ui(&self.ctx, f)?;
        }
        shown
    }

    /// Shows the last copied frame in the window, without waiting: when no
    /// window image is free this frame is skipped.
    pub fn present(&mut self) -> Result<()> {
        if !self.copied {
            return Ok(());
        }
        let sources = self.sources();
        let size = self.win().size();
        match self.present_overlaid(&sources, size, false)? {
            Presented::Shown(_) => {
                self.stats.presented += 1;
                if let Some(t) = self.title.take() {
                    self.win().set_title(&t);
                }
            }
            Presented::Busy => self.stats.busy += 1,
            Presented::Skipped => self.stats.resized += 1,
        }
        Ok(())
    }

    /// Writes the last presented image to `path`, or says on stderr (one
    /// line) that no frame was shown.
    pub fn write_screenshot(&mut self, path: &Path) -> Result<()> {
        if !self.screenshot(path)? {
            eprintln!(
                "vergence: no frame reached the mirror; {} not written",
                path.display()
            );
        }
        Ok(())
    }

    /// Presents the last copied frame once more, read back, and writes
    /// that image (what the window shows) to `path` as PNG. Waits for the
    /// GPU; for the end of a run. Returns whether an image was written.
    pub fn screenshot(&mut self, path: &Path) -> Result<bool> {
        if !self.copied {
            return Ok(false);
        }
        let sources = self.sources();
        // A resize may need one recreation before an image is shown.
        for _ in 0..3 {
            let size = self.win().size();
            if let Presented::Shown(Some(img)) = self.present_overlaid(&sources, size, true)? {
                save_png(&img, path)?;
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// Waits for the mirror's copies (before the images they read go away).
    pub fn finish(&mut self) -> Result<()> {
        let fences: Vec<vk::Fence> = self.slots.iter().map(|s| s.fence).collect();
        if fences.is_empty() {
            return Ok(());
        }
        // SAFETY: fences of this device.
        unsafe { self.ctx.device.wait_for_fences(&fences, true, u64::MAX) }
            .vk("waiting for the mirror copies")
    }

    /// Fills in the statistics' window figures.
    pub fn final_stats(&mut self) -> MirrorStats {
        let s = self.win().size();
        self.stats.window_size = [s.width, s.height];
        self.stats.overlay = self.hud.figures();
        self.stats.present_mode = format!("{:?}", self.presenter.present_mode());
        self.stats.clone()
    }
}

impl Mirror {
    /// Destroys the Vulkan side (waiting for the device) and hands the
    /// window back, with the statistics, for a later session of the run.
    pub fn into_window(mut self) -> (Option<MirrorWindow>, MirrorStats) {
        let stats = self.final_stats();
        let w = self.window.take();
        (w, stats)
    }
}

impl Drop for Mirror {
    fn drop(&mut self) {
        let ctx = self.ctx.clone();
        // Waits for the device, then destroys the swapchain and surface
        // (the window is still open: it goes after this, or is handed back).
        self.presenter.destroy(&ctx);
        // SAFETY: the device is idle (the presenter waited); each object
        // belongs to it and is destroyed once.
        unsafe {
            for s in self.slots.drain(..) {
                ctx.device.destroy_fence(s.fence, None);
                ctx.device.destroy_command_pool(s.pool, None);
            }
            for v in self.layer_views.drain(..) {
                ctx.device.destroy_image_view(v, None);
            }
        }
        if let Some(image) = self.image.take() {
            image.destroy(&ctx);
        }
    }
}

/// What a run's desktop side carries from session to session: the mirror
/// window (opened once: winit makes one event loop per process), whether it
/// was closed, and the live toggles' configuration.
pub struct Desk {
    mode: Option<MirrorMode>,
    window: Option<MirrorWindow>,
    /// The profile's lenses, for the `distorted` mirror (None under OpenXR
    /// or with a profile without them).
    lenses: Option<MirrorLenses>,
    tried: bool,
    /// The window was closed (or Escape pressed): the run ends in order.
    pub closed: bool,
    /// Scenes on offer (a kiosk's; N moves to the next when there are two
    /// or more).
    pub scenes: usize,
    /// N was pressed: this session ends in order and the run goes on with
    /// the next scene.
    pub next_scene: bool,
    /// The configuration the keys switch.
    pub live: crate::targets::toggles::LiveConfig,
    /// The mirror's statistics so far (None: no mirror yet).
    pub stats: Option<MirrorStats>,
    /// Whether the mirror shows the overlay (`--overlay`; F3 switches it).
    pub overlay: bool,
    /// F4 was pressed: the loop measures the last frame's image error.
    pub measure: bool,
    /// F8 was pressed: the loop keeps the last frame's head pose.
    keep: bool,
    /// Poses kept so far (they are named `run 1`, `run 2`, ...).
    kept: u32,
    /// The keys held in the window at the last [`Desk::handle`].
    pub held: std::collections::HashSet<winit::keyboard::KeyCode>,
}

impl Desk {
    /// Why the session should end at the desk's request: the mirror
    /// window was closed, or the next scene was asked for.
    pub fn leaving(&self) -> Option<&'static str> {
        match (self.closed, self.next_scene) {
            (true, _) => Some("the mirror window was closed"),
            (false, true) => Some("the next scene was asked for"),
            (false, false) => None,
        }
    }

    /// For a run asked for mirror `asked` (see [`resolve`]) starting from
    /// `config`; F2 writes to `save_to`.
    pub fn new(
        asked: Option<MirrorMode>,
        config: crate::config::RenderConfig,
        save_to: Option<std::path::PathBuf>,
    ) -> Desk {
        Desk {
            mode: resolve(asked),
            window: None,
            lenses: None,
            tried: false,
            measure: false,
            keep: false,
            kept: 0,
            held: Default::default(),
            closed: false,
            scenes: 1,
            next_scene: false,
            live: crate::targets::toggles::LiveConfig::new(config, save_to),
            stats: None,
            overlay: true,
        }
    }

    /// No mirror at all.
    pub fn off(config: crate::config::RenderConfig) -> Desk {
        Desk::new(Some(MirrorMode::Off), config, None)
    }

    /// The lenses a `distorted` mirror draws through (the run's HMD
    /// profile's; set before [`Desk::prepare`]).
    pub fn set_lenses(&mut self, lenses: Option<MirrorLenses>) {
        self.lenses = lenses;
    }

    /// Readies the mirror window for a session of `eye`-sized images (the
    /// run's window when one is open, else opened now, once per run) and
    /// returns the extensions the Vulkan context needs for it (none
    /// without a window). The window stays here until [`Desk::mirror`]
    /// takes it, so a session that fails before leaves it to the next.
    pub fn prepare(&mut self, title: &str, eye: vk::Extent2D) -> ExtraExtensions {
        if self.window.is_none() && !self.tried {
            if let Some(mode) = self.mode {
                self.tried = true;
                let panel = self.lenses.map(|l| l.panel(eye));
                self.window = MirrorWindow::open(mode, title, eye, panel);
            }
        }
        let Some(w) = self.window.as_mut() else {
            return ExtraExtensions::default();
        };
        w.eye = eye;
        match w.extensions() {
            Ok(e) => e,
            Err(e) => {
                eprintln!("vergence: mirror off: {e}");
                self.window = None;
                ExtraExtensions::default()
            }
        }
    }

    /// The mirror on `ctx` (made with [`Desk::prepare`]'s extensions) for
    /// images of `format`, when a window is ready; a failure is one line on
    /// stderr and no mirror.
    pub fn mirror(&mut self, ctx: &Arc<Context>, format: vk::Format) -> Option<Mirror> {
        match Mirror::new(ctx, self.window.take()?, format, self.lenses.as_ref()) {
            Ok(mut m) => {
                m.hud.visible = self.overlay;
                Some(m)
            }
            Err(e) => {
                eprintln!("vergence: mirror off: {e}");
                None
            }
        }
    }

    /// Takes the window back from a session's mirror (destroying its
    /// Vulkan side) and adds up its statistics.
    pub fn put_back(&mut self, mirror: Mirror) {
        let (window, s) = mirror.into_window();
        self.window = window;
        let total = self.stats.get_or_insert_with(MirrorStats::default);
        total.mode = s.mode;
        total.present_mode = s.present_mode;
        total.window_size = s.window_size;
        total.copied += s.copied;
        total.presented += s.presented;
        total.busy += s.busy;
        total.resized += s.resized;
        total.overlay = match (total.overlay, s.overlay) {
            (Some(a), Some(b)) => Some(a.merged(&b)),
            (a, b) => a.or(b),
        };
    }

    /// Handles a frame's window input: a close ends the run, keys switch
    /// optimizations. Returns the new configuration when one changed.
    /// `next_frame` is the index of the next frame rendered.
    pub fn handle(
        &mut self,
        mirror: &mut Mirror,
        next_frame: u64,
    ) -> Option<crate::config::RenderConfig> {
        let input = mirror.pump();
        if input.close {
            self.closed = true;
        }
        let pressed = std::mem::take(&mut input.pressed);
        self.held.clone_from(&input.held);
        if pressed.contains(&crate::targets::hud::KEY) {
            mirror.hud.visible = !mirror.hud.visible;
            self.overlay = mirror.hud.visible;
        }
        if pressed.contains(&crate::targets::hud::HEATMAP_KEY) {
            mirror.hud.show_heatmap = !mirror.hud.show_heatmap;
        }
        if pressed.contains(&crate::targets::hud::MEASURE_KEY) {
            self.measure = true;
        }
        if pressed.contains(&super::keep_pose::KEY) {
            self.keep = true;
        }
        if self.scenes > 1 && pressed.contains(&winit::keyboard::KeyCode::KeyN) {
            self.next_scene = true;
        }
        self.live.handle(&pressed, next_frame)
    }

    /// After F8: the head pose of the last frame shown (`last`, in the
    /// scene's frame after locomotion) printed as `--pose` and `--spawn`
    /// values and appended as a named viewpoint to
    /// [`super::keep_pose::DEFAULT_FILE`], as F8 in `view` does; a failure
    /// only says so.
    pub fn keep_pose(&mut self, last: Option<&crate::view::StereoRig>) {
        if !std::mem::take(&mut self.keep) {
            return;
        }
        let Some(rig) = last else {
            eprintln!("vergence: pose not kept: no frame shown yet");
            return;
        };
        self.kept += 1;
        let file = std::path::Path::new(super::keep_pose::DEFAULT_FILE);
        match super::keep_pose::keep(&rig.head, &format!("run {}", self.kept), file) {
            Ok(line) => println!("{line}"),
            Err(e) => eprintln!("vergence: pose not kept: {e}"),
        }
    }

    /// After F4: the last frame (`rig` at scene time `time`, `extent` per
    /// eye, the section plane `section` it was cut by) rendered again with
    /// the current configuration and with the reference, its FLIP mean
    /// printed and shown in the overlay with the heat map (F5). The loop
    /// stops for two renders meanwhile; a failed measurement only says so.
    pub fn measure_error(
        &mut self,
        mirror: &mut Mirror,
        ctx: &std::sync::Arc<crate::gpu::Context>,
        scene: &crate::scene::Scene,
        last: Option<(&crate::view::StereoRig, f64)>,
        extent: vk::Extent2D,
        section: Option<[f64; 4]>,
    ) {
        if !std::mem::take(&mut self.measure) {
            return;
        }
        let Some(shown) = last else {
            eprintln!("vergence: image error not measured: no frame shown yet");
            return;
        };
        let config = {
            let mut rc = self.live.config.clone();
            rc.frame.section = section;
            rc
        };
        match crate::targets::error_probe::measure(ctx, scene, &config, shown, extent) {
            Ok(report) => {
                println!(
                    "image error: FLIP mean {:.4} against two-pass 4x for {}",
                    report.flip_mean, report.opt
                );
                mirror.hud.set_error(report);
                mirror.hud.visible = true;
                self.overlay = true;
            }
            Err(e) => eprintln!("vergence: image error not measured: {e}"),
        }
    }

    /// Whether the session should end (the window closed, or the next
    /// scene asked for).
    pub fn ending(&self) -> bool {
        self.closed || self.next_scene
    }
}

/// The hidden pixels of a `extent`-sized image of `fov` under `area`, as
/// few rectangles: per row the runs of hidden pixels, rows with the same
/// runs merged into one taller rectangle.
pub fn mask_rects(area: &HiddenArea, fov: &Fov, extent: vk::Extent2D) -> Vec<vk::ClearRect> {
    let (w, h) = (extent.width as usize, extent.height as usize);
    let mask = crate::view::lens::mask_image(area, fov, extent.width, extent.height);
    let runs = |y: usize| -> Vec<(u32, u32)> {
        let row = &mask[y * w..(y + 1) * w];
        let mut out = Vec::new();
        let mut x = 0;
        while x < w {
            if row[x] {
                let start = x;
                while x < w && row[x] {
                    x += 1;
                }
                out.push((start as u32, (x - start) as u32));
            } else {
                x += 1;
            }
        }
        out
    };
    let mut rects = Vec::new();
    let mut open: Vec<(u32, u32)> = Vec::new();
    let mut open_from = 0u32;
    let close = |rects: &mut Vec<vk::ClearRect>, runs: &[(u32, u32)], y0: u32, y1: u32| {
        for &(x, len) in runs {
            rects.push(vk::ClearRect {
                rect: vk::Rect2D {
                    offset: vk::Offset2D {
                        x: x as i32,
                        y: y0 as i32,
                    },
                    extent: vk::Extent2D {
                        width: len,
                        height: y1 - y0,
                    },
                },
                base_array_layer: 0,
                layer_count: 1,
            });
        }
    };
    for y in 0..h {
        let r = runs(y);
        if r != open {
            close(&mut rects, &open, open_from, y as u32);
            open = r;
            open_from = y as u32;
        }
    }
    close(&mut rects, &open, open_from, h as u32);
    rects
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mask_rectangles_cover_exactly_the_hidden_pixels() {
        let fov = Fov::symmetric(0.8, 0.7);
        let area = crate::view::lens::default_hidden_area(&fov);
        let extent = vk::Extent2D {
            width: 97,
            height: 61,
        };
        let mask = crate::view::lens::mask_image(&area, &fov, 97, 61);
        let mut covered = vec![0u8; mask.len()];
        let rects = mask_rects(&area, &fov, extent);
        for r in &rects {
            for y in r.rect.offset.y as u32..r.rect.offset.y as u32 + r.rect.extent.height {
                for x in r.rect.offset.x as u32..r.rect.offset.x as u32 + r.rect.extent.width {
                    covered[(y * 97 + x) as usize] += 1;
                }
            }
        }
        for (i, (&m, &c)) in mask.iter().zip(&covered).enumerate() {
            assert_eq!(c, m as u8, "pixel {i}");
        }
        assert!(mask.iter().any(|&m| m) && mask.iter().any(|&m| !m));
        assert!(rects.len() < 61 * 4, "{} rectangles", rects.len());
    }

    #[test]
    fn modes_show_their_eyes() {
        assert_eq!(MirrorMode::Left.eyes(), &[0]);
        assert_eq!(MirrorMode::Right.eyes(), &[1]);
        assert_eq!(MirrorMode::Both.eyes(), &[0, 1]);
        assert_eq!(MirrorMode::Cropped.eyes(), &[0]);
        assert!(MirrorMode::Off.eyes().is_empty());
    }
}
