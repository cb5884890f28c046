//! Adaptive quality (`--opt aq`) on lavapipe: along a path whose cost rises
//! (from open sky into the factory) and falls again, the controller drops
//! the render scale and brings it back; nothing is allocated after the
//! first frame (the targets and the readback were made for the largest
//! scale); each frame is read back at its own size; zero validation
//! messages. The controller's rules themselves are unit-tested on scripted
//! GPU times in `src/adaptive.rs`.

mod common;

use common::{context, framing_pose, load};
use vergence::config::RenderConfig;
use vergence::render::driver::FrameDriver;
use vergence::render::Renderer;
use vergence::view::profile::HmdProfile;
use vergence::view::{Pose, StereoRig};

const SIZE: u32 = 160;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn the_scale_drops_where_the_path_gets_expensive_and_recovers_without_allocating() {
    let ctx = context();
    let scene = load("factory:20000");
    let profile = HmdProfile::load("valve-index").unwrap();
    let dense = framing_pose(&scene, &profile);
    // The same place looking straight up: sky only.
    let sky = Pose::from_euler_deg(dense.position, 0.0, 85.0, 0.0);
    let cheap: StereoRig = profile.rig(sky);
    let costly: StereoRig = profile.rig(dense);
    let extent = ash::vk::Extent2D {
        width: SIZE,
        height: SIZE,
    };
    // Culled with the superfrustum so the sky view draws (almost) nothing:
    // its cost is the targets' clear and resolve alone, well apart from the
    // factory's on any machine's lavapipe (without culling a clean-clone CI
    // run measured 114 ms against 254, too close).
    let base = RenderConfig {
        frame: vergence::config::FrameConfig {
            msaa: 4,
            ..Default::default()
        },
        culling: vergence::config::CullingConfig {
            cull: vergence::config::Culling::Strategy(vergence::cull::Strategy::Superfrustum),
            ..Default::default()
        },
        submission: vergence::config::SubmissionConfig {
            frames_in_flight: 1,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    // The two views' GPU cost at scale 1, without aq.
    let cost = |rig: &StereoRig| {
        let r = Renderer::new(ctx.clone(), &scene, &base, extent).unwrap();
        let mut d = FrameDriver::new(r, &scene).unwrap();
        let mut t = Vec::new();
        for i in 0..7 {
            d.frame(rig, i, false).unwrap();
            d.finish().unwrap();
            t.extend(std::iter::from_fn(|| d.take_completed()).map(|r| r.gpu_ms()));
        }
        median(t)
    };
    let (t_sky, t_dense) = (cost(&cheap), cost(&costly));
    eprintln!("GPU ms at scale 1: sky {t_sky:.2}, factory {t_dense:.2}");
    // A budget the factory view misses by 30 %, and that the sky view
    // meets under the 70 % rule at the default level (1.06x per axis, 1.12x
    // the pixels) with room for timing noise on a loaded machine: the level
    // must climb back to the default there.
    let budget = t_dense / 1.3;
    assert!(
        1.3 * t_sky < 0.7 * budget,
        "the views' costs ({t_sky:.2} and {t_dense:.2} ms) are too close for this test"
    );
    let config = {
        let mut rc = base.clone();
        rc.effort.aq = true;
        rc.effort.budget_ms = Some(budget);
        rc
    };
    let before = ctx.validation_messages();
    let r = Renderer::new(ctx.clone(), &scene, &config, extent).unwrap();
    let mut d = FrameDriver::new(r, &scene).unwrap();
    let path: Vec<&StereoRig> = std::iter::repeat_n(&cheap, 12)
        .chain(std::iter::repeat_n(&costly, 24))
        .chain(std::iter::repeat_n(&cheap, 64))
        .collect();
    let mut frames = Vec::new();
    let mut gpu = Vec::new();
    let mut allocated = Vec::new();
    for (i, rig) in path.iter().enumerate() {
        d.frame(rig, i as u64, true).unwrap();
        d.finish().unwrap();
        let images = d.read_images().unwrap();
        let r = d.take_completed().expect("the frame finished");
        let aq = r.aq.expect("aq on the frame");
        assert_eq!(
            images[0].dimensions(),
            (aq.size[0], aq.size[1]),
            "frame {i} read back at its rendered size"
        );
        let want = (SIZE as f64 * aq.scale).round() as u32;
        assert_eq!(aq.size, [want, want], "frame {i}");
        allocated.push(ctx.allocated_bytes());
        gpu.push(r.gpu_ms());
        frames.push(aq);
    }
    drop(d);
    common::assert_no_validation_since(&ctx, before);
    let levels: Vec<usize> = frames.iter().map(|f| f.level).collect();
    eprintln!("levels along the path: {levels:?}");
    let start = levels[0];
    let lowest_dense = *levels[12..36].iter().min().unwrap();
    assert!(
        lowest_dense + 2 <= start,
        "the factory view dropped the level: {levels:?}"
    );
    // Back in the sky the level climbs (five frames a level). A timing
    // spike of a loaded 2-core machine legitimately drops it two levels:
    // every drop there must follow a frame measured over the controller's
    // 0.85 B extrapolation threshold (no rule drops below it); without
    // such a frame the level must be back at the start.
    let sky_top = *levels[36..].iter().max().unwrap();
    assert!(
        sky_top >= lowest_dense + 2,
        "back in the sky the level climbs: {levels:?}"
    );
    let spike = |i: usize| {
        gpu[i.saturating_sub(3)..i]
            .iter()
            .any(|&t| t > 0.85 * budget)
    };
    for i in 37..levels.len() {
        if levels[i] < levels[i - 1] {
            assert!(
                spike(i),
                "frame {i} dropped the level in the sky without an expensive frame: levels {levels:?}, GPU ms {gpu:?}"
            );
        }
    }
    if !(36..levels.len()).any(|i| gpu[i] > 0.85 * budget) {
        assert!(
            sky_top >= start,
            "back in the sky the level recovered: {levels:?}, GPU ms {gpu:?}"
        );
    }
    assert!(frames.iter().all(|f| (f.budget_ms - budget).abs() < 1e-9));
    // Nothing allocated after the first frame: the targets and the
    // readback were made for the largest scale.
    assert!(
        allocated.windows(2).all(|w| w[0] == w[1]),
        "allocations changed: {allocated:?}"
    );
}

/// With `inset`, frames that even the lowest render scale cannot bring
/// under the budget walk on down the inset's rungs: the scale stays at the
/// lowest, the wide view goes to one sample, then shrinks to its smallest
/// factor, every frame is
/// read back at its own size, nothing is allocated after the first frame,
/// no validation message; with `aq-scale-only` it stops at the lowest
/// scale.
#[test]
fn with_the_inset_the_rung_below_the_lowest_scale_shrinks_the_wide_view() {
    use vergence::config::StereoMode;
    walk_down_the_rungs(StereoMode::Multiview, false);
    // One wide set per eye, and the hidden-area mask's one-sample twin
    // drawing into the one-sample depth.
    walk_down_the_rungs(StereoMode::TwoPass, true);
}

fn walk_down_the_rungs(stereo: vergence::config::StereoMode, stencil_mask: bool) {
    use vergence::adaptive::{wide_rung_factors, MIN_SCALE, MIN_WIDE_FACTOR, STEP_PCT};
    let ctx = context();
    let scene = load("factory:2000");
    let profile = HmdProfile::load("valve-index").unwrap();
    let rig = profile.rig(framing_pose(&scene, &profile));
    let extent = ash::vk::Extent2D {
        width: SIZE,
        height: SIZE,
    };
    let config = RenderConfig {
        frame: vergence::config::FrameConfig {
            stereo,
            msaa: 4,
            ..Default::default()
        },
        effort: vergence::config::EffortConfig {
            aq: true,
            // No frame meets a microsecond.
            budget_ms: Some(0.001),
            inset: Some(vergence::config::Inset {
                wide_scale: 0.5,
                half_angle_deg: 20.0,
                fov_given: true,
                ..Default::default()
            }),
            stencil_mask,
            ..Default::default()
        },
        submission: vergence::config::SubmissionConfig {
            frames_in_flight: 1,
            ..Default::default()
        },
        ..RenderConfig::default()
    };
    // With aq-scale-only the controller stops at the lowest scale.
    let frames_of = |config: &RenderConfig| {
        let r = Renderer::new(ctx.clone(), &scene, config, extent).unwrap();
        let mut d = FrameDriver::new(r, &scene).unwrap();
        (0..48)
            .map(|i| {
                d.frame(&rig, i, false).unwrap();
                d.finish().unwrap();
                d.take_completed().expect("the frame finished").aq.unwrap()
            })
            .collect::<Vec<_>>()
    };
    let scale_only = frames_of(&{
        let mut rc = config.clone();
        rc.effort.aq_scale_only = true;
        rc
    });
    let last = scale_only.last().unwrap();
    assert_eq!((last.level, last.scale), (0, MIN_SCALE));
    assert!(scale_only
        .iter()
        .all(|f| f.wide_factor == 1.0 && !f.wide_one_sample));
    let before = ctx.validation_messages();
    let r = Renderer::new(ctx.clone(), &scene, &config, extent).unwrap();
    let mut d = FrameDriver::new(r, &scene).unwrap();
    let mut frames = Vec::new();
    let mut allocated = Vec::new();
    for i in 0..48 {
        d.frame(&rig, i, true).unwrap();
        d.finish().unwrap();
        let images = d.read_images().unwrap();
        let aq = d.take_completed().expect("the frame finished").aq.unwrap();
        assert_eq!(
            images[0].dimensions(),
            (aq.size[0], aq.size[1]),
            "frame {i}"
        );
        allocated.push(ctx.allocated_bytes());
        frames.push(aq);
    }
    drop(d);
    common::assert_no_validation_since(&ctx, before);
    let factors = wide_rung_factors(MIN_WIDE_FACTOR, STEP_PCT).unwrap();
    let seen: Vec<(f64, f64)> = frames.iter().map(|f| (f.scale, f.wide_factor)).collect();
    eprintln!("(scale, wide factor) along the frames: {seen:?}");
    let last = frames.last().unwrap();
    assert_eq!(last.level, 0, "{seen:?}");
    assert_eq!((last.scale, last.wide_factor), (MIN_SCALE, factors[0]));
    // The rungs are reached only at the lowest scale: first the wide view
    // at one sample (the MSAA rung: multiview, two scopes, 4x), then its
    // factors, which keep one sample; the wide factor never grows while
    // the frames stay over budget.
    for f in &frames {
        assert!(f.wide_factor == 1.0 || f.scale == MIN_SCALE, "{seen:?}");
        assert!(!f.wide_one_sample || f.scale == MIN_SCALE, "{seen:?}");
        assert!(f.wide_factor == 1.0 || f.wide_one_sample, "{seen:?}");
    }
    // (Whether a frame lands on the MSAA rung itself depends on where the
    // two-level drops fall; the ladder's order is unit-tested in
    // src/adaptive.rs.)
    assert!(last.wide_one_sample, "the lowest level is at one sample");
    assert!(frames
        .windows(2)
        .all(|w| w[1].wide_factor <= w[0].wide_factor));
    assert!(
        allocated.windows(2).all(|w| w[0] == w[1]),
        "allocations changed: {allocated:?}"
    );
}

/// Adaptive quality composes with the techniques that follow the frame's
/// drawn size: over a budget no frame meets, the controller lowers the
/// scale frame by frame, and each frame equals the same technique rendered
/// by a renderer made at the size adaptive quality drew (same rig, pixel
/// for pixel) — for RDM with its fill, the sky after the resolve, RDM with
/// the resolved sky, LOD, occlusion, the stencil mask and two-pass, and the
/// far field (on the CPU's split and the GPU's, with alternate eyes).
#[test]
fn each_frame_equals_the_technique_at_the_size_it_was_drawn() {
    use vergence::bench::plan::cull_names;
    let ctx = context();
    let scene = load("factory:2000");
    let profile = HmdProfile::load("valve-index").unwrap();
    let rig = profile.rig(framing_pose(&scene, &profile));
    let rigs = vec![rig.clone(); 6];
    let config = |opts: &str| {
        let mut c = RenderConfig::default();
        c.apply_opts(&format!("superfrustum,{opts}"), &cull_names())
            .unwrap();
        c.submission.frames_in_flight = 1;
        c.validate().unwrap();
        c
    };
    let mut failures = Vec::new();
    for opts in [
        "gpu-cull",
        "rdm=0.4",
        "resolved-sky",
        "rdm=0.4,resolved-sky",
        "gpu-cull,lod",
        "gpu-cull,occlusion",
        "stencil-mask,two-pass",
        "mffr",
        "mffr,mffr-alternate-eye",
        "gpu-cull,mffr",
        "lms",
        "lms=0.3,stencil-mask,two-pass",
    ] {
        let adaptive = {
            let mut rc = config(opts);
            rc.effort.aq = true;
            rc.effort.budget_ms = Some(0.001);
            rc
        };
        let (results, images) = common::frame_by_frame(&ctx, &scene, &adaptive, &rigs, SIZE);
        let last = results.last().unwrap().aq.unwrap();
        assert!(last.scale < 1.0, "{opts}: the scale fell to {}", last.scale);
        // The first frame (scale 1 or above) and the last (lowest so far).
        for i in [0, rigs.len() - 1] {
            let size = results[i].aq.unwrap().size;
            assert_eq!(size[0], size[1]);
            let (_, fixed) =
                common::frame_by_frame(&ctx, &scene, &config(opts), &rigs[..1], size[0]);
            let differing: usize = (0..2)
                .map(|e| common::pixels_differing(&images[i][e], &fixed[0][e]))
                .sum();
            // LMS's resample reads through the sampler, whose sub-texel
            // rounding follows the targets' size: a code value at a few
            // pixels.
            let rounding = opts.starts_with("lms")
                && differing * 200 <= (2 * SIZE * SIZE) as usize
                && (0..2).all(|e| {
                    images[i][e]
                        .pixels()
                        .zip(fixed[0][e].pixels())
                        .all(|(p, q)| (0..4).all(|c| p[c].abs_diff(q[c]) <= 1))
                });
            if differing != 0 && !rounding {
                failures.push(format!(
                    "{opts},aq frame {i} at {size:?}: {differing} pixels"
                ));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "frames that differ from the technique rendered at their size: {failures:#?}"
    );
}
