//! Multi-resolution foveated rendering (`--opt inset`) on lavapipe: inside
//! the inset (away from the feathered seam) the eye image is the
//! full-resolution render's own pixels; outside it, the wide view rendered
//! at half size and upsampled bilinearly; multiview equals two-pass; the
//! gaze moves the inset; the four views in one multiview scope equal the
//! two-scope path; zero validation messages (`render_config` checks).

mod common;

use common::{context, framing_pose, load, render_config};
use vergence::config::{Inset, RenderConfig, StereoMode};
use vergence::view::inset::{inset_rect, weight, PixelRect, FEATHER_PX};
use vergence::view::profile::HmdProfile;

const W: u32 = 192;
const H: u32 = 160;

/// What every test here renders: factory:2000 on valve-index, framed, and
/// the profile's FOVs.
fn fixture() -> (
    std::sync::Arc<vergence::gpu::Context>,
    vergence::scene::Scene,
    HmdProfile,
    vergence::view::Pose,
    Vec<vergence::view::Fov>,
) {
    let ctx = context();
    let scene = load("factory:2000");
    let profile = HmdProfile::load("valve-index").unwrap();
    let pose = framing_pose(&scene, &profile);
    let fovs = profile.views.iter().map(|v| v.fov).collect();
    (ctx, scene, profile, pose, fovs)
}

const SETTINGS: Inset = common::INSET_SETTINGS;

fn srgb_to_linear(v: u8) -> f32 {
    common::srgb_to_linear(v) as f32
}

fn linear_to_srgb(l: f32) -> f32 {
    common::linear_to_srgb(l as f64) as f32
}

/// `img` sampled at the centre of pixel (x, y) of a `w`×`h` image the way
/// a linear clamp-to-edge sampler does (in linear light: the images are
/// sRGB), for one channel.
fn bilinear(img: &image::RgbaImage, x: u32, y: u32, w: u32, h: u32, ch: usize) -> f32 {
    let (sw, sh) = img.dimensions();
    let u = (x as f32 + 0.5) / w as f32 * sw as f32 - 0.5;
    let v = (y as f32 + 0.5) / h as f32 * sh as f32 - 0.5;
    let (x0, y0) = (u.floor(), v.floor());
    let (fx, fy) = (u - x0, v - y0);
    let at = |xi: f32, yi: f32| {
        let xi = xi.clamp(0.0, sw as f32 - 1.0) as u32;
        let yi = yi.clamp(0.0, sh as f32 - 1.0) as u32;
        srgb_to_linear(img.get_pixel(xi, yi)[ch])
    };
    let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1.0, y0) * fx;
    let bottom = at(x0, y0 + 1.0) * (1.0 - fx) + at(x0 + 1.0, y0 + 1.0) * fx;
    linear_to_srgb(top * (1.0 - fy) + bottom * fy)
}

/// `img` read at the centre of pixel (x, y) of a `w`×`h` image the way
/// `inset-catmull-rom`'s composite reads it: the Catmull-Rom filter
/// (Keys, a = −1/2) over the 4×4 texels around the point in linear light,
/// clamped to the range of the nearest 2×2, for one channel.
fn catmull_rom(img: &image::RgbaImage, x: u32, y: u32, w: u32, h: u32, ch: usize) -> f32 {
    let (sw, sh) = img.dimensions();
    let u = ((x as f32 + 0.5) / w as f32 * sw as f32).clamp(0.5, sw as f32 - 0.5) - 0.5;
    let v = ((y as f32 + 0.5) / h as f32 * sh as f32).clamp(0.5, sh as f32 - 0.5) - 0.5;
    let (x0, y0) = (u.floor() as i64, v.floor() as i64);
    let weights = |f: f32| {
        [
            f * (-0.5 + f * (1.0 - 0.5 * f)),
            1.0 + f * f * (-2.5 + 1.5 * f),
            f * (0.5 + f * (2.0 - 1.5 * f)),
            f * f * (-0.5 + 0.5 * f),
        ]
    };
    let (wx, wy) = (weights(u - u.floor()), weights(v - v.floor()));
    let at = |xi: i64, yi: i64| {
        let xi = xi.clamp(0, sw as i64 - 1) as u32;
        let yi = yi.clamp(0, sh as i64 - 1) as u32;
        srgb_to_linear(img.get_pixel(xi, yi)[ch])
    };
    let (mut sum, mut lo, mut hi) = (0.0f32, f32::MAX, f32::MIN);
    for (j, wj) in wy.iter().enumerate() {
        for (i, wi) in wx.iter().enumerate() {
            let c = at(x0 - 1 + i as i64, y0 - 1 + j as i64);
            sum += wi * wj * c;
            if (1..=2).contains(&i) && (1..=2).contains(&j) {
                lo = lo.min(c);
                hi = hi.max(c);
            }
        }
    }
    linear_to_srgb(sum.clamp(lo, hi))
}

fn config(stereo: StereoMode, inset: Option<Inset>, gaze: [f32; 2]) -> RenderConfig {
    RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo,
            msaa: 4,
            ..Default::default()
        },
        effort: vergence::config::EffortConfig {
            inset,
            gaze,
            ..Default::default()
        },
        ..RenderConfig::default()
    }
}

fn core(r: &PixelRect, x: u32, y: u32) -> bool {
    weight(r, x, y, FEATHER_PX) >= 1.0
}

/// Pixels of `got`'s core of `r` (inside, equal to `full`'s).
fn core_matches(got: &image::RgbaImage, full: &image::RgbaImage, r: &PixelRect) -> (usize, usize) {
    let (mut inside, mut same) = (0, 0);
    for y in 0..H {
        for x in 0..W {
            if core(r, x, y) {
                inside += 1;
                same += usize::from(got.get_pixel(x, y) == full.get_pixel(x, y));
            }
        }
    }
    (inside, same)
}

/// What a `w`×`h` eye image `got` holds around the inset `rect`: (core
/// pixels, of them equal to `full`'s; periphery pixels beyond the feather,
/// of them within 2.5 levels of `wide` upsampled bilinearly).
fn regions(
    got: &image::RgbaImage,
    full: &image::RgbaImage,
    wide: &image::RgbaImage,
    rect: &PixelRect,
    (w, h): (u32, u32),
) -> (usize, usize, usize, usize) {
    let (mut inside, mut same, mut outside, mut close) = (0, 0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let p = got.get_pixel(x, y);
            let wt = weight(rect, x, y, FEATHER_PX);
            if wt >= 1.0 {
                inside += 1;
                same += usize::from(p == full.get_pixel(x, y));
            } else if wt == 0.0 {
                outside += 1;
                let ok = (0..3).all(|c| (p[c] as f32 - bilinear(wide, x, y, w, h, c)).abs() <= 2.5);
                close += usize::from(ok);
            }
        }
    }
    (inside, same, outside, close)
}

/// `inset-catmull-rom`: the inset's core is still the full render's
/// pixels, and the periphery the wide view read through the Catmull-Rom
/// filter (not bilinearly: the two differ there).
#[test]
fn with_catmull_rom_the_periphery_is_the_wide_view_through_its_filter() {
    let (ctx, scene, profile, pose, fovs) = fixture();
    let render = |c: &RenderConfig, w, h| render_config(&ctx, &scene, &profile, pose, c, w, h);
    let full = render(&config(StereoMode::Multiview, None, [0.0; 2]), W, H);
    let wide = render(&config(StereoMode::Multiview, None, [0.0; 2]), W / 2, H / 2);
    let inset = Inset {
        catmull_rom: true,
        ..SETTINGS
    };
    let got = render(&config(StereoMode::Multiview, Some(inset), [0.0; 2]), W, H);
    let rect = inset_rect(&fovs, [0.0, 0.0], 15.0, W, H);
    for eye in 0..2 {
        let (img, sharp, soft) = (&got.images[eye], &full.images[eye], &wide.images[eye]);
        let (inside, same) = core_matches(img, sharp, &rect);
        assert_eq!(same, inside, "eye {eye}: the core is the full render's");
        let (mut outside, mut close, mut unlike_bilinear) = (0, 0, 0);
        for y in 0..H {
            for x in 0..W {
                if weight(&rect, x, y, FEATHER_PX) > 0.0 {
                    continue;
                }
                outside += 1;
                let p = img.get_pixel(x, y);
                let near =
                    |f: &dyn Fn(usize) -> f32| (0..3).all(|c| (p[c] as f32 - f(c)).abs() <= 2.5);
                close += usize::from(near(&|c| catmull_rom(soft, x, y, W, H, c)));
                unlike_bilinear += usize::from(!near(&|c| bilinear(soft, x, y, W, H, c)));
            }
        }
        assert!(
            close * 1000 >= outside * 995,
            "eye {eye}: {close} of {outside} periphery pixels match the Catmull-Rom read"
        );
        assert!(
            unlike_bilinear > 50,
            "eye {eye}: {unlike_bilinear} pixels unlike the bilinear read"
        );
    }
}

#[test]
fn the_inset_is_the_full_render_and_the_rest_the_wide_view_upsampled() {
    let (ctx, scene, profile, pose, fovs) = fixture();
    // The two-scope path (the default, and what two-pass draws); the four
    // views in one scope are compared with it below.
    let settings = SETTINGS;
    let full = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &config(StereoMode::Multiview, None, [0.0; 2]),
        W,
        H,
    );
    let wide = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &config(StereoMode::Multiview, None, [0.0; 2]),
        W / 2,
        H / 2,
    );
    // A multiview render with `inset` at `gaze`.
    let with_inset = |inset: Inset, gaze: [f32; 2]| {
        render_config(
            &ctx,
            &scene,
            &profile,
            pose,
            &config(StereoMode::Multiview, Some(inset), gaze),
            W,
            H,
        )
    };
    let mv = with_inset(settings, [0.0; 2]);
    let rect = inset_rect(&fovs, [0.0, 0.0], 15.0, W, H);
    assert!(rect.width() > 20 && rect.width() < W - 20, "{rect:?}");
    for eye in 0..2 {
        let (got, sharp, soft) = (&mv.images[eye], &full.images[eye], &wide.images[eye]);
        let (inside, same, outside, close) = regions(got, sharp, soft, &rect, (W, H));
        assert_eq!(
            same, inside,
            "eye {eye}: the inset's core is the full render's pixels"
        );
        assert!(
            close * 1000 >= outside * 995,
            "eye {eye}: {close} of {outside} periphery pixels match the wide view upsampled"
        );
        // The periphery really is the lower resolution: it differs from
        // the full render somewhere.
        let differs = (0..H)
            .flat_map(|y| (0..W).map(move |x| (x, y)))
            .filter(|&(x, y)| !rect.contains(x, y))
            .any(|(x, y)| got.get_pixel(x, y) != sharp.get_pixel(x, y));
        assert!(differs, "eye {eye}: the periphery is not the full render");
    }
    // Two-pass draws the same eye images.
    let tp = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &config(StereoMode::TwoPass, Some(settings), [0.0; 2]),
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
    assert!(mv.stats.gpu_ms.contains_key("forward-wide"));
    assert!(mv.stats.gpu_ms.contains_key("forward-inset"));
    assert!(mv.stats.gpu_ms.contains_key("inset-composite"));
    // The inset views draw their own list, culled by the eyes' volumes
    // through the rectangle: more than the wide views' alone, fewer than a
    // second full list, and fewer still for a narrower inset.
    let all = full.stats.instances_drawn;
    let inset_list = |r: &common::Frame| r.stats.instances_drawn - all;
    assert!(
        mv.stats.instances_drawn > all && inset_list(&mv) < all,
        "{} instance draws with inset against {all} without",
        mv.stats.instances_drawn
    );
    let narrow = with_inset(
        Inset {
            half_angle_deg: 3.0,
            ..settings
        },
        [0.0; 2],
    );
    assert!(
        inset_list(&narrow) * 4 < all && inset_list(&narrow) < inset_list(&mv),
        "a ±3° inset draws {} of {all} instances",
        inset_list(&narrow)
    );
    // The gaze moves it: to the right, the sharp core follows.
    let gaze = [0.6, 0.0];
    let moved = with_inset(settings, gaze);
    let right = inset_rect(&fovs, gaze, 15.0, W, H);
    assert!(right.x0 > rect.x1 - 10, "{right:?} vs {rect:?}");
    let (inside, same) = core_matches(&moved.images[0], &full.images[0], &right);
    assert_eq!(same, inside, "the moved inset is the full render's pixels");
    let centre_sharp = (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .filter(|&(x, y)| core(&rect, x, y) && !right.contains(x, y))
        .all(|(x, y)| moved.images[0].get_pixel(x, y) == full.images[0].get_pixel(x, y));
    assert!(!centre_sharp, "the old centre is no longer the full render");
    // Off-axis both ways (up-left, down-right): the core stays the full
    // render's pixels with the inset's narrower list.
    for gaze in [[-0.5, -0.5], [0.4, 0.6]] {
        let moved = with_inset(settings, gaze);
        let r = inset_rect(&fovs, gaze, 15.0, W, H);
        for eye in 0..2 {
            let (inside, same) = core_matches(&moved.images[eye], &full.images[eye], &r);
            assert!(inside > 100, "{r:?}");
            assert_eq!(
                same, inside,
                "gaze {gaze:?}, eye {eye}: the core is the full render's"
            );
        }
    }
}

/// With `inset-views=4` the four views go into one scope (layers 2 and 3 the
/// wide views, each drawn into a region of its layer through a widened
/// FOV): the core is still the full render's pixels, the periphery the
/// wide view upsampled, and the eye images equal the two-scope path's but
/// for a few edge pixels (the wide view's vertices are projected through
/// another matrix, equal up to rounding), at three gazes.
#[test]
fn four_views_in_one_scope_equal_the_two_scope_path() {
    let (ctx, scene, profile, pose, fovs) = fixture();
    let four = Inset {
        four_views: true,
        ..SETTINGS
    };
    let two = SETTINGS;
    let render = |inset: Option<Inset>, gaze: [f32; 2], w: u32, h: u32| {
        render_config(
            &ctx,
            &scene,
            &profile,
            pose,
            &config(StereoMode::Multiview, inset, gaze),
            w,
            h,
        )
    };
    let full = render(None, [0.0; 2], W, H);
    let wide = render(None, [0.0; 2], W / 2, H / 2);
    for gaze in [[0.0, 0.0], [0.6, 0.0], [-0.5, -0.5]] {
        let one = render(Some(four), gaze, W, H);
        let split = render(Some(two), gaze, W, H);
        assert!(one.stats.gpu_ms.contains_key("forward-four-view"));
        assert!(!one.stats.gpu_ms.contains_key("forward-wide"));
        assert!(split.stats.gpu_ms.contains_key("forward-wide"));
        // One list for the four views: the eye's, drawn once.
        assert_eq!(one.stats.instances_drawn, full.stats.instances_drawn);
        let rect = inset_rect(&fovs, gaze, 15.0, W, H);
        for eye in 0..2 {
            let (inside, same, outside, close) = regions(
                &one.images[eye],
                &full.images[eye],
                &wide.images[eye],
                &rect,
                (W, H),
            );
            assert!(inside > 100, "{rect:?}");
            assert_eq!(
                same, inside,
                "gaze {gaze:?}, eye {eye}: the core is the full render's"
            );
            assert!(
                close * 1000 >= outside * 995,
                "gaze {gaze:?}, eye {eye}: {close} of {outside} periphery pixels match the wide view upsampled"
            );
            let diff = common::pixels_differing(&one.images[eye], &split.images[eye]);
            assert!(
                diff * 100 <= (W * H) as usize,
                "gaze {gaze:?}, eye {eye}: {diff} pixels differ from the two-scope path"
            );
        }
    }
    // With the stencil mask the wide views' layers get the hidden area
    // through their own FOVs: the same black corners as two scopes.
    let masked = |inset: Inset| {
        render_config(
            &ctx,
            &scene,
            &profile,
            pose,
            &{
                let mut rc = config(StereoMode::Multiview, Some(inset), [0.0; 2]);
                rc.effort.stencil_mask = true;
                rc
            },
            W,
            H,
        )
    };
    let (one, split) = (masked(four), masked(two));
    for eye in 0..2 {
        let black = |img: &image::RgbaImage| {
            img.pixels()
                .filter(|p| p[0] == 0 && p[1] == 0 && p[2] == 0)
                .count()
        };
        let hidden = black(&split.images[eye]);
        assert!(hidden > 1000, "eye {eye}: {hidden} hidden pixels");
        assert!(
            black(&one.images[eye]).abs_diff(hidden) * 50 <= hidden,
            "eye {eye}: {} black pixels with four views, {hidden} with two scopes",
            black(&one.images[eye])
        );
        let diff = common::pixels_differing(&one.images[eye], &split.images[eye]);
        assert!(
            diff * 100 <= (W * H) as usize,
            "stencil mask, eye {eye}: {diff} pixels differ from the two-scope path"
        );
    }
}

/// With `aq` the eyes are drawn smaller than their images (the targets are
/// made once at the largest scale): the inset follows the render scale, in
/// two scopes and in four views. At scale 0.75 the core is the full render
/// at that size pixel for pixel and the periphery that size's wide view
/// upsampled; the images come back at the drawn size.
#[test]
fn with_aq_the_inset_follows_the_render_scale() {
    let (ctx, scene, profile, pose, fovs) = fixture();
    for four_views in [false, true] {
        let inset = Inset {
            half_angle_deg: 20.0,
            four_views,
            ..SETTINGS
        };
        let config = {
            let mut rc = config(StereoMode::Multiview, Some(inset), [0.2, -0.1]);
            rc.effort.aq = true;
            rc
        };
        let before = ctx.validation_messages();
        let extent = ash::vk::Extent2D {
            width: W,
            height: H,
        };
        let mut r = vergence::render::Renderer::new(ctx.clone(), &scene, &config, extent).unwrap();
        r.set_render_scale(0.75);
        let (w, h) = (r.extent().width, r.extent().height);
        assert!(w < W && h < H, "{w}x{h}");
        r.render(&profile.rig(pose), None, true).unwrap();
        let got = r.read_images().unwrap();
        // aq's inset rung: the wide view at half its scale, in the same
        // targets.
        let allocated = ctx.allocated_bytes();
        r.set_inset_wide_factor(0.5);
        r.render(&profile.rig(pose), None, true).unwrap();
        let rung = r.read_images().unwrap();
        // aq's MSAA rung (two scopes only): the wide view at one sample
        // into its resolve image, at F again.
        assert_eq!(r.has_inset_msaa_rung(), !four_views);
        r.set_inset_wide_factor(1.0);
        r.set_inset_wide_one_sample(true);
        r.render(&profile.rig(pose), None, true).unwrap();
        let one_sample = r.read_images().unwrap();
        assert_eq!(ctx.allocated_bytes(), allocated, "nothing reallocated");
        drop(r);
        common::assert_no_validation_since(&ctx, before);
        let plain = |w, h| {
            render_config(
                &ctx,
                &scene,
                &profile,
                pose,
                &config_without_aq(None, [0.2, -0.1]),
                w,
                h,
            )
        };
        let (full, wide) = (plain(w, h), plain(w / 2, h / 2));
        // The rung's wide view: F × 0.5 of the drawn size, as
        // `InsetPass::wide_extent` rounds it.
        let q = vergence::render::scaled(
            ash::vk::Extent2D {
                width: w,
                height: h,
            },
            0.25,
        );
        let quarter = plain(q.width, q.height);
        let wide1 = render_config(
            &ctx,
            &scene,
            &profile,
            pose,
            &{
                let mut rc = config_without_aq(None, [0.2, -0.1]);
                rc.frame.msaa = 1;
                rc
            },
            w / 2,
            h / 2,
        );
        let rect = inset_rect(&fovs, [0.2, -0.1], 20.0, w, h);
        let mut cases = vec![(&got, &wide, "F"), (&rung, &quarter, "F / 2 (the rung)")];
        if !four_views {
            cases.push((&one_sample, &wide1, "one sample (the MSAA rung)"));
        }
        for (images, want, what) in cases {
            for (eye, img) in images.iter().enumerate() {
                assert_eq!(img.dimensions(), (w, h));
                let (inside, same, outside, close) =
                    regions(img, &full.images[eye], &want.images[eye], &rect, (w, h));
                let (_, _, _, close_half) =
                    regions(img, &full.images[eye], &wide.images[eye], &rect, (w, h));
                assert!(inside > 100, "{rect:?}");
                assert_eq!(
                    same, inside,
                    "four views {four_views}, wide at {what}, eye {eye}: the core is the full render's at the scaled size"
                );
                assert!(
                    close * 1000 >= outside * 995,
                    "four views {four_views}, wide at {what}, eye {eye}: {close} of {outside} periphery pixels match the wide view at that scale"
                );
                if what != "F" {
                    assert!(
                        close_half < close,
                        "four views {four_views}, eye {eye}: on the rung the periphery is not the F wide view ({close_half} against {close})"
                    );
                }
            }
        }
    }
}

/// With `inset-wide-1x` the wide views are drawn at one sample while the
/// insets keep 4×: the core is still the 4× full render pixel for pixel,
/// and the periphery is the one-sample half-size render upsampled, not the
/// 4× one — in multiview and two-pass, and with the stencil mask (whose
/// hidden-area pipeline has a one-sample twin for the wide scope).
#[test]
fn wide_views_at_one_sample_keep_the_inset_at_4x() {
    let (ctx, scene, profile, pose, fovs) = fixture();
    let inset = Inset {
        wide_1x: true,
        ..SETTINGS
    };
    let gaze = [0.1, 0.2];
    let rect = inset_rect(&fovs, gaze, 15.0, W, H);
    let extent = ash::vk::Extent2D {
        width: W,
        height: H,
    };
    let c = config(StereoMode::Multiview, Some(inset), gaze);
    let r = vergence::render::Renderer::new(ctx.clone(), &scene, &c, extent).unwrap();
    let path = r.inset_path.clone().unwrap_or_default();
    assert!(path.contains("wide views at 1 sample"), "{path}");
    drop(r);
    for (stereo, stencil_mask) in [
        (StereoMode::Multiview, false),
        (StereoMode::TwoPass, false),
        (StereoMode::Multiview, true),
    ] {
        let with = |inset: Option<Inset>, msaa: u32, w: u32, h: u32| {
            let c = {
                let mut rc = config(stereo, inset, gaze);
                rc.frame.msaa = msaa;
                rc.effort.stencil_mask = stencil_mask;
                rc
            };
            render_config(&ctx, &scene, &profile, pose, &c, w, h)
        };
        let got = with(Some(inset), 4, W, H);
        let full = with(None, 4, W, H);
        let (wide1, wide4) = (with(None, 1, W / 2, H / 2), with(None, 4, W / 2, H / 2));
        for eye in 0..2 {
            let img = &got.images[eye];
            let (inside, same, outside, close) =
                regions(img, &full.images[eye], &wide1.images[eye], &rect, (W, H));
            let (_, _, _, close4) =
                regions(img, &full.images[eye], &wide4.images[eye], &rect, (W, H));
            let what = format!("{stereo:?}, stencil mask {stencil_mask}, eye {eye}");
            assert!(inside > 100, "{rect:?}");
            assert_eq!(same, inside, "{what}: the core is the 4× full render's");
            assert!(
                close * 1000 >= outside * 995,
                "{what}: {close} of {outside} periphery pixels match the one-sample wide view"
            );
            assert!(
                close4 < close,
                "{what}: the periphery is not the 4× wide view ({close4} against {close} pixels match)"
            );
        }
    }
}

/// An inset wide enough at this size for a core with instances in it.
const WIDE: Inset = Inset {
    half_angle_deg: 30.0,
    ..SETTINGS
};

/// The wide views' hole (`view::inset_hole`): the wide views skip what
/// lies wholly under the inset's core in both eyes, and the eye images are
/// bit for bit those of `inset-wide-all`, which draws it, in multiview and
/// two-pass, at 4× and with one-sample wide views, at three gazes.
#[test]
fn the_wide_views_hole_leaves_the_eye_images_as_they_were() {
    let (ctx, scene, profile, pose, _) = fixture();
    let base = WIDE;
    // (stereo, wide 1x, gaze, Catmull-Rom reads, inset-taa, inset-taau,
    // inset-sharpen): the hole's margin follows the reads' reach
    // (view::inset_hole::read_reach, view::taau::READ_REACH and the
    // sharpening's pixel beyond it).
    for (stereo, wide_1x, gaze, catmull_rom, taa, taau, sharpen) in [
        (
            StereoMode::Multiview,
            false,
            [0.0, 0.0],
            false,
            None,
            false,
            None,
        ),
        (
            StereoMode::TwoPass,
            false,
            [0.3, -0.2],
            false,
            None,
            false,
            None,
        ),
        (
            StereoMode::Multiview,
            true,
            [-0.2, 0.1],
            false,
            None,
            false,
            None,
        ),
        (
            StereoMode::Multiview,
            false,
            [0.1, 0.0],
            true,
            None,
            false,
            None,
        ),
        (
            StereoMode::TwoPass,
            true,
            [0.0, 0.1],
            true,
            Some(0.1),
            false,
            None,
        ),
        (
            StereoMode::Multiview,
            true,
            [0.2, 0.0],
            false,
            Some(0.1),
            true,
            None,
        ),
        (
            StereoMode::TwoPass,
            true,
            [-0.1, 0.2],
            false,
            Some(0.1),
            true,
            Some(2.0),
        ),
    ] {
        let run = |wide_all: bool| {
            let inset = Inset {
                wide_1x,
                wide_all,
                catmull_rom,
                taa,
                taa_jitter: taau,
                taau,
                sharpen,
                ..base
            };
            render_config(
                &ctx,
                &scene,
                &profile,
                pose,
                &config(stereo, Some(inset), gaze),
                W,
                H,
            )
        };
        let (hole, all) = (run(false), run(true));
        let what = format!(
            "{stereo:?}, wide 1× {wide_1x}, gaze {gaze:?}, Catmull-Rom {catmull_rom}, taa {taa:?}, taau {taau}, sharpen {sharpen:?}"
        );
        assert!(
            hole.stats.instances_drawn < all.stats.instances_drawn,
            "{what}: the hole skips nothing ({} instances drawn, {} without it)",
            hole.stats.instances_drawn,
            all.stats.instances_drawn
        );
        assert!(hole.stats.triangles < all.stats.triangles, "{what}");
        for eye in 0..2 {
            let diff = common::pixels_differing(&hole.images[eye], &all.images[eye]);
            assert_eq!(diff, 0, "{what}, eye {eye}: {diff} pixels differ");
        }
        eprintln!(
            "{what}: {} of {} instances drawn, {} of {} triangles",
            hole.stats.instances_drawn,
            all.stats.instances_drawn,
            hole.stats.triangles,
            all.stats.triangles
        );
    }
}

/// With `gpu-cull` the cull makes the inset's two lists (the wide views'
/// with the hole, the inset's own): the eye images equal the CPU-built
/// lists' bit for bit, and so do those of `inset-wide-all`, which draws
/// more instances; with `lod` the wide views' levels follow their density.
#[test]
fn with_gpu_cull_the_cull_makes_the_inset_lists() {
    let (ctx, scene, profile, pose, fovs) = fixture();
    let base = WIDE;
    for (stereo, gaze) in [
        (StereoMode::Multiview, [0.0, 0.0]),
        (StereoMode::TwoPass, [0.3, -0.2]),
    ] {
        let run = |gpu_cull: bool, wide_all: bool| {
            let mut c = config(stereo, Some(Inset { wide_all, ..base }), gaze);
            if gpu_cull {
                c.apply_opts(
                    "superfrustum,gpu-cull",
                    &vergence::bench::plan::cull_names(),
                )
                .unwrap();
            }
            render_config(&ctx, &scene, &profile, pose, &c, W, H)
        };
        let (cpu, gpu, gpu_all) = (run(false, false), run(true, false), run(true, true));
        let what = format!("{stereo:?}, gaze {gaze:?}");
        let drawn = |f: &common::Frame| f.stats.instances_drawn;
        assert!(
            drawn(&gpu) < drawn(&gpu_all),
            "{what}: the hole skips nothing on the GPU ({} against {})",
            drawn(&gpu),
            drawn(&gpu_all)
        );
        let culled = gpu
            .stats
            .gpu_cull
            .expect("GPU culling stats")
            .passed_frustum;
        // Both lists: every kept instance is in the wide list or the
        // inset's, and the inset's is not all of them.
        assert!(
            drawn(&gpu_all) > culled && drawn(&gpu_all) < 2 * culled,
            "{what}: {} drawn for {culled} kept",
            drawn(&gpu_all)
        );
        for eye in 0..2 {
            for (name, other) in [("CPU lists", &cpu), ("inset-wide-all", &gpu_all)] {
                let diff = common::pixels_differing(&gpu.images[eye], &other.images[eye]);
                assert_eq!(
                    diff, 0,
                    "{what}, eye {eye}: {diff} pixels differ from {name}"
                );
            }
        }
        eprintln!(
            "{what}: GPU lists {} (wide-all {}) of {culled} kept",
            drawn(&gpu),
            drawn(&gpu_all)
        );
    }
    // With lod the wide views select their levels at their own density:
    // at F = 0.5 they draw fewer triangles than at F = 1 (the inset's list,
    // at the eyes' density, is the same), and the core is still the full
    // render's (the inset's levels are the eyes').
    let lod = |inset: Option<Inset>| {
        let mut c = config(StereoMode::Multiview, inset, [0.0; 2]);
        c.apply_opts(
            "superfrustum,gpu-cull,lod",
            &vergence::bench::plan::cull_names(),
        )
        .unwrap();
        render_config(&ctx, &scene, &profile, pose, &c, W, H)
    };
    let at = |wide_scale: f64| {
        lod(Some(Inset {
            wide_scale,
            wide_all: true,
            ..base
        }))
    };
    let (half, whole, full) = (at(0.5), at(1.0), lod(None));
    assert!(
        half.stats.triangles < whole.stats.triangles,
        "the wide views' levels do not follow their density: {} triangles at F = 0.5, {} at 1",
        half.stats.triangles,
        whole.stats.triangles
    );
    let rect = inset_rect(&fovs, [0.0; 2], 30.0, W, H);
    for eye in 0..2 {
        let (inside, same) = core_matches(&half.images[eye], &full.images[eye], &rect);
        assert!(inside > 100, "{rect:?}");
        assert_eq!(
            same, inside,
            "lod, eye {eye}: the core is the full render's"
        );
    }
}

fn config_without_aq(inset: Option<Inset>, gaze: [f32; 2]) -> RenderConfig {
    config(StereoMode::Multiview, inset, gaze)
}

/// The focus views a quad-views runtime would give for `fovs`: `k` times
/// each eye's tangents (what `examples/quad_views_layer.rs` offers).
fn focus_of(fovs: &[vergence::view::Fov], k: f64) -> [vergence::view::Fov; 2] {
    let f = |v: &vergence::view::Fov| {
        let t = v.tangents();
        vergence::view::Fov {
            left: (t[0] * k).atan(),
            right: (t[1] * k).atan(),
            up: (t[2] * k).atan(),
            down: (t[3] * k).atan(),
        }
    };
    [f(&fovs[0]), f(&fovs[1])]
}

/// A quad output (`XR_VARJO_quad_views`): no composite; the wide views go
/// out as the half-size render's own pixels and the insets as the full
/// render's pixels inside the rectangle the runtime's focus views give,
/// with nothing feathered, in multiview (copied), two-pass (blitted into
/// another format) and with `inset-wide-1x` (the one-sample half-size
/// render's pixels); the rectangle follows the focus views.
#[test]
fn a_quad_output_gives_the_wide_views_and_the_insets_as_they_are() {
    use ash::vk;
    use vergence::gpu::memory::{Image, ImageDesc};
    use vergence::render::{FrameOutput, OutputSpec, Renderer};
    let (ctx, scene, profile, pose, fovs) = fixture();
    let settings = SETTINGS;
    let plain = |stereo, w, h| {
        render_config(
            &ctx,
            &scene,
            &profile,
            pose,
            &config(stereo, None, [0.0; 2]),
            w,
            h,
        )
    };
    let full = plain(StereoMode::Multiview, W, H);
    let wide = plain(StereoMode::Multiview, W / 2, H / 2);
    // inset-wide-1x: the wide views at one sample.
    let wide_1x = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &{
            let mut rc = config(StereoMode::Multiview, None, [0.0; 2]);
            rc.frame.msaa = 1;
            rc
        },
        W / 2,
        H / 2,
    );
    for (stereo, format, k, one) in [
        (
            StereoMode::Multiview,
            vergence::render::attachments::COLOR_FORMAT,
            0.4,
            false,
        ),
        (StereoMode::TwoPass, vk::Format::B8G8R8A8_SRGB, 0.25, false),
        (
            StereoMode::Multiview,
            vergence::render::attachments::COLOR_FORMAT,
            0.3,
            true,
        ),
    ] {
        let settings = Inset {
            wide_1x: one,
            ..settings
        };
        let wide = if one { &wide_1x } else { &wide };
        let before = ctx.validation_messages();
        let spec = OutputSpec {
            color_format: format,
            depth: false,
            quad: true,
        };
        let extent = vk::Extent2D {
            width: W,
            height: H,
        };
        let mut r = Renderer::with_output(
            ctx.clone(),
            &scene,
            &config(stereo, Some(settings), [0.0; 2]),
            extent,
            Some(spec),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let (sets, layers) = match stereo {
            StereoMode::Multiview => (1, 2),
            StereoMode::TwoPass => (2, 1),
        };
        let half = vk::Extent2D {
            width: W / 2,
            height: H / 2,
        };
        let make = |e| {
            (0..sets)
                .map(|_| {
                    Image::new(
                        &ctx,
                        &ImageDesc::eye_copy("quad", format, e, layers, "test"),
                    )
                    .unwrap()
                })
                .collect::<Vec<_>>()
        };
        let (wide_out, inset_out) = (make(half), make(extent));
        let out = FrameOutput {
            color: wide_out.iter().map(|i| i.image).collect(),
            inset: inset_out.iter().map(|i| i.image).collect(),
            ..FrameOutput::default()
        };
        let focus = focus_of(&fovs, k);
        r.set_focus(Some(focus));
        r.record_frame(&profile.rig(pose), None).unwrap();
        r.submit_frame(Some(&out), true).unwrap();
        let got = r.read_quad_images().unwrap();
        let stats = r.take_completed().expect("the frame finished");
        assert!(stats.gpu_ms.contains_key("forward-inset"));
        assert!(
            !stats.gpu_ms.contains_key("inset-composite"),
            "the runtime composites: {:?}",
            stats.gpu_ms.keys()
        );
        let rect = vergence::view::inset::focus_rect(&fovs, &focus, W, H);
        assert_eq!(r.inset_rect(), rect);
        assert_eq!(
            (r.output_extent(), r.inset_extent()),
            (
                half,
                vk::Extent2D {
                    width: rect.width(),
                    height: rect.height()
                }
            )
        );
        assert!(
            rect.width() > 20 && rect.width() < W - 40,
            "{stereo:?}: {rect:?}"
        );
        // BGRA blits hold the same colours: compare RGB channels.
        let rgb = |p: &image::Rgba<u8>| {
            if format == vk::Format::B8G8R8A8_SRGB {
                [p[2], p[1], p[0]]
            } else {
                [p[0], p[1], p[2]]
            }
        };
        for eye in 0..2 {
            let (w_img, i_img) = (&got[eye], &got[2 + eye]);
            assert_eq!(w_img.dimensions(), (W / 2, H / 2));
            assert_eq!(i_img.dimensions(), (rect.width(), rect.height()));
            let wide_diff = (0..H / 2)
                .flat_map(|y| (0..W / 2).map(move |x| (x, y)))
                .filter(|&(x, y)| {
                    let p = wide.images[eye].get_pixel(x, y);
                    rgb(w_img.get_pixel(x, y)) != [p[0], p[1], p[2]]
                })
                .count();
            assert!(
                wide_diff * 1000 <= (W * H / 4) as usize,
                "{stereo:?} eye {eye}: {wide_diff} wide-view pixels differ from the half-size render"
            );
            let inset_diff = (0..rect.height())
                .flat_map(|y| (0..rect.width()).map(move |x| (x, y)))
                .filter(|&(x, y)| {
                    let p = full.images[eye].get_pixel(rect.x0 + x, rect.y0 + y);
                    rgb(i_img.get_pixel(x, y)) != [p[0], p[1], p[2]]
                })
                .count();
            assert_eq!(
                inset_diff, 0,
                "{stereo:?} eye {eye}: the inset is the full render's pixels, seam included"
            );
        }
        drop(r);
        for i in wide_out.into_iter().chain(inset_out) {
            i.destroy(&ctx);
        }
        common::assert_no_validation_since(&ctx, before);
    }
}
