//! Shared helpers for integration tests: render a scene through the library
//! with validation on and fail on any validation message.

#![allow(dead_code)]

pub mod sequence;
pub mod xvfb;

use std::path::PathBuf;
use std::sync::Arc;
use vergence::config::{RenderConfig, StereoMode};
use vergence::gpu::{Context, Validation};
use vergence::render::{FrameStats, Renderer};
use vergence::scene::Scene;
use vergence::view::profile::HmdProfile;
use vergence::view::{frame_bounds, Pose};

/// Repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A fresh, empty scratch folder `vergence-TEST-PID-NAME` in the temp dir.
pub fn scratch(test: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vergence-{test}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    dir
}

/// Runs `cmd` (vergence) and returns its stderr, asserting the failure a
/// user should see: a non-zero exit that is not a panic, and exactly one
/// `error:` line.
pub fn fails_with_one_error(cmd: &mut std::process::Command) -> String {
    let out = cmd.output().expect("vergence runs");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        !out.status.success(),
        "expected failure for {cmd:?}: {stderr}"
    );
    assert_ne!(
        out.status.code(),
        Some(101),
        "panicked for {cmd:?}: {stderr}"
    );
    assert!(
        !stderr.contains("panicked"),
        "panicked for {cmd:?}: {stderr}"
    );
    let errors = stderr.lines().filter(|l| l.starts_with("error:")).count();
    assert_eq!(errors, 1, "one error line expected: {stderr}");
    stderr
}

/// Whether `program` is an executable file on PATH.
pub fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(program).is_file()))
}

/// Runs `vergence render ARGS --out OUT` (the binary of this build),
/// asserts it succeeded and returns the `stats.json` it wrote.
pub fn render_cli(args: &[&str], out: &std::path::Path) -> serde_json::Value {
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
        .arg("render")
        .args(args)
        .arg("--out")
        .arg(out)
        .status()
        .expect("vergence runs");
    assert!(status.success(), "vergence render {args:?} failed");
    let text = std::fs::read_to_string(out.join("stats.json")).expect("stats.json written");
    serde_json::from_str(&text).expect("stats.json is JSON")
}

/// Validation must be on in tests; `VERGENCE_VALIDATION=required` (set by
/// `cargo xtask test`) makes a missing layer an error.
pub fn context() -> Arc<Context> {
    let v = match Validation::from_env() {
        Validation::Off => Validation::IfAvailable,
        other => other,
    };
    Arc::new(Context::new_headless(v).expect("a Vulkan device (lavapipe) is available"))
}

/// One rendered stereo frame.
pub struct Frame {
    /// Left and right images.
    pub images: [image::RgbaImage; 2],
    /// Frame statistics.
    pub stats: FrameStats,
}

/// Loads a scene by `--scene` spec, relative paths from the repo root.
pub fn load(spec: &str) -> Scene {
    let path = root().join(spec);
    let spec = if path.exists() {
        path.to_string_lossy().into_owned()
    } else {
        spec.to_string()
    };
    Scene::load(&spec).unwrap_or_else(|e| panic!("{e}"))
}

/// A pose framing the whole scene from the front, slightly above.
pub fn framing_pose(scene: &Scene, profile: &HmdProfile) -> Pose {
    let (lo, hi) = scene.bounds();
    frame_bounds(lo, hi, &profile.views[0].fov, -10.0)
}

/// Renders `scene` from `pose` and checks the frame is validation-clean.
pub fn render(
    ctx: &Arc<Context>,
    scene: &Scene,
    profile: &HmdProfile,
    pose: Pose,
    stereo: StereoMode,
    msaa: u32,
    size: u32,
) -> Frame {
    let config = RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo,
            msaa,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    render_config(ctx, scene, profile, pose, &config, size, size)
}

/// Renders `scene` from `pose` with `config` at `width`×`height` per eye and
/// checks the frame is validation-clean.
pub fn render_config(
    ctx: &Arc<Context>,
    scene: &Scene,
    profile: &HmdProfile,
    pose: Pose,
    config: &RenderConfig,
    width: u32,
    height: u32,
) -> Frame {
    let before = ctx.validation_messages();
    let extent = ash::vk::Extent2D { width, height };
    let mut r = Renderer::new(ctx.clone(), scene, config, extent).unwrap_or_else(|e| panic!("{e}"));
    let stats = r
        .render(&profile.rig(pose), None, true)
        .unwrap_or_else(|e| panic!("{e}"));
    let images = r.read_images().unwrap();
    drop(r);
    assert_no_validation_since(ctx, before);
    Frame { images, stats }
}

/// Fails, listing them, when validation messages came after `before` (a
/// count from [`Context::validation_messages`]).
pub fn assert_no_validation_since(ctx: &Context, before: usize) {
    assert_eq!(
        ctx.validation_messages(),
        before,
        "Vulkan validation messages: {:#?}",
        ctx.validation_log()
    );
}

/// Drives `config` over `rigs` at `size`×`size` per eye, one frame each
/// (frame `i` numbered `i`), waiting for and reading back every frame;
/// asserts no validation message. Returns the frames' results and images.
pub fn frame_by_frame(
    ctx: &Arc<Context>,
    scene: &Scene,
    config: &RenderConfig,
    rigs: &[vergence::view::StereoRig],
    size: u32,
) -> (
    Vec<vergence::render::driver::FrameResult>,
    Vec<[image::RgbaImage; 2]>,
) {
    let before = ctx.validation_messages();
    let extent = ash::vk::Extent2D {
        width: size,
        height: size,
    };
    let renderer = Renderer::new(ctx.clone(), scene, config, extent)
        .unwrap_or_else(|e| panic!("{}: {e}", config.opt_string()));
    let mut driver = vergence::render::driver::FrameDriver::new(renderer, scene).unwrap();
    let mut results = Vec::new();
    let mut images = Vec::new();
    for (i, rig) in rigs.iter().enumerate() {
        driver
            .frame(rig, i as u64, true)
            .unwrap_or_else(|e| panic!("{e}"));
        driver.finish().unwrap();
        results.extend(std::iter::from_fn(|| driver.take_completed()));
        images.push(driver.read_images().unwrap());
    }
    drop(driver);
    assert_eq!(
        ctx.validation_messages(),
        before,
        "{}: Vulkan validation messages: {:#?}",
        config.opt_string(),
        ctx.validation_log()
    );
    (results, images)
}

/// How many pixels of `a` and `b` (same size) differ.
pub fn pixels_differing(a: &image::RgbaImage, b: &image::RgbaImage) -> usize {
    a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
}

/// An 8-bit sRGB value as linear light (IEC 61966-2-1's decoding).
pub fn srgb_to_linear(c: u8) -> f64 {
    let c = c as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light as an sRGB code value on 0–255, unrounded (IEC 61966-2-1's
/// encoding).
pub fn linear_to_srgb(l: f64) -> f64 {
    let c = if l <= 0.0031308 {
        l * 12.92
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    };
    c * 255.0
}

/// The inset the inset tests draw: the wide view at half size, ±15°, two
/// scopes at the frame's MSAA, no accumulation.
pub const INSET_SETTINGS: vergence::config::Inset = vergence::config::Inset {
    wide_scale: 0.5,
    half_angle_deg: 15.0,
    fov_given: true,
    four_views: false,
    wide_1x: false,
    composite: false,
    wide_all: false,
    taa: None,
    taa_jitter: false,
    taau: false,
    catmull_rom: false,
    sharpen: None,
    taau_lanczos: false,
};
