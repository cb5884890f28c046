//! Headless rendering into PNG files plus a `stats.json`: the `vergence
//! render` command.

use crate::config::RenderConfig;
use crate::cull::CullStats;
use crate::error::{Error, Result};
use crate::gpu::{Context, Validation};
use crate::render::driver::{FrameDriver, FrameResult};
use crate::render::{FloorKind, Renderer};
use crate::scene::{Scene, SceneFeatures};
use crate::view::profile::HmdProfile;
use crate::view::Pose;
use ash::vk;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// What to render.
#[derive(Clone, Debug)]
pub struct RenderJob {
    /// `--scene` value.
    pub scene: String,
    /// HMD profile name or path.
    pub hmd: String,
    /// Head pose (None: a camera of the scene, or framing the scene's
    /// bounds as `run` spawns).
    pub pose: Option<Pose>,
    /// A camera of the scene (index or name) as the head pose.
    pub camera: Option<String>,
    /// How the head is placed without `pose` or `camera` (`--frame`).
    pub framing: super::framing::Framing,
    /// Exact views to render instead of the profile's eyes at `pose`.
    pub rig: Option<crate::view::StereoRig>,
    /// Renderer configuration.
    pub config: RenderConfig,
    /// Per-eye size override (else the profile's resolution).
    pub size: Option<(u32, u32)>,
    /// Output folder.
    pub out: PathBuf,
    /// Frames to render (>1 measures: medians over frames after 2 warm-up
    /// frames, plus the raster floors).
    pub frames: u32,
    /// `--preview distorted`: also write what the panels show
    /// (`left_distorted.png`, `right_distorted.png`), drawn by this method.
    pub distorted: Option<crate::render::distortion::Method>,
    /// With `timewarp=K`: the head's turn rate along the measured frames
    /// (degrees per second about the vertical axis).
    pub head_turn_deg_s: f64,
}

/// The distortion preview's figures (`preview` in stats.json).
#[derive(Clone, Debug, serde::Serialize)]
pub struct PreviewStats {
    /// "distorted".
    pub mode: &'static str,
    /// fragment, grid or mesh.
    pub method: crate::render::distortion::Method,
    /// Panel-image pixels per eye: the panel's own, or scaled down where
    /// the profile's panel is more than twice the rendered eye image along
    /// an axis.
    pub panel: [u32; 2],
    /// GPU ms of the preview for both eyes (median and p95 over the
    /// frames measured, one run per frame).
    pub gpu_ms: Percentiles,
}

/// Scene counts reported in stats.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SceneCounts {
    /// Scene name.
    pub name: String,
    /// Source nodes.
    pub nodes: usize,
    /// Meshes.
    pub meshes: usize,
    /// Primitives.
    pub primitives: usize,
    /// Materials.
    pub materials: usize,
    /// Textures.
    pub textures: usize,
    /// Instances.
    pub instances: usize,
    /// Triangles over all instances.
    pub triangles: usize,
    /// Features the renderer built pipelines and streams for.
    pub features: SceneFeatures,
}

impl SceneCounts {
    /// Counts of `scene`.
    pub fn of(scene: &Scene) -> SceneCounts {
        SceneCounts {
            name: scene.name.clone(),
            nodes: scene.nodes,
            meshes: scene.meshes.len(),
            primitives: scene.primitives.len(),
            materials: scene.materials.len(),
            textures: scene.textures.len(),
            instances: scene.instances.len(),
            triangles: scene.instanced_triangles(),
            features: scene.features(),
        }
    }
}

/// The contents of `stats.json`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RenderStats {
    /// Scene counts.
    pub scene: SceneCounts,
    /// HMD profile name.
    pub hmd: String,
    /// Per-eye resolution.
    pub resolution: [u32; 2],
    /// Configuration used.
    pub config: RenderConfig,
    /// GPU name.
    pub device: String,
    /// Driver description.
    pub driver: String,
    /// Draw calls.
    pub draw_calls: u64,
    /// Instances drawn.
    pub instances_drawn: u64,
    /// Triangles submitted.
    pub triangles: u64,
    /// Points in the scene's point cloud (absent without one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points_total: Option<u64>,
    /// Points rasterized in the frame, both eyes together (a point counts
    /// once per eye it lands in; absent without a cloud).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points_drawn: Option<u64>,
    /// Points the octree chose within `config.points_budget` (absent
    /// without a cloud).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points_selected: Option<u64>,
    /// The cloud's octree: nodes and build time (absent without one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub points_octree: Option<OctreeReport>,
    /// CPU ms per phase (load, cull, batch, record, submit, wait).
    pub cpu_ms: BTreeMap<String, f64>,
    /// GPU ms per pass.
    pub gpu_ms: BTreeMap<String, f64>,
    /// Fragment-shader invocations (pipeline statistics; null if unsupported).
    pub fragment_invocations: Option<u64>,
    /// Vertex-shader invocations.
    pub vertex_invocations: Option<u64>,
    /// GPU memory in bytes per category.
    pub gpu_memory: BTreeMap<String, u64>,
    /// Whether transient attachments got lazily allocated memory.
    pub lazily_allocated_attachments: bool,
    /// Validation messages seen (0 when validation is off or clean).
    pub validation_messages: usize,
    /// Frames measured (stats are medians when > 1).
    pub frames: u32,
    /// GPU ms of the whole frame (sum of passes): median and 95th percentile.
    pub gpu_frame_ms: Percentiles,
    /// CPU ms of the frame's own work (cull, moving instances' upload,
    /// batch, record, submit: [`FrameResult::cpu_ms`], as the bench and
    /// `view`'s overlay count it): median and 95th percentile.
    pub cpu_frame_ms: Percentiles,
    /// Wall-clock ms from one frame's start to the next's, as the loop ran
    /// with `config.frames_in_flight` frames in flight (measured when
    /// frames > 1).
    pub frame_interval_ms: Percentiles,
    /// The floors at the same resolution and MSAA (measured when frames > 1).
    pub floor_gpu_ms: Option<Floors>,
    /// Culling counters of the last frame (None without a culling strategy).
    pub cull: Option<CullStats>,
    /// With `gpu-cull`: the compute cull's counters of the last frame, read
    /// back from the GPU (tested, inside the volumes, drawn early, drawn
    /// late, occluded).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_cull: Option<crate::render::GpuCullStats>,
    /// The head pose rendered from (the rig's head, world space: position
    /// and orientation quaternion).
    pub pose: crate::view::PoseFile,
    /// The same pose as a `--pose` value (x,y,z,yaw,pitch,roll).
    pub pose_arg: String,
    /// Where the pose came from: `--pose`, `--camera NAME`, `--rig`, or
    /// the framing (`--frame outside`, `inside` or `spawn`).
    pub pose_from: String,
    /// What the renderer chose per technique (the foveation, inset, LMS,
    /// LOD and point paths; per-view render areas), at the top level.
    #[serde(flatten)]
    pub renderer: crate::render::report::RendererReport,
    /// With `--preview distorted`: the distortion preview's figures.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub preview: Option<PreviewStats>,
    /// With `timewarp=K`: the warp's error against the truly rendered
    /// frames, its holes and its GPU cost (filled in by
    /// `bench::timewarp::measure`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timewarp: Option<crate::render::timewarp::TimewarpStats>,
    /// In a scene with moving instances: the instances that move, and what
    /// the last frame uploaded of them (moved instances, bytes, copy
    /// regions).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motion: Option<MotionReport>,
}

/// `stats.json`'s `points_octree` block.
#[derive(Clone, Debug, serde::Serialize)]
pub struct OctreeReport {
    /// Nodes.
    pub nodes: usize,
    /// Build time, milliseconds (this process, at load).
    pub build_ms: f64,
    /// Points built per second, millions.
    pub build_mpoints_per_s: f64,
    /// For a cloud from a file: `{"read": PATH}` (then `build_ms` is the
    /// time to read and check it), `{"written": PATH}` or
    /// `{"not_used": WHY}`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cache: Option<crate::scene::octree::CacheUse>,
}

impl OctreeReport {
    /// The report of `tree` over `points` points.
    pub fn of(tree: &crate::scene::octree::Octree, points: usize) -> OctreeReport {
        OctreeReport {
            nodes: tree.nodes.len(),
            build_ms: tree.build_ms,
            build_mpoints_per_s: points as f64 / (tree.build_ms.max(1e-6) * 1e3),
            cache: tree.cache.clone(),
        }
    }

    /// The report of the scene's point octree, if it has one.
    pub fn of_scene(scene: &Scene) -> Option<OctreeReport> {
        let c = scene.points.as_ref()?;
        c.octree.as_ref().map(|t| OctreeReport::of(t, c.len()))
    }
}

/// `stats.json`'s `motion` block.
#[derive(Clone, Debug, serde::Serialize)]
pub struct MotionReport {
    /// Instances of the scene that move.
    pub moving_instances: usize,
    /// What the last frame uploaded.
    #[serde(flatten)]
    pub last_frame: crate::render::instance_updates::UpdateStats,
}

impl MotionReport {
    /// The scene's moving instances and what `frame` uploaded; None for a
    /// scene where nothing moves.
    pub fn of(scene: &Scene, frame: &crate::render::FrameStats) -> Option<MotionReport> {
        (!scene.moving.is_empty()).then(|| MotionReport {
            moving_instances: scene.moving_instances(),
            last_frame: frame.motion.unwrap_or_default(),
        })
    }
}

pub use crate::stats::Percentiles;

/// GPU ms of the floor frames.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Floors {
    /// Clearing the attachments (and resolving) only.
    pub clear: Percentiles,
    /// One full-screen triangle with a trivial fragment shader.
    pub fullscreen_triangle: Percentiles,
}

/// Loads a scene with a spinner when it takes more than a moment.
pub fn load_scene(spec: &str) -> Result<(Scene, f64)> {
    load_scene_with(spec, false)
}

/// [`load_scene`]; with `write_octree_cache`, a point cloud's octree is
/// built and written to its cache file.
pub fn load_scene_with(spec: &str, write_octree_cache: bool) -> Result<(Scene, f64)> {
    let t = Instant::now();
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_message(format!("loading {spec}"));
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    let scene = Scene::load_with(spec, write_octree_cache);
    bar.finish_and_clear();
    let ms = t.elapsed().as_secs_f64() * 1e3;
    let scene = scene?;
    tracing::info!(
        "loaded {} ({} instances) in {ms:.1} ms",
        scene.name,
        scene.instances.len()
    );
    Ok((scene, ms))
}

/// Loads an HMD profile the stereo renderer can use: exactly two views.
pub fn load_stereo_profile(name: &str) -> Result<HmdProfile> {
    let profile = HmdProfile::load(name)?;
    if profile.views.len() != 2 {
        return Err(Error::Profile {
            name: name.to_string(),
            message: format!(
                "the renderer needs exactly 2 views, the profile has {}",
                profile.views.len()
            ),
        });
    }
    Ok(profile)
}

/// `rigs` rendered in order by a fresh renderer of `config`, frame `j` at
/// scene time `start_time + j / DEFAULT_FRAME_RATE` (where moving
/// instances stand), each frame read back: what an image comparison
/// outside the timed loops renders (the bench's temporal-error sequence,
/// `view`'s on-demand error). With `supersample` k > 1 the frames are
/// rendered at k × `extent` per axis and reduced to `extent` ([`to_size`]).
pub fn render_sequence(
    ctx: &Arc<Context>,
    scene: &Scene,
    config: &RenderConfig,
    rigs: &[crate::view::StereoRig],
    (extent, supersample): (vk::Extent2D, u32),
    start_time: f64,
) -> Result<Vec<[image::RgbaImage; 2]>> {
    let renderer = new_renderer(ctx, scene, config, supersampled(extent, supersample))?;
    let mut driver = FrameDriver::new(renderer, scene)?;
    let mut out = Vec::with_capacity(rigs.len());
    for (j, rig) in rigs.iter().enumerate() {
        driver.set_time(start_time + j as f64 / crate::render::driver::DEFAULT_FRAME_RATE);
        driver.frame(rig, j as u64, true)?;
        out.push(driver.read_images()?.map(|img| to_size(img, extent)));
    }
    driver.finish()?;
    Ok(out)
}

/// `extent` times `k` per axis (at least 1): where a supersampled
/// reference renders before [`to_size`] brings it back.
pub fn supersampled(extent: vk::Extent2D, k: u32) -> vk::Extent2D {
    let k = k.max(1);
    vk::Extent2D {
        width: extent.width * k,
        height: extent.height * k,
    }
}

/// `img` at `extent`: unchanged when it already is; a whole multiple k of
/// it (a supersampled reference, [`render_sequence`]'s `supersample`)
/// reduced by the k × k box filter in linear light
/// ([`super::downsample::box_linear`]); else resampled bilinearly (a frame
/// `aq` rendered smaller or larger, as a compositor scales the sub-image
/// to the eye).
pub fn to_size(img: image::RgbaImage, extent: vk::Extent2D) -> image::RgbaImage {
    if img.dimensions() == (extent.width, extent.height) {
        return img;
    }
    if extent.width > 0 && img.width().is_multiple_of(extent.width) {
        let k = img.width() / extent.width;
        if k >= 2 && img.height() == k * extent.height {
            return super::downsample::box_linear(&img, k);
        }
    }
    image::imageops::resize(
        &img,
        extent.width,
        extent.height,
        image::imageops::FilterType::Triangle,
    )
}

/// Creates the renderer; an allocation failure names what was being
/// allocated for: the per-eye size, the MSAA samples and an estimate of
/// the render targets' need (colour and depth per sample plus a resolved
/// colour image, for both views), instead of Vulkan's bare "a device
/// memory allocation has failed".
pub fn new_renderer(
    ctx: &Arc<Context>,
    scene: &Scene,
    config: &RenderConfig,
    extent: vk::Extent2D,
) -> Result<Renderer> {
    Renderer::new(ctx.clone(), scene, config, extent).map_err(|e| {
        let memory = match &e {
            Error::Vulkan { result, .. } => matches!(
                *result,
                vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY
            ),
            Error::Gpu(m) => m.contains("out of GPU memory") || m.contains("allocation"),
            _ => false,
        };
        if !memory {
            return e;
        }
        let per_pixel = 8 * config.frame.msaa as u64 + 4;
        let need = extent.width as u64 * extent.height as u64 * 2 * per_pixel;
        Error::Gpu(format!(
            "out of GPU memory making the renderer for {}x{} px per eye at {}x MSAA (its colour, depth and resolve images take about {:.1} MiB for 2 views, besides the scene): {e}; try a smaller --width/--height or --msaa 1",
            extent.width,
            extent.height,
            config.frame.msaa,
            need as f64 / (1u64 << 20) as f64
        ))
    })
}

/// The pose of the scene camera `name` (its index in the file, or its
/// name), or an error listing the cameras there are.
pub fn scene_camera(scene: &Scene, name: &str) -> Result<Pose> {
    let found = match name.parse::<usize>() {
        Ok(i) => scene.cameras.iter().find(|c| c.index == i),
        Err(_) => scene.cameras.iter().find(|c| c.name == name),
    };
    found.map(|c| c.pose).ok_or_else(|| {
        let list: Vec<String> = scene
            .cameras
            .iter()
            .map(|c| format!("{} '{}'", c.index, c.name))
            .collect();
        Error::config(
            "--camera",
            format!(
                "'{name}': {} has {}",
                scene.name,
                if list.is_empty() {
                    "no cameras".to_string()
                } else {
                    format!("cameras {}", list.join(", "))
                }
            ),
        )
    })
}

/// Per-eye size from the override or the profile.
pub fn eye_extent(profile: &HmdProfile, size: Option<(u32, u32)>) -> vk::Extent2D {
    let (w, h) = size.unwrap_or((
        profile.views[0].resolution[0],
        profile.views[0].resolution[1],
    ));
    vk::Extent2D {
        width: w,
        height: h,
    }
}

/// Renders one frame as `job` says and writes `left.png`, `right.png` and
/// `stats.json` into `job.out`.
pub fn render_to_dir(job: &RenderJob) -> Result<RenderStats> {
    let (stats, _, mut outputs) = render_to_dir_keeping(job)?;
    write_stats(&mut outputs, job, &stats)?;
    outputs.commit()?;
    Ok(stats)
}

/// Adds `stats.json` to `outputs` (the last file of a render's set).
pub fn write_stats(
    outputs: &mut crate::fsio::OutputSet,
    job: &RenderJob,
    stats: &RenderStats,
) -> Result<()> {
    outputs.write(&job.out.join("stats.json"), |w| json_to(w, stats))
}

/// What [`render_to_dir_keeping`] loaded and made, for a measurement that
/// follows on the same scene (the timewarp): no second load, no second
/// Vulkan device.
pub struct Loaded {
    /// The device context.
    pub ctx: Arc<Context>,
    /// The scene.
    pub scene: Scene,
    /// The HMD profile.
    pub profile: HmdProfile,
}

/// What [`render_frames`] rendered, with what it rendered it from.
struct Rendered {
    profile: HmdProfile,
    scene: Scene,
    load_ms: f64,
    ctx: Arc<Context>,
    extent: vk::Extent2D,
    driver: FrameDriver,
    rig: crate::view::StereoRig,
    frames: u32,
    warmup: u32,
    all: Vec<FrameResult>,
}

/// Loads the job's profile (its lenses with a distortion preview) and
/// scene, checks the output folder (the images and statistics land
/// together or not at all, so it is checked before anything is rendered),
/// and renders the warm-up and measured frames.
fn render_frames(job: &RenderJob) -> Result<Rendered> {
    let profile = load_stereo_profile(&job.hmd)?;
    job.config.validate()?;
    let mut config = job.config.clone();
    config.resolve_lens(Some(&profile))?;
    if job.distorted.is_some() {
        profile_lenses(&profile)?;
    }
    let (scene, load_ms) = load_scene(&job.scene)?;
    crate::fsio::prepare_output(&job.out.join("stats.json"))?;
    let ctx = Arc::new(Context::new_headless(Validation::from_env())?);
    let extent = eye_extent(&profile, job.size);
    let renderer = new_renderer(&ctx, &scene, &config, extent)?;
    let mut driver = FrameDriver::new(renderer, &scene)?;
    let rig = head_rig(job, &scene, &profile)?;
    let frames = job.frames.max(1);
    let warmup = if frames > 1 { 2 } else { 0 };
    let all = run_frames(&mut driver, &rig, warmup, warmup + frames)?;
    Ok(Rendered {
        profile,
        scene,
        load_ms,
        ctx,
        extent,
        driver,
        rig,
        frames,
        warmup,
        all,
    })
}

/// [`render_to_dir`], handing back the context, scene and profile it used
/// and its outputs uncommitted (the images and `rig.json`, without
/// `stats.json`): a measurement that follows adds its files and the
/// statistics ([`write_stats`]), and everything lands together.
pub fn render_to_dir_keeping(
    job: &RenderJob,
) -> Result<(RenderStats, Loaded, crate::fsio::OutputSet)> {
    let Rendered {
        profile,
        scene,
        load_ms,
        ctx,
        extent,
        mut driver,
        rig,
        frames,
        warmup,
        all,
    } = render_frames(job)?;
    let mut outputs = crate::fsio::OutputSet::default();
    let cull_stats = all.last().and_then(|r| r.cull);
    let frame = median_frame(&all);
    let [left, right] = driver.read_images()?;
    let build_ms = driver.culling().map(|c| c.build_ms);
    let renderer = driver.renderer_mut();
    let floor_gpu_ms = measure_floors(renderer, warmup, frames)?;
    let eyes = [&left, &right];
    let preview = distortion_preview(
        &ctx,
        &rig,
        extent,
        eyes,
        (&profile, frames),
        job,
        &mut outputs,
    )?;
    outputs.write(&job.out.join("left.png"), |w| png_to(w, &left))?;
    outputs.write(&job.out.join("right.png"), |w| png_to(w, &right))?;
    let series =
        |get: fn(&FrameResult) -> f64| Percentiles::of(&all.iter().map(get).collect::<Vec<_>>());
    let cull_median = build_ms.map(|b| (b, series(|r| r.cull_ms).median));
    let motion = (!scene.moving.is_empty()).then(|| series(|r| r.motion_ms).median);
    let cpu_ms = cpu_ms_table(load_ms, cull_median, motion, &frame);
    let mut stats = RenderStats {
        scene: SceneCounts::of(&scene),
        hmd: profile.name.clone(),
        resolution: [extent.width, extent.height],
        config: renderer.config.clone(),
        device: ctx.device_name.clone(),
        driver: ctx.driver.clone(),
        draw_calls: frame.draw_calls,
        instances_drawn: frame.instances_drawn,
        triangles: frame.triangles,
        points_total: renderer.points_total(),
        points_drawn: frame.points_drawn,
        points_selected: frame.points_selected,
        points_octree: OctreeReport::of_scene(&scene),
        cpu_ms,
        gpu_ms: frame.gpu_ms.clone(),
        fragment_invocations: frame.pipeline.map(|p| p.fragment_invocations),
        vertex_invocations: frame.pipeline.map(|p| p.vertex_invocations),
        gpu_memory: ctx.memory_snapshot(),
        lazily_allocated_attachments: renderer.lazily_allocated(),
        validation_messages: ctx.validation_messages(),
        frames,
        gpu_frame_ms: series(FrameResult::gpu_ms),
        cpu_frame_ms: series(FrameResult::cpu_ms),
        frame_interval_ms: Percentiles::of(
            &all.iter().filter_map(|r| r.interval_ms).collect::<Vec<_>>(),
        ),
        floor_gpu_ms,
        cull: cull_stats,
        gpu_cull: frame.gpu_cull,
        pose: crate::view::PoseFile::from(&rig.head),
        pose_arg: rig.head.pose_arg(),
        pose_from: pose_from(job),
        renderer: renderer.report(),
        preview,
        timewarp: None,
        motion: MotionReport::of(&scene, &frame),
    };
    drop(driver);
    // Teardown may speak too.
    stats.validation_messages = ctx.validation_messages();
    // The exact views rendered: `render --rig` and the simulator take it.
    let rig_file = crate::view::RigFile::of(&rig);
    outputs.write(&job.out.join("rig.json"), |w| json_to(w, &rig_file))?;
    Ok((
        stats,
        Loaded {
            ctx,
            scene,
            profile,
        },
        outputs,
    ))
}

/// Where the rendered pose came from, as `stats.json`'s `pose_from` says.
fn pose_from(job: &RenderJob) -> String {
    match (&job.rig, &job.camera, job.pose) {
        (Some(_), ..) => "--rig".to_string(),
        (None, Some(name), _) => format!("--camera {name}"),
        (None, None, Some(_)) => "--pose".to_string(),
        (None, None, None) => format!(
            "--frame {}",
            serde_json::to_value(job.framing)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default()
        ),
    }
}

/// `stats.json`'s CPU times: loading, the BVH build and the cull's median
/// (with CPU culling), the motion's median (with moving instances), and
/// the median frame's batch, record, submit and wait.
fn cpu_ms_table(
    load_ms: f64,
    cull: Option<(f64, f64)>,
    motion: Option<f64>,
    frame: &crate::render::FrameStats,
) -> BTreeMap<String, f64> {
    let mut cpu_ms = BTreeMap::new();
    cpu_ms.insert("load".to_string(), load_ms);
    if let Some((build_ms, cull_ms)) = cull {
        cpu_ms.insert("bvh_build".to_string(), build_ms);
        cpu_ms.insert("cull".to_string(), cull_ms);
    }
    if let Some(m) = motion {
        cpu_ms.insert("motion".to_string(), m);
    }
    let c = &frame.cpu_ms;
    for (k, v) in [
        ("batch", c.batch),
        ("record", c.record),
        ("submit", c.submit),
        ("wait", c.wait),
    ] {
        cpu_ms.insert(k.to_string(), v);
    }
    if let Some(t) = c.record_threads {
        cpu_ms.insert("record_threads_sum".to_string(), t.sum);
        cpu_ms.insert("record_threads_slowest".to_string(), t.slowest);
    }
    cpu_ms
}

/// With `--distorted`, the lens-distorted preview of the rendered eyes
/// (`frames` times, for its GPU times), written beside them.
fn distortion_preview(
    ctx: &Arc<Context>,
    rig: &crate::view::StereoRig,
    extent: vk::Extent2D,
    eyes: [&image::RgbaImage; 2],
    (profile, frames): (&HmdProfile, u32),
    job: &RenderJob,
    outputs: &mut crate::fsio::OutputSet,
) -> Result<Option<PreviewStats>> {
    let Some(method) = job.distorted else {
        return Ok(None);
    };
    let lenses = profile_lenses(profile)?;
    let (Some(l), Some(r)) = (rig.views.first(), rig.views.get(1)) else {
        return Err(Error::Gpu("the distortion preview needs two views".into()));
    };
    let fovs = [&l.fov, &r.fov];
    let mut p =
        crate::render::distortion::DistortionPreview::new(ctx, lenses, fovs, extent, method)?;
    let out = p.run(&eyes.map(|e| e.clone()), frames)?;
    outputs.write(&job.out.join("left_distorted.png"), |w| {
        png_to(w, &out.images[0])
    })?;
    outputs.write(&job.out.join("right_distorted.png"), |w| {
        png_to(w, &out.images[1])
    })?;
    Ok(Some(PreviewStats {
        mode: "distorted",
        method,
        panel: [p.panel().width, p.panel().height],
        gpu_ms: Percentiles::of(&out.gpu_ms),
    }))
}

/// The lenses of a profile's two views, for the distortion preview; one
/// error naming the profile when it has none.
pub fn profile_lenses(profile: &HmdProfile) -> Result<[&crate::view::distortion::Lens; 2]> {
    let lens = |i: usize| profile.views.get(i).and_then(|v| v.lens.as_ref());
    match (lens(0), lens(1)) {
        (Some(l), Some(r)) => Ok([l, r]),
        _ => Err(Error::Profile {
            name: profile.name.clone(),
            message: "has no [views.lens] table for both eyes, which --preview distorted needs \
                      (profiles with lenses: vive, rift-dk1)"
                .into(),
        }),
    }
}

/// Writes a stereo pair as `dir/left.png` and `dir/right.png`, creating
/// `dir` ([`crate::fsio::write_output`]: no planted link is followed).
pub fn save_pair(dir: &Path, images: &[image::RgbaImage; 2]) -> Result<()> {
    save_png(&images[0], &dir.join("left.png"))?;
    save_png(&images[1], &dir.join("right.png"))
}

/// Writes `value` as pretty-printed JSON to `path`, creating its folder.
/// The JSON streams through a buffered writer into a fresh temporary file
/// renamed into place at the end ([`crate::fsio::write_output`]: no
/// whole-document string in memory, no half-written file on failure, no
/// planted link followed).
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    crate::fsio::write_output(path, |w| json_to(w, value))
}

/// `value` as pretty-printed JSON into `w`.
fn json_to(w: &mut dyn std::io::Write, value: &impl serde::Serialize) -> std::io::Result<()> {
    serde_json::to_writer_pretty(w, value).map_err(std::io::Error::from)
}

/// `img` as PNG into `w`.
pub fn png_to(w: &mut dyn std::io::Write, img: &image::RgbaImage) -> std::io::Result<()> {
    use image::ImageEncoder as _;
    image::codecs::png::PngEncoder::new(w)
        .write_image(
            img.as_raw(),
            img.width(),
            img.height(),
            image::ExtendedColorType::Rgba8,
        )
        .map_err(std::io::Error::other)
}

/// Writes an RGBA image as PNG ([`crate::fsio::write_output`]).
pub fn save_png(img: &image::RgbaImage, path: &Path) -> Result<()> {
    crate::fsio::write_output(path, |w| png_to(w, img))
}

/// The views to render: `--rig`'s (with the profile's masks when the file
/// has none), else the profile's eyes at `--camera`, `--pose` or the
/// framing.
fn head_rig(
    job: &RenderJob,
    scene: &Scene,
    profile: &HmdProfile,
) -> Result<crate::view::StereoRig> {
    let head = match (&job.camera, job.pose) {
        (Some(name), _) => scene_camera(scene, name)?,
        (None, Some(pose)) => pose,
        (None, None) => super::framing::head_pose(scene, profile, job.framing),
    };
    let rig = match job.rig.clone() {
        // A rig file written before rig.json carried hidden areas: the
        // profile's masks, when it has as many views.
        Some(mut r) if r.hidden_area.is_none() && r.views.len() == profile.views.len() => {
            r.hidden_area = Some(profile.hidden_areas.clone());
            r
        }
        Some(r) => r,
        None => profile.rig(head),
    };
    Ok(rig)
}

/// Renders `total` frames of `rig`, reading back the last; the results of
/// those after `warmup`.
fn run_frames(
    driver: &mut FrameDriver,
    rig: &crate::view::StereoRig,
    warmup: u32,
    total: u32,
) -> Result<Vec<FrameResult>> {
    let mut all: Vec<FrameResult> = Vec::new();
    let keep = |r: FrameResult, all: &mut Vec<FrameResult>| {
        if r.index >= warmup as u64 {
            all.push(r);
        }
    };
    for i in 0..total {
        driver.frame(rig, i as u64, i + 1 == total)?;
        while let Some(r) = driver.take_completed() {
            keep(r, &mut all);
        }
    }
    driver.finish()?;
    while let Some(r) = driver.take_completed() {
        keep(r, &mut all);
    }
    Ok(all)
}

/// The last frame's statistics with its CPU and GPU times replaced by the
/// medians over `all`.
fn median_frame(all: &[FrameResult]) -> crate::render::FrameStats {
    let median_of = |get: &dyn Fn(&FrameResult) -> f64| {
        Percentiles::of(&all.iter().map(get).collect::<Vec<_>>()).median
    };
    let mut frame = all.last().map(|r| r.stats.clone()).unwrap_or_default();
    frame.cpu_ms.batch = median_of(&|r| r.stats.cpu_ms.batch);
    frame.cpu_ms.record = median_of(&|r| r.stats.cpu_ms.record);
    frame.cpu_ms.submit = median_of(&|r| r.stats.cpu_ms.submit);
    frame.cpu_ms.wait = median_of(&|r| r.stats.cpu_ms.wait);
    if frame.cpu_ms.record_threads.is_some() {
        let threads = |r: &FrameResult| r.stats.cpu_ms.record_threads.unwrap_or_default();
        frame.cpu_ms.record_threads = Some(crate::render::submission::ThreadTimes {
            sum: median_of(&|r| threads(r).sum),
            slowest: median_of(&|r| threads(r).slowest),
        });
    }
    for (name, v) in frame.gpu_ms.iter_mut() {
        *v = median_of(&|r| r.stats.gpu_ms.get(name).copied().unwrap_or(0.0));
    }
    frame
}

/// With more than one frame: the clear-only and full-screen-triangle
/// floors, measured as many times after as many warm-ups.
fn measure_floors(renderer: &mut Renderer, warmup: u32, frames: u32) -> Result<Option<Floors>> {
    Ok(if frames > 1 {
        let mut measure = |kind| -> Result<Percentiles> {
            let mut v = Vec::new();
            for i in 0..warmup + frames {
                let ms = renderer.render_floor(kind)?;
                if i >= warmup {
                    v.push(ms);
                }
            }
            Ok(Percentiles::of(&v))
        };
        Some(Floors {
            clear: measure(FloorKind::Clear)?,
            fullscreen_triangle: measure(FloorKind::FullscreenTriangle)?,
        })
    } else {
        None
    })
}
