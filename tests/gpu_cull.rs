//! GPU-driven culling (`--opt gpu-cull`): the compute cull draws exactly the
//! instances CPU culling keeps (the counts read back from the GPU equal the
//! CPU batches'), the images are pixel-identical, multiview and two-pass,
//! with frames in flight and the masks and MSAA modes combined; zero
//! validation messages; combinations that cannot work are one clear error.

mod common;

use common::{context, load};
use glam::DVec3;
use std::sync::Arc;
use vergence::bench::plan::cull_names;
use vergence::config::{Culling, RenderConfig, StereoMode};
use vergence::cull::Strategy;
use vergence::gpu::Context;
use vergence::render::driver::{FrameDriver, FrameResult};
use vergence::render::Renderer;
use vergence::scene::Scene;
use vergence::view::profile::HmdProfile;
use vergence::view::{Pose, StereoRig};

const SIZE: u32 = 96;
const FRAMES: usize = 4;

/// A head path through the factory: it walks and turns each frame, so the
/// visible set changes from frame to frame.
fn path(profile: &HmdProfile) -> Vec<StereoRig> {
    (0..FRAMES)
        .map(|i| {
            let at = DVec3::new(20.0 - 2.0 * i as f64, 1.7, -20.0 + i as f64);
            profile.rig(Pose::from_euler_deg(at, 30.0 + 9.0 * i as f64, -4.0, 0.0))
        })
        .collect()
}

/// Drives `config` over `rigs`; returns every frame's result and the last
/// frame's images.
fn drive(
    ctx: &Arc<Context>,
    scene: &Scene,
    config: &RenderConfig,
    rigs: &[StereoRig],
) -> (Vec<FrameResult>, [image::RgbaImage; 2]) {
    let before = ctx.validation_messages();
    let extent = ash::vk::Extent2D {
        width: SIZE,
        height: SIZE,
    };
    let renderer =
        Renderer::new(ctx.clone(), scene, config, extent).unwrap_or_else(|e| panic!("{e}"));
    let mut driver = FrameDriver::new(renderer, scene).unwrap();
    let mut results = Vec::new();
    for (i, rig) in rigs.iter().enumerate() {
        driver
            .frame(rig, i as u64, i + 1 == rigs.len())
            .unwrap_or_else(|e| panic!("{e}"));
        results.extend(std::iter::from_fn(|| driver.take_completed()));
    }
    driver.finish().unwrap();
    results.extend(std::iter::from_fn(|| driver.take_completed()));
    let images = driver.read_images().unwrap();
    drop(driver);
    assert_eq!(
        ctx.validation_messages(),
        before,
        "Vulkan validation messages: {:#?}",
        ctx.validation_log()
    );
    assert_eq!(results.len(), rigs.len());
    (results, images)
}

/// The configuration of `opts`; a trailing `@N` sets N frames in flight.
fn config(opts: &str) -> RenderConfig {
    let mut c = RenderConfig::default();
    let (opts, slots) = match opts.split_once('@') {
        Some((o, n)) => (o.to_string(), n.parse().unwrap()),
        None => (opts.to_string(), 2),
    };
    c.apply_opts(&opts, &cull_names()).unwrap();
    c.submission.frames_in_flight = slots;
    c
}

/// Compares the GPU-culled run of `opts` with the CPU-culled one, frame by
/// frame (counts) and on the last frame's pixels.
fn same_as_cpu(ctx: &Arc<Context>, scene: &Scene, rigs: &[StereoRig], opts: &str) {
    let (cpu, cpu_img) = drive(ctx, scene, &config(opts), rigs);
    let gpu_opts = match opts.split_once('@') {
        Some((o, n)) => format!("{o},gpu-cull@{n}"),
        None => format!("{opts},gpu-cull"),
    };
    let (gpu, gpu_img) = drive(ctx, scene, &config(&gpu_opts), rigs);
    for (k, (c, g)) in cpu.iter().zip(&gpu).enumerate() {
        let kept = c.cull.expect("CPU culling stats").accepted;
        let g_cull = g.stats.gpu_cull.expect("GPU culling stats");
        assert_eq!(
            g_cull.tested,
            scene.instances.len() as u64,
            "{opts} frame {k}"
        );
        assert_eq!(
            g_cull.passed_frustum, kept,
            "{opts} frame {k}: instances kept"
        );
        assert!(
            kept > 0 && kept < scene.instances.len() as u64 / 2,
            "{opts} frame {k}: {kept}"
        );
        assert_eq!(
            g.stats.instances_drawn, c.stats.instances_drawn,
            "{opts} frame {k}: instances drawn"
        );
        assert_eq!(
            g.stats.triangles, c.stats.triangles,
            "{opts} frame {k}: triangles"
        );
        assert_eq!(
            g.stats.draw_calls, c.stats.draw_calls,
            "{opts} frame {k}: draw calls"
        );
        assert!(g.stats.gpu_ms.contains_key("cull-early") || g.stats.gpu_ms.is_empty());
    }
    for eye in 0..2 {
        let differing = common::pixels_differing(&cpu_img[eye], &gpu_img[eye]);
        assert_eq!(
            differing, 0,
            "{opts} eye {eye}: pixels differ from CPU culling"
        );
    }
}

#[test]
fn frustum_gpu_cull_matches_cpu_culling_multiview_and_two_pass() {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    let scene = load("factory:4000");
    let rigs = path(&profile);
    for stereo in ["multiview", "two-pass"] {
        for strategy in Strategy::ALL.iter().filter(|s| !s.may_miss()) {
            same_as_cpu(&ctx, &scene, &rigs, &format!("{stereo},{strategy}"));
        }
    }
}

#[test]
fn gpu_cull_combines_with_msaa_masks_and_foveation() {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    let scene = load("factory:2000");
    let rigs = path(&profile);
    for opts in [
        "multiview,no-msaa,superfrustum",
        "two-pass,per-eye,stencil-mask",
        "multiview,conical,rdm",
        "two-pass,no-msaa,superfrustum,stencil-mask,rdm,foveation",
        "multiview,per-eye,foveation=high",
        "multiview,superfrustum@1",
        "two-pass,conical-superfrustum,stencil-mask@3",
    ] {
        same_as_cpu(&ctx, &scene, &rigs, opts);
    }
}

/// With a monoscopic far field the GPU splits the visible instances into
/// the near views' draws and the far pass's as the CPU batcher does: the
/// same counts every frame and the same pixels, for a fixed and an
/// automatic split, without the split, and with alternating far eyes.
#[test]
fn gpu_cull_splits_near_from_far_like_the_cpu() {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    let scene = load("factory:3000");
    let rigs = path(&profile);
    for opts in [
        "multiview,superfrustum,mffr=12",
        "two-pass,per-eye,mffr",
        "multiview,superfrustum,no-msaa,mffr=8,mffr-no-split",
        "multiview,conical-superfrustum,mffr=10,mffr-alternate-eye,stencil-mask",
    ] {
        same_as_cpu(&ctx, &scene, &rigs, opts);
    }
}

#[test]
fn impossible_gpu_cull_combinations_are_one_clear_error() {
    let mut c = RenderConfig::default();
    c.apply_opts("gpu-cull", &cull_names()).unwrap();
    let e = c.validate().unwrap_err().to_string();
    assert!(e.contains("gpu-cull needs a culling strategy"), "{e}");
    let mut c = RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo: StereoMode::Multiview,
            ..Default::default()
        },
        culling: vergence::config::CullingConfig {
            cull: Culling::Strategy(Strategy::PerEye),
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    c.apply_opts("gpu-cull,occlusion,mffr", &cull_names())
        .unwrap();
    let e = c.validate().unwrap_err().to_string();
    assert!(e.contains("occlusion and mffr cannot be combined"), "{e}");
    let stderr = common::fails_with_one_error(
        std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
            .args([
                "render",
                "--scene",
                "factory:10",
                "--opt",
                "per-eye,gpu-cull,occlusion,mffr",
            ])
            .arg("--out")
            .arg(common::scratch("gpu-cull", "mffr")),
    );
    assert!(stderr.contains("occlusion and mffr"), "{stderr}");
    // A CPU visible list (the bench's empty-frame floor) is refused, not
    // silently replaced by the GPU's.
    let ctx = context();
    let scene = load("factory:50");
    let profile = HmdProfile::load("valve-index").unwrap();
    let extent = ash::vk::Extent2D {
        width: 16,
        height: 16,
    };
    let mut r = Renderer::new(ctx.clone(), &scene, &config("per-eye,gpu-cull"), extent).unwrap();
    let rig = profile.rig(Pose::default());
    let e = r.render(&rig, Some(&[]), false).unwrap_err().to_string();
    assert!(e.contains("culls on the GPU"), "{e}");
}

#[test]
fn every_bench_plan_loads_and_its_gpu_cull_configs_validate() {
    let dir = common::root().join("manifests/bench");
    let mut plans: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    plans.sort();
    assert!(plans.len() >= 20, "{} plans", plans.len());
    let mut gpu_plans = 0;
    for path in plans {
        let plan = vergence::bench::plan::Plan::load(&path)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let gpu: Vec<_> = plan
            .configs
            .iter()
            .filter(|c| c.opt.contains("gpu-cull"))
            .collect();
        gpu_plans += usize::from(!gpu.is_empty());
        for c in gpu {
            config(&c.opt)
                .validate()
                .unwrap_or_else(|e| panic!("{}: {}: {e}", path.display(), c.name));
        }
    }
    assert!(gpu_plans >= 8, "{gpu_plans} plans with gpu-cull configs");
}

/// Scenes with blended primitives (glass among opaque parts; blended
/// materials over the sky): the GPU culls and draws the opaque ones, the
/// CPU culls and sorts the blended ones and draws them after the sky.
/// Every frame draws the instances and triangles CPU culling draws and the
/// same pixels, in both stereo modes, with occlusion (the blended drawn in
/// its second part), the sky after the resolve, and the inset.
#[test]
fn gpu_cull_draws_blended_primitives_sorted_after_the_opaque_ones() {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    for spec in [
        "cad:1500",
        "assets/AlphaBlendModeTest/AlphaBlendModeTest.gltf",
    ] {
        let scene = load(spec);
        let start = common::framing_pose(&scene, &profile);
        let rigs: Vec<StereoRig> = (0..3)
            .map(|i| {
                let mut p = start;
                p.position += p.orientation * DVec3::new(0.3 * i as f64, 0.0, -0.2 * i as f64);
                profile.rig(p)
            })
            .collect();
        for opts in [
            "multiview,superfrustum",
            "two-pass,per-eye",
            "multiview,superfrustum,resolved-sky",
            "multiview,superfrustum,inset=0.5",
        ] {
            let (cpu, cpu_img) = drive(&ctx, &scene, &config(opts), &rigs);
            for extra in ["gpu-cull", "gpu-cull,occlusion"] {
                let gpu_opts = format!("{opts},{extra}");
                let (gpu, gpu_img) = drive(&ctx, &scene, &config(&gpu_opts), &rigs);
                for (k, (c, g)) in cpu.iter().zip(&gpu).enumerate() {
                    // (The inset's lists count their instances apart.)
                    if extra == "gpu-cull" && !opts.contains("inset") {
                        assert_eq!(
                            (g.stats.instances_drawn, g.stats.triangles),
                            (c.stats.instances_drawn, c.stats.triangles),
                            "{spec} {gpu_opts} frame {k}"
                        );
                    }
                }
                for eye in 0..2 {
                    let differing = common::pixels_differing(&cpu_img[eye], &gpu_img[eye]);
                    assert_eq!(
                        differing, 0,
                        "{spec} {gpu_opts} eye {eye}: pixels differ from CPU culling"
                    );
                }
            }
        }
    }
}
