//! Without a pose the head frames the scene from its bounds, whatever its
//! size or offset: a hundred garages 5 km from the origin, the 150 m
//! RetroUFO and a scan in survey coordinates (with stray points 50 km
//! away) each cover at least a fifth of the image (the pixels that change
//! when the scene is moved out of view, from the same pose); `--frame
//! inside` stands at the bounds' centre; `render` records the pose in
//! `stats.json` (`pose`, `pose_arg`, `pose_from`) and writes `rig.json`,
//! and rendering again with that `--pose` gives the same images.

mod common;

use common::{context, load, render_config, scratch};
use glam::{DAffine3, DVec3};
use vergence::config::RenderConfig;
use vergence::scene::points::PointCloud;
use vergence::scene::Scene;
use vergence::targets::framing::{head_pose, Framing};
use vergence::view::profile::HmdProfile;

const SIZE: u32 = 96;

/// The fraction of both eyes' pixels that differ between `scene` and the
/// same scene moved 10,000 km away, both seen from its framing.
fn coverage(scene: &Scene, moved_away: &Scene, framing: Framing) -> f64 {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    let pose = head_pose(scene, &profile, framing);
    let config = RenderConfig {
        frame: vergence::config::FrameConfig {
            msaa: 1,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    let with = render_config(&ctx, scene, &profile, pose, &config, SIZE, SIZE);
    let without = render_config(&ctx, moved_away, &profile, pose, &config, SIZE, SIZE);
    let differing: usize = (0..2)
        .map(|e| common::pixels_differing(&with.images[e], &without.images[e]))
        .sum();
    differing as f64 / (2 * SIZE * SIZE) as f64
}

/// `scene` with every instance (and the point cloud) shifted by `by`.
fn shifted(scene: &Scene, by: DVec3) -> Scene {
    let mut s = scene.clone();
    for inst in &mut s.instances {
        inst.transform.translation += by;
    }
    if let Some(c) = s.points.as_mut() {
        std::sync::Arc::make_mut(c).origin += by;
    }
    s
}

fn away(scene: &Scene) -> Scene {
    shifted(scene, DVec3::new(0.0, 1e7, 0.0))
}

#[test]
fn a_hundred_garages_five_kilometres_out_are_framed() {
    let garage = load("assets/garage/garage.gltf");
    let (lo, hi) = garage.bounds();
    let step = (hi - lo) * 1.3;
    let mut scene = garage.clone();
    scene.instances.clear();
    for i in 0..10 {
        for j in 0..10 {
            let at = DVec3::new(5000.0 + i as f64 * step.x, 0.0, j as f64 * step.z);
            for inst in &garage.instances {
                let mut placed = *inst;
                placed.transform = DAffine3::from_translation(at) * inst.transform;
                scene.instances.push(placed);
            }
        }
    }
    scene.nodes = scene.instances.len();
    let c = coverage(&scene, &away(&scene), Framing::Outside);
    assert!(
        c >= 0.2,
        "the garages cover {:.1} % of the image",
        100.0 * c
    );
}

#[test]
fn the_whole_retroufo_is_framed_from_outside_and_inside_stands_at_its_centre() {
    let scene = load("assets/retroufo/retroufo.glb");
    let (lo, hi) = scene.bounds();
    assert!((hi - lo).length() > 50.0, "a large model");
    let c = coverage(&scene, &away(&scene), Framing::Outside);
    assert!(c >= 0.2, "the UFO covers {:.1} % of the image", 100.0 * c);
    let profile = HmdProfile::load("valve-index").unwrap();
    let inside = head_pose(&scene, &profile, Framing::Inside);
    let centre = (lo + hi) * 0.5;
    assert!((inside.position.x - centre.x).abs() < 1e-6);
    assert!((inside.position.y - (lo.y + 1.6)).abs() < 1e-6);
}

#[test]
fn a_scan_in_survey_coordinates_with_stray_points_is_framed() {
    // A 30 × 8 × 20 m room of points (walls, floor) 512 km east and
    // 4,100 km south of the origin, and three stray returns 50 km away.
    let mut positions = Vec::new();
    let mut colors = Vec::new();
    for i in 0..300 {
        for j in 0..100 {
            let (u, v) = (i as f32 / 299.0, j as f32 / 99.0);
            positions.push([30.0 * u, 0.0, 20.0 * v]);
            positions.push([30.0 * u, 8.0 * v, 0.0]);
            positions.push([0.0, 8.0 * v, 20.0 * u]);
            colors.extend([[200, 80, 60, 255], [60, 160, 90, 255], [70, 90, 200, 255]]);
        }
    }
    for k in 0..3 {
        positions.push([50_000.0 + k as f32, 0.0, -50_000.0]);
        colors.push([255, 255, 255, 255]);
    }
    let n = positions.len();
    let scene = Scene {
        name: "survey scan".into(),
        points: Some(std::sync::Arc::new(PointCloud {
            origin: DVec3::new(512_000.0, 30.0, -4_100_000.0),
            positions,
            colors,
            classification: vec![0; n],
            ..PointCloud::default()
        })),
        ..Scene::default()
    };
    let c = coverage(&scene, &away(&scene), Framing::Outside);
    assert!(c >= 0.2, "the scan covers {:.1} % of the image", 100.0 * c);
}

#[test]
fn render_records_the_pose_it_used_and_takes_it_back() {
    let out = scratch("framing", "framed");
    let size = ["--width", "64", "--height", "64", "--msaa", "1"];
    let mut args = vec!["--scene", "assets/retroufo/retroufo.glb"];
    args.extend(size);
    let stats = common::render_cli(&args, &out);
    assert_eq!(stats["pose_from"], "--frame outside");
    let pose_arg = stats["pose_arg"].as_str().unwrap().to_string();
    assert!(stats["pose"]["position"].is_array());
    let rig = vergence::view::RigFile::load(&out.join("rig.json")).unwrap();
    assert_eq!(rig.views.len(), 2);
    let again = scratch("framing", "posed");
    let mut args = vec![
        "--scene",
        "assets/retroufo/retroufo.glb",
        "--pose",
        &pose_arg,
    ];
    args.extend(size);
    let posed = common::render_cli(&args, &again);
    assert_eq!(posed["pose_from"], "--pose");
    for eye in ["left.png", "right.png"] {
        let a = image::open(out.join(eye)).unwrap().to_rgba8();
        let b = image::open(again.join(eye)).unwrap().to_rgba8();
        assert_eq!(common::pixels_differing(&a, &b), 0, "{eye}");
    }
}

/// `run --viewpoint` takes a viewpoints file (as F8 in `view` appends it)
/// beside x,y,z,yaw values: each entry joins the viewpoint cycle.
#[test]
fn run_takes_a_viewpoints_file() {
    let out = scratch("framing", "viewpoints").join("stats.json");
    std::fs::create_dir_all(out.parent().unwrap()).unwrap();
    let file = common::root().join("tests/bad_inputs/viewpoints/good.toml");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args([
            "run", "--xr", "headless", "--frames", "2", "--mirror", "off",
        ])
        .args(["--scene", "factory:50", "--width", "32", "--height", "32"])
        .arg("--viewpoint")
        .arg(&file)
        .args(["--viewpoint", "1,0,2,90", "--stats-out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let names: Vec<&str> = stats["viewpoints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        ["spawn", "--viewpoint 1", "--viewpoint 2"],
        "{stats}"
    );
}
