//! The timewarp simulation on lavapipe, with validation: no motion gives
//! the rendered frame back, a pure turn matches the frame rendered there
//! except at the border, holes open only at depth edges, and the CLI
//! measures it along a turning head.

mod common;

use ash::vk;
use glam::{DQuat, DVec3};
use std::process::Command;
use std::sync::Arc;
use vergence::config::{RenderConfig, StereoMode, Timewarp as Settings, TimewarpVariant};
use vergence::gpu::Context;
use vergence::render::timewarp::{Timewarp, WarpOutput};
use vergence::render::Renderer;
use vergence::scene::Scene;
use vergence::view::profile::HmdProfile;
use vergence::view::{Pose, StereoRig, View};

const W: u32 = 160;
const H: u32 = 176;

struct Frame {
    colour: [image::RgbaImage; 2],
    depth: [Vec<f32>; 2],
    rig: StereoRig,
}

fn config(stereo: StereoMode) -> RenderConfig {
    RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo,
            msaa: 4,
            ..Default::default()
        },
        simulator: vergence::config::SimulatorConfig {
            timewarp: Some(Settings {
                k: 2,
                variant: TimewarpVariant::Depth,
            }),
        },
        ..RenderConfig::default()
    }
}

fn render(ctx: &Arc<Context>, scene: &Scene, rig: &StereoRig, stereo: StereoMode) -> Frame {
    let extent = vk::Extent2D {
        width: W,
        height: H,
    };
    let mut r = Renderer::new(ctx.clone(), scene, &config(stereo), extent).unwrap();
    r.render(rig, None, true).unwrap();
    let colour = r.read_images().unwrap();
    let depth = r.read_depth().unwrap();
    Frame {
        colour,
        depth,
        rig: rig.clone(),
    }
}

fn warp(ctx: &Arc<Context>, from: &Frame, to: &StereoRig, variant: TimewarpVariant) -> WarpOutput {
    let before = ctx.validation_messages();
    let extent = vk::Extent2D {
        width: W,
        height: H,
    };
    let mut t = Timewarp::new(ctx, extent, variant).unwrap();
    let views = |r: &StereoRig| -> [View; 2] { [r.views[0], r.views[1]] };
    let (old, new) = (views(&from.rig), views(to));
    let out = t
        .warp(
            &from.colour,
            &from.depth,
            [&old[0], &old[1]],
            [&new[0], &new[1]],
            0.05,
        )
        .unwrap();
    drop(t);
    common::assert_no_validation_since(ctx, before);
    out
}

/// Each eye turned by `yaw` radians about its own position.
fn turned(rig: &StereoRig, yaw: f64) -> StereoRig {
    let mut r = rig.clone();
    for v in &mut r.views {
        v.pose.orientation *= DQuat::from_rotation_y(yaw);
    }
    r
}

/// Each eye moved by `d` metres (world space).
fn moved(rig: &StereoRig, d: DVec3) -> StereoRig {
    let mut r = rig.clone();
    for v in &mut r.views {
        v.pose.position += d;
    }
    r
}

fn setup() -> (Arc<Context>, Scene, StereoRig) {
    let ctx = common::context();
    let scene = common::load("factory:3000");
    let profile = HmdProfile::load("valve-index").unwrap();
    let head = Pose::from_euler_deg(DVec3::new(4.0, 1.7, 6.0), -30.0, -5.0, 0.0);
    let rig = profile.rig(head);
    (ctx, scene, rig)
}

#[test]
fn without_motion_every_variant_gives_the_rendered_frame_back() {
    let (ctx, scene, rig) = setup();
    for stereo in [StereoMode::Multiview, StereoMode::TwoPass] {
        let f = render(&ctx, &scene, &rig, stereo);
        assert!(f.depth[0].iter().any(|&z| z > 0.0), "depth was read back");
        for variant in [
            TimewarpVariant::Rotation,
            TimewarpVariant::Depth,
            TimewarpVariant::Fill,
        ] {
            let out = warp(&ctx, &f, &rig, variant);
            for eye in 0..2 {
                assert!(
                    out.images[eye] == f.colour[eye],
                    "{stereo:?} {variant:?} eye {eye}"
                );
                assert_eq!((out.holes[eye], out.border[eye]), (0, 0));
            }
        }
    }
}

#[test]
fn a_pure_turn_matches_the_frame_rendered_there_except_at_the_border() {
    let (ctx, scene, rig) = setup();
    let old = render(&ctx, &scene, &rig, StereoMode::Multiview);
    // 3° to the left: the old image slides right, a strip on the left is new.
    let new_rig = turned(&rig, 3f64.to_radians());
    let truth = render(&ctx, &scene, &new_rig, StereoMode::Multiview);
    for variant in [
        TimewarpVariant::Rotation,
        TimewarpVariant::Depth,
        TimewarpVariant::Fill,
    ] {
        let out = warp(&ctx, &old, &new_rig, variant);
        for eye in 0..2 {
            assert!(
                out.border[eye] > 0,
                "{variant:?}: the turn reveals a border"
            );
            let (mut sum, mut n) = (0.0, 0u64);
            for y in 0..H {
                // Columns clear of the border strip and of the right edge.
                for x in W / 8..W - 2 {
                    let a = out.images[eye].get_pixel(x, y).0;
                    let b = truth.colour[eye].get_pixel(x, y).0;
                    sum += (0..3)
                        .map(|c| (a[c] as f64 - b[c] as f64).abs())
                        .sum::<f64>()
                        / 3.0;
                    n += 1;
                }
            }
            let mean = sum / n as f64;
            assert!(
                mean < 6.0,
                "{variant:?} eye {eye}: mean difference {mean:.2} of 255"
            );
            // The border is the left strip: black there, not on the right.
            let black =
                |x: u32| (0..H).all(|y| out.images[eye].get_pixel(x, y).0[..3] == [0, 0, 0]);
            assert!(black(0) && !black(W - 1), "{variant:?} eye {eye}");
        }
    }
}

#[test]
fn holes_open_only_next_to_depth_edges() {
    let (ctx, scene, rig) = setup();
    let old = render(&ctx, &scene, &rig, StereoMode::Multiview);
    // A step sideways: near things shift more than far ones.
    let right = rig.views[0].pose.orientation * DVec3::X;
    let new_rig = moved(&rig, right * 0.25);
    let truth = render(&ctx, &scene, &new_rig, StereoMode::Multiview);
    let out = warp(&ctx, &old, &new_rig, TimewarpVariant::Depth);
    let filled = warp(&ctx, &old, &new_rig, TimewarpVariant::Fill);
    for eye in 0..2 {
        assert!(out.holes[eye] > 0, "eye {eye}: a sideways step disoccludes");
        assert_eq!(out.holes, filled.holes);
        // A depth edge: within 6 pixels the (reverse-Z) depth of the truth
        // changes by a factor of 1.5 or more.
        let z = &truth.depth[eye];
        let at = |x: i64, y: i64| {
            z[(y.clamp(0, H as i64 - 1) * W as i64 + x.clamp(0, W as i64 - 1)) as usize]
        };
        let near_edge = |x: i64, y: i64| {
            let c = at(x, y);
            (-6..=6).any(|dy| {
                (-6..=6).any(|dx| {
                    let n = at(x + dx, y + dy);
                    let (lo, hi) = (c.min(n), c.max(n));
                    hi > 1.5 * lo
                })
            })
        };
        let (mut holes, mut at_edges) = (0u64, 0u64);
        for y in 0..H {
            for x in 0..W {
                let a = out.images[eye].get_pixel(x, y).0;
                let f = filled.images[eye].get_pixel(x, y).0;
                // A hole: black in the depth variant, filled in the other.
                if a[..3] == [0, 0, 0] && f[..3] != [0, 0, 0] {
                    holes += 1;
                    if near_edge(x as i64, y as i64) {
                        at_edges += 1;
                    }
                }
            }
        }
        assert!(holes > 0);
        assert!(
            at_edges as f64 >= 0.95 * holes as f64,
            "eye {eye}: {at_edges} of {holes} holes next to a depth edge"
        );
    }
}

#[test]
fn render_measures_timewarp_along_a_turning_head() {
    let out = common::scratch("timewarp", "cli");
    let stats = common::render_cli(
        &[
            "--scene",
            "factory:500",
            "--hmd",
            "valve-index",
            "--width",
            "96",
            "--height",
            "106",
            "--frames",
            "7",
            "--head-turn",
            "120",
            "--opt",
            "timewarp=3, timewarp-fill",
        ],
        &out,
    );
    let t = &stats["timewarp"];
    assert_eq!(t["k"], 3);
    assert_eq!(t["variant"], "fill");
    assert_eq!(t["frames_warped"], 4);
    let flip = t["flip_mean"].as_f64().unwrap();
    assert!(flip > 0.0 && flip < 0.1, "{flip}");
    assert!(t["border_fraction"].as_f64().unwrap() > 0.0);
    assert!(t["warp_gpu_ms"]["median"].as_f64().unwrap() > 0.0);
    assert_eq!(stats["validation_messages"], 0);
    for f in ["left_warped.png", "right_truth.png"] {
        assert!(out.join(f).exists(), "{f}");
    }
}

#[test]
fn timewarp_outside_render_and_bad_values_are_one_error() {
    let dir = common::scratch("timewarp", "bad");
    let bin = env!("CARGO_BIN_EXE_vergence");
    let render = |opt: &str, frames: &str| {
        let mut c = Command::new(bin);
        c.args([
            "render",
            "--scene",
            "factory:10",
            "--hmd",
            "monado-sim",
            "--width",
            "32",
            "--height",
            "32",
            "--frames",
            frames,
            "--opt",
            opt,
            "--out",
        ])
        .arg(&dir);
        c
    };
    let e = common::fails_with_one_error(&mut render("timewarp=1", "4"));
    assert!(e.contains("timewarp=K"), "{e}");
    let e = common::fails_with_one_error(&mut render("timewarp=4", "3"));
    assert!(e.contains("more than 4"), "{e}");
    let e = common::fails_with_one_error(&mut render(
        "timewarp=2,gpu-cull,occlusion,superfrustum",
        "4",
    ));
    assert!(e.contains("occlusion"), "{e}");
    let e = common::fails_with_one_error(Command::new(bin).args([
        "run",
        "--xr",
        "headless",
        "--frames",
        "1",
        "--opt",
        "timewarp=2",
    ]));
    assert!(e.contains("render --frames"), "{e}");
}
