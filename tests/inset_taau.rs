//! Temporal upsampling of the inset's wide views (`--opt inset-taau`) on
//! lavapipe: at a still pose the accumulated periphery comes nearer the
//! full-size render than the plain inset's upsampled one (the jittered
//! samples land where they lie at the eye's resolution); along the
//! bench's slow turn it shimmers less than the plain inset against a 2×
//! supersampled reference; after a faster turn the history still lies
//! where the scene is; the inset itself is the plain inset's, and two-pass
//! and multiview run over frames in flight with no validation message.

mod common;

use common::sequence::{config, diff, frames, rect, third_of_a_pixel, turning, W};
use common::{context, framing_pose, load};
use vergence::config::{Inset, StereoMode};
use vergence::view::inset::{weight, PixelRect, FEATHER_PX};
use vergence::view::profile::HmdProfile;

/// One-sample wide views at half size: the samples the upsampling takes
/// are point samples.
const PLAIN: Inset = Inset {
    wide_1x: true,
    ..common::INSET_SETTINGS
};

const TAAU: Inset = Inset {
    taa: Some(0.1),
    taa_jitter: true,
    taau: true,
    ..PLAIN
};

/// `inset-sharpen` at its default strength.
const SHARPENED: Inset = Inset {
    sharpen: Some(vergence::view::sharpen::DEFAULT_STRENGTH),
    ..TAAU
};

/// `inset-taau-lanczos`: the history read through Lanczos-3.
const LANCZOS: Inset = Inset {
    taau_lanczos: true,
    ..TAAU
};

/// The context, factory:2000 framed for the valve-index profile, and the
/// inset's rectangle.
fn fixture() -> (
    std::sync::Arc<vergence::gpu::Context>,
    vergence::scene::Scene,
    HmdProfile,
    vergence::view::Pose,
    PixelRect,
) {
    let ctx = context();
    let scene = load("factory:2000");
    let profile = HmdProfile::load("valve-index").unwrap();
    let pose = framing_pose(&scene, &profile);
    let r = rect(&profile);
    (ctx, scene, profile, pose, r)
}

#[test]
fn at_a_still_pose_the_upsampled_periphery_nears_the_full_render() {
    let (ctx, scene, profile, pose, r) = fixture();
    let periphery = |x, y| weight(&r, x, y, FEATHER_PX) == 0.0;
    let core = |x, y| weight(&r, x, y, FEATHER_PX) >= 1.0;
    // Three jitter periods at one pose.
    let rigs = vec![profile.rig(pose); 24];
    let full = frames(
        &ctx,
        &scene,
        &config(StereoMode::Multiview, None),
        &rigs[..1],
        1,
    );
    let plain = frames(
        &ctx,
        &scene,
        &config(StereoMode::Multiview, Some(PLAIN)),
        &rigs[..1],
        1,
    );
    let up = frames(
        &ctx,
        &scene,
        &config(StereoMode::Multiview, Some(TAAU)),
        &rigs,
        1,
    );
    for eye in 0..2 {
        let (plain_err, _) = diff(&plain[0][eye], &full[0][eye], periphery);
        let (up_err, _) = diff(&up[23][eye], &full[0][eye], periphery);
        println!("eye {eye}: periphery against the full render: plain {plain_err:.3}, inset-taau {up_err:.3} levels");
        assert!(
            up_err < 0.8 * plain_err,
            "eye {eye}: inset-taau {up_err:.3} levels from the full render, the plain inset {plain_err:.3}"
        );
        // The inset is the plain inset's own.
        let (_, core_differ) = diff(&up[23][eye], &plain[0][eye], core);
        assert_eq!(core_differ, 0, "eye {eye}: the inset changed");
    }
}

#[test]
fn upsampling_cuts_the_shimmer_of_a_slow_turn() {
    let (ctx, scene, profile, pose, _) = fixture();
    // A third of a pixel a frame at this size (the bench's sequence);
    // the first 16 frames warm the history, the last 8 are measured.
    let rigs = turning(&profile, pose, third_of_a_pixel(&profile, W), 24);
    let measured = |f: Vec<[image::RgbaImage; 2]>| f[16..].to_vec();
    let reference = measured(frames(
        &ctx,
        &scene,
        &config(StereoMode::Multiview, None),
        &rigs,
        2,
    ));
    let masks = [vec![], vec![]];
    let score = |inset: Inset| -> f64 {
        let test = measured(frames(
            &ctx,
            &scene,
            &config(StereoMode::Multiview, Some(inset)),
            &rigs,
            1,
        ));
        (0..2)
            .map(|eye| {
                let t: Vec<_> = test.iter().map(|p| p[eye].clone()).collect();
                let r: Vec<_> = reference.iter().map(|p| p[eye].clone()).collect();
                vergence::bench::flicker::flicker(&t, &r, &masks[eye]).unwrap()
            })
            .sum::<f64>()
            / 2.0
    };
    let plain = score(PLAIN);
    let taa = score(Inset {
        taa: Some(0.1),
        ..PLAIN
    });
    let up = score(TAAU);
    let sharp = score(SHARPENED);
    let lanczos = score(LANCZOS);
    // Measured here: plain 0.00180, inset-taa 0.00041, inset-taau 0.00062
    // (the jitter's own frame-to-frame change: each frame's samples land
    // elsewhere in the pixel), inset-sharpen 0.00080, inset-taau-lanczos
    // 0.00065: on this small, detailed frame the sharpening and the
    // sharper history read also keep more of what the wide views alias,
    // the opposite of the garage at the bench's size (docs/techniques/inset.md,
    // "Sharpening the upsampled periphery", "The history read through
    // Lanczos-3").
    println!(
        "one-sample wide views: flicker plain {plain:.6}, inset-taa {taa:.6}, inset-taau {up:.6}, inset-sharpen {sharp:.6}, inset-taau-lanczos {lanczos:.6}"
    );
    assert!(
        up < 0.8 * plain,
        "inset-taau flickers {up:.6}, the plain inset {plain:.6}"
    );
    assert!(
        sharp < 0.8 * plain,
        "inset-sharpen flickers {sharp:.6}, the plain inset {plain:.6}"
    );
    assert!(
        lanczos < 0.8 * plain,
        "inset-taau-lanczos flickers {lanczos:.6}, the plain inset {plain:.6}"
    );
}

#[test]
fn the_upsampled_history_follows_a_turning_head() {
    let (ctx, scene, profile, pose, r) = fixture();
    let periphery = |x, y| weight(&r, x, y, FEATHER_PX) == 0.0;
    // A degree a frame, two-pass: reprojected, the history stays on the
    // scene, and the last frame's periphery is nearer the full render at
    // that pose than the plain inset's (measured here: 1.15 levels against
    // 1.60; read where the pixel is now, it would trail the scene by
    // degrees). Read through Lanczos-3 instead of Catmull-Rom, the history
    // softens less with each frame's fractional move and comes nearer
    // still (1.11 against 1.15 levels, eye 0; 1.07 against 1.11, eye 1).
    let turn = turning(&profile, pose, 1.0, 12);
    let plain = frames(
        &ctx,
        &scene,
        &config(StereoMode::TwoPass, Some(PLAIN)),
        &turn,
        1,
    );
    let up = frames(
        &ctx,
        &scene,
        &config(StereoMode::TwoPass, Some(TAAU)),
        &turn,
        1,
    );
    let lanczos = frames(
        &ctx,
        &scene,
        &config(StereoMode::TwoPass, Some(LANCZOS)),
        &turn,
        1,
    );
    let full = frames(
        &ctx,
        &scene,
        &config(StereoMode::TwoPass, None),
        &turn[11..],
        1,
    );
    for eye in 0..2 {
        let (plain_err, _) = diff(&plain[11][eye], &full[0][eye], periphery);
        let (up_err, _) = diff(&up[11][eye], &full[0][eye], periphery);
        let (lanczos_err, _) = diff(&lanczos[11][eye], &full[0][eye], periphery);
        println!("eye {eye}: turning, periphery against the full render: plain {plain_err:.3}, inset-taau {up_err:.3}, inset-taau-lanczos {lanczos_err:.3} levels");
        assert!(
            up_err < plain_err,
            "eye {eye}: inset-taau {up_err:.3} levels from the full render, the plain inset {plain_err:.3}"
        );
        assert!(
            lanczos_err < up_err,
            "eye {eye}: inset-taau-lanczos {lanczos_err:.3} levels from the full render, inset-taau {up_err:.3}"
        );
    }
}

/// `inset-sharpen` is the composite's sharpening of the same history: the
/// eye images equal `view::sharpen` applied to the unsharpened images'
/// periphery (in linear light), within the 8-bit rounding of the images
/// it starts from; the inset is untouched.
#[test]
fn the_composite_sharpens_as_the_model_does() {
    let (ctx, scene, profile, pose, r) = fixture();
    let rigs = turning(&profile, pose, third_of_a_pixel(&profile, W), 12);
    let up = frames(
        &ctx,
        &scene,
        &config(StereoMode::Multiview, Some(TAAU)),
        &rigs,
        1,
    );
    let sharp = frames(
        &ctx,
        &scene,
        &config(StereoMode::Multiview, Some(SHARPENED)),
        &rigs,
        1,
    );
    // Pixels whose cross lies wholly in the wide view alone.
    let wide_alone = |x: u32, y: u32| {
        [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)]
            .iter()
            .all(|&(dx, dy)| {
                let (px, py) = (x as i64 + dx, y as i64 + dy);
                px >= 0
                    && py >= 0
                    && px < W as i64
                    && py < common::sequence::H as i64
                    && weight(&r, px as u32, py as u32, FEATHER_PX) == 0.0
            })
    };
    let core = |x, y| weight(&r, x, y, FEATHER_PX) >= 1.0;
    let (mut worst, mut sum, mut n, mut changed) = (0.0f64, 0.0f64, 0usize, 0usize);
    for eye in 0..2 {
        let (a, b) = (&up[11][eye], &sharp[11][eye]);
        let (w, h) = a.dimensions();
        for c in 0..3 {
            let plane: Vec<f64> = a.pixels().map(|p| common::srgb_to_linear(p[c])).collect();
            let model = vergence::view::sharpen::sharpen_image(
                &plane,
                w as usize,
                vergence::view::sharpen::DEFAULT_STRENGTH,
            );
            for y in 0..h {
                for x in 0..w {
                    if !wide_alone(x, y) {
                        continue;
                    }
                    let i = (y * w + x) as usize;
                    let got = b.get_pixel(x, y)[c] as f64;
                    let d = (got - common::linear_to_srgb(model[i].clamp(0.0, 1.0))).abs();
                    worst = worst.max(d);
                    sum += d;
                    n += 1;
                    changed += usize::from(got != a.get_pixel(x, y)[c] as f64);
                }
            }
        }
        let (_, core_differ) = diff(&up[11][eye], &sharp[11][eye], core);
        assert_eq!(core_differ, 0, "eye {eye}: the inset changed");
    }
    let mean = sum / n.max(1) as f64;
    println!("sharpened against the model: mean {mean:.3}, worst {worst:.2} levels; {changed} channel values changed by it of {n}");
    assert!(
        changed > n / 100,
        "the sharpening changed only {changed} of {n} values"
    );
    assert!(mean < 0.3, "mean {mean:.3} levels from the model");
    assert!(worst < 4.0, "worst {worst:.2} levels from the model");
}
