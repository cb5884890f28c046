//! `resolved-sky`: the sky drawn once per pixel under the resolved 4× MSAA
//! image draws the image of the sky drawn at every sample inside the
//! forward scope, up to 8-bit rounding, with blended materials, occlusion's
//! two scopes, both stereo modes, the stencil mask (whose hidden area
//! stays black), RDM (whose fill replaces the sky the resolved pass
//! drew into the skipped quads), the inset (the sky goes under the wide
//! views' resolved image too, before the composite) and the monoscopic far
//! field (the sky goes under the far image, which the composite then lays
//! under the near field). Every frame runs under Vulkan validation (with
//! synchronization validation in `cargo xtask test`); any message fails.

mod common;

use common::{context, fails_with_one_error, framing_pose, load, render_config, scratch};
use vergence::config::{cull_names, RenderConfig, StereoMode};
use vergence::view::profile::HmdProfile;

fn config(stereo: StereoMode, opt: &str) -> RenderConfig {
    let mut c = RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo,
            msaa: 4,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    c.apply_opts(opt, &cull_names()).unwrap();
    c.validate().unwrap();
    c
}

/// The configurations whose sky in the scope is not the reference at the
/// image's border, with the plain frame to hold both to, the border's
/// width and the tolerance inside it. Lens-matched shading resamples the
/// sky from its image, which smooths the horizon by a few code values, and
/// its outermost pixels repeat the LMS pixels wholly inside the frustum;
/// the sky after the resolve goes under the resampled image at the eye's
/// resolution instead. The inset's
/// accumulation jitters the wide views' viewport, which leaves a sliver at
/// the border uncovered: with the sky in the scope it holds the clear
/// colour and darkens the border rows, with the sky after the resolve it
/// stays transparent and the accumulation gives it no weight; inside, the
/// accumulated 8-bit histories round apart by up to three code values.
fn edge_case(opt: &str) -> Option<(&'static str, u32, u8)> {
    if opt.starts_with("lms") {
        Some(("resolved-sky", 3, 6))
    } else if opt.contains("inset-taa") {
        Some(("inset=0.5,resolved-sky", 3, 3))
    } else {
        None
    }
}

/// `got` (the sky after the resolve) within `tolerance` code values of
/// `want` (the sky in the scope) away from a `border` pixels wide, and
/// overall nearer `plain` than `want` is (see [`edge_case`]).
fn nearer_the_plain_frame(
    what: &str,
    (want, got, plain): (&image::RgbaImage, &image::RgbaImage, &image::RgbaImage),
    border: u32,
    tolerance: u8,
) {
    let (w, h) = got.dimensions();
    let mut worst = 0;
    for y in border..h - border {
        for x in border..w - border {
            let (p, q) = (want.get_pixel(x, y), got.get_pixel(x, y));
            worst = worst.max((0..3).map(|c| p[c].abs_diff(q[c])).max().unwrap_or(0));
        }
    }
    assert!(
        worst <= tolerance,
        "{what}: {worst} code values from the sky in the scope away from the border"
    );
    let distance = |a: &image::RgbaImage| -> u64 {
        a.pixels()
            .zip(plain.pixels())
            .flat_map(|(p, q)| (0..3).map(move |c| p[c].abs_diff(q[c]) as u64))
            .sum()
    };
    let (got_d, want_d) = (distance(got), distance(want));
    assert!(
        got_d <= want_d,
        "{what}: {got_d} from the plain frame, the sky in the scope {want_d}"
    );
}

/// The largest difference of any colour channel between `a` and `b`.
fn largest_difference(a: &image::RgbaImage, b: &image::RgbaImage) -> u8 {
    a.pixels()
        .zip(b.pixels())
        .flat_map(|(p, q)| (0..3).map(move |c| p[c].abs_diff(q[c])))
        .max()
        .unwrap_or(0)
}

#[test]
fn the_sky_under_the_resolved_image_draws_the_image_of_the_sky_in_the_scope() {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    // AlphaBlendModeTest: blended materials over the sky; cad: glass parts
    // among a thousand opaque ones; factory: occlusion's two scopes.
    for (spec, opts) in [
        (
            "assets/AlphaBlendModeTest/AlphaBlendModeTest.gltf",
            &["", "stencil-mask", "rdm=0.3", "mffr", "mffr=3", "lms"][..],
        ),
        ("cad:1500", &[""][..]),
        (
            "factory:3000",
            &[
                "superfrustum,gpu-cull,occlusion",
                "inset=0.5",
                "inset=0.5,inset-wide-1x",
                "inset=0.5,inset-taau",
                "inset=0.5,inset-taa,inset-taa-jitter",
                "mffr",
                "superfrustum,gpu-cull,mffr",
                "mffr,mffr-alternate-eye,mffr-depth-shift",
                "lms",
                "lms=0.3,stencil-mask",
            ][..],
        ),
    ] {
        let scene = load(spec);
        let pose = framing_pose(&scene, &profile);
        for stereo in [StereoMode::Multiview, StereoMode::TwoPass] {
            for &opt in opts {
                let what = format!("{spec} {stereo:?} '{opt}'");
                let want =
                    render_config(&ctx, &scene, &profile, pose, &config(stereo, opt), 160, 144);
                let with = if opt.is_empty() {
                    "resolved-sky".to_string()
                } else {
                    format!("{opt},resolved-sky")
                };
                let got = render_config(
                    &ctx,
                    &scene,
                    &profile,
                    pose,
                    &config(stereo, &with),
                    160,
                    144,
                );
                assert!(
                    got.stats.gpu_ms.contains_key("sky-resolved"),
                    "{what}: no sky-resolved pass in {:?}",
                    got.stats.gpu_ms.keys()
                );
                for eye in 0..2 {
                    // The sky is in view: the top row is not black.
                    let top: u32 = (0..want.images[eye].width())
                        .map(|x| want.images[eye].get_pixel(x, 0).0[2] as u32)
                        .sum();
                    assert!(
                        top > 20 * want.images[eye].width(),
                        "{what}: no sky in view"
                    );
                    if let Some((plain, border, tolerance)) = edge_case(opt) {
                        let plain = &render_config(
                            &ctx,
                            &scene,
                            &profile,
                            pose,
                            &config(stereo, plain),
                            160,
                            144,
                        )
                        .images[eye];
                        let (want, got) = (&want.images[eye], &got.images[eye]);
                        nearer_the_plain_frame(&what, (want, got, plain), border, tolerance);
                    } else {
                        // Nothing may differ by more than rounding, the
                        // stencil mask's hidden area (black) included.
                        let worst = largest_difference(&want.images[eye], &got.images[eye]);
                        assert!(
                            worst <= 2,
                            "{what}: eye {eye} differs by {worst} code values"
                        );
                    }
                    // Every pixel is opaque: the sky filled what the scene
                    // left uncovered.
                    assert!(
                        got.images[eye].pixels().all(|p| p.0[3] == 255),
                        "{what}: eye {eye} has uncovered pixels"
                    );
                }
            }
        }
    }
}

#[test]
fn resolved_sky_with_what_it_cannot_run_with_is_one_error() {
    for (opt, expect) in [
        ("no-msaa,resolved-sky", "needs msaa4"),
        ("inset,inset-views=4,resolved-sky", "inset-views=4"),
    ] {
        let stderr = fails_with_one_error(
            std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
                .args(["render", "--scene", "factory:10", "--opt", opt])
                .arg("--out")
                .arg(scratch("resolved-sky", "bad")),
        );
        assert!(
            stderr.contains("resolved-sky") && stderr.contains(expect),
            "{opt}: {stderr}"
        );
    }
}
