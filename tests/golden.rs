//! Golden images: each scene is rendered in both stereo modes and compared
//! with FLIP against images in tests/golden/ (made on Mesa lavapipe inside
//! the Debian 13 root). Regenerate with `VERGENCE_BLESS=1 cargo xtask test`.
//! On failure the test writes the images and FLIP heat maps to
//! target/golden-diff/.

mod common;

use common::{context, framing_pose, load, render_config, root};
use vergence::bench::metrics::{flip, DESKTOP_PPD};
use vergence::config::{RenderConfig, StereoMode};
use vergence::view::profile::HmdProfile;
use vergence::view::Pose;

/// Largest accepted mean FLIP error against a golden image. Renders on the
/// same driver match exactly; the margin absorbs rasterizer differences
/// between Mesa versions (and LLVM vector widths) in edges and MSAA.
const GOLDEN_MEAN: f32 = 0.02;
/// Largest accepted mean FLIP error between multiview and two-pass.
const MODES_MEAN: f32 = 0.005;
const SIZE: u32 = 160;

fn check(name: &str, spec: &str, pose: Option<Pose>) {
    check_with(name, spec, pose, &RenderConfig::default());
}

/// Renders `spec` with `config` in both stereo modes (4× MSAA) and compares
/// with the goldens `name-left.png` / `name-right.png`.
fn check_with(name: &str, spec: &str, pose: Option<Pose>, config: &RenderConfig) {
    let ctx = context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let scene = load(spec);
    let pose = pose.unwrap_or_else(|| framing_pose(&scene, &profile));
    let mode = |stereo| {
        let mut rc = config.clone();
        rc.frame.stereo = stereo;
        rc.frame.msaa = 4;
        rc
    };
    let mv = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &mode(StereoMode::Multiview),
        SIZE,
        SIZE,
    );
    let tp = render_config(
        &ctx,
        &scene,
        &profile,
        pose,
        &mode(StereoMode::TwoPass),
        SIZE,
        SIZE,
    );
    let dir = root().join("tests/golden");
    let diff_dir = root().join("target/golden-diff");
    let bless = std::env::var("VERGENCE_BLESS").is_ok_and(|v| v == "1");
    let mut failures = Vec::new();
    for (eye, label) in ["left", "right"].iter().enumerate() {
        let golden_path = dir.join(format!("{name}-{label}.png"));
        if bless {
            std::fs::create_dir_all(&dir).unwrap();
            tp.images[eye].save(&golden_path).unwrap();
        }
        let golden = image::open(&golden_path)
            .unwrap_or_else(|e| {
                panic!(
                    "{}: {e} (bless with VERGENCE_BLESS=1)",
                    golden_path.display()
                )
            })
            .to_rgba8();
        for (mode, frame) in [("multiview", &mv), ("two-pass", &tp)] {
            let r = flip(&golden, &frame.images[eye], DESKTOP_PPD).unwrap();
            if r.mean > GOLDEN_MEAN {
                std::fs::create_dir_all(&diff_dir).unwrap();
                frame.images[eye]
                    .save(diff_dir.join(format!("{name}-{mode}-{label}.png")))
                    .unwrap();
                r.heatmap()
                    .save(diff_dir.join(format!("{name}-{mode}-{label}-flip.png")))
                    .unwrap();
                failures.push(format!(
                    "{name} {mode} {label}: FLIP mean {:.4} > {GOLDEN_MEAN}",
                    r.mean
                ));
            }
        }
        let modes = flip(&tp.images[eye], &mv.images[eye], DESKTOP_PPD).unwrap();
        if modes.mean > MODES_MEAN {
            failures.push(format!(
                "{name} {label}: multiview vs two-pass FLIP mean {:.4} > {MODES_MEAN}",
                modes.mean
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{failures:#?} (images in {})",
        diff_dir.display()
    );
    assert_eq!(mv.stats.instances_drawn, tp.stats.instances_drawn);
    // Both modes draw each batch once per eye: two-pass records twice the calls.
    assert_eq!(tp.stats.draw_calls, 2 * mv.stats.draw_calls);
}

#[test]
fn box_() {
    check("Box", "assets/Box/Box.gltf", None);
}

#[test]
fn box_textured() {
    check("BoxTextured", "assets/BoxTextured/BoxTextured.gltf", None);
}

#[test]
fn alpha_blend_mode_test() {
    check(
        "AlphaBlendModeTest",
        "assets/AlphaBlendModeTest/AlphaBlendModeTest.gltf",
        None,
    );
}

#[test]
fn normal_tangent_mirror_test() {
    check(
        "NormalTangentMirrorTest",
        "assets/NormalTangentMirrorTest/NormalTangentMirrorTest.gltf",
        None,
    );
}

#[test]
fn orientation_test() {
    check(
        "OrientationTest",
        "assets/OrientationTest/OrientationTest.gltf",
        None,
    );
}

#[test]
fn multi_uv_test() {
    check("MultiUVTest", "assets/MultiUVTest/MultiUVTest.gltf", None);
}

#[test]
fn garage() {
    check("garage", "assets/garage/garage.gltf", None);
}

#[test]
fn retroufo() {
    check("retroufo", "assets/retroufo/retroufo.glb", None);
}

#[test]
fn simple_instancing() {
    check(
        "SimpleInstancing",
        "assets/SimpleInstancing/SimpleInstancing.gltf",
        None,
    );
}

#[test]
fn factory() {
    let pose = Pose::from_euler_deg(glam::DVec3::new(3.0, 1.7, 2.0), -25.0, -5.0, 0.0);
    check("factory", "factory:3000", Some(pose));
}

#[test]
fn factory_stencil_mask() {
    let pose = Pose::from_euler_deg(glam::DVec3::new(3.0, 1.7, 2.0), -25.0, -5.0, 0.0);
    let config = RenderConfig {
        effort: vergence::config::EffortConfig {
            stencil_mask: true,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    check_with("factory-stencil-mask", "factory:3000", Some(pose), &config);
}
