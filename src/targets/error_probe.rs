//! The desk overlay's image error on demand (F4 in `view`): the frame the
//! window shows, rendered again with the current configuration and with
//! the full-quality reference the bench uses (`two-pass`, 4× MSAA, no
//! culling or effort reduction), compared as the bench compares them
//! (`bench::runner::stereo_error`: FLIP mean over the visible pixels of
//! both eyes, the left eye's heat map).

use crate::config::RenderConfig;
use crate::error::Result;
use crate::gpu::Context;
use crate::scene::Scene;
use crate::view::StereoRig;
use ash::vk;
use std::sync::Arc;

/// What one measurement found.
#[derive(Clone, Debug)]
pub struct ErrorReport {
    /// FLIP mean of both eyes against the reference.
    pub flip_mean: f64,
    /// The foveated FLIP mean of both eyes (looking at the image centre;
    /// `bench::foveated`).
    pub flip_foveated_mean: f64,
    /// The left eye's FLIP heat map.
    pub heatmap: image::RgbaImage,
    /// The `--opt` list measured.
    pub opt: String,
}

/// The reference configuration: the bench's default (`two-pass` at 4×,
/// nothing else on), with `config`'s near plane and section plane.
pub fn reference_of(config: &RenderConfig) -> RenderConfig {
    let mut r = RenderConfig {
        frame: crate::config::FrameConfig {
            near: config.frame.near,
            section: config.frame.section,
            ..Default::default()
        },
        submission: crate::config::SubmissionConfig {
            frames_in_flight: 1,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    r.apply_opts("two-pass,msaa4", &crate::config::cull_names())
        .expect("the reference's options parse");
    r
}

/// One frame of `rig` at scene time `time` with `config`, read back.
fn render(
    ctx: &Arc<Context>,
    scene: &Scene,
    config: &RenderConfig,
    (rig, time): (&StereoRig, f64),
    extent: vk::Extent2D,
) -> Result<[image::RgbaImage; 2]> {
    let frames = super::headless::render_sequence(
        ctx,
        scene,
        config,
        std::slice::from_ref(rig),
        (extent, 1),
        time,
    )?;
    frames
        .into_iter()
        .next()
        .ok_or_else(|| crate::error::Error::Gpu("no frame rendered".into()))
}

/// Measures `config`'s error for `rig` at scene time `time` (where moving
/// instances stand), at `extent` per eye.
pub fn measure(
    ctx: &Arc<Context>,
    scene: &Scene,
    config: &RenderConfig,
    (rig, time): (&StereoRig, f64),
    extent: vk::Extent2D,
) -> Result<ErrorReport> {
    let reference = render(ctx, scene, &reference_of(config), (rig, time), extent)?;
    let test = render(ctx, scene, config, (rig, time), extent)?;
    let e = crate::bench::runner::stereo_error(&reference, &test, rig)?;
    Ok(ErrorReport {
        flip_mean: e.flip_mean,
        flip_foveated_mean: e.flip_foveated_mean,
        heatmap: e.heatmap,
        opt: config.opt_string(),
    })
}
