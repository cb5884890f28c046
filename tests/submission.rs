//! Submission paths (`--record-threads`, `--per-draw`) draw exactly the
//! images of the plain path: recording the draws on several threads into
//! secondary command buffers keeps their order, and passing per-draw data
//! by push constants, a dynamic uniform offset or a storage-buffer index
//! reaches the same material and instances. Every frame is rendered under
//! Vulkan validation (with synchronization validation in `cargo xtask
//! test`), and any message fails the test.

mod common;

use common::{context, fails_with_one_error, framing_pose, load, render_config, scratch};
use vergence::config::{PerDraw, RenderConfig, StereoMode};
use vergence::view::profile::HmdProfile;

fn config(stereo: StereoMode, opt: &str, threads: Option<u32>, per_draw: PerDraw) -> RenderConfig {
    let mut c = RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo,
            ..Default::default()
        },
        submission: vergence::config::SubmissionConfig {
            record_threads: threads,
            per_draw,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    c.apply_opts(opt, &vergence::config::cull_names()).unwrap();
    c
}

/// Asserts `got` drew what `want` did: the same draw calls, both eyes equal
/// pixel for pixel.
fn same(got: &common::Frame, want: &common::Frame, what: &str) {
    assert_eq!(got.stats.draw_calls, want.stats.draw_calls, "{what}");
    for eye in 0..2 {
        assert!(
            got.images[eye] == want.images[eye],
            "{what}: eye {eye} differs"
        );
    }
}

#[test]
fn parallel_recording_draws_the_images_of_one_thread() {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    // cad: unique meshes, one draw each; AlphaBlendModeTest: blended draws,
    // so the sky lands inside a run rather than at the end.
    for spec in [
        "cad:1500",
        "assets/AlphaBlendModeTest/AlphaBlendModeTest.gltf",
    ] {
        let scene = load(spec);
        let pose = framing_pose(&scene, &profile);
        for stereo in [StereoMode::Multiview, StereoMode::TwoPass] {
            for opt in ["", "stencil-mask,rdm"] {
                let plain = config(stereo, opt, None, PerDraw::Push);
                let want = render_config(&ctx, &scene, &profile, pose, &plain, 160, 144);
                assert!(want.stats.draw_calls > 2, "{spec}: nothing drawn");
                for threads in [1, 3, 8] {
                    let c = config(stereo, opt, Some(threads), PerDraw::Push);
                    let got = render_config(&ctx, &scene, &profile, pose, &c, 160, 144);
                    same(
                        &got,
                        &want,
                        &format!("{spec} {stereo:?} '{opt}' on {threads} threads"),
                    );
                }
            }
        }
    }
}

#[test]
fn the_three_per_draw_paths_draw_identical_images() {
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    for spec in [
        "cad:1200",
        "assets/AlphaBlendModeTest/AlphaBlendModeTest.gltf",
    ] {
        let scene = load(spec);
        let pose = framing_pose(&scene, &profile);
        for stereo in [StereoMode::Multiview, StereoMode::TwoPass] {
            let push = config(stereo, "", None, PerDraw::Push);
            let want = render_config(&ctx, &scene, &profile, pose, &push, 160, 144);
            for per_draw in [PerDraw::Ubo, PerDraw::Ssbo] {
                for threads in [None, Some(4)] {
                    let c = config(stereo, "", threads, per_draw);
                    let got = render_config(&ctx, &scene, &profile, pose, &c, 160, 144);
                    same(
                        &got,
                        &want,
                        &format!("{spec} {stereo:?} {per_draw:?} threads {threads:?}"),
                    );
                }
            }
        }
    }
}

#[test]
fn cad_scenes_draw_one_call_per_unique_part() {
    let out = scratch("submission", "cad");
    let stats = common::render_cli(
        &[
            "--scene",
            "cad:3000",
            "--width",
            "96",
            "--height",
            "96",
            "--record-threads",
            "2",
            "--per-draw",
            "ubo",
        ],
        &out,
    );
    // 3000 unique meshes with one instance each, plus the sky.
    assert_eq!(stats["draw_calls"], 3001, "{stats}");
    assert_eq!(stats["instances_drawn"], 3000, "{stats}");
    assert_eq!(stats["validation_messages"], 0, "{stats}");
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn bad_submission_values_are_one_error() {
    let out = scratch("submission", "bad");
    let render = |args: &[&str]| {
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_vergence"));
        cmd.arg("render").args(args).arg("--out").arg(&out);
        fails_with_one_error(&mut cmd)
    };
    for (args, want) in [
        (&["--record-threads", "0"][..], "--record-threads"),
        (&["--record-threads", "65"][..], "--record-threads"),
        (&["--record-threads", "x"][..], "--record-threads"),
        (&["--per-draw", "uniform"][..], "--per-draw"),
        (&["--scene", "cad"][..], "cad:N"),
        (&["--scene", "cad:0"][..], "cad:N"),
        (&["--scene", "cad:100001"][..], "cad:N"),
        (
            &["--record-threads", "2", "--opt", "superfrustum,gpu-cull"][..],
            "gpu-cull",
        ),
        (&["--per-draw", "ssbo", "--opt", "mffr"][..], "mffr"),
    ] {
        let stderr = render(args);
        assert!(stderr.contains(want), "{args:?}: {stderr}");
    }
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn frames_with_changing_draw_lists_match_on_every_path() {
    use vergence::render::Renderer;
    let ctx = context();
    let profile = HmdProfile::load("valve-index").unwrap();
    let scene = load("cad:1500");
    let pose = framing_pose(&scene, &profile);
    let rig = profile.rig(pose);
    // Few draws, then all (the per-draw record buffers grow while the
    // previous frame is in flight), then a middle run.
    let lists: Vec<Vec<u32>> = [0..100u32, 0..1500, 200..900]
        .into_iter()
        .map(|r| r.collect())
        .collect();
    let extent = ash::vk::Extent2D {
        width: 128,
        height: 112,
    };
    let frames = |threads: Option<u32>, per_draw: PerDraw| {
        let mut c = config(StereoMode::TwoPass, "rdm", threads, per_draw);
        c.submission.frames_in_flight = 2;
        let before = ctx.validation_messages();
        let mut r = Renderer::new(ctx.clone(), &scene, &c, extent).unwrap();
        let mut out = Vec::new();
        for list in &lists {
            let stats = r.render(&rig, Some(list), true).unwrap();
            out.push((stats.draw_calls, r.read_images().unwrap()));
        }
        drop(r);
        assert_eq!(
            ctx.validation_messages(),
            before,
            "{threads:?} {per_draw:?}: {:#?}",
            ctx.validation_log()
        );
        out
    };
    let want = frames(None, PerDraw::Push);
    assert!(want[0].0 < want[1].0, "the lists draw different counts");
    for (threads, per_draw) in [
        (Some(3), PerDraw::Push),
        (Some(4), PerDraw::Ubo),
        (Some(2), PerDraw::Ssbo),
        (None, PerDraw::Ubo),
        (None, PerDraw::Ssbo),
    ] {
        let got = frames(threads, per_draw);
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(g.0, w.0, "frame {i}, {threads:?} {per_draw:?}: draw calls");
            assert!(
                g.1 == w.1,
                "frame {i}, {threads:?} {per_draw:?}: images differ"
            );
        }
    }
}
