//! Stereo geometry seen in pixels: the eyes' images differ exactly as the
//! eye offset predicts, and fragment statistics are reported.

mod common;

use common::{context, load, render};
use glam::DVec3;
use vergence::config::StereoMode;
use vergence::view::profile::HmdProfile;
use vergence::view::Pose;

use common::srgb_to_linear;

/// Sub-pixel horizontal centroid of the red box along one row above the
/// horizon: each pixel's coverage is recovered from its linear red-minus-green
/// value between the sky's (row start) and the box's (row centre), which MSAA
/// resolve blends linearly.
fn red_centroid(img: &image::RgbaImage, row: u32) -> f64 {
    let v = |x: u32| {
        let p = img.get_pixel(x, row);
        srgb_to_linear(p[0]) - srgb_to_linear(p[1])
    };
    let (bg, fg) = (v(1), v(img.width() / 2));
    assert!(fg - bg > 0.3, "the red box covers the row centre");
    let (mut sum, mut n) = (0.0, 0.0);
    for x in 0..img.width() {
        let c = ((v(x) - bg) / (fg - bg)).clamp(0.0, 1.0);
        sum += c * (x as f64 + 0.5);
        n += c;
    }
    sum / n
}

#[test]
fn disparity_matches_eye_offset() {
    let ctx = context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let scene = load("assets/Box/Box.gltf");
    let size = 256;
    let z = 3.0;
    let frame = render(
        &ctx,
        &scene,
        &profile,
        Pose {
            position: DVec3::new(0.0, 0.0, z),
            ..Pose::default()
        },
        StereoMode::Multiview,
        4,
        size,
    );
    // A point at depth d seen from an eye offset by x projects to
    // (-x / d - tan l) / (tan r - tan l) * W. The box's front face is at
    // z = 0.5, depth 2.5; its centroid shifts by IPD / d * W / (tan r - tan l).
    let [l, r, _, _] = profile.views[0].fov.tangents();
    let ipd = profile.ipd();
    let expected = ipd / (z - 0.5) * size as f64 / (r - l);
    let row = size / 2 - size / 16;
    let shift = red_centroid(&frame.images[0], row) - red_centroid(&frame.images[1], row);
    assert!(
        (shift - expected).abs() < 0.35,
        "disparity {shift:.3} px, expected {expected:.3} px"
    );
    assert!(shift > 0.0, "the left eye sees the box further right");
}

#[test]
fn zero_ipd_gives_identical_eyes() {
    let ctx = context();
    let text = include_str!("../manifests/hmd/monado-sim.toml")
        .replace("-0.0315", "0.0")
        .replace("0.0315", "0.0");
    let profile = HmdProfile::parse("ipd0", &text).unwrap();
    let scene = load("assets/Box/Box.gltf");
    let frame = render(
        &ctx,
        &scene,
        &profile,
        Pose {
            position: DVec3::new(0.2, 0.1, 3.0),
            ..Pose::default()
        },
        StereoMode::Multiview,
        4,
        96,
    );
    let diff: Vec<u8> = frame.images[0]
        .as_raw()
        .iter()
        .zip(frame.images[1].as_raw())
        .map(|(a, b)| a.abs_diff(*b))
        .collect();
    let max = diff.iter().copied().max().unwrap_or(0);
    let differing = diff.iter().filter(|&&d| d > 0).count();
    // Identical geometry in both views; only rounding in the per-view
    // matrices (computed separately for each view) may differ.
    assert!(
        max <= 1,
        "eyes differ by up to {max} ({differing} channels)"
    );
}

#[test]
fn fragment_invocations_scale_with_msaa_off_and_pixels() {
    let ctx = context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let scene = load("assets/Box/Box.gltf");
    let pose = Pose {
        position: DVec3::new(0.0, 0.0, 3.0),
        ..Pose::default()
    };
    let a = render(&ctx, &scene, &profile, pose, StereoMode::TwoPass, 1, 64);
    let b = render(&ctx, &scene, &profile, pose, StereoMode::TwoPass, 1, 128);
    let (fa, fb) = (
        a.stats.pipeline.unwrap().fragment_invocations,
        b.stats.pipeline.unwrap().fragment_invocations,
    );
    // Every pixel is shaded at least once (sky or box) in both eyes.
    assert!(fa >= 2 * 64 * 64, "{fa}");
    let ratio = fb as f64 / fa as f64;
    assert!(
        (ratio - 4.0).abs() < 0.3,
        "4x the pixels -> about 4x the fragments, got {ratio}"
    );
}

/// The forward scopes start their colour as don't-care when the sky fills
/// what geometry leaves (no stencil, no far field, no LMS): a frame looking
/// at the sky after one looking at machines must equal that sky frame
/// rendered alone, so no pixel shows the earlier frame, and no pixel of
/// either is black (what lavapipe shows for a don't-care sample nobody
/// wrote). With the sky left out (a mutation) every configuration fails.
#[test]
fn frames_that_do_not_clear_colour_still_write_every_pixel() {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    let scene = load("factory:2000");
    let (lo, hi) = scene.bounds();
    let centre = (lo + hi) * 0.5;
    let machines = Pose::from_euler_deg(centre + DVec3::new(0.0, 1.6, 0.0), 30.0, -10.0, 0.0);
    let sky = Pose::from_euler_deg(centre + DVec3::new(0.0, 1.6, 0.0), 30.0, 60.0, 0.0);
    let rigs = [profile.rig(machines), profile.rig(sky)];
    for opt in [
        "multiview,superfrustum",
        "multiview,superfrustum,no-msaa",
        "two-pass,per-eye",
        "multiview,superfrustum,inset",
        "multiview,superfrustum,gpu-cull,occlusion",
        "multiview,superfrustum,stencil-mask",
        "multiview,superfrustum,gpu-cull,occlusion,stencil-mask",
        "multiview,superfrustum,stencil-mask,mffr",
    ] {
        let mut config = vergence::config::RenderConfig::default();
        config
            .apply_opts(opt, &vergence::config::cull_names())
            .unwrap();
        let (_, frames) = common::frame_by_frame(&ctx, &scene, &config, &rigs, 96);
        let (_, alone) = common::frame_by_frame(&ctx, &scene, &config, &rigs[1..], 96);
        let busy = common::pixels_differing(&frames[0][0], &alone[0][0]);
        assert!(
            busy > 96 * 96 / 10,
            "{opt}: the two views differ ({busy} px)"
        );
        for eye in 0..2 {
            let diff = common::pixels_differing(&frames[1][eye], &alone[0][eye]);
            assert_eq!(
                diff, 0,
                "{opt}: eye {eye}: {diff} pixels kept the last frame"
            );
            // No sample was left to the attachment's start: neither the sky
            // nor the factory's materials are black, and lavapipe shows a
            // don't-care sample nobody wrote as black. With the stencil
            // mask (marked in depth, its colour written by the mask) the
            // black pixels are the hidden area's, the same in every frame.
            let hidden =
                |img: &image::RgbaImage| img.pixels().filter(|p| p.0[..3] == [0, 0, 0]).count();
            let expected = if opt.contains("stencil-mask") {
                let n = hidden(&alone[0][eye]);
                assert!(n > 96 * 96 / 20, "{opt}: eye {eye}: {n} hidden pixels");
                n
            } else {
                0
            };
            for (i, frame) in [&frames[0][eye], &frames[1][eye], &alone[0][eye]]
                .into_iter()
                .enumerate()
            {
                let black = hidden(frame);
                assert_eq!(
                    black, expected,
                    "{opt}: eye {eye}, image {i}: {black} black pixels"
                );
                // lavapipe's unwritten samples are transparent too; every
                // draw here (sky, opaque materials, the mask) writes alpha 1.
                let clear = frame.pixels().filter(|p| p.0[3] != 255).count();
                assert_eq!(
                    clear, 0,
                    "{opt}: eye {eye}, image {i}: {clear} pixels not opaque"
                );
            }
        }
    }
}
