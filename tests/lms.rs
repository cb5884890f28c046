//! Lens-matched shading (`--opt lms`) on lavapipe, which offers no
//! VK_NV_clip_space_w_scaling, so the vertex-shader path runs (the native
//! path is measured on the H200 by the `lms` bench plan): with coefficient
//! 0 the four quadrant draws and the resample give the plain render pixel
//! for pixel; with a coefficient, every eye pixel is the LMS image read
//! through the map of `view::lms`, which this test predicts from a render
//! at four times the resolution; multiview equals two-pass; stats say the
//! path and the size; zero validation messages (`render_config` checks).

mod common;

use common::{context, fails_with_one_error, framing_pose, load, render_config, scratch};
use vergence::config::{Lms, RenderConfig, StereoMode};
use vergence::view::lms::{inverse, Coefficients, Layout};
use vergence::view::profile::HmdProfile;

const W: u32 = 192;
const H: u32 = 160;

fn config(stereo: StereoMode, lms: Option<f64>) -> RenderConfig {
    RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo,
            msaa: 4,
            ..Default::default()
        },
        effort: vergence::config::EffortConfig {
            lms: lms.map(|k| Lms {
                coefficient: Some(k),
                ..Lms::default()
            }),
            ..Default::default()
        },
        ..RenderConfig::default()
    }
}

#[test]
fn lms_at_zero_is_the_plain_render() {
    let ctx = context();
    let scene = load("factory:2000");
    let profile = HmdProfile::load("valve-index").unwrap();
    let pose = framing_pose(&scene, &profile);
    for stereo in [StereoMode::Multiview, StereoMode::TwoPass] {
        let plain = render_config(&ctx, &scene, &profile, pose, &config(stereo, None), W, H);
        let lms = render_config(
            &ctx,
            &scene,
            &profile,
            pose,
            &config(stereo, Some(0.0)),
            W,
            H,
        );
        for eye in 0..2 {
            // The sky is drawn as four quadrant quads instead of one
            // triangle, so its interpolated directions may round apart by
            // one level at a few pixels; everything else is identical.
            let (mut differ, mut worst) = (0usize, 0i32);
            for (p, q) in plain.images[eye].pixels().zip(lms.images[eye].pixels()) {
                if p != q {
                    differ += 1;
                    for ch in 0..4 {
                        worst = worst.max((p[ch] as i32 - q[ch] as i32).abs());
                    }
                }
            }
            assert!(
                differ * 1000 <= (W * H) as usize && worst <= 1,
                "{stereo:?} eye {eye}: lms=0 draws the plain image; {differ} pixels differ, by up to {worst}"
            );
        }
        assert!(lms.stats.gpu_ms.contains_key("forward-lms"));
        assert!(lms.stats.gpu_ms.contains_key("lms-resample"));
        // Four quadrants: four times the scene's draws, plus the resample.
        assert!(lms.stats.draw_calls >= 4 * plain.stats.draw_calls);
    }
}

/// The LMS image's texel (i, j) as the hi-resolution render shows it: the
/// texel's square mapped back to eye NDC, the hi-res pixels inside it
/// averaged in linear light (what the 4× MSAA resolve approximates).
fn texel(hi: &image::RgbaImage, c: &Coefficients, l: &Layout, i: i64, j: i64, ch: usize) -> f64 {
    let i = i.clamp(0, l.size[0] as i64 - 1) as f64;
    let j = j.clamp(0, l.size[1] as i64 - 1) as f64;
    let (hw, hh) = hi.dimensions();
    let to_hi = |px: f64, py: f64| {
        let q = [
            (px - l.centre[0] as f64) / (W as f64 * 0.5),
            (py - l.centre[1] as f64) / (H as f64 * 0.5),
        ];
        let e = inverse(c, q);
        (
            (e[0] + 1.0) * 0.5 * hw as f64,
            (e[1] + 1.0) * 0.5 * hh as f64,
        )
    };
    let (x0, y0) = to_hi(i, j);
    let (x1, y1) = to_hi(i + 1.0, j + 1.0);
    let range = |a: f64, b: f64, n: u32| {
        let lo = (a.min(b).round() as i64).clamp(0, n as i64 - 1);
        let hi = (a.max(b).round() as i64).clamp(lo + 1, n as i64);
        lo as u32..hi as u32
    };
    let (mut sum, mut n) = (0.0, 0.0);
    for y in range(y0, y1, hh) {
        for x in range(x0, x1, hw) {
            sum += common::srgb_to_linear(hi.get_pixel(x, y)[ch]);
            n += 1.0;
        }
    }
    sum / n
}

/// Eye pixel (x, y) predicted the way `lms_resample.frag` computes it:
/// its NDC mapped into the LMS image, kept between the outermost drawn
/// LMS pixels' centres, and read bilinearly, in linear light; as 8-bit
/// sRGB.
fn predicted(
    hi: &image::RgbaImage,
    c: &Coefficients,
    l: &Layout,
    x: u32,
    y: u32,
    ch: usize,
) -> f64 {
    let size = [W as f64, H as f64];
    let ndc = [
        (x as f64 + 0.5) / size[0] * 2.0 - 1.0,
        (y as f64 + 0.5) / size[1] * 2.0 - 1.0,
    ];
    let (a, b) = c.at(ndc[0], ndc[1]);
    let mut p = l.lms_pixel(c, ndc);
    // Kept between the centres of the outermost LMS pixels wholly inside
    // the eye's frustum, whose edges x = ±1 (this row) and y = ±1 (this
    // column) land at LMS NDC ±1 / (1 + k + the other axis' term).
    let other = [b * ndc[1].abs(), a * ndc[0].abs()];
    let sides = [(c.left, c.right), (c.up, c.down)];
    for k in 0..2 {
        let centre = l.centre[k] as f64;
        let lo = centre - size[k] * 0.5 / (1.0 + sides[k].0 + other[k]);
        let hi = centre + size[k] * 0.5 / (1.0 + sides[k].1 + other[k]);
        let first = lo.ceil() + 0.5;
        let last = (hi.floor() - 0.5).max(first);
        p[k] = p[k].clamp(first, last);
    }
    let (u, v) = (p[0] - 0.5, p[1] - 0.5);
    let (i, j) = (u.floor(), v.floor());
    let (fx, fy) = (u - i, v - j);
    let (i, j) = (i as i64, j as i64);
    let t = |di: i64, dj: i64| texel(hi, c, l, i + di, j + dj, ch);
    let top = t(0, 0) * (1.0 - fx) + t(1, 0) * fx;
    let bottom = t(0, 1) * (1.0 - fx) + t(1, 1) * fx;
    let lin = top * (1.0 - fy) + bottom * fy;
    let s = if lin <= 0.0031308 {
        lin * 12.92
    } else {
        1.055 * lin.powf(1.0 / 2.4) - 0.055
    };
    s * 255.0
}

#[test]
fn every_pixel_is_the_lms_image_read_through_the_map() {
    let ctx = context();
    let scene = load("factory:2000");
    let profile = HmdProfile::load("valve-index").unwrap();
    let pose = framing_pose(&scene, &profile);
    let k = 0.4;
    let mv = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &config(StereoMode::Multiview, Some(k)),
        W,
        H,
    );
    let plain = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &config(StereoMode::Multiview, None),
        W,
        H,
    );
    let hi = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &config(StereoMode::Multiview, None),
        4 * W,
        4 * H,
    );
    // Total error of a prediction through coefficient k against eye `eye`.
    let error = |eye: usize, k: f64, close: &mut usize| {
        let c = Coefficients::uniform(k);
        let l = Layout::new(&c, [W, H]);
        let mut sum = 0.0;
        for y in 0..H {
            for x in 0..W {
                let p = mv.images[eye].get_pixel(x, y);
                let mut ok = true;
                for ch in 0..3 {
                    let e = (p[ch] as f64 - predicted(&hi.images[eye], &c, &l, x, y, ch)).abs();
                    ok &= e <= 12.0;
                    sum += e;
                }
                *close += usize::from(ok);
            }
        }
        sum
    };
    for eye in 0..2 {
        // The outermost pixels read only LMS pixels wholly inside the
        // frustum: the border is not darkened by undrawn samples.
        let ring = |img: &image::RgbaImage| {
            let (mut sum, mut n) = (0.0, 0.0);
            for (x, y, p) in img.enumerate_pixels() {
                if x == 0 || y == 0 || x == W - 1 || y == H - 1 {
                    sum += (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0;
                    n += 1.0;
                }
            }
            sum / n
        };
        let (lms_ring, plain_ring) = (ring(&mv.images[eye]), ring(&plain.images[eye]));
        assert!(
            lms_ring > plain_ring - 3.0,
            "eye {eye}: the border averages {lms_ring:.1}, without LMS {plain_ring:.1}"
        );
        let got = &mv.images[eye];
        let mut close = 0usize;
        let err_map = error(eye, k, &mut close);
        let n = (W * H) as usize;
        assert!(
            close * 100 >= n * 95,
            "eye {eye}: {close} of {n} pixels match the predicted resample"
        );
        // The prediction through the coefficient drawn explains the image
        // better than the plain render and than predictions through other
        // coefficients: the map is what was drawn.
        let err_plain: f64 = got
            .pixels()
            .zip(plain.images[eye].pixels())
            .map(|(p, q)| {
                (0..3)
                    .map(|ch| (p[ch] as f64 - q[ch] as f64).abs())
                    .sum::<f64>()
            })
            .sum();
        for (what, other) in [
            ("the plain render", err_plain),
            ("lms=0.3", error(eye, 0.3, &mut 0)),
            ("lms=0.49", error(eye, 0.49, &mut 0)),
        ] {
            assert!(
                err_map < 0.92 * other,
                "eye {eye}: error against the prediction {err_map:.0}, against {what} {other:.0}"
            );
        }
    }
    // Two-pass draws the same eye images.
    let tp = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &config(StereoMode::TwoPass, Some(k)),
        W,
        H,
    );
    for eye in 0..2 {
        let diff = common::pixels_differing(&mv.images[eye], &tp.images[eye]);
        assert!(
            diff * 1000 <= (W * H) as usize,
            "eye {eye}: {diff} pixels differ"
        );
    }
}

#[test]
fn stats_say_the_path_the_coefficients_and_the_size() {
    let out = scratch("lms", "stats");
    let stats = common::render_cli(
        &[
            "--scene",
            "factory:500",
            "--hmd",
            "vive",
            "--width",
            "320",
            "--height",
            "300",
            "--opt",
            "multiview,msaa4,lms",
        ],
        &out,
    );
    let lms = &stats["lms"];
    let path = lms["path"].as_str().unwrap();
    assert!(
        path == "nv-clip-space-w-scaling" || path.starts_with("vertex-shader"),
        "{path}"
    );
    // Fitted to the Vive's lens (see view::lms's fit test): well above 0,
    // under the cap.
    for side in ["left", "right", "up", "down"] {
        let k = lms["coefficients"][side].as_f64().unwrap();
        assert!(
            k > 0.15 && k < vergence::view::lms::MAX_COEFFICIENT,
            "{side}: {k}"
        );
    }
    let size = [
        lms["size"][0].as_u64().unwrap(),
        lms["size"][1].as_u64().unwrap(),
    ];
    assert!(size[0] < 320 && size[1] < 300, "{size:?}");
    let fraction = lms["pixel_fraction"].as_f64().unwrap();
    assert!((fraction - (size[0] * size[1]) as f64 / (320.0 * 300.0)).abs() < 1e-9);
    assert_eq!(stats["validation_messages"], 0);
    // lms=K sets every side; lms-emulated forces the vertex-shader path.
    let out = scratch("lms", "explicit");
    let stats = common::render_cli(
        &[
            "--scene",
            "factory:500",
            "--width",
            "320",
            "--height",
            "300",
            "--opt",
            "two-pass,lms=0.25,lms-emulated",
        ],
        &out,
    );
    assert_eq!(stats["lms"]["coefficients"]["left"], 0.25);
    assert_eq!(stats["lms"]["path"], "vertex-shader (lms-emulated)");
}

/// The stencil mask through the quadrants' w scaling: where the lens hides
/// the eye image (what the rectilinear mask changes, shrunk by five pixels
/// for LMS's coarser periphery and the resample's filter, away from the
/// border) the LMS frame shows
/// what the mask leaves there, and elsewhere (five pixels from the
/// hidden area) it is LMS's frame without the mask.
#[test]
fn the_stencil_mask_lands_where_the_lens_hides_the_eye() {
    let ctx = context();
    let scene = load("factory:2000");
    let profile = HmdProfile::load("valve-index").unwrap();
    let pose = framing_pose(&scene, &profile);
    let render = |lms: Option<f64>, stereo: StereoMode, mask: bool| {
        let c = {
            let mut rc = config(stereo, lms);
            rc.effort.stencil_mask = mask;
            rc
        };
        render_config(&ctx, &scene, &profile, pose, &c, W, H)
    };
    let plain = render(None, StereoMode::Multiview, false);
    let masked = render(None, StereoMode::Multiview, true);
    for stereo in [StereoMode::Multiview, StereoMode::TwoPass] {
        let lms = render(Some(0.4), stereo, false);
        let both = render(Some(0.4), stereo, true);
        for eye in 0..2 {
            let hidden = |x: u32, y: u32| {
                plain.images[eye].get_pixel(x, y) != masked.images[eye].get_pixel(x, y)
            };
            // At the periphery an LMS pixel spans up to D^(3/2) ≈ 2.4 eye
            // pixels: the mask's edge lands to within one of them, and the
            // resample's bilinear reads reach one more.
            let near = |x: u32, y: u32, want: bool| {
                let (x0, y0) = (x.saturating_sub(5), y.saturating_sub(5));
                (y0..(y + 6).min(H)).all(|j| (x0..(x + 6).min(W)).all(|i| hidden(i, j) == want))
            };
            let (mut inside, mut outside, mut wrong) = (0, 0, Vec::new());
            for y in 0..H {
                for x in 0..W {
                    let got = both.images[eye].get_pixel(x, y);
                    let close = |p: &image::Rgba<u8>| {
                        (0..4).all(|ch| (p[ch] as i32 - got[ch] as i32).abs() <= 1)
                    };
                    // Within four pixels of the border the resample reads
                    // from up to D² eye pixels inwards (it repeats the
                    // outermost drawn pixels), past a thin hidden band.
                    let border = x < 4 || y < 4 || x + 4 >= W || y + 4 >= H;
                    if near(x, y, true) && !border {
                        inside += 1;
                        if !close(masked.images[eye].get_pixel(x, y)) {
                            wrong.push((
                                "hidden",
                                x,
                                y,
                                got.0,
                                masked.images[eye].get_pixel(x, y).0,
                            ));
                        }
                    } else if near(x, y, false) {
                        outside += 1;
                        if !close(lms.images[eye].get_pixel(x, y)) {
                            wrong.push(("visible", x, y, got.0, lms.images[eye].get_pixel(x, y).0));
                        }
                    }
                }
            }
            let n = (W * H) as usize;
            assert!(
                inside * 20 > n,
                "{stereo:?} eye {eye}: {inside} hidden pixels"
            );
            assert!(
                outside * 2 > n,
                "{stereo:?} eye {eye}: {outside} visible pixels"
            );
            assert!(
                wrong.len() * 1000 <= n,
                "{stereo:?} eye {eye}: {} pixels are not what the mask and LMS give (where, x, y, got, want): {:?}",
                wrong.len(),
                &wrong[..wrong.len().min(12)]
            );
        }
    }
}

#[test]
fn what_lms_cannot_combine_with_is_one_error() {
    for opt in ["lms,inset", "lms,mffr", "lms=0.7", "lms=-1", "lms=nan"] {
        let err = fails_with_one_error(
            std::process::Command::new(env!("CARGO_BIN_EXE_vergence")).args([
                "render",
                "--scene",
                "factory:10",
                "--opt",
                opt,
                "--out",
                scratch("lms", "refused").to_str().unwrap(),
            ]),
        );
        assert!(err.contains("lms"), "{opt}: {err}");
    }
}
