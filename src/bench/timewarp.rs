//! The timewarp measurement of `render --frames N --opt timewarp=K`
//! ([`crate::render::timewarp`]): the head turns at `--head-turn` degrees
//! per second (at the profile's refresh rate) for N frames; every frame is
//! rendered (the truth), every K-th one is a source, and each frame between
//! is warped from the last source to its own pose and compared with its
//! truth by FLIP (both eyes, at the headset's pixels per degree).

use super::metrics;
use crate::error::{Error, Result};
use crate::render::driver::FrameDriver;
use crate::render::timewarp::{Timewarp, TimewarpStats};
use crate::targets::headless::{self, Loaded, Percentiles, RenderJob};
use crate::view::{Pose, StereoRig};
use glam::DQuat;

/// Checks `job`'s timewarp settings before anything is rendered or
/// written: K against the frame count, no fixed rig, a bounded turn rate.
pub fn check(job: &RenderJob) -> Result<crate::config::Timewarp> {
    job.config.validate()?;
    let settings = job
        .config
        .simulator
        .timewarp
        .ok_or_else(|| Error::config("--opt", "the timewarp measurement needs timewarp=K"))?;
    let k = settings.k;
    if job.frames <= k {
        return Err(Error::config(
            "--frames",
            format!(
                "{} frames leave nothing to warp with timewarp={k}: give more than {k}",
                job.frames
            ),
        ));
    }
    if job.rig.is_some() {
        return Err(Error::config(
            "--rig",
            "timewarp turns the head from --pose or --camera (or the framing pose), not from a fixed rig",
        ));
    }
    let max = crate::cli::MAX_HEAD_TURN_DEG_S;
    if !job.head_turn_deg_s.is_finite() || job.head_turn_deg_s.abs() > max {
        return Err(Error::config(
            "--head-turn",
            format!(
                "{} must be within ±{max} degrees per second",
                job.head_turn_deg_s
            ),
        ));
    }
    Ok(settings)
}

/// Runs the measurement `job` describes (its `config.timewarp` is set) on
/// the context, scene and profile `render` already `loaded`, and adds the
/// last warped pair and its truth to `outputs`, the render's set
/// (`{left,right}_warped.png`, `{left,right}_truth.png` in `job.out`).
pub fn measure(
    job: &RenderJob,
    loaded: &Loaded,
    outputs: &mut crate::fsio::OutputSet,
) -> Result<TimewarpStats> {
    let settings = check(job)?;
    let k = settings.k;
    let Loaded {
        ctx,
        scene,
        profile,
    } = loaded;
    let before = ctx.validation_messages();
    let extent = headless::eye_extent(profile, job.size);
    let mut config = job.config.clone();
    config.resolve_lens(Some(profile))?;
    let renderer = headless::new_renderer(ctx, scene, &config, extent)?;
    let near = renderer.config.frame.near;
    let mut driver = FrameDriver::new(renderer, scene)?;
    let head = match (&job.camera, job.pose) {
        (Some(name), _) => headless::scene_camera(scene, name)?,
        (None, Some(pose)) => pose,
        (None, None) => crate::targets::framing::head_pose(scene, profile, job.framing),
    };
    let step = job.head_turn_deg_s.to_radians() / profile.refresh_hz;
    let rig_at = |i: u32| -> StereoRig {
        profile.rig(Pose {
            position: head.position,
            orientation: head.orientation * DQuat::from_rotation_y(step * i as f64),
        })
    };
    let ppd = (metrics::headset_ppd(
        extent.width,
        profile.views[0].fov.left,
        profile.views[0].fov.right,
    ) as f64)
        .max(metrics::MIN_FLIP_PPD) as f32;
    let mut warp = Timewarp::new(ctx, extent, settings.variant)?;
    let pixels = 2.0 * extent.width as f64 * extent.height as f64;
    let mut source: Option<([image::RgbaImage; 2], [Vec<f32>; 2], StereoRig)> = None;
    let (mut flips, mut warp_ms, mut render_ms) = (Vec::new(), Vec::new(), Vec::new());
    let (mut holes, mut border, mut cracks) = (0.0, 0.0, 0.0);
    let mut last = None;
    for i in 0..job.frames {
        let rig = rig_at(i);
        driver.frame(&rig, i as u64, true)?;
        driver.finish()?;
        while let Some(r) = driver.take_completed() {
            render_ms.push(r.gpu_ms());
        }
        let truth = driver.read_images()?;
        let depth = Timewarp::source_depth(driver.renderer_mut(), settings.variant)?;
        if i % k == 0 {
            source = Some((truth, depth, rig));
            continue;
        }
        let (colour, z, old) = source.as_ref().expect("frame 0 is a source");
        let out = warp.warp(
            colour,
            z,
            [&old.views[0], &old.views[1]],
            [&rig.views[0], &rig.views[1]],
            near,
        )?;
        for (t, w) in truth.iter().zip(&out.images) {
            flips.push(metrics::flip(t, w, ppd)?.mean as f64);
        }
        warp_ms.push(out.gpu_ms);
        holes += (out.holes[0] + out.holes[1]) as f64 / pixels;
        border += (out.border[0] + out.border[1]) as f64 / pixels;
        cracks += (out.cracks[0] + out.cracks[1]) as f64 / pixels;
        last = Some((out.images, truth));
    }
    driver.finish()?;
    // Their teardown is counted with the rest.
    drop(driver);
    drop(warp);
    let warped = warp_ms.len();
    if let Some((images, truth)) = last {
        let pairs = [
            (&images[0], "left_warped.png"),
            (&images[1], "right_warped.png"),
            (&truth[0], "left_truth.png"),
            (&truth[1], "right_truth.png"),
        ];
        for (image, name) in pairs {
            outputs.write(&job.out.join(name), |w| headless::png_to(w, image))?;
        }
    }
    let n = warped.max(1) as f64;
    Ok(TimewarpStats {
        k,
        variant: settings.variant,
        head_turn_deg_s: job.head_turn_deg_s,
        frames_rendered: job.frames,
        frames_warped: warped as u32,
        flip_mean: flips.iter().sum::<f64>() / flips.len().max(1) as f64,
        flip_max: flips.iter().copied().fold(0.0, f64::max),
        holes_fraction: holes / n,
        border_fraction: border / n,
        cracks_fraction: cracks / n,
        warp_gpu_ms: Percentiles::of(&warp_ms),
        render_gpu_ms: Percentiles::of(&render_ms),
        validation_messages: ctx.validation_messages() - before,
    })
}
