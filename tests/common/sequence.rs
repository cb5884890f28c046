//! Frame sequences along a head path, for the tests of techniques that
//! carry state from frame to frame (the inset's accumulation and
//! upsampling): their size, configuration and inset rectangle, the rigs
//! of a steady turn, the frames with no validation message, and a
//! per-pixel difference over a region.

use std::sync::Arc;
use vergence::config::{Inset, RenderConfig, StereoMode};
use vergence::gpu::Context;
use vergence::scene::Scene;
use vergence::targets::headless::render_sequence;
use vergence::view::inset::PixelRect;
use vergence::view::profile::HmdProfile;
use vergence::view::{Pose, StereoRig};

/// The sequences' eye size.
pub const W: u32 = 192;
/// The sequences' eye height.
pub const H: u32 = 160;

/// `stereo` at 4× MSAA with `inset`.
pub fn config(stereo: StereoMode, inset: Option<Inset>) -> RenderConfig {
    RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo,
            msaa: 4,
            ..Default::default()
        },
        effort: vergence::config::EffortConfig {
            inset,
            ..Default::default()
        },
        ..RenderConfig::default()
    }
}

/// The rectangle of [`super::INSET_SETTINGS`]' inset at the centre, at
/// the sequences' size.
pub fn rect(profile: &HmdProfile) -> PixelRect {
    let fovs: Vec<_> = profile.views.iter().map(|v| v.fov).collect();
    let half_angle = super::INSET_SETTINGS.half_angle_deg;
    vergence::view::inset::inset_rect(&fovs, [0.0, 0.0], half_angle, W, H)
}

/// `n` rigs from `pose`, turning right by `step_deg` a frame.
pub fn turning(profile: &HmdProfile, pose: Pose, step_deg: f64, n: usize) -> Vec<StereoRig> {
    (0..n)
        .map(|j| {
            let turn = Pose::from_euler_deg(glam::DVec3::ZERO, -step_deg * j as f64, 0.0, 0.0);
            profile.rig(pose.compose(&turn))
        })
        .collect()
}

/// The frames of `config` along `rigs` at the sequences' size
/// (`supersample` × it), failing on any validation message.
pub fn frames(
    ctx: &Arc<Context>,
    scene: &Scene,
    config: &RenderConfig,
    rigs: &[StereoRig],
    supersample: u32,
) -> Vec<[image::RgbaImage; 2]> {
    let before = ctx.validation_messages();
    let extent = ash::vk::Extent2D {
        width: W,
        height: H,
    };
    let out = render_sequence(ctx, scene, config, rigs, (extent, supersample), 0.0)
        .unwrap_or_else(|e| panic!("{}: {e}", config.opt_string()));
    super::assert_no_validation_since(ctx, before);
    out
}

/// Mean absolute difference per channel (0..255) of `a` and `b` over the
/// pixels `keep` selects, and how many differ at all.
pub fn diff(
    a: &image::RgbaImage,
    b: &image::RgbaImage,
    keep: impl Fn(u32, u32) -> bool,
) -> (f64, usize) {
    let (mut sum, mut n, mut differ) = (0.0, 0usize, 0usize);
    for (x, y, p) in a.enumerate_pixels() {
        if !keep(x, y) {
            continue;
        }
        let q = b.get_pixel(x, y);
        let d: f64 = (0..3)
            .map(|c| (p[c] as f64 - q[c] as f64).abs())
            .sum::<f64>()
            / 3.0;
        sum += d;
        n += 1;
        differ += usize::from(d > 0.0);
    }
    (sum / n.max(1) as f64, differ)
}

/// The step, degrees a frame, that turns the view a third of a pixel a
/// frame at `width` pixels across the profile's first view (the bench's
/// flicker sequence).
pub fn third_of_a_pixel(profile: &HmdProfile, width: u32) -> f64 {
    let fov = profile.views[0].fov;
    let ppd = width as f64 / (fov.right.atan() - fov.left.atan()).to_degrees();
    1.0 / (3.0 * ppd)
}
