//! Frame sequences along a head path, for the tests of techniques that
//! carry state from frame to frame (the inset's accumulation and
//! upsampling): the rigs of a steady turn, the frames with no validation
//! message, and a per-pixel difference over a region.

use std::sync::Arc;
use vergence::config::RenderConfig;
use vergence::gpu::Context;
use vergence::scene::Scene;
use vergence::targets::headless::render_sequence;
use vergence::view::profile::HmdProfile;
use vergence::view::{Pose, StereoRig};

/// `n` rigs from `pose`, turning right by `step_deg` a frame.
pub fn turning(profile: &HmdProfile, pose: Pose, step_deg: f64, n: usize) -> Vec<StereoRig> {
    (0..n)
        .map(|j| {
            let turn = Pose::from_euler_deg(glam::DVec3::ZERO, -step_deg * j as f64, 0.0, 0.0);
            profile.rig(pose.compose(&turn))
        })
        .collect()
}

/// The frames of `config` along `rigs` at `size` (`supersample` × it),
/// failing on any validation message.
pub fn frames(
    ctx: &Arc<Context>,
    scene: &Scene,
    config: &RenderConfig,
    rigs: &[StereoRig],
    size: (u32, u32),
    supersample: u32,
) -> Vec<[image::RgbaImage; 2]> {
    let before = ctx.validation_messages();
    let extent = ash::vk::Extent2D {
        width: size.0,
        height: size.1,
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
