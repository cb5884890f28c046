//! Effort reduction: the HMD stencil mask. Hidden pixels stay untouched,
//! visible pixels are unchanged, and fragment-shader invocations (pipeline
//! statistics) drop by the masked fraction.

mod common;

use glam::DVec3;
use vergence::config::{RenderConfig, StereoMode};
use vergence::view::lens::{mask_image, masked_fraction};
use vergence::view::profile::HmdProfile;
use vergence::view::Pose;

const W: u32 = 160;
const H: u32 = 120;

fn config(stereo: StereoMode, stencil_mask: bool) -> RenderConfig {
    RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo,
            msaa: 1,
            ..Default::default()
        },
        effort: vergence::config::EffortConfig {
            stencil_mask,
            ..Default::default()
        },
        ..RenderConfig::default()
    }
}

/// Pixels whose 3×3 neighbourhood is entirely `want` in `mask`.
fn interior(mask: &[bool], want: bool) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for y in 1..H - 1 {
        for x in 1..W - 1 {
            let all = (-1i32..=1).all(|dy| {
                (-1i32..=1).all(|dx| {
                    mask[((y as i32 + dy) as u32 * W + (x as i32 + dx) as u32) as usize] == want
                })
            });
            if all {
                out.push((x, y));
            }
        }
    }
    out
}

#[test]
fn stencil_mask_leaves_hidden_pixels_untouched_and_the_rest_unchanged() {
    let ctx = common::context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let scene = common::load("factory:2000");
    let pose = Pose::from_euler_deg(DVec3::new(3.0, 1.7, 2.0), -25.0, -5.0, 0.0);
    for stereo in [StereoMode::Multiview, StereoMode::TwoPass] {
        let off = common::render_config(&ctx, &scene, &profile, pose, &config(stereo, false), W, H);
        let on = common::render_config(&ctx, &scene, &profile, pose, &config(stereo, true), W, H);
        for eye in 0..2 {
            let fov = profile.views[eye].fov;
            let mask = mask_image(&profile.hidden_areas[eye], &fov, W, H);
            let hidden = interior(&mask, true);
            let visible = interior(&mask, false);
            assert!(hidden.len() > 1000 && visible.len() > 10000);
            for &(x, y) in &hidden {
                assert_eq!(
                    on.images[eye].get_pixel(x, y).0,
                    [0, 0, 0, 255],
                    "{stereo:?} eye {eye}: hidden pixel ({x}, {y}) was drawn"
                );
            }
            for &(x, y) in &visible {
                assert_eq!(
                    on.images[eye].get_pixel(x, y),
                    off.images[eye].get_pixel(x, y),
                    "{stereo:?} eye {eye}: visible pixel ({x}, {y}) changed"
                );
            }
        }
    }
}

#[test]
fn fragment_invocations_drop_by_the_masked_fraction() {
    let ctx = common::context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let fraction: f64 = (0..2)
        .map(|e| masked_fraction(&profile.hidden_areas[e], &profile.views[e].fov, W, H))
        .sum::<f64>()
        / 2.0;
    assert!(
        (fraction - 0.215).abs() < 0.02,
        "lens default hides {fraction}"
    );
    // Sky only (looking up from far above the hall): one shaded fragment
    // per pixel, so the drop must equal the masked fraction.
    let factory = common::load("factory:2000");
    let up = Pose::from_euler_deg(DVec3::new(0.0, 5000.0, 0.0), 0.0, 89.0, 0.0);
    let invocations = |pose, mask| {
        let f = common::render_config(
            &ctx,
            &factory,
            &profile,
            pose,
            &config(StereoMode::Multiview, mask),
            W,
            H,
        );
        f.stats
            .pipeline
            .expect("pipeline statistics")
            .fragment_invocations as f64
    };
    let (off, on) = (invocations(up, false), invocations(up, true));
    assert_eq!(
        off,
        (2 * W * H) as f64,
        "one invocation per pixel without the mask"
    );
    let drop = 1.0 - on / off;
    let pose = Pose::from_euler_deg(DVec3::new(3.0, 1.7, 2.0), -25.0, -5.0, 0.0);
    let (f_off, f_on) = (invocations(pose, false), invocations(pose, true));
    let f_drop = 1.0 - f_on / f_off;
    eprintln!(
        "{}: sky {off} -> {on} invocations ({:.1} % less), factory:2000 {f_off} -> {f_on} ({:.1} % less); masked {:.1} %",
        ctx.device_name,
        drop * 100.0,
        f_drop * 100.0,
        fraction * 100.0
    );
    if ctx.device_name.contains("llvmpipe") {
        // llvmpipe counts fragment-shader invocations per covered block
        // before its early depth/stencil test, so the statistic cannot
        // show the saving there (the pixels above prove the test happens).
        // Should that change, this fails and the assertions below apply.
        assert_eq!(on, off, "llvmpipe now counts after early tests");
        return;
    }
    assert!(
        (drop - fraction).abs() < 0.005,
        "sky: invocations dropped by {drop:.4}, masked fraction {fraction:.4}"
    );
    // A real frame: the hidden border holds less overdraw than the centre,
    // so the drop is smaller, but it must be substantial.
    assert!(
        f_drop > 0.5 * fraction,
        "factory: drop {f_drop:.4} vs masked {fraction:.4}"
    );
}

#[test]
fn foveation_uses_the_shading_rate_attachment_or_falls_back_to_off() {
    use vergence::view::foveation::{shaded_fraction, Level};
    let ctx = common::context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let factory = common::load("factory:2000");
    let pose = Pose::from_euler_deg(DVec3::new(3.0, 1.7, 2.0), -25.0, -5.0, 0.0);
    let up = Pose::from_euler_deg(DVec3::new(0.0, 5000.0, 0.0), 0.0, 89.0, 0.0);
    let (w, h) = (320, 240);
    let make = |level| {
        let mut rc = config(StereoMode::Multiview, false);
        rc.effort.foveation = level;
        rc
    };
    let extent = ash::vk::Extent2D {
        width: w,
        height: h,
    };
    let r = vergence::render::Renderer::new(ctx.clone(), &factory, &make(Level::High), extent)
        .expect("renderer");
    let path = r.report().foveation;
    drop(r);
    let full = common::render_config(&ctx, &factory, &profile, pose, &make(Level::Off), w, h);
    let fov = common::render_config(&ctx, &factory, &profile, pose, &make(Level::High), w, h);
    let sky_full = common::render_config(&ctx, &factory, &profile, up, &make(Level::Off), w, h);
    let sky_fov = common::render_config(&ctx, &factory, &profile, up, &make(Level::High), w, h);
    let inv = |f: &common::Frame| f.stats.pipeline.expect("statistics").fragment_invocations as f64;
    match ctx.caps.shading_rate_texel {
        None => {
            assert!(
                path.starts_with("off: ") && path.contains("VK_KHR_fragment_shading_rate"),
                "{path}"
            );
            for eye in 0..2 {
                assert_eq!(
                    full.images[eye], fov.images[eye],
                    "fallback renders at full rate"
                );
            }
            assert_eq!(inv(&sky_full), inv(&sky_fov));
        }
        Some(texel) => {
            assert!(path.starts_with("vk-khr-fragment-shading-rate"), "{path}");
            let want = shaded_fraction(Level::High, [0.0, 0.0], w, h, texel);
            let got = inv(&sky_fov) / inv(&sky_full);
            eprintln!(
                "{}: sky invocations x{got:.3} (rate image predicts x{want:.3})",
                ctx.device_name
            );
            assert!(
                (got - want).abs() < 0.05,
                "sky invocations x{got:.3}, rate image x{want:.3}"
            );
            for eye in 0..2 {
                let f = vergence::bench::metrics::flip(&full.images[eye], &fov.images[eye], 30.0)
                    .unwrap();
                eprintln!("eye {eye}: FLIP mean {:.4} vs full rate", f.mean);
                assert!(
                    f.mean > 0.0 && f.mean < 0.1,
                    "foveated frame differs but stays close: {}",
                    f.mean
                );
            }
        }
    }
}

#[test]
fn stats_name_the_paths_that_ran() {
    use vergence::targets::headless::{render_to_dir, RenderJob};
    let out = common::root().join("target/effort-stats");
    let mut config = RenderConfig {
        frame: vergence::config::FrameConfig {
            msaa: 1,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    config
        .apply_opts("stencil-mask,foveation=medium", &["none"])
        .unwrap();
    let job = RenderJob {
        scene: "factory:500".into(),
        hmd: "monado-sim".into(),
        pose: Some(Pose::from_euler_deg(
            DVec3::new(3.0, 1.7, 2.0),
            -25.0,
            -5.0,
            0.0,
        )),
        camera: None,
        framing: Default::default(),
        rig: None,
        config,
        size: Some((96, 64)),
        out: out.clone(),
        frames: 1,
        distorted: None,
        head_turn_deg_s: 0.0,
    };
    let stats = render_to_dir(&job).unwrap_or_else(|e| panic!("{e}"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("stats.json")).unwrap()).unwrap();
    assert_eq!(json["config"]["stencil_mask"], true);
    assert_eq!(json["foveation"], stats.renderer.foveation);
    let ctx = common::context();
    if ctx.caps.shading_rate_texel.is_none() {
        assert!(
            stats.renderer.foveation.starts_with("off: "),
            "{}",
            stats.renderer.foveation
        );
        assert_eq!(
            json["config"]["foveation"], "off",
            "the fallback is recorded"
        );
    } else {
        assert!(stats
            .renderer
            .foveation
            .starts_with("vk-khr-fragment-shading-rate"));
    }
    // Per-view render areas: the line states what the device's extension
    // list says, and that vergence does not use them.
    // SAFETY: enumeration on the context's valid physical device.
    let exts = unsafe {
        ctx.instance
            .enumerate_device_extension_properties(ctx.physical_device)
    }
    .unwrap();
    let listed = exts.iter().any(|e| {
        e.extension_name_as_c_str().ok() == Some(ash::qcom::multiview_per_view_render_areas::NAME)
    });
    assert_eq!(ctx.caps.per_view_render_areas, listed);
    let line = &stats.renderer.per_view_render_areas;
    let said = if listed {
        "offered by "
    } else {
        "not offered by "
    };
    assert!(
        line.starts_with(&format!("{said}{}; unused: ", ctx.device_name)),
        "{line}"
    );
    assert_eq!(json["per_view_render_areas"], line.as_str());
}

#[test]
fn per_view_render_areas_line_states_the_offer() {
    use vergence::render::report::per_view_render_areas;
    let on = per_view_render_areas(true, "GPU X");
    let off = per_view_render_areas(false, "GPU X");
    assert!(on.starts_with("offered by GPU X; unused: "), "{on}");
    assert!(off.starts_with("not offered by GPU X; unused: "), "{off}");
    for line in [on, off] {
        assert!(!line.contains('\n') && line.len() < 160, "{line}");
    }
}

#[test]
fn rdm_skips_checker_quads_beyond_the_radius_and_the_fill_restores_them() {
    use vergence::bench::metrics::flip;
    let ctx = common::context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let scene = common::load("factory:2000");
    let pose = Pose::from_euler_deg(DVec3::new(3.0, 1.7, 2.0), -25.0, -5.0, 0.0);
    let radius = 0.5f32;
    let cfg = |stereo, opts: &str| {
        let mut c = config(stereo, false);
        c.apply_opts(opts, &["none"]).unwrap();
        c
    };
    let rdm = format!("rdm={radius}");
    let nofill = format!("rdm={radius},rdm-nofill");
    let mut filled_by_mode = Vec::new();
    for stereo in [StereoMode::Multiview, StereoMode::TwoPass] {
        let off = common::render_config(&ctx, &scene, &profile, pose, &cfg(stereo, ""), W, H);
        let holes =
            common::render_config(&ctx, &scene, &profile, pose, &cfg(stereo, &nofill), W, H);
        let filled = common::render_config(&ctx, &scene, &profile, pose, &cfg(stereo, &rdm), W, H);
        assert!(
            filled.stats.gpu_ms.contains_key("rdm-fill"),
            "{:?}",
            filled.stats.gpu_ms
        );
        assert!(!holes.stats.gpu_ms.contains_key("rdm-fill"));
        for eye in 0..2 {
            let (mut skipped, mut black_after_fill) = (0, 0);
            for y in 0..H {
                for x in 0..W {
                    let nx = (x as f32 + 0.5) / W as f32 * 2.0 - 1.0;
                    let ny = (y as f32 + 0.5) / H as f32 * 2.0 - 1.0;
                    let d = (nx * nx + ny * ny).sqrt();
                    let checker = ((x / 2 + y / 2) & 1) == 1;
                    let px = |f: &common::Frame| f.images[eye].get_pixel(x, y).0;
                    if d < radius - 0.02 {
                        assert_eq!(
                            px(&holes),
                            px(&off),
                            "{stereo:?} inside the radius at ({x}, {y})"
                        );
                        assert_eq!(px(&filled), px(&off), "{stereo:?} fill changed ({x}, {y})");
                    } else if d > radius + 0.02 && checker {
                        skipped += 1;
                        assert_eq!(
                            px(&holes),
                            [0, 0, 0, 255],
                            "{stereo:?} skipped quad drawn at ({x}, {y})"
                        );
                        if px(&filled) == [0, 0, 0, 255] {
                            black_after_fill += 1;
                        }
                    }
                }
            }
            assert!(skipped > 2000, "{skipped} skipped pixels");
            assert!(
                black_after_fill * 100 < skipped,
                "{black_after_fill} of {skipped} still empty"
            );
            let e_holes = flip(&off.images[eye], &holes.images[eye], 30.0)
                .unwrap()
                .mean;
            let e_fill = flip(&off.images[eye], &filled.images[eye], 30.0)
                .unwrap()
                .mean;
            eprintln!(
                "{stereo:?} eye {eye}: FLIP mean {e_holes:.4} with holes, {e_fill:.4} filled"
            );
            // At 160×120 a 2×2 quad is coarse next to the scene's detail, so
            // the reconstruction error is large here; it must still remove
            // most of the holes' error.
            assert!(
                e_fill < e_holes / 3.0 && e_fill < 0.15,
                "fill {e_fill}, holes {e_holes}"
            );
        }
        filled_by_mode.push(filled);
    }
    for eye in 0..2 {
        let m = flip(
            &filled_by_mode[0].images[eye],
            &filled_by_mode[1].images[eye],
            30.0,
        )
        .unwrap();
        assert!(m.mean < 0.005, "multiview vs two-pass with RDM: {}", m.mean);
    }
}

/// With the inset the checkerboard goes in the wide views, with LMS in its
/// image, and the fill runs in place before the composite or resample:
/// the centre (the inset, or LMS's image inside the radius) is the frame
/// without RDM pixel for pixel, and the fill removes most of the holes'
/// error.
#[test]
fn rdm_in_the_wide_views_and_the_lms_image_fills_before_they_are_composited() {
    use vergence::bench::metrics::flip;
    let ctx = common::context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let scene = common::load("factory:2000");
    let pose = Pose::from_euler_deg(DVec3::new(3.0, 1.7, 2.0), -25.0, -5.0, 0.0);
    let render = |stereo, opts: &str| {
        let mut c = config(stereo, false);
        c.frame.msaa = 4;
        c.apply_opts(opts, &["none"]).unwrap();
        c.validate().unwrap();
        common::render_config(&ctx, &scene, &profile, pose, &c, W, H)
    };
    for (stereo, base) in [
        (StereoMode::Multiview, "inset=0.5"),
        (StereoMode::TwoPass, "inset=0.5"),
        (StereoMode::Multiview, "inset=0.5,inset-taau"),
        (StereoMode::Multiview, "lms=0.3"),
        (StereoMode::TwoPass, "lms=0.3,stencil-mask"),
    ] {
        let off = render(stereo, base);
        let holes = render(stereo, &format!("{base},rdm=0.4,rdm-nofill"));
        let filled = render(stereo, &format!("{base},rdm=0.4"));
        let what = format!("{stereo:?} {base}");
        assert!(filled.stats.gpu_ms.contains_key("rdm-fill"), "{what}");
        for eye in 0..2 {
            let (cx, cy) = (W / 2, H / 2);
            for y in cy - 8..cy + 8 {
                for x in cx - 8..cx + 8 {
                    let px = |f: &common::Frame| f.images[eye].get_pixel(x, y).0;
                    assert_eq!(
                        px(&filled),
                        px(&off),
                        "{what}: the centre changed at ({x}, {y})"
                    );
                }
            }
            let e_holes = flip(&off.images[eye], &holes.images[eye], 30.0)
                .unwrap()
                .mean;
            let e_fill = flip(&off.images[eye], &filled.images[eye], 30.0)
                .unwrap()
                .mean;
            eprintln!("{what} eye {eye}: FLIP mean {e_holes:.4} with holes, {e_fill:.4} filled");
            assert!(e_holes > 0.01, "{what}: no holes ({e_holes})");
            assert!(
                e_fill < e_holes / 2.0 && e_fill < 0.15,
                "{what}: fill {e_fill}, holes {e_holes}"
            );
        }
    }
}

/// The MFFR tests' frame: factory:20000 on the simulated HMD from the
/// hall's corner, at 320×240 per eye.
struct MffrScene {
    ctx: std::sync::Arc<vergence::gpu::Context>,
    profile: HmdProfile,
    scene: vergence::scene::Scene,
    pose: Pose,
}

impl MffrScene {
    fn new() -> MffrScene {
        MffrScene {
            ctx: common::context(),
            profile: HmdProfile::load("monado-sim").unwrap(),
            scene: common::load("factory:20000"),
            pose: Pose::from_euler_deg(DVec3::new(3.0, 1.7, 2.0), -25.0, -5.0, 0.0),
        }
    }

    fn render(&self, c: &RenderConfig) -> common::Frame {
        common::render_config(
            &self.ctx,
            &self.scene,
            &self.profile,
            self.pose,
            c,
            320,
            240,
        )
    }
}

/// The FLIP mean of `b` against `a`, both eyes averaged.
fn flip_both(a: &common::Frame, b: &common::Frame) -> f32 {
    (0..2)
        .map(|e| {
            vergence::bench::metrics::flip(&a.images[e], &b.images[e], 30.0)
                .unwrap()
                .mean
        })
        .sum::<f32>()
        / 2.0
}

/// MFFR with the inset's two scopes: the far field is composited into the
/// wide views and into the inset, each scope's near field drawn over it.
/// Inside the inset the frame is MFFR's own pixel for pixel; overall it is
/// as near the inset without MFFR as MFFR is to the plain frame.
#[test]
fn mffr_composites_the_far_field_into_the_wide_views_and_the_inset() {
    use vergence::bench::plan::cull_names;
    let m = MffrScene::new();
    let (w, h) = (320, 240);
    let render = |stereo, opts: &str| {
        let mut c = RenderConfig {
            frame: vergence::config::FrameConfig {
                stereo,
                ..Default::default()
            },
            ..RenderConfig::default()
        };
        c.apply_opts(opts, &cull_names()).unwrap();
        c.validate().unwrap();
        m.render(&c)
    };
    let mean = flip_both;
    let join = |parts: &[&str]| {
        let v: Vec<&str> = parts.iter().copied().filter(|p| !p.is_empty()).collect();
        v.join(",")
    };
    for (stereo, cull, taau) in [
        (StereoMode::Multiview, "", ""),
        (StereoMode::TwoPass, "", ""),
        (StereoMode::Multiview, "superfrustum,gpu-cull", ""),
        (StereoMode::Multiview, "", "inset-taau"),
    ] {
        let what = format!("{stereo:?} {cull} {taau}");
        let plain = render(stereo, cull);
        let mffr = render(stereo, &join(&[cull, "mffr=8"]));
        let inset = render(stereo, &join(&[cull, "inset=0.5", taau]));
        let both = render(stereo, &join(&[cull, "inset=0.5", taau, "mffr=8"]));
        assert!(both.stats.gpu_ms.contains_key("mffr-far"), "{what}");
        if taau.is_empty() {
            for e in 0..2 {
                for y in h / 2 - 8..h / 2 + 8 {
                    for x in w / 2 - 8..w / 2 + 8 {
                        assert_eq!(
                            both.images[e].get_pixel(x, y),
                            mffr.images[e].get_pixel(x, y),
                            "{what}: inside the inset at ({x}, {y})"
                        );
                    }
                }
            }
        }
        let (e_both, e_mffr) = (mean(&inset, &both), mean(&plain, &mffr));
        eprintln!("{what}: FLIP inset+mffr vs inset {e_both:.4}, mffr vs plain {e_mffr:.4}");
        assert!(
            e_both < 0.1 && e_both < 2.0 * e_mffr + 0.01,
            "{what}: {e_both} vs {e_mffr}"
        );
    }
}

#[test]
fn mffr_composites_one_far_field_into_both_eyes() {
    use vergence::bench::metrics::flip;
    let m = MffrScene::new();
    let (ctx, profile, scene, pose) = (&m.ctx, &m.profile, &m.scene, m.pose);
    let (w, h) = (320, 240);
    let cfg = |stereo, opts: &str| {
        let mut c = RenderConfig {
            frame: vergence::config::FrameConfig {
                stereo,
                ..Default::default()
            },
            ..RenderConfig::default()
        };
        c.apply_opts(opts, &["none"]).unwrap();
        c
    };
    let render = |c: &RenderConfig| m.render(c);
    let stereo = render(&cfg(StereoMode::Multiview, ""));
    let mean = flip_both;
    // Split beyond everything: the far field holds only the sky.
    let all_near = render(&cfg(StereoMode::Multiview, "mffr=100000"));
    assert!(all_near.stats.gpu_ms.contains_key("mffr-far"));
    let e_all_near = mean(&stereo, &all_near);
    // Automatic split (1 px disparity) and a close split that puts most of
    // the hall in the far field.
    let auto = render(&cfg(StereoMode::Multiview, "mffr"));
    let close = render(&cfg(StereoMode::Multiview, "mffr=8"));
    let shifted = render(&cfg(StereoMode::Multiview, "mffr=8,mffr-depth-shift"));
    let (e_auto, e_close, e_shift) = (
        mean(&stereo, &auto),
        mean(&stereo, &close),
        mean(&stereo, &shifted),
    );
    eprintln!(
        "MFFR FLIP mean vs stereo: sky only {e_all_near:.4}, auto split {e_auto:.4}, split 8 m {e_close:.4}, split 8 m depth-shifted {e_shift:.4}"
    );
    assert!(e_all_near < 0.01, "resampled sky: {e_all_near}");
    assert!(e_auto < 0.03, "auto split: {e_auto}");
    assert!(e_close < 0.1, "8 m split: {e_close}");
    assert!(
        shifted.images[0] != close.images[0],
        "depth shift changes the far field"
    );
    // Alternate eye: one far image per eye (both rendered on the first
    // frame), so the far field keeps its disparity.
    let alt = render(&cfg(StereoMode::Multiview, "mffr=8,mffr-alternate-eye"));
    let e_alt = mean(&stereo, &alt);
    eprintln!("MFFR alternate eye, split 8 m: FLIP mean {e_alt:.4}");
    assert!(
        e_alt < e_close,
        "per-eye far images {e_alt} vs one {e_close}"
    );
    // Later frames re-render one eye's far image each; a still rig gives
    // the same frame again.
    let extent = ash::vk::Extent2D {
        width: w,
        height: h,
    };
    let mut r = vergence::render::Renderer::new(
        ctx.clone(),
        scene,
        &cfg(StereoMode::Multiview, "mffr=8,mffr-alternate-eye"),
        extent,
    )
    .unwrap();
    let rig = profile.rig(pose);
    let mut frames = Vec::new();
    for _ in 0..3 {
        let stats = r.render(&rig, None, true).unwrap();
        assert!(stats.gpu_ms.contains_key("mffr-far"));
        frames.push(r.read_images().unwrap());
    }
    drop(r);
    assert_eq!(frames[0], frames[1]);
    assert_eq!(frames[1], frames[2]);
    // Both eyes of the far field come from one image: with the split at
    // 8 m, content beyond it has no disparity left in the plain variant.
    let tp = render(&cfg(StereoMode::TwoPass, "mffr=8"));
    for e in 0..2 {
        let m = flip(&close.images[e], &tp.images[e], 30.0).unwrap().mean;
        assert!(m < 0.005, "multiview vs two-pass with MFFR: {m}");
    }
}

/// The far-field split by depth draws fewer instances and triangles and
/// changes no pixel: an instance left out of the near passes lies wholly
/// beyond the split plane (its depth would fail against the cleared depth),
/// one left out of the far pass wholly before the far camera's near plane.
#[test]
fn mffr_depth_split_draws_less_and_changes_no_pixel() {
    let ctx = common::context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let scene = common::load("factory:20000");
    let extent = ash::vk::Extent2D {
        width: 160,
        height: 120,
    };
    let rig = profile.rig(Pose::from_euler_deg(
        DVec3::new(3.0, 1.7, 2.0),
        -25.0,
        -5.0,
        0.0,
    ));
    for (stereo, opts) in [
        (StereoMode::Multiview, "mffr=8"),
        (StereoMode::TwoPass, "mffr=12,mffr-depth-shift"),
        (StereoMode::Multiview, "mffr=8,mffr-alternate-eye"),
    ] {
        let mut c = RenderConfig {
            frame: vergence::config::FrameConfig {
                stereo,
                ..Default::default()
            },
            ..RenderConfig::default()
        };
        c.apply_opts(opts, &["none"]).unwrap();
        let run = |partition: bool| {
            let mut r = vergence::render::Renderer::new(ctx.clone(), &scene, &c, extent).unwrap();
            r.mffr_partition = partition;
            let mut out = Vec::new();
            for _ in 0..2 {
                let stats = r.render(&rig, None, true).unwrap();
                out.push((stats, r.read_images().unwrap()));
            }
            out
        };
        let (split, whole) = (run(true), run(false));
        for ((s, a), (w, b)) in split.iter().zip(&whole) {
            assert!(a == b, "{opts}: the split changed pixels");
            assert!(
                s.triangles < w.triangles && s.instances_drawn < w.instances_drawn,
                "{opts}: {} vs {} triangles",
                s.triangles,
                w.triangles
            );
        }
        eprintln!(
            "{opts}: triangles per frame {} with the split, {} without",
            split[1].0.triangles, whole[1].0.triangles
        );
    }
    assert_eq!(ctx.validation_messages(), 0, "{:?}", ctx.validation_log());
}

#[test]
fn a_fallback_is_said_once() {
    let dir = common::scratch("effort", "said-once");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args([
            "render",
            "--scene",
            "factory:50",
            "--width",
            "48",
            "--height",
            "40",
        ])
        .args(["--opt", "foveation=high", "--out"])
        .arg(&dir)
        .env("NO_COLOR", "1")
        .output()
        .expect("vergence runs");
    assert!(out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    let said = stderr
        .lines()
        .filter(|l| l.contains("foveation High"))
        .count();
    let ctx = common::context();
    let expected = usize::from(ctx.caps.shading_rate_texel.is_none());
    assert_eq!(said, expected, "{stderr}");
}
