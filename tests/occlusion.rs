//! Two-phase hierarchical-Z occlusion culling (`--opt gpu-cull,occlusion`):
//! boxes behind a wall are not drawn from the second frame on (the GPU's
//! own counters), the visible ones are, and every frame's image equals the
//! unculled one — also while the camera moves past the wall and boxes come
//! into view (disocclusion), in multiview and two-pass, at 1 and 4
//! samples, with the stencil mask; zero validation messages. LOD
//! (`--opt gpu-cull,lod`): a far RetroUFO draws coarser levels within FLIP
//! 0.01 of LOD off, and instances under the error bound are dropped.

mod common;

use common::{context, framing_pose, load};
use glam::{DAffine3, DVec3};
use std::sync::Arc;
use vergence::bench::plan::cull_names;
use vergence::config::RenderConfig;
use vergence::gpu::Context;
use vergence::render::driver::FrameResult;
use vergence::scene::{shapes, Instance, Material, Mesh, Scene};
use vergence::view::profile::HmdProfile;
use vergence::view::{Pose, StereoRig};

const SIZE: u32 = 96;

/// Boxes behind the wall (hidden from the start pose).
const HIDDEN: usize = 9;
/// A wall 10 m wide and 6 m high at z = -6 (its centre at eye height), a
/// 3×3 grid of 1 m boxes behind it at z = -14 and two boxes far to the
/// sides at z = -10 (beyond the wall's silhouette; whether the frustum
/// keeps them depends on the profile's FOV). Two materials so the wall and
/// the boxes differ.
fn wall_scene() -> Scene {
    let red = Material {
        base_color: [0.8, 0.1, 0.1, 1.0],
        ..Material::default()
    };
    let mut scene = Scene {
        name: "wall".into(),
        primitives: vec![
            shapes::cuboid([5.0, 3.0, 0.25], 0),
            shapes::cuboid([0.5, 0.5, 0.5], 1),
        ],
        meshes: vec![
            Mesh {
                name: "wall".into(),
                primitives: vec![0],
            },
            Mesh {
                name: "box".into(),
                primitives: vec![1],
            },
        ],
        materials: vec![Material::default(), red],
        ..Scene::default()
    };
    let at = |mesh: u32, p: DVec3| Instance {
        mesh,
        transform: DAffine3::from_translation(p),
    };
    scene.instances.push(at(0, DVec3::new(0.0, 1.7, -6.0)));
    for i in 0..3 {
        for j in 0..3 {
            let p = DVec3::new(-1.5 + 1.5 * i as f64, 0.7 + 1.0 * j as f64, -14.0);
            scene.instances.push(at(1, p));
        }
    }
    scene.instances.push(at(1, DVec3::new(-9.5, 1.7, -10.0)));
    scene.instances.push(at(1, DVec3::new(9.5, 1.7, -10.0)));
    scene.nodes = scene.instances.len();
    scene
}

fn config(opts: &str) -> RenderConfig {
    let mut c = RenderConfig::default();
    c.apply_opts(opts, &cull_names()).unwrap();
    c.validate().unwrap();
    c
}

/// Renders every rig of `rigs` with `opts`, each frame read back; returns
/// the results and each frame's images.
fn frames(
    ctx: &Arc<Context>,
    scene: &Scene,
    opts: &str,
    rigs: &[StereoRig],
) -> (Vec<FrameResult>, Vec<[image::RgbaImage; 2]>) {
    let (results, images) = common::frame_by_frame(ctx, scene, &config(opts), rigs, SIZE);
    assert_eq!(results.len(), rigs.len());
    (results, images)
}

/// Pixels that differ between two frames (both eyes).
fn differing(a: &[image::RgbaImage; 2], b: &[image::RgbaImage; 2]) -> usize {
    a.iter()
        .zip(b)
        .map(|(x, y)| x.pixels().zip(y.pixels()).filter(|(p, q)| p != q).count())
        .sum()
}

fn rig_at(x: f64) -> StereoRig {
    HmdProfile::load("valve-index")
        .unwrap()
        .rig(Pose::from_euler_deg(DVec3::new(x, 1.7, 0.0), 0.0, 0.0, 0.0))
}

#[test]
fn boxes_behind_a_wall_are_not_drawn_and_the_image_is_unchanged() {
    let ctx = context();
    let scene = wall_scene();
    let rigs: Vec<StereoRig> = (0..4).map(|_| rig_at(0.0)).collect();
    for mode in ["multiview", "two-pass"] {
        for msaa in ["msaa4", "no-msaa"] {
            let base = format!("{mode},{msaa},superfrustum,gpu-cull");
            let (plain, reference) = frames(&ctx, &scene, &base, &rigs);
            let opts = format!("{base},occlusion");
            let (culled, images) = frames(&ctx, &scene, &opts, &rigs);
            for (i, (r, p)) in culled.iter().zip(&plain).enumerate() {
                let c = r.stats.gpu_cull.expect("gpu-cull counters");
                let inside = p.stats.gpu_cull.unwrap().passed_frustum;
                assert_eq!(c.tested, scene.instances.len() as u64, "{opts}");
                assert_eq!(c.passed_frustum, inside, "{opts}: {c:?}");
                assert!(
                    inside > HIDDEN as u64,
                    "{opts}: the wall and the boxes are in view"
                );
                let shown = inside - HIDDEN as u64;
                // Frame 0 starts from "all visible" and learns what is
                // hidden; from the second frame on the hidden boxes are
                // neither drawn early nor late.
                // The early phase runs over what was visible at the end of
                // the last frame: every instance on the first.
                let listed = if i == 0 {
                    scene.instances.len() as u64
                } else {
                    shown
                };
                assert_eq!(c.tested_early, listed, "{opts} frame {i}: {c:?}");
                if i >= 1 {
                    assert_eq!(c.occluded, HIDDEN as u64, "{opts} frame {i}: {c:?}");
                    assert_eq!(c.drawn_early, shown, "{opts} frame {i}: {c:?}");
                    assert_eq!(c.drawn_late, 0, "{opts} frame {i}: {c:?}");
                    assert_eq!(r.stats.instances_drawn, shown, "{opts} frame {i}");
                    assert!(r.stats.triangles < p.stats.triangles, "{opts} frame {i}");
                }
                assert_eq!(
                    differing(&images[i], &reference[i]),
                    0,
                    "{opts} frame {i}: the image differs from the unculled one"
                );
            }
            // The wall is on screen (the test sees something).
            let wall = reference[0][0].get_pixel(SIZE / 2, SIZE / 2);
            assert_ne!(*wall, image::Rgba([0, 0, 0, 255]));
        }
    }
}

#[test]
fn walking_past_the_wall_never_loses_a_visible_box() {
    let ctx = context();
    let scene = wall_scene();
    // From behind the wall's centre to well past its right edge in 12
    // steps: the boxes behind it come into view one column at a time.
    let rigs: Vec<StereoRig> = (0..12).map(|i| rig_at(0.9 * i as f64)).collect();
    let opts = "multiview,msaa4,superfrustum,gpu-cull,stencil-mask";
    let (plain, reference) = frames(&ctx, &scene, opts, &rigs);
    let (culled, images) = frames(&ctx, &scene, &format!("{opts},occlusion"), &rigs);
    let mut late_total = 0;
    let mut missing_frames = 0;
    let mut missing_pixels = 0;
    for i in 0..rigs.len() {
        let d = differing(&images[i], &reference[i]);
        missing_pixels += d;
        missing_frames += (d > 0) as usize;
        let c = culled[i].stats.gpu_cull.unwrap();
        late_total += c.drawn_late;
        assert!(
            culled[i].stats.instances_drawn <= plain[i].stats.instances_drawn,
            "frame {i}"
        );
    }
    // The two-phase scheme draws a newly visible box in the same frame
    // (late), so no frame misses anything.
    assert_eq!(
        (missing_frames, missing_pixels),
        (0, 0),
        "frames and pixels where something visible was missing"
    );
    assert!(
        late_total > 0,
        "boxes came into view through the late phase"
    );
    let last = culled.last().unwrap().stats.gpu_cull.unwrap();
    assert!(
        last.occluded < HIDDEN as u64,
        "past the wall fewer boxes stay hidden: {last:?}"
    );
}

/// Both eyes' FLIP mean against `reference`, at the headset's ppd for
/// this image size.
fn flip_mean(reference: &[image::RgbaImage; 2], test: &[image::RgbaImage; 2]) -> f32 {
    let fov = HmdProfile::load("valve-index").unwrap().views[0].fov;
    let ppd = vergence::bench::metrics::headset_ppd(SIZE, fov.left, fov.right).max(10.0);
    reference
        .iter()
        .zip(test)
        .map(|(r, t)| vergence::bench::metrics::flip(r, t, ppd).unwrap().mean)
        .sum::<f32>()
        / 2.0
}

#[test]
fn lod_draws_coarser_levels_within_flip_of_lod_off() {
    let ctx = context();
    let scene = load("assets/retroufo/retroufo.glb");
    let profile = HmdProfile::load("valve-index").unwrap();
    let near = framing_pose(&scene, &profile);
    let (lo, hi) = scene.bounds();
    let size = (hi - lo).length();
    // The framed view, then twice and four times as far: farther views
    // draw coarser levels.
    let back = |k: f64| {
        let mut p = near;
        p.position += near.orientation * DVec3::new(0.0, 0.0, k * size);
        profile.rig(p)
    };
    let rigs: Vec<StereoRig> = [0.0, 1.0, 3.0].into_iter().map(back).collect();
    for extra in ["", ",occlusion"] {
        let base = format!("multiview,msaa4,superfrustum,gpu-cull{extra}");
        let (plain, reference) = frames(&ctx, &scene, &base, &rigs);
        let opts = format!("{base},lod");
        let (lod, images) = frames(&ctx, &scene, &opts, &rigs);
        let mut coarse_before = 0;
        for i in 0..rigs.len() {
            let c = lod[i].stats.gpu_cull.unwrap();
            let coarse: u64 = c.lod_triangles[1..].iter().sum();
            assert_eq!(
                c.lod_triangles.iter().sum::<u64>(),
                lod[i].stats.triangles,
                "{opts} frame {i}: per-level triangles add up"
            );
            assert!(
                lod[i].stats.triangles <= plain[i].stats.triangles,
                "{opts} frame {i}"
            );
            assert!(
                coarse >= coarse_before || c.lod_dropped > 0,
                "{opts} frame {i}"
            );
            coarse_before = coarse;
            let e = flip_mean(&reference[i], &images[i]);
            assert!(e <= 0.01, "{opts} frame {i}: FLIP mean {e} against LOD off");
        }
        let last = &lod.last().unwrap().stats;
        assert!(
            last.triangles < plain.last().unwrap().stats.triangles,
            "{opts}: the far view draws fewer triangles ({} vs {})",
            last.triangles,
            plain.last().unwrap().stats.triangles
        );
    }
}

#[test]
fn lod_drops_instances_under_the_error_bound() {
    let ctx = context();
    // The wall scene and a row of 10 cm boxes 60 m away, far under a
    // pixel at this image size.
    let mut scene = wall_scene();
    scene.primitives.push(shapes::cuboid([0.05, 0.05, 0.05], 1));
    scene.meshes.push(Mesh {
        name: "speck".into(),
        primitives: vec![2],
    });
    for i in 0..21 {
        let p = DVec3::new(-40.0 + 4.0 * i as f64, 1.7, -60.0);
        scene.instances.push(Instance {
            mesh: 2,
            transform: DAffine3::from_translation(p),
        });
    }
    scene.nodes = scene.instances.len();
    let rigs = vec![rig_at(0.0)];
    let base = "multiview,msaa4,superfrustum,gpu-cull";
    let (plain, reference) = frames(&ctx, &scene, base, &rigs);
    let (lod, images) = frames(&ctx, &scene, &format!("{base},lod=1"), &rigs);
    let c = lod[0].stats.gpu_cull.unwrap();
    assert!(c.lod_dropped > 0, "{c:?}");
    assert_eq!(
        lod[0].stats.instances_drawn + c.lod_dropped,
        plain[0].stats.instances_drawn,
        "every instance inside the volume is drawn or dropped"
    );
    let e = flip_mean(&reference[0], &images[0]);
    assert!(e <= 0.01, "FLIP mean {e} against LOD off");
    // A looser bound drops more.
    let (loose, _) = frames(&ctx, &scene, &format!("{base},lod=8"), &rigs);
    assert!(loose[0].stats.gpu_cull.unwrap().lod_dropped > c.lod_dropped);
}

#[test]
fn lod_without_gpu_cull_and_bad_bounds_are_one_clear_error() {
    let mut c = RenderConfig::default();
    c.apply_opts("multiview,superfrustum,lod", &cull_names())
        .unwrap();
    let e = c.validate().unwrap_err().to_string();
    assert!(e.contains("lod") && e.contains("gpu-cull"), "{e}");
    for bad in ["lod=0", "lod=-1", "lod=x", "lod=1e9", "lod=nan"] {
        let e = RenderConfig::default()
            .apply_opts(bad, &cull_names())
            .unwrap_err()
            .to_string();
        assert!(e.contains("lod=PX"), "{bad}: {e}");
    }
}

#[test]
fn occlusion_without_gpu_cull_is_one_clear_error() {
    let mut c = RenderConfig::default();
    c.apply_opts("multiview,superfrustum,occlusion", &cull_names())
        .unwrap();
    let e = c.validate().unwrap_err().to_string();
    assert!(e.contains("occlusion") && e.contains("gpu-cull"), "{e}");
}

/// `lod-cache`: the first render builds the chains and writes them next to
/// the scene, the second reads them (same chains, same pixels); a cache
/// cut short or made for other content is rebuilt with a warning, and a
/// folder that cannot be written only loses the cache.
#[test]
fn lod_chains_are_cached_next_to_the_scene_and_rebuilt_when_stale() {
    let dir = common::scratch("lod-cache", "scene");
    let glb = dir.join("retroufo.glb");
    std::fs::copy(common::root().join("assets/retroufo/retroufo.glb"), &glb).unwrap();
    let cache = dir.join("retroufo.glb.lodcache");
    let args = |opt: &'static str| {
        vec![
            "--scene".to_string(),
            glb.display().to_string(),
            "--pose".into(),
            "0,2,40,0,-3,0".into(),
            "--width".into(),
            "96".into(),
            "--height".into(),
            "96".into(),
            "--opt".into(),
            opt.into(),
        ]
    };
    let run = |opt: &'static str, name: &str| {
        let out = common::scratch("lod-cache", name);
        let a = args(opt);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let stats = common::render_cli(&a, &out);
        assert_eq!(stats["validation_messages"], 0, "{name}");
        let img = image::open(out.join("left.png")).unwrap().to_rgba8();
        (stats, img)
    };
    let opt = "superfrustum,gpu-cull,lod,lod-cache";
    let (plain, plain_img) = run("superfrustum,gpu-cull,lod", "plain");
    assert!(plain["lod"].get("cache").is_none(), "{}", plain["lod"]);
    assert!(!cache.exists());
    let (first, first_img) = run(opt, "first");
    assert!(
        first["lod"]["cache"]["written"].is_string(),
        "{}",
        first["lod"]
    );
    assert!(cache.exists());
    let (second, second_img) = run(opt, "second");
    assert!(
        second["lod"]["cache"]["read"].is_string(),
        "{}",
        second["lod"]
    );
    for s in [&first, &second] {
        assert_eq!(s["lod"]["levels"], plain["lod"]["levels"]);
        assert_eq!(s["lod"]["index_bytes"], plain["lod"]["index_bytes"]);
        assert_eq!(
            s["gpu_cull"]["lod_triangles"],
            plain["gpu_cull"]["lod_triangles"]
        );
    }
    assert!(first_img == plain_img && second_img == plain_img);
    // Cut short: rebuilt and written again, the same image.
    let bytes = std::fs::read(&cache).unwrap();
    std::fs::write(&cache, &bytes[..bytes.len() / 2]).unwrap();
    let (again, again_img) = run(opt, "truncated");
    assert!(
        again["lod"]["cache"]["written"].is_string(),
        "{}",
        again["lod"]
    );
    assert_eq!(std::fs::read(&cache).unwrap(), bytes);
    assert!(again_img == plain_img);
    // Read-only folder (as a non-root user would find it; root ignores the
    // mode, so only check when the write really fails): renders anyway.
    use std::os::unix::fs::PermissionsExt;
    std::fs::remove_file(&cache).unwrap();
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o555)).unwrap();
    let (ro, ro_img) = run(opt, "read-only");
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
    if !cache.exists() {
        assert!(
            ro["lod"]["cache"]["not_written"].is_string(),
            "{}",
            ro["lod"]
        );
    }
    assert!(ro_img == plain_img);
}

#[test]
fn lod_cache_without_lod_is_one_clear_error() {
    let mut c = RenderConfig::default();
    c.apply_opts("superfrustum,gpu-cull,lod-cache", &cull_names())
        .unwrap();
    let e = c.validate().unwrap_err().to_string();
    assert!(e.contains("lod-cache keeps the chains lod builds"), "{e}");
}

/// Occlusion with the inset: the depth pyramid comes from the wide views
/// (the whole field of view), the wide and inset scopes each draw the
/// early set and then the late one. The hidden boxes are not drawn from
/// the second frame on, and every frame equals the inset without
/// occlusion — standing still and walking past the wall's edge — in
/// multiview and two-pass, with the wide views at the frame's samples, at
/// one sample, and accumulated (inset-taau).
#[test]
fn occlusion_composes_with_the_inset() {
    let ctx = context();
    let scene = wall_scene();
    let still: Vec<StereoRig> = (0..3).map(|_| rig_at(0.0)).collect();
    let walk: Vec<StereoRig> = (0..8).map(|i| rig_at(1.3 * i as f64)).collect();
    let cases = [
        "multiview,msaa4,superfrustum,gpu-cull,inset=0.5",
        "two-pass,msaa4,superfrustum,gpu-cull,inset=0.5",
        "multiview,msaa4,superfrustum,gpu-cull,inset=0.5,inset-wide-1x",
        "multiview,no-msaa,superfrustum,gpu-cull,inset=0.5,inset-taau",
    ];
    for base in cases {
        let opts = format!("{base},occlusion");
        let (_, reference) = frames(&ctx, &scene, base, &still);
        let (culled, images) = frames(&ctx, &scene, &opts, &still);
        for (i, r) in culled.iter().enumerate().skip(1) {
            let c = r.stats.gpu_cull.expect("gpu-cull counters");
            assert_eq!(c.occluded, HIDDEN as u64, "{opts} frame {i}: {c:?}");
            assert_eq!(c.drawn_late, 0, "{opts} frame {i}: {c:?}");
            assert_eq!(
                differing(&images[i], &reference[i]),
                0,
                "{opts} frame {i}: the image differs from the inset's without occlusion"
            );
        }
        let (_, reference) = frames(&ctx, &scene, base, &walk);
        let (culled, images) = frames(&ctx, &scene, &opts, &walk);
        let late: u64 = culled
            .iter()
            .map(|r| r.stats.gpu_cull.unwrap().drawn_late)
            .sum();
        assert!(
            late > 0,
            "{opts}: boxes came into view through the late phase"
        );
        for i in 0..walk.len() {
            assert_eq!(
                differing(&images[i], &reference[i]),
                0,
                "{opts} walking, frame {i}: something visible was missing"
            );
        }
    }
}

/// `config(opts)` with adaptive quality over a budget no frame meets, so
/// the controller lowers the render scale (and with the inset its wide
/// rungs) frame by frame, the same way in every run.
fn over_budget(opts: &str) -> RenderConfig {
    {
        let mut rc = config(opts);
        rc.effort.aq = true;
        rc.effort.budget_ms = Some(0.001);
        rc.submission.frames_in_flight = 1;
        rc
    }
}

/// Occlusion with adaptive quality: the depth pyramid follows the size the
/// frame is drawn at. While the scale falls every frame, the hidden boxes
/// stay undrawn and each frame equals adaptive quality's without
/// occlusion, with and without the inset.
#[test]
fn occlusion_follows_adaptive_qualitys_scale() {
    let ctx = context();
    let scene = wall_scene();
    let rigs: Vec<StereoRig> = (0..10).map(|_| rig_at(0.0)).collect();
    for base in [
        "multiview,msaa4,superfrustum,gpu-cull",
        "two-pass,msaa4,superfrustum,gpu-cull,inset=0.5",
    ] {
        let run =
            |opts: &str| common::frame_by_frame(&ctx, &scene, &over_budget(opts), &rigs, SIZE);
        let (plain, reference) = run(base);
        let (culled, images) = run(&format!("{base},occlusion"));
        let scales: Vec<f64> = culled.iter().map(|r| r.aq.unwrap().scale).collect();
        assert!(
            scales.last() < scales.first(),
            "{base}: the scale fell: {scales:?}"
        );
        for i in 1..rigs.len() {
            assert_eq!(culled[i].aq.unwrap().size, plain[i].aq.unwrap().size);
            let c = culled[i].stats.gpu_cull.unwrap();
            assert_eq!(c.occluded, HIDDEN as u64, "{base} frame {i}: {c:?}");
            assert_eq!(
                differing(&images[i], &reference[i]),
                0,
                "{base},occlusion frame {i} (scale {}): differs from aq alone",
                scales[i]
            );
        }
    }
}

/// LOD with adaptive quality: levels are chosen at the density the frame
/// is drawn at, so as the scale falls the same view draws coarser levels.
#[test]
fn lod_follows_adaptive_qualitys_scale() {
    let ctx = context();
    let scene = load("assets/retroufo/retroufo.glb");
    let profile = HmdProfile::load("valve-index").unwrap();
    let mut pose = framing_pose(&scene, &profile);
    let (lo, hi) = scene.bounds();
    pose.position += pose.orientation * DVec3::new(0.0, 0.0, (hi - lo).length());
    let rigs: Vec<StereoRig> = (0..10).map(|_| profile.rig(pose)).collect();
    let opts = "multiview,msaa4,superfrustum,gpu-cull,lod";
    let (frames, _) = common::frame_by_frame(&ctx, &scene, &over_budget(opts), &rigs, SIZE);
    let (first, last) = (&frames[0], frames.last().unwrap());
    for r in &frames {
        let c = r.stats.gpu_cull.unwrap();
        assert_eq!(c.lod_triangles.iter().sum::<u64>(), r.stats.triangles);
    }
    assert!(last.aq.unwrap().scale < first.aq.unwrap().scale);
    assert!(
        last.stats.triangles < first.stats.triangles,
        "at scale {} against {}: {} triangles against {}",
        last.aq.unwrap().scale,
        first.aq.unwrap().scale,
        last.stats.triangles,
        first.stats.triangles,
    );
}
