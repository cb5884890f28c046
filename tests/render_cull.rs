//! Culling strategies feed the draw batches: conservative strategies draw
//! fewer instances and leave the image unchanged; `vergence render --opt`
//! accepts every strategy name.

use glam::DVec3;
use std::path::PathBuf;
use vergence::bench::metrics::{flip, DESKTOP_PPD};
use vergence::config::RenderConfig;
use vergence::targets::headless::{render_to_dir, RenderJob, RenderStats};
use vergence::view::Pose;

fn job(cull: &str, name: &str) -> (RenderStats, [image::RgbaImage; 2]) {
    let out = std::env::temp_dir().join(format!("vergence-cull-{}-{name}", std::process::id()));
    let config = RenderConfig {
        culling: vergence::config::CullingConfig {
            cull: cull.parse().expect("a culling name"),
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    let job = RenderJob {
        scene: "factory:4000".into(),
        hmd: "valve-index".into(),
        pose: Some(Pose::from_euler_deg(
            DVec3::new(20.0, 1.7, -20.0),
            30.0,
            0.0,
            0.0,
        )),
        camera: None,
        framing: Default::default(),
        rig: None,
        config,
        size: Some((128, 128)),
        out: out.clone(),
        frames: 1,
        distorted: None,
        head_turn_deg_s: 0.0,
    };
    let stats = render_to_dir(&job).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(stats.validation_messages, 0);
    let load = |p: PathBuf| image::open(p).unwrap().to_rgba8();
    (
        stats,
        [load(out.join("left.png")), load(out.join("right.png"))],
    )
}

#[test]
fn conservative_culling_keeps_the_image() {
    let (full, full_img) = job("none", "none");
    for strategy in ["per-eye", "superfrustum", "conical-superfrustum"] {
        let (culled, img) = job(strategy, strategy);
        let c = culled.cull.expect("cull stats present");
        assert!(
            culled.instances_drawn < full.instances_drawn / 2,
            "{strategy}: {} of {}",
            culled.instances_drawn,
            full.instances_drawn
        );
        assert_eq!(
            c.accepted, culled.instances_drawn,
            "{strategy}: every kept instance is drawn"
        );
        assert!(culled.cpu_ms.contains_key("cull") && culled.cpu_ms.contains_key("bvh_build"));
        for eye in 0..2 {
            let r = flip(&full_img[eye], &img[eye], DESKTOP_PPD).unwrap();
            assert!(
                r.mean < 1e-3,
                "{strategy} eye {eye}: FLIP mean {} vs drawing everything",
                r.mean
            );
        }
    }
}

#[test]
fn every_strategy_name_is_accepted_by_opt() {
    let out = std::env::temp_dir().join(format!("vergence-opt-{}", std::process::id()));
    for s in vergence::cull::Strategy::ALL {
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
            .args([
                "render",
                "--scene",
                "factory:200",
                "--width",
                "32",
                "--height",
                "32",
                "--opt",
            ])
            .arg(format!("two-pass,{}", s.name()))
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert!(
            status.status.success(),
            "{}: {}",
            s.name(),
            String::from_utf8_lossy(&status.stderr)
        );
        let stats: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("stats.json")).unwrap())
                .unwrap();
        assert_eq!(stats["config"]["cull"], s.name());
        assert_eq!(stats["config"]["stereo"], "two-pass");
    }
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"))
        .args([
            "render",
            "--scene",
            "factory:10",
            "--opt",
            "warp-speed",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("unknown optimization 'warp-speed'"));
}
