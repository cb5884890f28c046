//! The section plane (`render --section x,y,z,nx,ny,nz`): the scene
//! shaders clip what lies beyond it (pixels), CPU culling skips instances
//! wholly beyond it (counts), GPU culling draws them and the clipping
//! still cuts them, and a plane beyond everything changes nothing.

mod common;

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The 1 m Box seen straight on, its front face 0.9 m away.
const BOX_POSE: &str = "0,0,1.4,0,0,0";

/// Runs `vergence render ARGS --out DIR` and returns the left eye and
/// stats.json.
fn render(name: &str, args: &[&str]) -> (image::RgbaImage, Value) {
    let out: PathBuf = common::scratch("section", name);
    let o = Command::new(env!("CARGO_BIN_EXE_vergence"))
        .arg("render")
        .args(args)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("vergence runs");
    assert!(
        o.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let stats: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["validation_messages"], 0, "{name}: validation");
    (load(&out.join("left.png")), stats)
}

fn load(p: &Path) -> image::RgbaImage {
    image::open(p).unwrap().to_rgba8()
}

fn is_red(p: &image::Rgba<u8>) -> bool {
    let [r, g, b, _] = p.0;
    r > 60 && u32::from(r) > 2 * u32::from(g) + 10 && u32::from(r) > 2 * u32::from(b) + 10
}

/// The column where the box's front face is split by x = 0: the middle of
/// its red columns in the uncut image (a face at one depth projects
/// affinely, so its centre line lands midway).
fn split_column(img: &image::RgbaImage) -> u32 {
    let cols: Vec<u32> = img
        .enumerate_pixels()
        .filter(|(_, _, p)| is_red(p))
        .map(|(x, _, _)| x)
        .collect();
    (cols.iter().min().unwrap() + cols.iter().max().unwrap()) / 2
}

/// Red pixels (the Box's material) left of and right of column `mid`
/// (two columns either side left out for antialiasing).
fn red_halves(img: &image::RgbaImage, mid: u32) -> [u32; 2] {
    let mut n = [0u32; 2];
    for (x, _, p) in img.enumerate_pixels() {
        if is_red(p) && x + 2 < mid {
            n[0] += 1;
        }
        if is_red(p) && x > mid + 2 {
            n[1] += 1;
        }
    }
    n
}

fn box_args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "--scene",
        "assets/Box/Box.gltf",
        "--pose",
        BOX_POSE,
        "--width",
        "128",
        "--height",
        "128",
    ];
    v.extend_from_slice(extra);
    v
}

#[test]
fn the_far_side_of_the_plane_is_cut_away() {
    std::env::set_current_dir(common::root()).unwrap();
    let (whole, _) = render("box-whole", &box_args(&[]));
    let mid = split_column(&whole);
    let [l0, r0] = red_halves(&whole, mid);
    assert!(
        l0 > 1000 && r0 > 1000,
        "the box fills the centre: {l0} {r0}"
    );
    // Cut away x > 0: the box's right half.
    let (cut, stats) = render("box-cut", &box_args(&["--section", "0,0,0,1,0,0"]));
    let [l1, r1] = red_halves(&cut, mid);
    assert!(
        (f64::from(l1) - f64::from(l0)).abs() <= 0.05 * f64::from(l0),
        "the near side stays: {l1} of {l0}"
    );
    assert!(
        r1 * 50 < r0,
        "the far side is gone: {r1} of {r0} red pixels left"
    );
    assert_eq!(stats["config"]["section"][0], 1.0, "{}", stats["config"]);
    // A plane beyond everything leaves every pixel as it was.
    let (far, _) = render("box-far", &box_args(&["--section", "0,0,-100,0,0,-1"]));
    assert_eq!(far.as_raw(), whole.as_raw(), "a plane cutting nothing");
}

#[test]
fn culling_skips_instances_wholly_beyond_the_plane_and_gpu_cull_still_clips() {
    std::env::set_current_dir(common::root()).unwrap();
    fn with<'a>(extra: &[&'a str]) -> Vec<&'a str> {
        let mut v = vec![
            "--scene",
            "factory:2000",
            "--pose",
            "20,1.7,-20,30,0,0",
            "--width",
            "96",
            "--height",
            "96",
        ];
        v.extend_from_slice(extra);
        v
    }
    let (_, full) = render("factory-full", &with(&["--opt", "per-eye"]));
    // Everything farther than 10 m ahead of the head (yaw 30°: looking
    // towards −Z turned 30° left) is cut.
    let yaw = 30f64.to_radians();
    let (fx, fz) = (-yaw.sin(), -yaw.cos());
    let plane = format!("{},1.7,{},{fx},0,{fz}", 20.0 + 10.0 * fx, -20.0 + 10.0 * fz);
    let (cut_img, cut) = render(
        "factory-cut",
        &with(&["--opt", "per-eye", "--section", &plane]),
    );
    let n = |s: &Value, k: &str| s["cull"][k].as_u64().unwrap_or_else(|| panic!("{k}: {s}"));
    assert!(
        n(&cut, "accepted") < n(&full, "accepted"),
        "fewer kept: {} of {}",
        n(&cut, "accepted"),
        n(&full, "accepted")
    );
    assert_eq!(
        n(&cut, "accepted") + n(&cut, "rejected"),
        n(&full, "accepted") + n(&full, "rejected")
    );
    assert_eq!(cut["instances_drawn"], cut["cull"]["accepted"]);
    // GPU culling keeps the instances beyond the plane, but the shaders
    // clip them: the image matches the CPU-culled one.
    let (gpu_img, gpu) = render(
        "factory-gpu",
        &with(&["--opt", "per-eye,gpu-cull", "--section", &plane]),
    );
    assert_eq!(gpu["config"]["gpu_cull"], true, "{}", gpu["config"]);
    let differ = gpu_img
        .pixels()
        .zip(cut_img.pixels())
        .filter(|(a, b)| a.0.iter().zip(b.0.iter()).any(|(x, y)| x.abs_diff(*y) > 8))
        .count();
    assert!(
        differ * 200 < (96 * 96) as usize,
        "{differ} pixels differ between gpu-cull and CPU culling with the plane"
    );
}

/// The plane switched on and off between frames of one session: frames
/// with it equal a renderer made with it, frames without equal one made
/// without (the clipping pipelines are built when a plane first comes, and
/// frames without one keep drawing with the pipelines that do not clip).
#[test]
fn a_plane_set_and_cleared_between_frames_cuts_exactly_those_frames() {
    use glam::DVec3;
    use vergence::bench::plan::cull_names;
    use vergence::config::{PerDraw, RenderConfig};
    use vergence::render::culling::plane_of;
    use vergence::render::driver::FrameDriver;
    use vergence::render::Renderer;
    use vergence::view::profile::HmdProfile;
    use vergence::view::Pose;
    let ctx = common::context();
    let scene = common::load("assets/Box/Box.gltf");
    let rig = HmdProfile::load("valve-index")
        .unwrap()
        .rig(Pose::from_euler_deg(
            DVec3::new(0.2, 0.1, 1.4),
            0.0,
            0.0,
            0.0,
        ));
    // Cuts away x > 0 (the box's right half).
    let plane = [1.0, 0.0, 0.0, 0.0];
    let extent = ash::vk::Extent2D {
        width: 96,
        height: 96,
    };
    let before = ctx.validation_messages();
    for (opts, per_draw) in [
        ("multiview", PerDraw::Push),
        ("two-pass,no-msaa", PerDraw::Ssbo),
        ("multiview,mffr=0.5", PerDraw::Push),
        ("multiview,superfrustum,gpu-cull", PerDraw::Push),
    ] {
        let config = |section: Option<[f64; 4]>| {
            let mut c = RenderConfig {
                frame: vergence::config::FrameConfig {
                    section,
                    ..Default::default()
                },
                submission: vergence::config::SubmissionConfig {
                    per_draw,
                    ..Default::default()
                },
                ..RenderConfig::default()
            };
            c.apply_opts(opts, &cull_names()).unwrap();
            c
        };
        let one = |section| {
            let r = Renderer::new(ctx.clone(), &scene, &config(section), extent).unwrap();
            let mut d = FrameDriver::new(r, &scene).unwrap();
            d.frame(&rig, 0, true).unwrap();
            d.finish().unwrap();
            d.read_images().unwrap()
        };
        let (whole, cut) = (one(None), one(Some(plane)));
        assert_ne!(whole, cut, "{opts}: the plane cuts something");
        let r = Renderer::new(ctx.clone(), &scene, &config(None), extent).unwrap();
        let mut d = FrameDriver::new(r, &scene).unwrap();
        for (i, on) in [false, true, false, true, true, false]
            .into_iter()
            .enumerate()
        {
            d.set_section(on.then(|| plane_of(plane)));
            d.frame(&rig, i as u64, true).unwrap();
            d.finish().unwrap();
            let got = d.read_images().unwrap();
            let want = if on { &cut } else { &whole };
            assert!(&got == want, "{opts}: frame {i} (plane {on}) differs");
        }
    }
    assert_eq!(
        ctx.validation_messages(),
        before,
        "Vulkan validation messages: {:#?}",
        ctx.validation_log()
    );
}
