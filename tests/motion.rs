//! Moving instances (a manifest placement's `motion`): every frame of a
//! moving scene equals, pixel for pixel, a static scene whose instances
//! stand where the motion has them at that frame's time — with CPU culling
//! (the hierarchy refitted for the moved boxes), GPU culling (their boxes
//! copied in), occlusion and the far field, in multiview and two-pass, two
//! frames in flight — and only the moving instances are uploaded, in one
//! copy region per run of consecutive instances. Zero validation messages.

mod common;

use common::context;
use glam::DVec3;
use std::path::Path;
use std::sync::Arc;
use vergence::bench::plan::cull_names;
use vergence::config::RenderConfig;
use vergence::gpu::Context;
use vergence::render::driver::{FrameResult, DEFAULT_FRAME_RATE};
use vergence::scene::motion::transforms_at;
use vergence::scene::{manifest, Scene};
use vergence::view::profile::HmdProfile;
use vergence::view::{Pose, StereoRig};

const SIZE: u32 = 96;
const FRAMES: u64 = 4;

/// Two static boxes and a 5×1×3 grid of boxes that spin fast (a quarter
/// turn in about 9 frames) and bob by 25 m, in and out of the frustum
/// from frame to frame, with static boxes in front of part of the grid.
fn moving_scene() -> Scene {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = r#"
name = "moving-test"
[[gltf]]
file = "../../assets/Box/Box.gltf"
translation = [-7.0, 0.5, -6.0]
scale = 1.4
grid = { count = [5, 1, 3], spacing = [3.5, 0.0, 3.0] }
motion = { spin_deg_s = 900.0, bob_m = 25.0, bob_period_s = 0.2 }
[[gltf]]
file = "../../assets/Box/Box.gltf"
translation = [0.0, 1.5, -4.0]
[[gltf]]
file = "../../assets/Box/Box.gltf"
translation = [2.0, 0.0, -9.0]
"#;
    manifest::from_text(&root.join("manifests/scenes/moving-test.toml"), text).unwrap()
}

fn config(opts: &str) -> RenderConfig {
    let mut c = RenderConfig::default();
    c.apply_opts(opts, &cull_names()).unwrap();
    c.validate().unwrap();
    c
}

fn rig() -> StereoRig {
    HmdProfile::load("valve-index")
        .unwrap()
        .rig(Pose::from_euler_deg(
            DVec3::new(0.0, 1.6, 2.0),
            0.0,
            -10.0,
            0.0,
        ))
}

/// Renders frames 0.. of `scene` with `opts` through one driver (frames in
/// flight as configured, each read back); returns the results and images.
fn frames(
    ctx: &Arc<Context>,
    scene: &Scene,
    opts: &str,
    n: u64,
) -> (Vec<FrameResult>, Vec<[image::RgbaImage; 2]>) {
    let rigs: Vec<StereoRig> = (0..n).map(|_| rig()).collect();
    common::frame_by_frame(ctx, scene, &config(opts), &rigs, SIZE)
}

/// `scene` frozen where its moving instances stand at frame `i`.
fn frozen_at(scene: &Scene, i: u64) -> Scene {
    let mut s = scene.clone();
    let mut moved = Vec::new();
    transforms_at(&scene.moving, i as f64 / DEFAULT_FRAME_RATE, &mut moved);
    for m in moved {
        s.instances[m.index as usize].transform = m.transform;
    }
    s.moving.clear();
    s
}

fn differing(a: &[image::RgbaImage; 2], b: &[image::RgbaImage; 2]) -> usize {
    a.iter()
        .zip(b)
        .map(|(x, y)| x.pixels().zip(y.pixels()).filter(|(p, q)| p != q).count())
        .sum()
}

#[test]
fn every_moving_frame_equals_the_scene_frozen_at_its_time() {
    let ctx = context();
    let scene = moving_scene();
    let moving = scene.moving_instances();
    assert_eq!(moving, 15);
    let frozen: Vec<Scene> = (0..FRAMES).map(|i| frozen_at(&scene, i)).collect();
    for opts in [
        "multiview,superfrustum",
        "two-pass,per-eye,no-msaa",
        "multiview,superfrustum,gpu-cull",
        "two-pass,superfrustum,gpu-cull,occlusion",
        "multiview,superfrustum,mffr=6",
    ] {
        let (results, images) = frames(&ctx, &scene, opts, FRAMES);
        assert_eq!(results.len() as u64, FRAMES, "{opts}");
        let gpu = opts.contains("gpu-cull");
        for (i, r) in results.iter().enumerate() {
            // Only the moving instances went up: 64 bytes each, plus the
            // cull's 48-byte box with gpu-cull, in one run each.
            let m = r
                .stats
                .motion
                .unwrap_or_else(|| panic!("{opts}: no motion stats"));
            assert_eq!(m.moved, moving as u64, "{opts} frame {i}");
            let per = if gpu { 64 + 48 } else { 64 };
            assert_eq!(m.upload_bytes, per * moving as u64, "{opts} frame {i}");
            assert_eq!(m.regions, if gpu { 2 } else { 1 }, "{opts} frame {i}");
        }
        for i in 0..FRAMES as usize {
            let (_, want) = frames(&ctx, &frozen[i], opts, 1);
            let d = differing(&images[i], &want[0]);
            assert_eq!(
                d, 0,
                "{opts}: frame {i} differs from the frozen scene in {d} pixels"
            );
        }
        // The motion shows: consecutive frames differ.
        for i in 1..FRAMES as usize {
            assert!(
                differing(&images[i], &images[i - 1]) > 20,
                "{opts}: frames {} and {i} look alike",
                i - 1
            );
        }
    }
}

#[test]
fn a_static_scene_uploads_nothing() {
    let ctx = context();
    let scene = frozen_at(&moving_scene(), 0);
    let (results, _) = frames(&ctx, &scene, "multiview,superfrustum,gpu-cull", 2);
    assert!(results.iter().all(|r| r.stats.motion.is_none()));
}

#[test]
fn the_shipped_moving_scenes_load_with_their_fleets_moving() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = manifest::load(&root.join("manifests/scenes/moving-fleet.toml")).unwrap();
    // 400 RetroUFOs of 77 instances each move; the factory stands still.
    assert_eq!(scene.moving_instances(), 400 * 77);
    assert_eq!(scene.instances.len(), 20_000 + 400 * 77);
    let text = std::fs::read_to_string(root.join("manifests/scenes/moving-factory.toml")).unwrap();
    assert!(text.contains("instances = 1000000") && text.contains("motion = "));
}
