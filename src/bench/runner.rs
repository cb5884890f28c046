//! Runs a [`Plan`]: for every scene × HMD × scale group it renders the
//! reference images, then each configuration along the same head path,
//! timing every frame and comparing the chosen frames with the reference.

use super::cull::{head_path, orbit_path};
use super::metrics::{self, MIN_FLIP_PPD};
use super::plan::PathKind;
use super::plan::{sanitize, Plan};
use crate::config::RenderConfig;
use crate::error::Result;
use crate::gpu::Context;
use crate::render::driver::{FrameDriver, FrameResult};
use crate::render::{FloorKind, Renderer};
use crate::rss::process_rss_bytes;
use crate::scene::Scene;
use crate::stats::Summary;
use crate::targets::headless::load_scene;
use crate::view::inset::{inset_rect, PixelRect};
use crate::view::lens::mask_image_until;
use crate::view::profile::HmdProfile;
use crate::view::StereoRig;
use ash::vk;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Image error of a configuration against the reference, averaged over the
/// compared frames and both eyes. Pixels the lens hides are set to black
/// in both images first: FLIP's statistics leave them out, PSNR and SSIM
/// run over the whole image (where those pixels agree exactly).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ImageError {
    /// Mean FLIP over visible pixels.
    pub flip_mean: f64,
    /// With `inset`: mean FLIP over the visible pixels inside the inset
    /// rectangle (the full-density region around the gaze, where the eye
    /// looks), averaged over eyes and compared frames; without one, over
    /// the plan's first inset configuration's rectangle. None when the
    /// plan has no inset.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flip_inset_mean: Option<f64>,
    /// FLIP as the eye sees it, looking at the image centre or, with the
    /// plan's `gaze = "saccades"`, where it truly looks on each compared
    /// frame ([`super::foveated`]: each pixel low-passed to what the eye
    /// resolves at its eccentricity), over visible pixels, averaged over
    /// eyes and compared frames; never above `flip_mean`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flip_foveated_mean: Option<f64>,
    /// 99th percentile of per-pixel FLIP over one eye's visible pixels,
    /// averaged over eyes and compared frames.
    pub flip_p99: f64,
    /// PSNR in dB (capped at 100 for identical images).
    pub psnr_db: f64,
    /// Mean SSIM.
    pub ssim: f64,
    /// Pixels per degree FLIP was evaluated at (from the profile).
    pub ppd: f64,
    /// Frames compared.
    pub frames: u32,
}

/// Culling accuracy against exact per-eye culling, per measured frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CullAccuracy {
    /// Mean instances kept that no eye sees.
    pub false_positives: f64,
    /// Mean instances dropped that some eye sees.
    pub false_negatives: f64,
    /// Total false negatives over the measured frames.
    pub false_negatives_total: u64,
}

/// CPU ms per phase (medians over the measured frames).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PhaseMs {
    /// Culling.
    pub cull: f64,
    /// Building draw batches.
    pub batch: f64,
    /// Recording command buffers.
    pub record: f64,
    /// Submitting.
    pub submit: f64,
    /// With `record_threads`: the recording threads' own times summed
    /// (part of `record`; against the one-thread `record`, how much each
    /// thread slowed down in company).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub record_threads_sum: Option<f64>,
    /// With `record_threads`: the slowest thread's recording time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub record_threads_slowest: Option<f64>,
    /// In a scene with moving instances: moving them (transforms, bounds,
    /// the CPU hierarchy's update, staging their records).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<f64>,
}

/// GPU memory while the configuration ran.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GpuMemory {
    /// Bytes vergence allocated (buffers, images, attachments).
    pub allocated: u64,
    /// Device-local bytes in use, from VK_EXT_memory_budget (None: not
    /// offered).
    pub usage: Option<u64>,
    /// Device-local budget, from VK_EXT_memory_budget.
    pub budget: Option<u64>,
}

/// Everything measured for one configuration in one group.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ConfigResult {
    /// Configuration name from the plan (`reference` for the reference).
    pub name: String,
    /// Its `--opt` list.
    pub opt: String,
    /// Stereo mode.
    pub stereo: String,
    /// MSAA samples.
    pub msaa: u32,
    /// Culling strategy.
    pub cull: String,
    /// What the renderer chose per technique (the foveation, inset, LMS,
    /// LOD and point paths; per-view render areas), at the top level: the
    /// same block as `render`'s stats.json. Results written before it
    /// named the foveation path `foveation_path`; they still load.
    #[serde(flatten)]
    pub renderer: crate::render::report::RendererReport,
    /// Measured frames.
    pub frames: u32,
    /// CPU ms per phase.
    pub cpu_ms: PhaseMs,
    /// CPU ms per frame: cull + batch + record + submit.
    pub cpu_frame_ms: Summary,
    /// GPU ms per pass (medians).
    pub gpu_ms: BTreeMap<String, f64>,
    /// GPU ms per frame (sum of the passes' timestamps).
    pub gpu_frame_ms: Summary,
    /// Frames in flight the loop ran with.
    pub frames_in_flight: u32,
    /// A model, not a measurement: per frame the larger of CPU and GPU
    /// time, what a perfectly pipelined loop would sustain.
    pub model_frame_ms: Summary,
    /// The measured wall-clock frame intervals (one frame's start to the
    /// next's), in order (for histograms).
    pub frame_times_ms: Vec<f64>,
    /// Wall-clock frame interval of the loop that ran (measured: one
    /// frame's start to the next's, frames back to back with
    /// `frames_in_flight` in flight).
    pub wall_frame_ms: Summary,
    /// The profile's refresh budget in ms.
    pub budget_ms: f64,
    /// Frames whose measured interval exceeded the budget.
    pub frames_over_budget: u32,
    /// Frames whose measured interval exceeded twice the budget.
    pub frames_over_2x_budget: u32,
    /// Draw calls (median).
    pub draw_calls: f64,
    /// Instances drawn (median).
    pub instances_drawn: f64,
    /// With a point cloud: median points chosen by the octree per frame,
    /// and median points rasterized (both eyes together).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points_selected: Option<f64>,
    /// See `points_selected`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub points_drawn: Option<f64>,
    /// Triangles submitted (median).
    pub triangles: f64,
    /// Fragment-shader invocations (median; None without pipeline
    /// statistics).
    pub fragment_invocations: Option<f64>,
    /// With `gpu-cull`: instances the compute cull tested (median).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu_cull_tested: Option<f64>,
    /// With `gpu-cull`: instances passing the frustum test (median).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu_cull_passed_frustum: Option<f64>,
    /// With `gpu-cull,occlusion`: instances the early phase tested (those
    /// visible at the end of the previous frame; median).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu_cull_tested_early: Option<f64>,
    /// With `gpu-cull,occlusion`: instances drawn by the late phase
    /// (newly visible; median).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu_cull_drawn_late: Option<f64>,
    /// With `gpu-cull,occlusion`: instances inside the volumes hidden by
    /// the depth pyramid (median).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu_cull_occluded: Option<f64>,
    /// With `gpu-cull,lod`: instances inside the volumes dropped as under
    /// the error bound (median).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu_cull_lod_dropped: Option<f64>,
    /// In a scene with moving instances: instances uploaded per frame
    /// (median).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub moved_instances: Option<f64>,
    /// In a scene with moving instances: bytes uploaded per frame
    /// (median).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion_upload_bytes: Option<f64>,
    /// GPU memory.
    pub gpu_memory: GpuMemory,
    /// Process resident set size after the configuration ran.
    pub rss_bytes: Option<u64>,
    /// Image error against the reference (None for the reference itself).
    pub error: Option<ImageError>,
    /// Culling accuracy (None without culling).
    pub cull_accuracy: Option<CullAccuracy>,
    /// Baseline GPU p50 over this configuration's GPU p50.
    pub gpu_speedup: Option<f64>,
    /// Baseline frame-time p50 over this configuration's.
    pub frame_speedup: Option<f64>,
    /// With the plan's `repeats` above 1: each run's GPU and wall-clock
    /// frame medians, the first run (this result's own figures) first.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub runs: Vec<RunMedians>,
    /// With `runs`: the GPU speed-up's range over the runs: the baseline's
    /// fastest run over this configuration's slowest to the baseline's
    /// slowest over its fastest.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gpu_speedup_range: Option<[f64; 2]>,
    /// Left-eye image of the last compared frame, relative to the output
    /// folder.
    pub image: Option<String>,
    /// FLIP heat map of that image against the reference.
    pub heatmap: Option<String>,
    /// Temporal error against the reference along the plan's flicker
    /// sequence, both eyes averaged (`bench::flicker`; None when off, for
    /// the reference itself and for timewarp configurations).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flicker: Option<f64>,
    /// The flicker as the eye sees it looking at the image centre
    /// ([`super::foveated`]: each frame low-passed to what the eye resolves
    /// at each pixel's eccentricity); never above `flicker`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flicker_foveated: Option<f64>,
    /// With a flicker sequence and `inset` in this configuration or, over
    /// the same pixels, in another of the plan: the flicker split by where
    /// the composite takes each pixel from (inside the inset, the
    /// feathered seam, the wide view alone), both eyes averaged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flicker_regions: Option<FlickerRegions>,
    /// Left-eye map of the per-pixel flicker, relative to the output
    /// folder (magma on a square-root scale, white at 0.05).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flicker_heatmap: Option<String>,
    /// With `inset` and a flicker sequence: the flicker of the reference
    /// sequence put through a perfect wide view of this configuration's
    /// scale and filter (`bench::flicker_floor`) — the least any wide view
    /// of that size could add.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flicker_floor: Option<f64>,
    /// With `timewarp=K`: the warped frames (its `error` is theirs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timewarp: Option<TimewarpResult>,
    /// Measured frames whose GPU time exceeded the budget (the bench's
    /// loop is not paced to the display, so this is the share a headset
    /// would miss on the GPU side).
    #[serde(default)]
    pub gpu_frames_over_budget: u32,
    /// With `aq`: the render scales the controller chose.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aq: Option<AqSummary>,
}

/// Below this many measured frames a GPU time is shown with its sample
/// size and spread.
pub const FEW_FRAMES: usize = 10;

impl ConfigResult {
    /// Why a technique this configuration asks for did not run on this
    /// device (foveation without a shading-rate attachment falls back to
    /// off): such a configuration is marked "not applied" in the reports
    /// and is never ranked or chosen. None when everything it asks for ran.
    pub fn not_applied(&self) -> Option<String> {
        let asks_foveation = self
            .opt
            .split(',')
            .any(|o| o.trim().starts_with("foveation") && o.trim() != "foveation=off");
        (asks_foveation && self.renderer.foveation.starts_with("off"))
            .then(|| format!("foveation fell back ({})", self.renderer.foveation))
    }

    /// The GPU frame time p50 for a table: with the sample size and the
    /// standard deviation when it rests on few frames, and its range over
    /// the runs when the plan repeated them.
    pub fn gpu_p50_text(&self) -> String {
        let g = &self.gpu_frame_ms;
        let mut text = if g.n < FEW_FRAMES {
            format!("{:.3} (n={}, sd {:.3})", g.p50, g.n, g.std)
        } else {
            format!("{:.3}", g.p50)
        };
        if let Some([lo, hi]) = range(self.runs.iter().map(|r| r.gpu_p50)) {
            text += &format!(" [{lo:.3}–{hi:.3} over {} runs]", self.runs.len());
        }
        text
    }

    /// The GPU speed-up for a table, with its range over the runs.
    pub fn gpu_speedup_text(&self) -> String {
        match (self.gpu_speedup, self.gpu_speedup_range) {
            (Some(s), Some([lo, hi])) => format!("{s:.2}× [{lo:.2}–{hi:.2}×]"),
            (Some(s), None) => format!("{s:.2}×"),
            _ => "–".into(),
        }
    }
}

/// One run's medians of a configuration measured `repeats` times.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunMedians {
    /// GPU frame time p50, ms.
    pub gpu_p50: f64,
    /// Wall-clock frame interval p50, ms.
    pub wall_p50: f64,
}

/// The least and greatest of `values` (None with fewer than two).
fn range(values: impl Iterator<Item = f64>) -> Option<[f64; 2]> {
    let v: Vec<f64> = values.collect();
    (v.len() > 1).then(|| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        [lo, hi]
    })
}

/// The flicker of one region of the eye image.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RegionFlicker {
    /// Mean flicker over the region's lens-visible pixels.
    pub mean: f64,
    /// The region's share of the lens-visible pixels (so `mean × share`
    /// summed over the regions is the whole image's flicker).
    pub share: f64,
}

/// A configuration's flicker by the composite's regions
/// ([`crate::view::inset::weight`]): where the inset's weight is 1, where
/// it falls through the feather, and where it is 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FlickerRegions {
    /// Inside the inset, deeper than the feather.
    pub inset: RegionFlicker,
    /// The feathered seam (weight strictly between 0 and 1).
    pub seam: RegionFlicker,
    /// The wide view alone (outside the inset rectangle).
    pub periphery: RegionFlicker,
}

/// What adaptive quality did over a configuration's measured frames.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AqSummary {
    /// Mean render scale per axis.
    pub mean_scale: f64,
    /// Smallest render scale.
    pub min_scale: f64,
    /// Largest render scale.
    pub max_scale: f64,
    /// Frames whose level differs from the previous frame's.
    pub level_changes: u32,
    /// Frames on the inset's rung (the wide view below its scale F).
    #[serde(default)]
    pub wide_rung_frames: u32,
    /// Frames with the inset's wide view at one sample (aq's MSAA rung
    /// and the levels below it).
    #[serde(default)]
    pub wide_one_sample_frames: u32,
    /// Smallest factor on the inset's wide-view scale (1 off the rung).
    #[serde(default = "one")]
    pub min_wide_factor: f64,
    /// The budget the controller held frames to, milliseconds.
    pub budget_ms: f64,
}

/// A timewarp configuration's warped frames: at every compared frame i the
/// frames i - 1 … i - (K - 1) are rendered and each is warped to frame i's
/// pose (every age a warped frame can have); `error` compares those with
/// the reference, this with the configuration's own rendering of frame i.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TimewarpResult {
    /// Every K-th frame is rendered.
    pub k: u32,
    /// How the frames between are reprojected.
    pub variant: String,
    /// Warped frames compared.
    pub warps: u32,
    /// FLIP mean of the warped frames against the frames truly rendered at
    /// their poses with the same configuration.
    pub flip_vs_rendered: f64,
    /// GPU ms of one warp (both eyes; median).
    pub warp_gpu_ms: f64,
    /// GPU ms per displayed frame when one in K is rendered and the others
    /// warped: (render p50 + (K - 1) × warp) / K.
    pub gpu_ms_per_displayed_frame: f64,
}

/// The raster floors at a group's resolution, with the baseline's stereo
/// mode and MSAA: GPU ms of an empty frame (no draws, every pass), of
/// clearing only, and of one full-screen triangle with a trivial shader.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Floors {
    /// The frame with nothing visible.
    pub empty_frame: Summary,
    /// Clear (and resolve) only.
    pub clear: Summary,
    /// One full-screen triangle.
    pub fullscreen_triangle: Summary,
}

/// One scene × HMD × scale group.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Group {
    /// Scene as the plan names it.
    pub scene: String,
    /// Instances in the scene.
    pub instances: usize,
    /// Triangles over all instances.
    pub scene_triangles: usize,
    /// HMD profile.
    pub hmd: String,
    /// Resolution scale.
    pub scale: f64,
    /// Per-eye resolution.
    pub resolution: [u32; 2],
    /// Refresh rate of the profile.
    pub refresh_hz: f64,
    /// Name of the baseline configuration.
    pub baseline: String,
    /// The head path's seed.
    #[serde(default)]
    pub path_seed: u64,
    /// Floors.
    pub floors: Option<Floors>,
    /// The reference first, then the plan's configurations in order.
    pub results: Vec<ConfigResult>,
}

/// Everything a bench run measured (`results.json`).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BenchResults {
    /// The plan.
    pub plan: Option<Plan>,
    /// GPU name.
    pub device: String,
    /// Driver.
    pub driver: String,
    /// Host CPU model.
    pub cpu: String,
    /// Command line that produced the results.
    pub command: String,
    /// Unix time the run started.
    pub started_unix: u64,
    /// Whether every group and configuration finished (false after Ctrl-C
    /// or an error).
    pub complete: bool,
    /// The error that stopped the run early, naming the group (None when
    /// it finished or was interrupted); what finished before it is kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Validation messages seen (0 without validation).
    pub validation_messages: usize,
    /// The groups.
    pub groups: Vec<Group>,
    /// With `vergence tune`: what it chose and under which limits.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub choice: Option<TuneChoice>,
}

/// What `vergence tune` chose from its measurements.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TuneChoice {
    /// The chosen configuration's name and `--opt` list.
    pub name: String,
    /// Its `--opt` list.
    pub opt: String,
    /// The frame budget (ms, the measured wall-clock frame interval's p95).
    pub budget_ms: f64,
    /// The FLIP mean cap (None: the least error within the budget wins).
    pub max_flip: Option<f64>,
    /// The flicker cap as given (a number or "baseline"), if any.
    pub max_flicker: Option<String>,
    /// The rule that picked it.
    pub rule: String,
    /// One line per candidate: its frame time against the budget, its
    /// error and flicker against the caps.
    pub why: Vec<String>,
}

/// The head path of a plan for one group: one rig per frame (warm-up
/// frames first).
fn path_rigs(plan: &Plan, scene: &Scene, profile: &HmdProfile) -> Vec<StereoRig> {
    // The meshes' and the point cloud's bounds together.
    let (lo, hi) = scene.bounds();
    (0..(plan.warmup + plan.frames) as u64)
        .map(|i| {
            profile.rig(match plan.path {
                PathKind::Walk => head_path(i, plan.path_seed, lo, hi),
                PathKind::Orbit => orbit_path(i, plan.path_seed, lo, hi),
            })
        })
        .collect()
}

/// Per-eye resolution of `profile` at `scale` (at least 16 px, at most
/// [`super::plan::MAX_EYE_PIXELS`]).
pub fn scaled_extent(profile: &HmdProfile, scale: f64) -> vk::Extent2D {
    let px = |v: u32| {
        ((v as f64 * scale).round() as u32)
            .clamp(super::plan::MIN_EYE_PIXELS, super::plan::MAX_EYE_PIXELS)
    };
    vk::Extent2D {
        width: px(profile.views[0].resolution[0]),
        height: px(profile.views[0].resolution[1]),
    }
}

/// Called after every configuration with (finished, total, label).
pub type Progress<'a> = &'a mut dyn FnMut(usize, usize, &str);

/// Runs `plan` on `ctx`, writing images under `out/images`. Stops early
/// (results marked incomplete) when a quit is requested.
pub fn run_plan(
    ctx: &Arc<Context>,
    plan: &Plan,
    out: &Path,
    progress: Progress,
) -> Result<BenchResults> {
    let mut results = BenchResults {
        plan: Some(plan.clone()),
        device: ctx.device_name.clone(),
        driver: ctx.driver.clone(),
        cpu: cpu_model(),
        command: std::env::args().collect::<Vec<_>>().join(" "),
        started_unix: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0),
        complete: false,
        ..BenchResults::default()
    };
    let total = plan.scenes.len()
        * plan.hmds.len()
        * plan.scales.len()
        * plan.seeds().len()
        * (plan.configs.len() + 1);
    let profiles = plan
        .hmds
        .iter()
        .map(|h| crate::targets::headless::load_stereo_profile(&plan.input_path(h)))
        .collect::<Result<Vec<_>>>()?;
    match run_groups(ctx, plan, &profiles, out, total, progress, &mut results) {
        Ok(finished) => results.complete = finished,
        // Keep what finished: the caller writes it, then reports the error.
        Err(e) => results.error = Some(e),
    }
    results.validation_messages = ctx.validation_messages();
    Ok(results)
}

/// The groups of [`run_plan`], appended to `results` as they finish;
/// false when a quit was requested. An error names its group.
fn run_groups(
    ctx: &Arc<Context>,
    plan: &Plan,
    profiles: &[HmdProfile],
    out: &Path,
    total: usize,
    progress: Progress,
    results: &mut BenchResults,
) -> std::result::Result<bool, String> {
    let mut done = 0;
    let several = plan.seeds().len() > 1;
    for scene_spec in &plan.scenes {
        let (scene, _) = load_scene(&plan.input_path(scene_spec))
            .map_err(|e| format!("scene {scene_spec}: {e}"))?;
        for profile in profiles {
            for (&scale, seed) in plan
                .scales
                .iter()
                .flat_map(|s| plan.seeds().into_iter().map(move |seed| (s, seed)))
            {
                let seeded = Plan {
                    path_seed: seed,
                    ..plan.clone()
                };
                let mut group = Group {
                    scene: scene_spec.clone(),
                    instances: scene.instances.len(),
                    scene_triangles: scene.instanced_triangles(),
                    hmd: profile.name.clone(),
                    scale,
                    resolution: {
                        let e = scaled_extent(profile, scale);
                        [e.width, e.height]
                    },
                    refresh_hz: plan.refresh_hz(profile),
                    baseline: plan.baseline_name().to_string(),
                    path_seed: seed,
                    ..Group::default()
                };
                let finished = run_group(
                    ctx,
                    &seeded,
                    &scene,
                    profile,
                    scale,
                    out,
                    &mut group,
                    &mut |label| {
                        done += 1;
                        progress(done, total, label);
                    },
                );
                let label = format!(
                    "scene {scene_spec}, HMD profile {}, scale {scale}{}",
                    profile.name,
                    if several {
                        format!(", path seed {seed}")
                    } else {
                        String::new()
                    }
                );
                // A group cut short is reported with the configurations
                // it finished.
                results.groups.push(group);
                match finished {
                    Ok(true) => {}
                    Ok(false) => return Ok(false),
                    Err(e) => return Err(format!("{label}: {e}")),
                }
            }
        }
    }
    Ok(true)
}

/// Reference images of one group: per compared frame, both eyes.
type RefImages = Vec<[image::RgbaImage; 2]>;

#[allow(clippy::too_many_arguments)]
fn run_group(
    ctx: &Arc<Context>,
    plan: &Plan,
    scene: &Scene,
    profile: &HmdProfile,
    scale: f64,
    out: &Path,
    group: &mut Group,
    tick: &mut dyn FnMut(&str),
) -> Result<bool> {
    let extent = scaled_extent(profile, scale);
    let rigs = path_rigs(plan, scene, profile);
    let Some(masks) = visible_masks(&rigs[0], extent) else {
        return Ok(false);
    };
    let fov = profile.views[0].fov;
    let ppd = (metrics::headset_ppd(extent.width, fov.left, fov.right) as f64).max(MIN_FLIP_PPD);
    let levels = foveation_levels(&rigs[0], extent, ppd, [[0.0; 2]; 2]);
    let fovs = [
        rigs[0].views[0].fov,
        rigs[0].views[1 % rigs[0].views.len()].fov,
    ];
    let gaze = super::gaze::BenchGaze::new(plan, fovs, rigs.len(), plan.refresh_hz(profile));
    let group_dir = format!(
        "images/{}-{}-{}{}",
        sanitize(&group.scene),
        sanitize(&group.hmd),
        scale,
        if plan.path_seeds.is_empty() {
            String::new()
        } else {
            format!("-seed{}", plan.path_seed)
        }
    );
    let mut run = GroupRun {
        ctx,
        plan,
        scene,
        profile,
        rigs,
        extent,
        masks,
        levels,
        gaze,
        ppd,
        out,
        group_dir,
        reference_images: Vec::new(),
        sequence: Vec::new(),
        reference_sequence: Vec::new(),
        inset_config: None,
        floors: Vec::new(),
    };
    let Some(reference) = run.reference()? else {
        return Ok(false);
    };
    group.results.push(reference);
    tick("reference");
    for c in &plan.configs {
        if crate::quit::requested() {
            fill_speedups(group);
            return Ok(false);
        }
        let floors = (c.name == group.baseline).then_some(&mut group.floors);
        let Some(r) = run.config(c, floors)? else {
            fill_speedups(group);
            return Ok(false);
        };
        group.results.push(r);
        tick(&c.name);
    }
    fill_speedups(group);
    Ok(true)
}

/// One group's measurement: its scene, profile and size, the reference's
/// images and flicker sequence, and the flicker floors found so far.
struct GroupRun<'a> {
    ctx: &'a Arc<Context>,
    plan: &'a Plan,
    scene: &'a Scene,
    profile: &'a HmdProfile,
    rigs: Vec<StereoRig>,
    extent: vk::Extent2D,
    /// Per eye: pixels the lens shows.
    masks: [Vec<bool>; 2],
    /// Per eye: each pixel's foveation level.
    levels: [Vec<f32>; 2],
    /// The plan's moving gaze (None: the image centre).
    gaze: Option<super::gaze::BenchGaze>,
    ppd: f64,
    out: &'a Path,
    group_dir: String,
    reference_images: RefImages,
    /// The temporal-error sequence: the first measured view turning by a
    /// third of a pixel a frame.
    sequence: Vec<StereoRig>,
    reference_sequence: RefImages,
    /// The plan's first configuration with an inset (lens resolved): the
    /// regions of configurations without one are measured over its
    /// rectangle.
    inset_config: Option<RenderConfig>,
    /// Flicker floors computed so far, by wide size, filter and inset.
    floors: Vec<(String, f64)>,
}

impl GroupRun<'_> {
    /// Measures the reference (supersampled) and renders its flicker
    /// sequence; None when the run was cut short.
    fn reference(&mut self) -> Result<Option<ConfigResult>> {
        let plan = self.plan;
        let mut config = plan.reference_config()?;
        config.resolve_lens(Some(self.profile))?;
        let ss = plan.reference_supersample;
        let Some(mut reference) = measure(
            self.ctx,
            plan,
            self.scene,
            &self.rigs,
            (self.extent, ss),
            ("reference", &plan.reference, &config),
            plan.refresh_hz(self.profile),
            Some(&mut self.reference_images),
            None,
            None,
        )?
        else {
            return Ok(None);
        };
        let saved = save_left(
            self.out,
            &self.group_dir,
            "reference",
            &self.reference_images,
        )?;
        reference.image = Some(saved);
        self.sequence = flicker_rigs(plan, &self.rigs, self.profile, self.ppd, 0);
        if !self.sequence.is_empty() {
            self.reference_sequence = crate::targets::headless::render_sequence(
                self.ctx,
                self.scene,
                &config,
                &self.sequence,
                (self.extent, ss),
                0.0,
            )?;
        }
        self.inset_config = plan
            .configs
            .iter()
            .filter_map(|c| {
                let mut config = plan.config_for(c).ok()?;
                config.resolve_lens(Some(self.profile)).ok()?;
                config.effort.inset.is_some().then_some(config)
            })
            .next();
        Ok(Some(reference))
    }

    /// Measures configuration `c` against the reference: times, error,
    /// flicker and heat maps (with `floors`, the baseline's raster floors
    /// too). None when the run was cut short.
    fn config(
        &mut self,
        c: &super::plan::PlanConfig,
        floors: Option<&mut Option<Floors>>,
    ) -> Result<Option<ConfigResult>> {
        let mut config = self.plan.config_for(c)?;
        config.resolve_lens(Some(self.profile))?;
        let compare = Comparison {
            reference: &self.reference_images,
            masks: &self.masks,
            levels: &self.levels,
            gaze: self.gaze.as_ref(),
            ppd: self.ppd,
            inset_config: self.inset_config.as_ref(),
        };
        let mut images = Vec::new();
        let Some(mut r) = measure(
            self.ctx,
            self.plan,
            self.scene,
            &self.rigs,
            (self.extent, 1),
            (&c.name, &c.opt, &config),
            self.plan.refresh_hz(self.profile),
            Some(&mut images),
            Some(&compare),
            floors,
        )?
        else {
            return Ok(None);
        };
        if !self.repeat(c, (&config, &compare), &mut r)? {
            return Ok(None);
        }
        r.image = Some(save_left(self.out, &self.group_dir, &c.name, &images)?);
        if !self.reference_sequence.is_empty() && config.simulator.timewarp.is_none() {
            self.flicker(&config, &c.name, &mut r)?;
        }
        if let (Some(last), Some(reference)) = (images.last(), self.reference_images.last()) {
            let flip = metrics::flip(&reference[0], &last[0], self.ppd as f32)?;
            let rel = format!("{}/{}.flip.png", self.group_dir, sanitize(&c.name));
            crate::targets::headless::save_png(&flip.heatmap(), &self.out.join(&rel))?;
            r.heatmap = Some(rel);
        }
        Ok(Some(r))
    }

    /// With the plan's `repeats` above 1: times configuration `c` again
    /// that many times less one (no images or errors) and keeps each run's
    /// medians in `r.runs`. False when the run was cut short.
    fn repeat(
        &self,
        c: &super::plan::PlanConfig,
        (config, compare): (&RenderConfig, &Comparison),
        r: &mut ConfigResult,
    ) -> Result<bool> {
        if self.plan.repeats < 2 {
            return Ok(true);
        }
        let medians = |r: &ConfigResult| RunMedians {
            gpu_p50: r.gpu_frame_ms.p50,
            wall_p50: r.wall_frame_ms.p50,
        };
        r.runs = vec![medians(r)];
        for _ in 1..self.plan.repeats {
            let Some(again) = measure(
                self.ctx,
                self.plan,
                self.scene,
                &self.rigs,
                (self.extent, 1),
                (&c.name, &c.opt, config),
                self.plan.refresh_hz(self.profile),
                None,
                // No images: only the gaze is taken from it.
                Some(compare),
                None,
            )?
            else {
                return Ok(false);
            };
            r.runs.push(medians(&again));
        }
        Ok(true)
    }

    /// The configuration's flicker along the sequence, by region with an
    /// inset, with its floor and heat map. A configuration with a history
    /// (inset-taa) runs into the sequence from further back, so what is
    /// measured is its settled image; the lead frames are not compared.
    fn flicker(&mut self, config: &RenderConfig, name: &str, r: &mut ConfigResult) -> Result<()> {
        let extent = self.extent;
        let lead = config.settle_frames();
        let rigs = flicker_rigs(self.plan, &self.rigs, self.profile, self.ppd, lead);
        let mut test = crate::targets::headless::render_sequence(
            self.ctx,
            self.scene,
            config,
            &rigs,
            (extent, 1),
            0.0,
        )?;
        test.drain(..lead.min(test.len()));
        let inset = self
            .sequence
            .first()
            .and_then(|rig| config_inset_rect(config, self.inset_config.as_ref(), rig, extent));
        let f = sequence_flicker(
            &test,
            &self.reference_sequence,
            (&self.masks, Some(&self.levels)),
            inset.as_ref(),
            extent,
        )?;
        r.flicker = Some(f.mean);
        r.flicker_foveated = f.foveated;
        r.flicker_regions = f.regions;
        if let Some(i) = config.effort.inset {
            r.flicker_floor = Some(self.flicker_floor(&i, inset.as_ref())?);
        }
        let rel = format!("{}/{}.flicker.png", self.group_dir, sanitize(name));
        let map = super::flicker::heatmap(&f.left_map, extent.width, extent.height, 0.05);
        crate::targets::headless::save_png(&map, &self.out.join(&rel))?;
        r.flicker_heatmap = Some(rel);
        Ok(())
    }

    /// The flicker of the reference sequence put through a perfect wide
    /// view of the inset's size and filter (computed once per size,
    /// filter and rectangle).
    fn flicker_floor(
        &mut self,
        i: &crate::config::Inset,
        inset: Option<&PixelRect>,
    ) -> Result<f64> {
        let wide = crate::render::scaled(self.extent, i.wide_scale);
        let key = format!("{:?} {} {inset:?}", wide, i.catmull_rom);
        if let Some(&(_, v)) = self.floors.iter().find(|(k, _)| *k == key) {
            return Ok(v);
        }
        let through: RefImages = self
            .reference_sequence
            .iter()
            .map(|pair| {
                pair.clone().map(|f| {
                    super::flicker_floor::through_wide_view(
                        &f,
                        (wide.width, wide.height),
                        inset,
                        i.catmull_rom,
                    )
                })
            })
            .collect();
        let v = sequence_flicker(
            &through,
            &self.reference_sequence,
            (&self.masks, None),
            None,
            self.extent,
        )?
        .mean;
        self.floors.push((key, v));
        Ok(v)
    }
}

/// The temporal-error sequence of a group: `plan.flicker_frames` views
/// from the first measured one, turning right by a third of a pixel
/// (at `ppd` pixels per degree) a frame — sub-pixel motion, where aliasing
/// shows as shimmer — after `lead` views of the same turn leading up to
/// it (for a configuration whose image settles over frames).
fn flicker_rigs(
    plan: &Plan,
    rigs: &[StereoRig],
    profile: &crate::view::profile::HmdProfile,
    ppd: f64,
    lead: usize,
) -> Vec<StereoRig> {
    let Some(first) = rigs.get((plan.warmup as usize).min(rigs.len().saturating_sub(1))) else {
        return Vec::new();
    };
    let step_deg = 1.0 / (3.0 * ppd.max(1.0));
    let lead = lead as i64;
    (-lead..plan.flicker_frames as i64)
        .map(|j| {
            let turn = crate::view::Pose::from_euler_deg(
                glam::DVec3::ZERO,
                -step_deg * j as f64,
                0.0,
                0.0,
            );
            profile.rig(first.head.compose(&turn))
        })
        .collect()
}

/// A sequence's flicker: both eyes averaged, split by region with an
/// inset, and the left eye's per-pixel map.
struct SequenceFlicker {
    mean: f64,
    /// With foveation levels: the foveated flicker.
    foveated: Option<f64>,
    regions: Option<FlickerRegions>,
    left_map: Vec<f32>,
}

/// The flicker of `test` against `reference` over the pixels the lens
/// shows, both eyes averaged; with `inset` (the rectangle in eye images of
/// `extent`) also by region.
fn sequence_flicker(
    test: &[[image::RgbaImage; 2]],
    reference: &[[image::RgbaImage; 2]],
    (masks, levels): (&[Vec<bool>; 2], Option<&[Vec<f32>; 2]>),
    inset: Option<&PixelRect>,
    extent: vk::Extent2D,
) -> Result<SequenceFlicker> {
    use super::flicker::{masked_mean, per_pixel};
    let width = extent.width.max(1) as usize;
    let weight = |i: usize| {
        inset.map_or(0.0, |r| {
            let (x, y) = ((i % width) as u32, (i / width) as u32);
            crate::view::inset::weight(r, x, y, crate::view::inset::FEATHER_PX)
        })
    };
    let in_inset = |i: usize| weight(i) >= 1.0;
    let in_seam = |i: usize| {
        let w = weight(i);
        w > 0.0 && w < 1.0
    };
    let in_periphery = |i: usize| weight(i) <= 0.0;
    let mut out = SequenceFlicker {
        mean: 0.0,
        foveated: levels.map(|_| 0.0),
        regions: inset.map(|_| FlickerRegions::default()),
        left_map: Vec::new(),
    };
    for eye in 0..2 {
        let t: Vec<image::RgbaImage> = test.iter().map(|p| p[eye].clone()).collect();
        let r: Vec<image::RgbaImage> = reference.iter().map(|p| p[eye].clone()).collect();
        let map = per_pixel(&t, &r)?;
        let hidden = &masks[eye];
        out.mean += masked_mean(&map, hidden, |_| true) / 2.0;
        if let (Some(sum), Some(levels)) = (out.foveated.as_mut(), levels) {
            let foveated = super::foveated::flicker_map(&t, &r, &levels[eye], hidden)?;
            *sum += masked_mean(&foveated, hidden, |_| true) / 2.0;
        }
        if let Some(regions) = out.regions.as_mut() {
            let shown = |i: usize| !hidden.get(i).copied().unwrap_or(false);
            let total = (0..map.len()).filter(|&i| shown(i)).count().max(1) as f64;
            for (region, keep) in [
                (&mut regions.inset, &in_inset as &dyn Fn(usize) -> bool),
                (&mut regions.seam, &in_seam),
                (&mut regions.periphery, &in_periphery),
            ] {
                let n = (0..map.len()).filter(|&i| shown(i) && keep(i)).count() as f64;
                region.mean += masked_mean(&map, hidden, keep) / 2.0;
                region.share += n / total / 2.0;
            }
        }
        if eye == 0 {
            out.left_map = map;
        }
    }
    Ok(out)
}

/// Speed-ups against the group's baseline, when it was measured (also for
/// a group cut short by Ctrl-C).
fn fill_speedups(group: &mut Group) {
    let base = group
        .results
        .iter()
        .find(|r| r.name == group.baseline)
        .map(|b| (b.gpu_frame_ms.p50, b.wall_frame_ms.p50));
    let base_runs: Vec<f64> = group
        .results
        .iter()
        .find(|r| r.name == group.baseline)
        .map(|b| b.runs.iter().map(|r| r.gpu_p50).collect())
        .unwrap_or_default();
    if let Some((gpu, frame)) = base {
        for r in &mut group.results {
            r.gpu_speedup = (r.gpu_frame_ms.p50 > 0.0).then(|| gpu / r.gpu_frame_ms.p50);
            r.frame_speedup = (r.wall_frame_ms.p50 > 0.0).then(|| frame / r.wall_frame_ms.p50);
            // The runs of one configuration come one after the other, so
            // a baseline run has no partner: the range spans the fastest
            // baseline over the slowest run to the slowest over the fastest.
            let base = range(base_runs.iter().copied());
            let own = range(r.runs.iter().map(|x| x.gpu_p50));
            r.gpu_speedup_range = match (base, own) {
                (Some([b_lo, b_hi]), Some([c_lo, c_hi])) if c_lo > 0.0 => {
                    Some([b_lo / c_hi, b_hi / c_lo])
                }
                _ => None,
            };
        }
    }
}

/// What a configuration's images are compared with.
struct Comparison<'a> {
    reference: &'a RefImages,
    /// Per eye: pixels the lens hides (excluded from the error).
    masks: &'a [Vec<bool>; 2],
    /// Per eye: each pixel's foveation level (the foveated error) with
    /// the eye on the image centre.
    levels: &'a [Vec<f32>; 2],
    /// The plan's moving gaze: the techniques follow its reports and the
    /// foveated error is measured at its true position per frame.
    gaze: Option<&'a super::gaze::BenchGaze>,
    ppd: f64,
    /// The plan's first configuration with `inset` (lens resolved): a
    /// configuration without one has its error and flicker measured over
    /// that one's inset rectangle too, so the regions compare.
    inset_config: Option<&'a RenderConfig>,
}

/// A stereo pair's error as the overlay's F4 shows it.
pub struct StereoError {
    /// FLIP mean of both eyes.
    pub flip_mean: f64,
    /// Foveated FLIP mean of both eyes (looking at the image centre).
    pub flip_foveated_mean: f64,
    /// The left eye's FLIP heat map.
    pub heatmap: image::RgbaImage,
}

/// The error of `test` against `reference` (both rendered for `rig`) as
/// the bench measures it: hidden pixels blacked out in both and left out,
/// FLIP at the left view's pixels per degree (at least
/// [`MIN_FLIP_PPD`]), uniform and foveated, with the left eye's heat map
/// (what the desk overlay shows on demand).
pub fn stereo_error(
    reference: &[image::RgbaImage; 2],
    test: &[image::RgbaImage; 2],
    rig: &StereoRig,
) -> Result<StereoError> {
    let extent = vk::Extent2D {
        width: reference[0].width(),
        height: reference[0].height(),
    };
    let masks = visible_masks(rig, extent).ok_or_else(|| {
        crate::error::Error::config("image error", "interrupted by a quit request")
    })?;
    let fov = rig
        .views
        .first()
        .map(|v| v.fov)
        .ok_or_else(|| crate::error::Error::config("image error", "the rig has no views"))?;
    let ppd = (metrics::headset_ppd(extent.width, fov.left, fov.right) as f64).max(MIN_FLIP_PPD);
    let levels = foveation_levels(rig, extent, ppd, [[0.0; 2]; 2]);
    let [left, right] = [0usize, 1].map(|eye| {
        let view = EyeView {
            mask: &masks[eye],
            levels: Some(&levels[eye]),
            ppd,
        };
        eye_error(&reference[eye], &test[eye], &view, None)
    });
    let ((left, flip), (right, _)) = (left?, right?);
    let foveated =
        (left.flip_foveated_mean.unwrap_or(0.0) + right.flip_foveated_mean.unwrap_or(0.0)) / 2.0;
    Ok(StereoError {
        flip_mean: (left.flip_mean + right.flip_mean) / 2.0,
        flip_foveated_mean: foveated,
        heatmap: flip.heatmap(),
    })
}

/// Per eye and pixel of eye images of `extent`, the foveated error's
/// pyramid level ([`super::foveated::level`]) with each eye looking at
/// `gaze` (NDC, +y down; the image centre is [0, 0]), at `ppd` pixels per
/// degree.
fn foveation_levels(
    rig: &StereoRig,
    extent: vk::Extent2D,
    ppd: f64,
    gaze: [[f64; 2]; 2],
) -> [Vec<f32>; 2] {
    [0usize, 1].map(|eye| {
        let fov = rig.views.get(eye).or(rig.views.first()).map(|v| v.fov);
        let e = fov.map_or_else(Vec::new, |fov| {
            super::foveated::eccentricity(extent.width, extent.height, &fov, gaze[eye])
        });
        e.iter()
            .map(|&d| super::foveated::level(d as f64, ppd))
            .collect()
    })
}

/// Per eye, which pixels the lens hides (the profile's hidden area, or its
/// lens-circle default). None when a quit was requested meanwhile.
fn visible_masks(rig: &StereoRig, extent: vk::Extent2D) -> Option<[Vec<bool>; 2]> {
    let n = (extent.width * extent.height) as usize;
    let mask = |eye: usize| match rig.hidden_area.as_deref().and_then(|h| h.get(eye)) {
        Some(area) => mask_image_until(
            area,
            &rig.views[eye].fov,
            extent.width,
            extent.height,
            &crate::quit::requested,
        ),
        None => Some(vec![false; n]),
    };
    Some([mask(0)?, mask(1)?])
}

/// Spin-up: the first view, unmeasured, until the GPU is back at its
/// clocks (see `Plan::spin_up_ms`). An even number of frames: the
/// renderer's frame count picks the round-robin eye and MFFR's alternate
/// eye, so the measured frames keep the parity they have without a
/// spin-up. aq's measured run then starts at its default level like a
/// session. False when a quit was requested.
fn spin_up(driver: &mut FrameDriver, plan: &Plan, first: &StereoRig) -> Result<bool> {
    let spin = std::time::Instant::now();
    let mut spun = 0u64;
    while spin.elapsed().as_secs_f64() * 1e3 < plan.spin_up_ms as f64 || spun % 2 == 1 {
        driver.frame(first, 0, false)?;
        spun += 1;
        while driver.take_completed().is_some() {}
        if crate::quit::requested() {
            return Ok(false);
        }
    }
    driver.finish()?;
    while driver.take_completed().is_some() {}
    driver.reset_aq();
    Ok(true)
}

/// The exact-culling ground truth, after the timed loop: the `judged`
/// frames' culls replayed (culling depends only on the rig and the frame
/// number), false positives and negatives averaged per frame.
fn cull_accuracy(
    c: &crate::render::culling::CullState,
    rigs: &[StereoRig],
    judged: std::ops::Range<usize>,
) -> Result<CullAccuracy> {
    let mut a = CullAccuracy::default();
    let n = judged.len().max(1) as f64;
    for i in judged {
        let (fp, fneg) = c.replay_accuracy(&rigs[i], i as u64)?;
        a.false_positives += fp as f64 / n;
        a.false_negatives += fneg as f64 / n;
        a.false_negatives_total += fneg;
    }
    Ok(a)
}

/// The plan's compared frames, rendered again and read back into
/// `images` (scaled to the eye size, as the compositor would show aq's
/// smaller frames), each with its error against the reference. Each is
/// rendered after the frame before it (frames in flight as measured); a
/// configuration with a history (inset-taa) runs the path from its settle
/// frames before, so the compared image is the settled one it showed in
/// the timed loop.
fn compared_frames(
    driver: &mut FrameDriver,
    plan: &Plan,
    rigs: &[StereoRig],
    (extent, config): (vk::Extent2D, &RenderConfig),
    images: &mut RefImages,
    compare: Option<&Comparison>,
) -> Result<Vec<ImageError>> {
    let mut errors = Vec::new();
    let lead = config.settle_frames().max(1);
    for k in plan.error_frame_indices() {
        let i = (plan.warmup + k) as usize;
        let first = i.saturating_sub(lead);
        for (j, rig) in rigs.iter().enumerate().take(i + 1).skip(first) {
            follow_gaze(driver, compare, j);
            driver.frame(rig, j as u64, j == i)?;
        }
        let pair = driver
            .read_images()?
            .map(|img| crate::targets::headless::to_size(img, extent));
        if let Some(cmp) = compare {
            if let Some(reference) = cmp.reference.get(images.len()) {
                let inset = config_inset_rect(config, cmp.inset_config, &rigs[i], extent);
                // Where the eye truly looks on this frame.
                let moved = cmp.gaze.map(|g| {
                    let gaze = [0, 1].map(|eye| g.true_ndc(i, eye));
                    foveation_levels(&rigs[i], extent, cmp.ppd, gaze)
                });
                let levels = moved.as_ref().unwrap_or(cmp.levels);
                errors.push(image_error(
                    (reference, &pair),
                    cmp,
                    levels,
                    inset.as_ref(),
                )?);
            }
        }
        images.push(pair);
    }
    Ok(errors)
}

/// With the plan's moving gaze: frame `frame`'s techniques follow the
/// gaze the tracker reported for it.
fn follow_gaze(driver: &mut FrameDriver, compare: Option<&Comparison>, frame: usize) {
    if let Some(g) = compare.and_then(|c| c.gaze) {
        driver.renderer_mut().set_gaze(g.reported_ndc(frame));
    }
}

/// Renders `config` along `rigs`: warm-up, measured frames, then the
/// compared frames (each preceded by its predecessor on the path, so
/// history-dependent techniques see a realistic previous frame), read back
/// into `images` and compared when `compare` is given. With `supersample`
/// k > 1 (the reference's) it renders at k × `extent` per axis and the
/// images are reduced to `extent`. None when a quit was requested before
/// it finished.
#[allow(clippy::too_many_arguments)]
fn measure(
    ctx: &Arc<Context>,
    plan: &Plan,
    scene: &Scene,
    rigs: &[StereoRig],
    (extent, supersample): (vk::Extent2D, u32),
    (name, opt, config): (&str, &str, &RenderConfig),
    refresh_hz: f64,
    mut images: Option<&mut RefImages>,
    compare: Option<&Comparison>,
    floors_out: Option<&mut Option<Floors>>,
) -> Result<Option<ConfigResult>> {
    let render_extent = crate::targets::headless::supersampled(extent, supersample);
    let renderer = crate::targets::headless::new_renderer(ctx, scene, config, render_extent)?;
    let mut driver = FrameDriver::new(renderer, scene)?;
    driver.set_display_budget(1000.0 / refresh_hz);
    let mut frames: Vec<FrameResult> = Vec::new();
    let n_accuracy = plan.frames.min(30) as usize;
    let warmup = plan.warmup as usize;
    let keep = |r: FrameResult, frames: &mut Vec<FrameResult>| {
        if r.index >= plan.warmup as u64 {
            frames.push(r);
        }
    };
    if let Some(first) = rigs.first() {
        follow_gaze(&mut driver, compare, 0);
        if !spin_up(&mut driver, plan, first)? {
            return Ok(None);
        }
    }
    for (i, rig) in rigs.iter().enumerate() {
        follow_gaze(&mut driver, compare, i);
        driver.frame(rig, i as u64, false)?;
        while let Some(r) = driver.take_completed() {
            keep(r, &mut frames);
        }
        if crate::quit::requested() {
            return Ok(None);
        }
    }
    driver.finish()?;
    while let Some(r) = driver.take_completed() {
        keep(r, &mut frames);
    }
    // The exact-culling ground truth, after the timed loop: the first
    // measured frames' culls replayed (culling depends only on the rig and
    // the frame number).
    let judged = warmup..(warmup + n_accuracy).min(rigs.len());
    let accuracy = match driver.culling() {
        Some(c) => Some(cull_accuracy(c, rigs, judged)?),
        None => None,
    };
    if let Some(f) = floors_out {
        *f = Some(floors(driver.renderer_mut(), plan, &rigs[0])?);
    }
    let mut result = summarize(name, opt, driver.renderer(), &frames, refresh_hz);
    result.cull_accuracy = accuracy;
    let device = ctx.memory_budget();
    result.gpu_memory = GpuMemory {
        allocated: ctx.allocated_bytes(),
        usage: device.map(|b| b.usage),
        budget: device.map(|b| b.budget),
    };
    if let (Some(images), Some(tw)) = (images.as_deref_mut(), config.simulator.timewarp) {
        let (errors, result_tw) =
            warped_errors(ctx, &mut driver, plan, rigs, extent, tw, images, compare)?;
        let gpu = result.gpu_frame_ms.p50;
        result.timewarp = Some(TimewarpResult {
            gpu_ms_per_displayed_frame: (gpu + (tw.k - 1) as f64 * result_tw.warp_gpu_ms)
                / tw.k as f64,
            ..result_tw
        });
        result.error = average_errors(&errors);
    } else if let Some(images) = images {
        let errors = compared_frames(&mut driver, plan, rigs, (extent, config), images, compare)?;
        result.error = average_errors(&errors);
    }
    drop(driver);
    result.rss_bytes = process_rss_bytes();
    Ok(Some(result))
}

/// The mean of `errors` (None when there are none).
fn average_errors(errors: &[ImageError]) -> Option<ImageError> {
    if errors.is_empty() {
        return None;
    }
    let n = errors.len() as f64;
    let avg = |get: fn(&ImageError) -> f64| errors.iter().map(get).sum::<f64>() / n;
    // The inset's mean where every compared frame has one.
    let inset: Option<f64> = errors.iter().map(|e| e.flip_inset_mean).sum();
    let foveated: Option<f64> = errors.iter().map(|e| e.flip_foveated_mean).sum();
    Some(ImageError {
        flip_mean: avg(|e| e.flip_mean),
        flip_inset_mean: inset.map(|s| s / n),
        flip_foveated_mean: foveated.map(|s| s / n),
        flip_p99: avg(|e| e.flip_p99),
        psnr_db: avg(|e| e.psnr_db),
        ssim: avg(|e| e.ssim),
        ppd: errors[0].ppd,
        frames: errors.len() as u32,
    })
}

/// The timewarp configuration's compared frames: at every error frame i,
/// frames i - (K - 1) … i are rendered in path order (with depth), and
/// each earlier one is warped to frame i's pose; the warped pairs are
/// compared, over the pixels the lens shows, with the reference
/// (`compare`) and with the frame truly rendered at i. `images` gets, per
/// error frame, the oldest warp (for the report's image and heat map).
/// Returns the errors against the reference and the warp figures.
#[allow(clippy::too_many_arguments)]
fn warped_errors(
    ctx: &Arc<Context>,
    driver: &mut FrameDriver,
    plan: &Plan,
    rigs: &[StereoRig],
    extent: vk::Extent2D,
    tw: crate::config::Timewarp,
    images: &mut RefImages,
    compare: Option<&Comparison>,
) -> Result<(Vec<ImageError>, TimewarpResult)> {
    let near = driver.renderer().config.frame.near;
    let config = driver.renderer().config.clone();
    let mut warp = crate::render::timewarp::Timewarp::new(ctx, extent, tw.variant)?;
    let (mut errors, mut own, mut warp_ms) = (Vec::new(), Vec::new(), Vec::new());
    let render = |driver: &mut FrameDriver, i: usize| -> Result<_> {
        driver.frame(&rigs[i], i as u64, true)?;
        driver.finish()?;
        while driver.take_completed().is_some() {}
        let colour = driver.read_images()?;
        let depth =
            crate::render::timewarp::Timewarp::source_depth(driver.renderer_mut(), tw.variant)?;
        Ok((colour, depth))
    };
    let ages = tw.k as usize - 1;
    for (n, k) in plan.error_frame_indices().into_iter().enumerate() {
        let i = (plan.warmup + k) as usize;
        // Frames i - (K - 1) … i in path order (the plan checked that
        // they exist), so history-dependent passes see the path as it runs.
        let mut sources = Vec::with_capacity(ages);
        for d in (1..=ages).rev() {
            sources.push((i - d, render(driver, i - d)?));
        }
        let (truth, _) = render(driver, i)?;
        let mut oldest = None;
        for (s, (colour, depth)) in &sources {
            let (old, new) = (&rigs[*s], &rigs[i]);
            let out = warp.warp(
                colour,
                depth,
                [&old.views[0], &old.views[1]],
                [&new.views[0], &new.views[1]],
                near,
            )?;
            warp_ms.push(out.gpu_ms);
            if let Some(cmp) = compare {
                // Against the same configuration's frame i, over the
                // pixels the lens shows (as the error against the
                // reference).
                let inset = config_inset_rect(&config, cmp.inset_config, new, extent);
                let own_error =
                    image_error((&truth, &out.images), cmp, cmp.levels, inset.as_ref())?;
                own.push(own_error.flip_mean);
                if let Some(reference) = cmp.reference.get(n) {
                    errors.push(image_error(
                        (reference, &out.images),
                        cmp,
                        cmp.levels,
                        inset.as_ref(),
                    )?);
                }
            }
            if oldest.is_none() {
                oldest = Some(out.images);
            }
        }
        images.push(oldest.unwrap_or(truth));
    }
    let figures = TimewarpResult {
        k: tw.k,
        variant: format!("{:?}", tw.variant).to_lowercase(),
        warps: warp_ms.len() as u32,
        flip_vs_rendered: own.iter().sum::<f64>() / own.len().max(1) as f64,
        warp_gpu_ms: Summary::of(&warp_ms).p50,
        gpu_ms_per_displayed_frame: 0.0,
    };
    Ok((errors, figures))
}

/// Error of one stereo pair against the reference, over visible pixels:
/// hidden pixels are blacked out in both images first and left out of the
/// FLIP statistics.
/// With `inset`, also the FLIP mean inside that rectangle.
fn image_error(
    (reference, test): (&[image::RgbaImage; 2], &[image::RgbaImage; 2]),
    cmp: &Comparison,
    levels: &[Vec<f32>; 2],
    inset: Option<&PixelRect>,
) -> Result<ImageError> {
    let [l, r] = [0usize, 1].map(|eye| {
        let view = EyeView {
            mask: &cmp.masks[eye],
            levels: Some(&levels[eye]),
            ppd: cmp.ppd,
        };
        eye_error(&reference[eye], &test[eye], &view, inset)
    });
    let ((l, _), (r, _)) = (l?, r?);
    Ok(ImageError {
        flip_mean: (l.flip_mean + r.flip_mean) / 2.0,
        flip_foveated_mean: l
            .flip_foveated_mean
            .zip(r.flip_foveated_mean)
            .map(|(a, b)| (a + b) / 2.0),
        flip_inset_mean: l
            .flip_inset_mean
            .zip(r.flip_inset_mean)
            .map(|(a, b)| (a + b) / 2.0),
        flip_p99: (l.flip_p99 + r.flip_p99) / 2.0,
        psnr_db: (l.psnr_db + r.psnr_db) / 2.0,
        ssim: (l.ssim + r.ssim) / 2.0,
        ppd: l.ppd,
        frames: 1,
    })
}

/// How one eye's images are compared: the pixels the lens hides, each
/// pixel's foveation level ([`super::foveated::level`]; None: no foveated
/// error) and FLIP's pixels per degree.
struct EyeView<'a> {
    mask: &'a [bool],
    levels: Option<&'a [f32]>,
    ppd: f64,
}

/// One eye's error against its reference over the pixels `v.mask` does not
/// hide (blacked out in both images first and left out of the FLIP
/// statistics), with the FLIP result itself (for its heat map). With
/// `inset`, also the FLIP mean over the visible pixels inside it; with
/// `v.levels`, the foveated FLIP mean.
fn eye_error(
    reference: &image::RgbaImage,
    test: &image::RgbaImage,
    v: &EyeView,
    inset: Option<&PixelRect>,
) -> Result<(ImageError, metrics::FlipResult)> {
    let (mask, ppd) = (v.mask, v.ppd);
    let (a, b) = (blackout(reference, mask), blackout(test, mask));
    let f = metrics::flip(&a, &b, ppd as f32)?;
    let (mean, p99) = masked_stats(&f.errors, mask);
    let foveated = match v.levels {
        Some(levels) => {
            let view = (ppd as f32, levels, mask);
            let map = super::foveated::flip_map(&a, &b, view, Some(&f.errors))?;
            Some(masked_stats(&map, mask).0)
        }
        None => None,
    };
    Ok((
        ImageError {
            flip_mean: mean,
            flip_foveated_mean: foveated,
            flip_inset_mean: inset.map(|r| rect_mean(&f.errors, a.width(), r, mask)),
            flip_p99: p99,
            psnr_db: metrics::psnr(&a, &b).min(100.0),
            ssim: metrics::ssim(&a, &b),
            ppd,
            frames: 1,
        },
        f,
    ))
}

/// `img` with the pixels `hidden` marks set to opaque black.
fn blackout(img: &image::RgbaImage, hidden: &[bool]) -> image::RgbaImage {
    let mut out = img.clone();
    for (p, &h) in out.pixels_mut().zip(hidden) {
        if h {
            *p = image::Rgba([0, 0, 0, 255]);
        }
    }
    out
}

/// The inset rectangle `config` renders at full density in eye images of
/// `extent` for `rig` (the renderer's own choice, [`inset_rect`] around
/// the configured gaze); without `inset`, `fallback`'s (the same pixels,
/// for comparing regions), or None.
fn config_inset_rect(
    config: &RenderConfig,
    fallback: Option<&RenderConfig>,
    rig: &StereoRig,
    extent: vk::Extent2D,
) -> Option<PixelRect> {
    let config = match config.effort.inset {
        Some(_) => config,
        None => fallback?,
    };
    let i = config.effort.inset?;
    let fovs: Vec<_> = rig.views.iter().take(2).map(|v| v.fov).collect();
    Some(inset_rect(
        &fovs,
        config.effort.gaze,
        i.half_angle_deg,
        extent.width,
        extent.height,
    ))
}

/// Mean of per-pixel `errors` (rows of `width`) over the pixels of `rect`
/// that `hidden` does not mark (0 when none is left).
pub fn rect_mean(errors: &[f32], width: u32, rect: &PixelRect, hidden: &[bool]) -> f64 {
    let width = width.max(1) as usize;
    super::flicker::masked_mean(errors, hidden, |i| {
        rect.contains((i % width) as u32, (i / width) as u32)
    })
}

/// Mean and 99th percentile of `errors` over the pixels `hidden` does not
/// mark (all pixels when the mask is shorter).
pub fn masked_stats(errors: &[f32], hidden: &[bool]) -> (f64, f64) {
    let v: Vec<f64> = errors
        .iter()
        .enumerate()
        .filter(|(i, _)| !hidden.get(*i).copied().unwrap_or(false))
        .map(|(_, &e)| e as f64)
        .collect();
    let s = Summary::of(&v);
    (s.mean, s.p99)
}

fn summarize(
    name: &str,
    opt: &str,
    renderer: &Renderer,
    frames: &[FrameResult],
    refresh_hz: f64,
) -> ConfigResult {
    let series =
        |get: &dyn Fn(&FrameResult) -> f64| -> Vec<f64> { frames.iter().map(get).collect() };
    let median = |get: &dyn Fn(&FrameResult) -> f64| Summary::of(&series(get)).p50;
    let gpu_cull_median = |get: &dyn Fn(&crate::render::GpuCullStats) -> u64| {
        (!frames.is_empty() && frames.iter().all(|f| f.stats.gpu_cull.is_some()))
            .then(|| median(&|f| f.stats.gpu_cull.map_or(0.0, |c| get(&c) as f64)))
    };
    let threads = renderer.config.submission.record_threads;
    let cpu = series(&FrameResult::cpu_ms);
    let gpu = series(&FrameResult::gpu_ms);
    let moving = !frames.is_empty() && frames.iter().any(|f| f.stats.motion.is_some());
    let model: Vec<f64> = cpu.iter().zip(&gpu).map(|(c, g)| c.max(*g)).collect();
    let wall: Vec<f64> = frames.iter().filter_map(|r| r.interval_ms).collect();
    let budget_ms = 1000.0 / refresh_hz;
    let mut passes: BTreeMap<String, f64> = BTreeMap::new();
    for f in frames {
        for name in f.stats.gpu_ms.keys() {
            passes.entry(name.clone()).or_default();
        }
    }
    for (pass, v) in passes.iter_mut() {
        *v = median(&|f| f.stats.gpu_ms.get(pass).copied().unwrap_or(0.0));
    }
    let config = &renderer.config;
    ConfigResult {
        name: name.to_string(),
        opt: opt.to_string(),
        stereo: config.frame.stereo.name().to_string(),
        msaa: config.frame.msaa,
        cull: config.culling.cull.name().to_string(),
        renderer: renderer.report(),
        frames: frames.len() as u32,
        cpu_ms: PhaseMs {
            cull: median(&|f| f.cull_ms),
            batch: median(&|f| f.stats.cpu_ms.batch),
            record: median(&|f| f.stats.cpu_ms.record),
            submit: median(&|f| f.stats.cpu_ms.submit),
            record_threads_sum: threads
                .map(|_| median(&|f| f.stats.cpu_ms.record_threads.unwrap_or_default().sum)),
            record_threads_slowest: threads
                .map(|_| median(&|f| f.stats.cpu_ms.record_threads.unwrap_or_default().slowest)),
            motion: moving.then(|| median(&|f| f.motion_ms)),
        },
        cpu_frame_ms: Summary::of(&cpu),
        gpu_ms: passes,
        gpu_frame_ms: Summary::of(&gpu),
        frames_in_flight: renderer.frames_in_flight() as u32,
        model_frame_ms: Summary::of(&model),
        wall_frame_ms: Summary::of(&wall),
        frames_over_budget: wall.iter().filter(|&&t| t > budget_ms).count() as u32,
        frames_over_2x_budget: wall.iter().filter(|&&t| t > 2.0 * budget_ms).count() as u32,
        frame_times_ms: wall,
        budget_ms,
        draw_calls: median(&|f| f.stats.draw_calls as f64),
        instances_drawn: median(&|f| f.stats.instances_drawn as f64),
        points_selected: renderer
            .points_total()
            .map(|_| median(&|f| f.stats.points_selected.unwrap_or(0) as f64)),
        points_drawn: renderer
            .points_total()
            .map(|_| median(&|f| f.stats.points_drawn.unwrap_or(0) as f64)),
        triangles: median(&|f| f.stats.triangles as f64),
        fragment_invocations: frames
            .iter()
            .all(|f| f.stats.pipeline.is_some())
            .then(|| {
                median(&|f| {
                    f.stats
                        .pipeline
                        .map_or(0.0, |p| p.fragment_invocations as f64)
                })
            })
            .filter(|_| !frames.is_empty()),
        gpu_cull_tested: gpu_cull_median(&|c| c.tested),
        gpu_cull_passed_frustum: gpu_cull_median(&|c| c.passed_frustum),
        gpu_cull_tested_early: gpu_cull_median(&|c| c.tested_early),
        gpu_cull_drawn_late: gpu_cull_median(&|c| c.drawn_late),
        gpu_cull_occluded: gpu_cull_median(&|c| c.occluded),
        gpu_cull_lod_dropped: gpu_cull_median(&|c| c.lod_dropped),
        moved_instances: moving
            .then(|| median(&|f| f.stats.motion.map_or(0.0, |m| m.moved as f64))),
        motion_upload_bytes: moving
            .then(|| median(&|f| f.stats.motion.map_or(0.0, |m| m.upload_bytes as f64))),
        timewarp: None,
        gpu_frames_over_budget: gpu.iter().filter(|&&t| t > budget_ms).count() as u32,
        aq: aq_summary(frames),
        ..ConfigResult::default()
    }
}

fn one() -> f64 {
    1.0
}

/// The render scales of `frames` rendered with `aq` (None without).
fn aq_summary(frames: &[FrameResult]) -> Option<AqSummary> {
    let a: Vec<crate::render::driver::AqFrame> = frames.iter().filter_map(|f| f.aq).collect();
    if a.is_empty() || a.len() != frames.len() {
        return None;
    }
    let scales: Vec<f64> = a.iter().map(|x| x.scale).collect();
    Some(AqSummary {
        mean_scale: scales.iter().sum::<f64>() / scales.len() as f64,
        min_scale: scales.iter().copied().fold(f64::INFINITY, f64::min),
        max_scale: scales.iter().copied().fold(0.0, f64::max),
        level_changes: a.windows(2).filter(|w| w[0].level != w[1].level).count() as u32,
        wide_rung_frames: a.iter().filter(|x| x.wide_factor < 1.0).count() as u32,
        wide_one_sample_frames: a.iter().filter(|x| x.wide_one_sample).count() as u32,
        min_wide_factor: a.iter().map(|x| x.wide_factor).fold(1.0, f64::min),
        budget_ms: a[0].budget_ms,
    })
}

/// The floors on `renderer` (the baseline's: same resolution, stereo mode
/// and MSAA).
fn floors(renderer: &mut Renderer, plan: &Plan, rig: &StereoRig) -> Result<Floors> {
    // At the full size, whatever scale a baseline with aq ended on.
    renderer.set_render_scale(1.0);
    renderer.set_inset_wide_factor(1.0);
    renderer.set_inset_wide_one_sample(false);
    let n = plan.warmup + plan.frames;
    let mut empty = Vec::new();
    for i in 0..n {
        let f = renderer.render(rig, Some(&[]), false)?;
        if i >= plan.warmup {
            empty.push(f.gpu_ms.values().sum());
        }
    }
    let mut series = |kind| -> Result<Summary> {
        let mut v = Vec::new();
        for i in 0..n {
            let ms = renderer.render_floor(kind)?;
            if i >= plan.warmup {
                v.push(ms);
            }
        }
        Ok(Summary::of(&v))
    };
    Ok(Floors {
        empty_frame: Summary::of(&empty),
        clear: series(FloorKind::Clear)?,
        fullscreen_triangle: series(FloorKind::FullscreenTriangle)?,
    })
}

/// Saves the left eye of the last image pair as `dir/name.png` under
/// `out`; returns the path relative to `out`.
fn save_left(out: &Path, dir: &str, name: &str, images: &RefImages) -> Result<String> {
    let rel = format!("{dir}/{}.png", sanitize(name));
    if let Some(pair) = images.last() {
        let path: PathBuf = out.join(&rel);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|e| crate::error::Error::Output {
                path: parent.to_path_buf(),
                message: e.to_string(),
            })?;
        }
        crate::targets::headless::save_png(&pair[0], &path)?;
    }
    Ok(rel)
}

/// The host CPU's model name (from /proc/cpuinfo).
fn cpu_model() -> String {
    crate::fsio::read_system_text(Path::new("/proc/cpuinfo"))
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .map(|m| {
            format!(
                "{m} ({} threads)",
                std::thread::available_parallelism().map_or(1, |n| n.get())
            )
        })
        .unwrap_or_else(|| "unknown".into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::points::PointCloud;
    use glam::DVec3;

    /// A cloud of `n` points on a 200 m square far from the origin.
    fn far_cloud(n: usize) -> Scene {
        let origin = DVec3::new(5.0e5, 20.0, -3.0e6);
        let positions = (0..n)
            .map(|i| {
                let t = i as f32 / n as f32;
                [200.0 * t, 10.0 * t, 200.0 * (1.0 - t)]
            })
            .collect();
        Scene::of_points(PointCloud {
            origin,
            positions,
            colors: vec![[200, 200, 200, 0]; n],
            classification: vec![0; n],
            ..PointCloud::default()
        })
    }

    #[test]
    fn head_paths_frame_a_scene_of_points_alone() {
        let scene = far_cloud(1000);
        let (lo, hi) = scene.bounds();
        let profile = HmdProfile::load("valve-index").unwrap();
        for path in ["walk", "orbit"] {
            let text = format!(
                "name = \"t\"\nscenes = [\"factory:10\"]\nhmds = [\"valve-index\"]\nframes = 8\npath = \"{path}\"\n[[configs]]\nname = \"a\"\nopt = \"two-pass\"\n"
            );
            let plan = Plan::parse("t", &text).unwrap();
            let diag = (hi - lo).length();
            for rig in path_rigs(&plan, &scene, &profile) {
                // Every head is near the cloud (a walk inside its box, an
                // orbit within about its diagonal), not at the origin.
                let d = rig.head.position.distance((lo + hi) * 0.5);
                assert!(d < 1.2 * diag, "{path}: head {d} m from the cloud's centre");
            }
        }
    }

    proptest::proptest! {
        /// `rect_mean` is the brute-force mean of the visible errors whose
        /// pixel lies inside the rectangle (0 when there are none).
        #[test]
        fn rect_mean_is_the_mean_of_the_visible_pixels_inside(
            w in 1u32..12,
            h in 1u32..12,
            corners in (0u32..12, 0u32..12, 0u32..12, 0u32..12),
            seed in 0u64..1000,
        ) {
            let (a, b, c, d) = corners;
            let rect = PixelRect {
                x0: a.min(b).min(w - 1),
                x1: (a.max(b) + 1).min(w),
                y0: c.min(d).min(h - 1),
                y1: (c.max(d) + 1).min(h),
            };
            let n = (w * h) as usize;
            let errors: Vec<f32> =
                (0..n).map(|i| ((i as u64 * 7919 + seed) % 101) as f32 / 100.0).collect();
            let hidden: Vec<bool> = (0..n).map(|i| (i as u64 + seed).is_multiple_of(3)).collect();
            let inside: Vec<f64> = (0..n)
                .filter(|&i| rect.contains(i as u32 % w, i as u32 / w) && !hidden[i])
                .map(|i| errors[i] as f64)
                .collect();
            let want = if inside.is_empty() {
                0.0
            } else {
                inside.iter().sum::<f64>() / inside.len() as f64
            };
            let got = rect_mean(&errors, w, &rect, &hidden);
            proptest::prop_assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        }
    }
}
