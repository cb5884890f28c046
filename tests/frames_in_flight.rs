//! Frames in flight: the frame driver keeps up to N frames on the GPU, its
//! results come out complete and in order, and the pixels do not depend on
//! N (also with history: alternate-eye MFFR, round-robin culling).

mod common;

use common::{context, framing_pose, load};
use glam::DVec3;
use vergence::config::{Culling, RenderConfig, StereoMode};
use vergence::cull::Strategy;
use vergence::render::driver::FrameDriver;
use vergence::render::Renderer;
use vergence::view::profile::HmdProfile;
use vergence::view::{Pose, StereoRig};

const W: u32 = 96;
const H: u32 = 80;
const FRAMES: u64 = 9;

/// A short head path: the rig turns a little each frame.
fn rigs(profile: &HmdProfile, base: Pose) -> Vec<StereoRig> {
    (0..FRAMES)
        .map(|i| {
            let turn = Pose::from_euler_deg(DVec3::ZERO, 3.0 * i as f64, 0.0, 0.0);
            profile.rig(base.compose(&turn))
        })
        .collect()
}

#[test]
fn at_most_n_frames_are_in_flight_and_results_come_in_order() {
    let ctx = context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let scene = load("factory:300");
    let path = rigs(&profile, framing_pose(&scene, &profile));
    for n in 1..=3u32 {
        let config = RenderConfig {
            frame: vergence::config::FrameConfig {
                msaa: 1,
                ..Default::default()
            },
            culling: vergence::config::CullingConfig {
                cull: Culling::Strategy(Strategy::Superfrustum),
                ..Default::default()
            },
            submission: vergence::config::SubmissionConfig {
                frames_in_flight: n,
                ..Default::default()
            },
            ..RenderConfig::default()
        };
        let extent = ash::vk::Extent2D {
            width: W,
            height: H,
        };
        let renderer = Renderer::new(ctx.clone(), &scene, &config, extent).unwrap();
        assert_eq!(renderer.frames_in_flight(), n as usize);
        let mut driver = FrameDriver::new(renderer, &scene).unwrap();
        let mut seen = Vec::new();
        for (k, rig) in path.iter().enumerate() {
            driver.record(rig, 100 + k as u64).unwrap();
            while let Some(r) = driver.take_completed() {
                seen.push(r);
            }
            // Frame k began by waiting for frame k - n: everything before
            // it has finished, at most n - 1 earlier frames are still out.
            let earlier_out = k - seen.len();
            assert!(
                earlier_out < n as usize,
                "{n} in flight: {earlier_out} earlier frames out while recording frame {k}"
            );
            driver.submit(None, false).unwrap();
            while let Some(r) = driver.take_completed() {
                seen.push(r);
            }
            assert!(k + 1 - seen.len() <= n as usize);
        }
        driver.finish().unwrap();
        while let Some(r) = driver.take_completed() {
            seen.push(r);
        }
        let indices: Vec<u64> = seen.iter().map(|r| r.index).collect();
        assert_eq!(indices, (100..100 + FRAMES).collect::<Vec<_>>());
        for (k, r) in seen.iter().enumerate() {
            assert!(r.gpu_ms() > 0.0, "{n}: frame {k} has its GPU time");
            assert!(r.stats.draw_calls > 0 && r.cull.is_some());
            assert_eq!(r.interval_ms.is_some(), k > 0);
        }
        drop(driver);
        assert_eq!(ctx.validation_messages(), 0, "{:#?}", ctx.validation_log());
    }
}

/// The last frame of the path, read back, with `n` frames in flight.
fn last_frame(config: &RenderConfig, n: u32) -> [image::RgbaImage; 2] {
    let ctx = context();
    let profile = HmdProfile::load("monado-sim").unwrap();
    let scene = load("factory:300");
    let path = rigs(&profile, framing_pose(&scene, &profile));
    let config = {
        let mut rc = config.clone();
        rc.submission.frames_in_flight = n;
        rc
    };
    let extent = ash::vk::Extent2D {
        width: W,
        height: H,
    };
    let renderer = Renderer::new(ctx.clone(), &scene, &config, extent).unwrap();
    let mut driver = FrameDriver::new(renderer, &scene).unwrap();
    for (k, rig) in path.iter().enumerate() {
        driver.frame(rig, k as u64, k + 1 == path.len()).unwrap();
    }
    let images = driver.read_images().unwrap();
    drop(driver);
    assert_eq!(ctx.validation_messages(), 0, "{:#?}", ctx.validation_log());
    images
}

#[test]
fn pixels_do_not_depend_on_frames_in_flight() {
    let mut stack = RenderConfig {
        frame: vergence::config::FrameConfig {
            msaa: 4,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    stack
        .apply_opts(
            "multiview,stencil-mask,round-robin,mffr,mffr-alternate-eye",
            &vergence::bench::plan::cull_names(),
        )
        .unwrap();
    let two_pass = RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo: StereoMode::TwoPass,
            msaa: 1,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    for config in [stack, two_pass] {
        let one = last_frame(&config, 1);
        for n in [2, 3] {
            let other = last_frame(&config, n);
            for eye in 0..2 {
                assert!(
                    one[eye] == other[eye],
                    "{:?} {} eye {eye}: {n} in flight differs from 1",
                    config.frame.stereo,
                    config.culling.cull
                );
            }
        }
    }
}
