//! `vergence view`: the desktop preview. An HMD profile's stereo rig,
//! carried by a mouse-and-keyboard [`FlyCamera`], rendered through the same
//! renderer and frame driver as every other loop; each frame is copied into
//! eye images (a [`FrameOutput`], as an OpenXR session's swapchains are)
//! and blitted into the window's swapchain, one eye or both side by side,
//! letterboxed to keep their aspect.

use super::headless::{eye_extent, load_scene, load_stereo_profile, save_png};
use super::hud::{Hud, HudInfo};
use super::toggles::LiveConfig;
use super::window::{display_available, Eyes, FlyCamera, Window};
use crate::config::{RenderConfig, StereoMode};
use crate::error::{Error, Result, VkContext};
use crate::gpu::memory::{Image, ImageDesc};
use crate::gpu::surface::{Pacing, Presented, Presenter, Source};
use crate::gpu::{Context, Direct, Validation};
use crate::render::attachments::COLOR_FORMAT;
use crate::render::driver::FrameDriver;
use crate::render::{FrameOutput, OutputSpec, Renderer};
use crate::view::Pose;
use ash::vk;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// What `vergence view` shows.
#[derive(Clone, Debug)]
pub struct ViewArgs {
    /// `--scene` value.
    pub scene: String,
    /// HMD profile name or path.
    pub hmd: String,
    /// Where the fly camera starts (None: framing the scene, as `render`
    /// does without `--pose`).
    pub pose: Option<Pose>,
    /// How the fly camera is placed without `pose` (`--frame`).
    pub framing: super::framing::Framing,
    /// Renderer configuration.
    pub config: RenderConfig,
    /// Per-eye size override (else the profile's resolution).
    pub size: Option<(u32, u32)>,
    /// End after this many presented frames (None: until closed).
    pub frames: Option<u64>,
    /// Write the last presented window image here (PNG): after the last of
    /// `frames`, or when the window is closed.
    pub screenshot: Option<PathBuf>,
    /// Which eyes the window shows.
    pub eyes: Eyes,
    /// Where F2 writes the live configuration (default `vergence-live.toml`).
    pub save_config: Option<PathBuf>,
    /// Whether the overlay starts shown (F3 switches it).
    pub overlay: bool,
}

/// What a `view` session did.
#[derive(Clone, Debug)]
pub struct ViewSummary {
    /// Frames presented.
    pub frames: u64,
    /// Per-eye size rendered.
    pub eye_size: [u32; 2],
    /// The window's size at the end.
    pub window_size: [u32; 2],
    /// The swapchain's present mode.
    pub present_mode: String,
    /// Vulkan validation messages seen.
    pub validation_messages: usize,
    /// The `--opt` string at the end (after the live toggles).
    pub opt: String,
}

/// The largest window `view` opens by default; larger content is shown
/// scaled down (the window can be resized).
const MAX_WINDOW: vk::Extent2D = vk::Extent2D {
    width: 1600,
    height: 900,
};

/// The window size for `content` pixels: the content's own size, scaled
/// down to fit [`MAX_WINDOW`] with its aspect kept.
pub fn initial_window_size(content: vk::Extent2D) -> vk::Extent2D {
    if content.width <= MAX_WINDOW.width && content.height <= MAX_WINDOW.height {
        return content;
    }
    crate::gpu::surface::letterbox(content, MAX_WINDOW).1
}

/// Images the renderer copies each frame into (one set per frame in
/// flight): one two-layer image under multiview, one image per eye in
/// two-pass, as an OpenXR session's swapchains would be.
pub(crate) struct EyeImages {
    sets: Vec<Vec<Image>>,
    multiview: bool,
    extent: vk::Extent2D,
}

impl EyeImages {
    pub(crate) fn new(
        ctx: &Context,
        stereo: StereoMode,
        extent: vk::Extent2D,
        slots: usize,
    ) -> Result<Self> {
        let multiview = stereo == StereoMode::Multiview;
        let (count, layers) = if multiview { (1, 2) } else { (2, 1) };
        let mut sets = Vec::new();
        for s in 0..slots {
            let mut set = Vec::new();
            for i in 0..count {
                set.push(Image::new(
                    ctx,
                    &ImageDesc::eye_copy(
                        &format!("window eye image {s}.{i}"),
                        COLOR_FORMAT,
                        extent,
                        layers,
                        "window",
                    ),
                )?);
            }
            sets.push(set);
        }
        Ok(EyeImages {
            sets,
            multiview,
            extent,
        })
    }

    pub(crate) fn output(&self, slot: usize) -> FrameOutput {
        FrameOutput {
            color: self.sets[slot].iter().map(|i| i.image).collect(),
            ..FrameOutput::default()
        }
    }

    pub(crate) fn source(&self, slot: usize, eye: usize) -> Source {
        let set = &self.sets[slot];
        let (image, layer) = if self.multiview {
            (set[0].image, eye as u32)
        } else {
            (set[eye].image, 0)
        };
        Source {
            image,
            layer,
            extent: self.extent,
        }
    }

    pub(crate) fn destroy(self, ctx: &Context) {
        for img in self.sets.into_iter().flatten() {
            img.destroy(ctx);
        }
    }
}

/// Runs the desktop preview until the window closes (or `args.frames`
/// frames were presented).
pub fn view(args: &ViewArgs) -> Result<ViewSummary> {
    if args.config.effort.aq {
        return Err(crate::error::Error::config(
            "--opt",
            "aq adapts a headset's frames to its display period (run, render --frames, bench); view shows the window at its own size: leave aq out",
        ));
    }
    display_available()?;
    let profile = load_stereo_profile(&args.hmd)?;
    args.config.validate()?;
    let mut config = args.config.clone();
    config.resolve_lens(Some(&profile))?;
    let (scene, _) = load_scene(&args.scene)?;
    let extent = eye_extent(&profile, args.size);
    let shown = args.eyes.indices();
    let content = vk::Extent2D {
        width: extent.width * shown.len() as u32,
        height: extent.height,
    };
    let mut window = Window::open(
        &format!("vergence view: {} ({})", scene.name, profile.name),
        initial_window_size(content),
    )?;
    let ctx = Arc::new(Context::with_extensions(
        Validation::from_env(),
        &Direct,
        &window.extensions()?,
    )?);
    let (display, handle) = window.handles()?;
    let mut presenter = Presenter::new(&ctx, display, handle, window.size(), Pacing::Vsync)?;
    let slots = config.submission.frames_in_flight.max(1) as usize;
    let mut live = LiveConfig::new(config.clone(), args.save_config.clone());
    // aq adapts a headset's frames; the window's images have the eye size.
    live.allowed.retain(|t| *t != super::toggles::Toggle::Aq);
    window.set_title(&format!(
        "vergence view: {} ({}) [{}]",
        scene.name,
        profile.name,
        live.config.opt_string()
    ));
    let result = EyeImages::new(&ctx, config.frame.stereo, extent, slots).and_then(|images| {
        let mut images = Some(images);
        let r = view_loop(
            args,
            &ctx,
            (&mut window, &mut presenter),
            &mut images,
            &mut live,
            &profile,
            &scene,
        );
        // Destroying waits for the device: nothing reads the eye images after.
        presenter.destroy(&ctx);
        if let Some(images) = images {
            images.destroy(&ctx);
        }
        r
    });
    presenter.destroy(&ctx);
    let frames = result?;
    let size = window.size();
    let summary = ViewSummary {
        frames,
        eye_size: [extent.width, extent.height],
        window_size: [size.width, size.height],
        present_mode: format!("{:?}", presenter.present_mode()),
        validation_messages: ctx.validation_messages(),
        opt: live.config.opt_string(),
    };
    Ok(summary)
}

/// Makes the renderer and driver for `config` (and, when `images` is
/// empty, the eye images for its stereo mode).
fn make_driver(
    ctx: &Arc<Context>,
    scene: &crate::scene::Scene,
    config: &RenderConfig,
    extent: vk::Extent2D,
    images: &mut Option<EyeImages>,
) -> Result<FrameDriver> {
    let spec = OutputSpec {
        color_format: COLOR_FORMAT,
        depth: false,
        quad: false,
    };
    if images.is_none() {
        let slots = config.submission.frames_in_flight.max(1) as usize;
        *images = Some(EyeImages::new(ctx, config.frame.stereo, extent, slots)?);
    }
    let renderer = Renderer::with_output(ctx.clone(), scene, config, extent, Some(spec))?;
    FrameDriver::new(renderer, scene)
}

fn view_loop(
    args: &ViewArgs,
    ctx: &Arc<Context>,
    (window, presenter): (&mut Window, &mut Presenter),
    images: &mut Option<EyeImages>,
    live: &mut LiveConfig,
    profile: &crate::view::profile::HmdProfile,
    scene: &crate::scene::Scene,
) -> Result<u64> {
    let extent = eye_extent(profile, args.size);
    let mut driver = make_driver(ctx, scene, &live.config, extent, images)?;
    let start = args
        .pose
        .unwrap_or_else(|| super::framing::head_pose(scene, profile, args.framing));
    let mut camera = FlyCamera::at(start);
    let mut presented = 0u64;
    let mut index = 0u64;
    let mut last = Instant::now();
    let started = last;
    let mut last_slot = None;
    let mut hud = Hud::new(args.overlay);
    let mut kept = 0u32;
    let budget_ms = 1000.0 / profile.refresh_hz.max(1.0);
    let run = (|| -> Result<()> {
        loop {
            if args.frames.is_some_and(|n| presented >= n) {
                return Ok(());
            }
            let input = window.pump();
            let pressed = std::mem::take(&mut input.pressed);
            let close = input.close;
            let time = last.duration_since(started).as_secs_f64();
            let view = ViewState {
                ctx,
                scene,
                profile,
                extent,
            };
            view.keys(&pressed, &mut hud, &mut kept, (&camera, time), &live.config);
            if let Some(new) = live.handle(&pressed, index) {
                // The frames in flight finish and the presenter's blits
                // are done (they read the eye images) before the renderer,
                // and the eye images when the stereo mode changed, are
                // made again.
                view.switch(&mut driver, new, live, images)?;
                last_slot = None;
                let opt = live.config.opt_string();
                window.set_title(&format!(
                    "vergence view: {} ({}) [{opt}]",
                    scene.name, profile.name
                ));
            }
            let images = images.as_ref().expect("made with the driver");
            let slots = driver.renderer().frames_in_flight().min(images.sets.len());
            let size = window.size();
            let opt = live.config.opt_string();
            let info = HudInfo {
                opt: &opt,
                budget_ms,
                keys: super::hud::KEYS,
            };
            let ui = hud.frame([size.width, size.height], &info);
            let input = window.input();
            if close {
                // The window is still there: present the last frame's eye
                // images once more, read back, so the screenshot is what
                // the window showed last.
                if let (Some(path), Some(slot)) = (&args.screenshot, last_slot) {
                    let sources = eye_sources(args, images, slot);
                    let size = window.size();
                    let shown = presenter.present_with(ctx, &sources, size, true, ui.as_ref())?;
                    if let Presented::Shown(Some(img)) = shown {
                        save_png(&img, path)?;
                    }
                }
                return Ok(());
            }
            if input.resized {
                presenter.resized();
            }
            let now = Instant::now();
            camera.update(input, (now - last).as_secs_f64());
            last = now;
            let rig = profile.rig(camera.pose());
            let slot = (index % slots as u64) as usize;
            driver.set_time((now - started).as_secs_f64());
            driver.record(&rig, index)?;
            driver.submit(Some(&images.output(slot)), false)?;
            index += 1;
            while let Some(r) = driver.take_completed() {
                hud.push(&r);
            }
            let final_frame = args.frames.is_some_and(|n| presented + 1 >= n);
            let want_shot = final_frame && args.screenshot.is_some();
            let target = (&mut *presenter, window.size());
            if present_eyes(ctx, args, target, (images, slot), want_shot, ui.as_ref())? {
                presented += 1;
                last_slot = Some(slot);
            }
            if index > 100 + 10 * args.frames.unwrap_or(u64::MAX / 20) {
                return Err(Error::Window(
                    "the window keeps rejecting its swapchain images".into(),
                ));
            }
        }
    })();
    let finished = driver.finish();
    drop(driver);
    run.and(finished).map(|()| presented)
}

/// Presents the shown eyes of frame slot `slot` with the HUD's frame `ui`
/// in a window of `size`; with `want_shot` the read-back goes to
/// `--screenshot`. Returns whether the frame was shown.
fn present_eyes(
    ctx: &Arc<Context>,
    args: &ViewArgs,
    (presenter, size): (&mut Presenter, vk::Extent2D),
    (images, slot): (&EyeImages, usize),
    want_shot: bool,
    ui: Option<&crate::gpu::ui_layer::UiFrame>,
) -> Result<bool> {
    let sources = eye_sources(args, images, slot);
    let shown = presenter.present_with(ctx, &sources, size, want_shot, ui);
    if let Some(f) = ui {
        presenter.retire_ui(ctx, f)?;
    }
    match shown? {
        Presented::Shown(shot) => {
            if let (Some(img), Some(path)) = (shot, &args.screenshot) {
                save_png(&img, path)?;
            }
            Ok(true)
        }
        Presented::Skipped | Presented::Busy => Ok(false),
    }
}

/// The window's source images: the shown eyes of frame slot `slot`.
fn eye_sources(args: &ViewArgs, images: &EyeImages, slot: usize) -> Vec<Source> {
    args.eyes
        .indices()
        .iter()
        .map(|&e| images.source(slot, e))
        .collect()
}

/// What the view's keys and live switches work with.
struct ViewState<'a> {
    ctx: &'a Arc<Context>,
    scene: &'a crate::scene::Scene,
    profile: &'a crate::view::profile::HmdProfile,
    extent: vk::Extent2D,
}

impl ViewState<'_> {
    /// The HUD's keys, F8 (keep the pose; `kept` counts them) and the
    /// error measure of the shown frame (`camera` at scene time).
    fn keys(
        &self,
        pressed: &[winit::keyboard::KeyCode],
        hud: &mut Hud,
        kept: &mut u32,
        (camera, time): (&FlyCamera, f64),
        config: &RenderConfig,
    ) {
        if pressed.contains(&super::hud::KEY) {
            hud.visible = !hud.visible;
        }
        if pressed.contains(&super::hud::HEATMAP_KEY) {
            hud.show_heatmap = !hud.show_heatmap;
        }
        if pressed.contains(&super::keep_pose::KEY) {
            *kept += 1;
            let file = Path::new(super::keep_pose::DEFAULT_FILE);
            match super::keep_pose::keep(&camera.pose(), &format!("view {kept}"), file) {
                Ok(line) => println!("{line}"),
                // The session goes on without it.
                Err(e) => eprintln!("vergence: pose not kept: {e}"),
            }
        }
        if !pressed.contains(&super::hud::MEASURE_KEY) {
            return;
        }
        // The frame the window shows, rendered again with the current
        // configuration and with the reference.
        let rig = self.profile.rig(camera.pose());
        match super::error_probe::measure(self.ctx, self.scene, config, (&rig, time), self.extent) {
            Ok(report) => {
                println!(
                    "image error: FLIP mean {:.4} against two-pass 4x for {}",
                    report.flip_mean, report.opt
                );
                hud.set_error(report);
                hud.visible = true;
            }
            // The session goes on without the measurement.
            Err(e) => eprintln!("vergence: image error not measured: {e}"),
        }
    }

    /// A live switch to `new`: the frames in flight finish and the
    /// presenter's blits are done (they read the eye images) before the
    /// renderer, and the eye images when the stereo mode changed, are made
    /// again. A configuration that cannot be made is reverted.
    fn switch(
        &self,
        driver: &mut FrameDriver,
        new: RenderConfig,
        live: &mut LiveConfig,
        images: &mut Option<EyeImages>,
    ) -> Result<()> {
        let old = driver.renderer().config.clone();
        driver.finish()?;
        while driver.take_completed().is_some() {}
        // SAFETY: waiting for the device on this thread.
        unsafe { self.ctx.device.device_wait_idle() }.vk("waiting before a live switch")?;
        let remake = |c: &RenderConfig, images: &mut Option<EyeImages>| {
            let multiview = c.frame.stereo == StereoMode::Multiview;
            if images.as_ref().is_some_and(|i| i.multiview != multiview) {
                if let Some(i) = images.take() {
                    i.destroy(self.ctx);
                }
            }
            make_driver(self.ctx, self.scene, c, self.extent, images)
        };
        *driver = match remake(&new, images) {
            Ok(d) => d,
            Err(e) => {
                live.revert(old.clone(), &e);
                remake(&old, images)?
            }
        };
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_initial_window_fits_the_screen_with_the_content_aspect() {
        let small = vk::Extent2D {
            width: 640,
            height: 360,
        };
        assert_eq!(initial_window_size(small), small);
        // Valve Index: 2016x2240 per eye, side by side.
        let index_pair = vk::Extent2D {
            width: 4032,
            height: 2240,
        };
        let w = initial_window_size(index_pair);
        assert_eq!((w.width, w.height), (1600, 889));
    }
}
