//! The `vergence` command line.

use anyhow::Context as _;
use clap::{Parser, Subcommand};
use glam::DVec3;
use std::path::PathBuf;
use std::process::ExitCode;
use vergence::config::{PerDraw, RenderConfig, StereoMode};
use vergence::interact::{MoveDirection, Settings};
use vergence::render::distortion::Method as DistortionMethod;
use vergence::scene::Scene;
use vergence::targets::framing::Framing;
use vergence::targets::headless::{self, RenderJob};
use vergence::targets::run::{RunArgs, XrMode};
use vergence::view::profile::{HmdProfile, DEFAULT_PROFILE};
use vergence::view::Pose;

/// Stereo VR rendering of very large scenes, with measured stereo optimizations.
#[derive(Parser)]
#[command(name = "vergence", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render one stereo frame headless into DIR/left.png, DIR/right.png and DIR/stats.json.
    Render(RenderArgs),
    /// Run the scene in a headset through OpenXR (or headless on an HMD profile).
    Run(RunCli),
    /// Look at a scene in a desktop window through an HMD profile's stereo
    /// rig: WASD (Q/E down/up) to move, drag with the left mouse button to
    /// look, Shift for speed, Escape to quit; keys 1-9 and 0 switch
    /// optimizations, P prints the --opt list, F2 saves it, H lists the keys.
    View(ViewCli),
    /// Time the stereo culling strategies on factory:N along a deterministic head path.
    CullBench(vergence::bench::cull::CullBenchArgs),
    /// Time an empty 2-layer multiview frame's clear and resolve routes
    /// (scope clear, transfer clear, depth without stencil, resolve
    /// attachment, command or compute) on the GPU.
    RasterFloors(vergence::bench::raster_floors::RasterFloorsArgs),
    /// Measure every optimization alone and combined along a head path:
    /// CPU and GPU time, pacing, counts, memory and image error; writes
    /// results.json, results.csv, report.md and report.html into DIR.
    Bench {
        /// A plan file (its scene and profile paths resolve against its
        /// folder) or a shipped plan by name (smoke, default, scale, and
        /// every plan in manifests/bench/, e.g. ufo-lod).
        #[arg(long, default_value = "default")]
        plan: String,
        /// Check the plan (its configurations, scenes and profiles) and
        /// stop, without measuring.
        #[arg(long)]
        check: bool,
        /// Output folder.
        #[arg(long, default_value = "bench-out")]
        out: PathBuf,
        /// Override the plan's measured frames per configuration.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100_000))]
        frames: Option<u32>,
        /// Override the plan's frames in flight (1 to 3) for every
        /// configuration that does not set its own.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=3))]
        frames_in_flight: Option<u32>,
    },
    /// Measure candidate optimization stacks and pick the one that meets a
    /// frame budget with the least error (or the fastest under an error cap);
    /// writes it as a config file for `run --config`.
    Tune {
        /// Frame budget in ms (frame time p95 must fit; (0, 1e6]).
        #[arg(long, value_parser = vergence::cli::parse_positive)]
        budget_ms: f64,
        /// Largest acceptable FLIP mean; then the fastest stack under it wins.
        #[arg(long, value_parser = vergence::cli::parse_non_negative)]
        max_flip: Option<f64>,
        /// Largest acceptable temporal error (flicker: per-pixel
        /// frame-to-frame change beyond the reference's along a slowly
        /// turning view), or `baseline`: what the baseline candidate
        /// measured; candidates above it, or unmeasured, are left out.
        #[arg(long, value_parser = vergence::bench::tune::parse_flicker_cap)]
        max_flicker: Option<vergence::bench::tune::FlickerCap>,
        /// Render the reference at this many times the eye size per axis
        /// (1 to 4) and reduce it by a box filter in linear light: a
        /// converged reference, against which the baseline's aliasing
        /// counts too.
        #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=4))]
        reference_supersample: u32,
        /// factory[:N], cad:N, a .gltf/.glb file or a scene manifest (.toml).
        #[arg(long, default_value = "factory")]
        scene: String,
        /// HMD profile.
        #[arg(long, default_value = DEFAULT_PROFILE)]
        hmd: String,
        /// Resolution scale relative to the profile.
        #[arg(long, default_value_t = 1.0)]
        scale: f64,
        /// Measured frames per candidate.
        #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u32).range(1..=100_000))]
        frames: u32,
        /// Head paths to measure along, as seeds (e.g. `1,5,9`; at most 8):
        /// a candidate qualifies only if it meets the budget and caps on
        /// every one. Default: one path, seed 1.
        #[arg(long, value_delimiter = ',')]
        path_seeds: Vec<u64>,
        /// Judge the candidates where the eye looks: the caps and the
        /// ranking use the foveated FLIP and flicker.
        #[arg(long)]
        foveated: bool,
        /// Where the eye looks while measuring: `centre` or `saccades`
        /// (scripted fixations and saccades the inset follows).
        #[arg(long, value_enum, default_value = "centre")]
        gaze: vergence::bench::plan::GazeKind,
        /// The eye tracker's latency with `--gaze saccades`, ms (0 to 500).
        #[arg(long, default_value_t = 0.0)]
        gaze_latency_ms: f64,
        /// Where to write the chosen configuration.
        #[arg(long, default_value = "vergence-tuned.toml")]
        out: PathBuf,
    },
    /// Compare two images: FLIP mean/p99, PSNR, SSIM, and a FLIP heat map.
    Compare {
        /// Reference image (PNG or JPEG).
        reference: PathBuf,
        /// Test image, same size.
        test: PathBuf,
        /// Pixels per degree for FLIP (default: a desktop monitor's 67; [0.01, 1000)).
        #[arg(long, value_parser = vergence::cli::parse_ppd)]
        ppd: Option<f32>,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
        /// Where to write the FLIP heat map (default: next to TEST as
        /// TEST.flip.png).
        #[arg(long)]
        heatmap: Option<PathBuf>,
    },
    /// Print a scene's nodes, meshes, triangles, materials, textures, instances and bounds.
    Inspect {
        /// factory[:N], cad:N, a .gltf/.glb file or a scene manifest (.toml).
        scene: String,
        /// For a point cloud: build its octree and write it next to the
        /// file (`FILE.octree`), which later loads read instead of
        /// building.
        #[arg(long)]
        write_octree: bool,
    },
    /// Print an HMD profile's lens sampling density: eye-image pixels per
    /// panel pixel per ring of the lens, over-rendering, the eye-image
    /// share no panel pixel reads, and the RDM radius that masks only
    /// over-rendered pixels.
    Lens {
        /// An HMD profile with [views.lens] tables (vive, rift-dk1) or a path.
        #[arg(long, default_value = "vive")]
        hmd: String,
        /// Also write the figures as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Laser-scan a scene into a point cloud (test data): scanner stations
    /// on a grid over the floor cast rays in every direction through the
    /// scene; hits become points with range noise, the material's colour
    /// and an intensity; written as LAS 1.4, LAZ when OUT ends in .laz, or
    /// E57 when it ends in .e57.
    Scan {
        /// The scene to scan (as for render).
        #[arg(long, default_value = "factory:20000")]
        scene: String,
        /// Scanner stations.
        #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=10_000))]
        stations: u32,
        /// Rays per station.
        #[arg(long, default_value_t = 250_000, value_parser = clap::value_parser!(u32).range(1..=100_000_000))]
        rays: u32,
        /// Range noise (one standard deviation), metres.
        #[arg(long, default_value_t = 0.003, value_parser = vergence::cli::parse_scan_noise)]
        noise: f64,
        /// Seed of the noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The LAS, LAZ or E57 file to write.
        #[arg(long)]
        out: PathBuf,
    },
}

/// `inspect --write-octree`'s outcome: an error unless the octree cache
/// was written.
fn octree_written(spec: &str, s: &vergence::scene::Scene) -> anyhow::Result<()> {
    use vergence::scene::octree_cache::CacheUse;
    let cache = s
        .points
        .as_ref()
        .and_then(|c| c.octree.as_ref())
        .and_then(|t| t.cache.as_ref());
    match cache {
        Some(CacheUse::Written(path)) => {
            println!("wrote the octree cache {}", path.display());
            Ok(())
        }
        Some(CacheUse::NotUsed(why)) => anyhow::bail!("--write-octree: {why}"),
        _ => anyhow::bail!("--write-octree: {spec} has no point cloud"),
    }
}

/// The most rays one `scan` casts (stations × rays per station): each hit
/// is a point of 17 bytes in memory, so this bounds a scan near 1.7 GB.
const MAX_SCAN_RAYS: u64 = 100_000_000;

#[derive(clap::Args)]
struct RenderArgs {
    /// factory[:N], cad:N, a .gltf/.glb file or a scene manifest (.toml).
    #[arg(long, default_value = "factory")]
    scene: String,
    /// HMD profile: a name in manifests/hmd/ (monado-sim, valve-index, quest-3, pimax-wide, vive, rift-dk1) or a path.
    #[arg(long, default_value = DEFAULT_PROFILE)]
    hmd: String,
    /// Head pose: x,y,z (metres), yaw, pitch, roll (degrees).
    #[arg(long, value_parser = vergence::cli::parse_pose, allow_hyphen_values = true, conflicts_with = "rig")]
    pose: Option<Pose>,
    /// Render exactly the views in a rig.json (as `run --capture` writes it)
    /// instead of the profile's eyes at --pose.
    #[arg(long)]
    rig: Option<PathBuf>,
    /// Use a camera of the glTF file as the head pose: its index or name
    /// (eyes and FOVs stay the profile's). Without --pose, --rig or
    /// --camera the head is placed as --frame says.
    #[arg(long, conflicts_with_all = ["pose", "rig"])]
    camera: Option<String>,
    /// Without a pose: where the head starts. outside: outside the
    /// scene's bounds with the whole scene in view (any size, any offset
    /// from the origin); inside: standing on the floor at the bounds'
    /// centre; spawn: the scene's own spawn, else its first camera.
    #[arg(long = "frame", value_enum, default_value_t = Framing::Outside)]
    framing: Framing,
    #[command(flatten)]
    frame: FrameOpts,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
    /// Frames to render; above 1, stats.json holds medians over the frames
    /// (after 2 warm-up frames) and the clear / full-screen-triangle floors.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: u32,
    /// Also write what the HMD's panels show: `distorted` draws barrel
    /// distortion and chromatic aberration of the eye images through the
    /// profile's [views.lens] (left_distorted.png, right_distorted.png;
    /// with --frames N its GPU time is measured N times).
    #[arg(long, value_enum)]
    preview: Option<PreviewMode>,
    /// How the distortion preview is drawn: per fragment, a grid warped in
    /// the vertex shader, or a pre-baked mesh.
    #[arg(long, value_enum, default_value_t = DistortionMethod::Mesh, requires = "preview")]
    distortion: DistortionMethod,
    /// With --opt timewarp=K: the head turns at this many degrees per
    /// second (about the vertical axis, at the profile's refresh rate)
    /// while the warped frames are measured against rendered ones.
    #[arg(long, default_value_t = 90.0, allow_hyphen_values = true,
          value_parser = vergence::cli::parse_head_turn)]
    head_turn: f64,
}

/// What `render --preview` shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum PreviewMode {
    /// The panel images through the profile's lens.
    Distorted,
}

/// How frames are rendered, shared by `render` and `run`.
#[derive(clap::Args)]
struct FrameOpts {
    /// Stereo mode.
    #[arg(long, value_enum, default_value_t = StereoMode::Multiview)]
    stereo: StereoMode,
    /// MSAA samples: 1 or 4.
    #[arg(long, default_value_t = 4)]
    msaa: u32,
    /// Frames the CPU prepares while the GPU renders earlier ones (1 to 3;
    /// 1 waits for each frame before starting the next).
    #[arg(long, default_value_t = 2)]
    frames_in_flight: u32,
    /// Per-eye width in pixels, 1 to 16384 (default: the runtime's
    /// recommended size, else the profile's).
    #[arg(long, requires = "height",
          value_parser = clap::value_parser!(u32).range(1..=vergence::cli::MAX_EYE_PIXELS as i64))]
    width: Option<u32>,
    /// Per-eye height in pixels, 1 to 16384.
    #[arg(long, requires = "width",
          value_parser = clap::value_parser!(u32).range(1..=vergence::cli::MAX_EYE_PIXELS as i64))]
    height: Option<u32>,
    /// Comma-separated optimizations (`--help` lists them by technique).
    #[arg(long, default_value = "", long_help = vergence::config::options::help(&cull_names()))]
    opt: String,
    /// A config file (as `vergence tune` writes it) whose `opt` list is
    /// applied before --opt.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Record the forward draws into N secondary command buffers on N
    /// threads (1 to 64), executed in order by the frame's primary one
    /// (default: straight into the primary on one thread).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=vergence::config::MAX_RECORD_THREADS as i64))]
    record_threads: Option<u32>,
    /// How each draw's material and instance start reach the shaders: push
    /// constants, a uniform buffer at a dynamic offset, or a storage buffer
    /// indexed by the draw's firstInstance.
    #[arg(long, value_enum, default_value_t = PerDraw::Push)]
    per_draw: PerDraw,
    /// A section plane x,y,z,nx,ny,nz: through the point (metres), cutting
    /// away the side the normal points to (clipped in the shaders; culling
    /// skips instances wholly beyond).
    #[arg(long, value_parser = vergence::cli::parse_section, allow_hyphen_values = true)]
    section: Option<[f64; 4]>,
    /// The frame budget of `--opt aq` in milliseconds (default: the
    /// runtime's display period, else the HMD profile's refresh period).
    #[arg(long)]
    budget_ms: Option<f64>,
}

impl FrameOpts {
    /// The renderer configuration these options describe.
    fn config(&self) -> anyhow::Result<RenderConfig> {
        let mut config = RenderConfig {
            frame: vergence::config::FrameConfig {
                stereo: self.stereo,
                msaa: self.msaa,
                section: self.section,
                ..Default::default()
            },
            effort: vergence::config::EffortConfig {
                budget_ms: self.budget_ms,
                ..Default::default()
            },
            submission: vergence::config::SubmissionConfig {
                frames_in_flight: self.frames_in_flight,
                record_threads: self.record_threads,
                per_draw: self.per_draw,
            },
            ..RenderConfig::default()
        };
        if let Some(path) = &self.config {
            let file = vergence::config::ConfigFile::load(path)?;
            config.apply_opts(&file.opt, &cull_names())?;
        }
        config.apply_opts(&self.opt, &cull_names())?;
        Ok(config)
    }

    /// The per-eye size override.
    fn size(&self) -> Option<(u32, u32)> {
        self.width.zip(self.height)
    }
}

#[derive(clap::Args)]
struct RunCli {
    /// factory[:N], cad:N, a .gltf/.glb file or a scene manifest (.toml).
    #[arg(long, default_value = "factory")]
    scene: String,
    /// HMD profile used when running headless.
    #[arg(long, default_value = DEFAULT_PROFILE)]
    hmd_fallback: String,
    /// auto: OpenXR if a runtime and headset are there, else headless;
    /// openxr: OpenXR or an error; headless: no OpenXR.
    #[arg(long, value_enum, default_value_t = XrMode::Auto)]
    xr: XrMode,
    /// Stop after N submitted frames (1 to 1,000,000,000).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=vergence::cli::MAX_RUN_FRAMES))]
    frames: Option<u64>,
    /// Stop after T seconds ((0, 1e6]).
    #[arg(long, value_parser = vergence::cli::parse_seconds)]
    seconds: Option<f64>,
    /// Write per-frame statistics as JSON.
    #[arg(long)]
    stats_out: Option<PathBuf>,
    #[command(flatten)]
    frame: FrameOpts,
    /// Write the last frame (frame N of --frames N, or the frame a
    /// --rehearse script ends on) as DIR/left.png, DIR/right.png and
    /// DIR/rig.json (the views it was rendered with).
    #[arg(long)]
    capture: Option<PathBuf>,
    /// When the OpenXR runtime goes away mid-run, retry every second until
    /// it is back (instead of exiting with an error).
    #[arg(long)]
    reconnect: bool,
    /// Where the tracking origin (the floor under the user) starts:
    /// x,y,z in metres and the yaw in degrees (0 looks down -Z). Default:
    /// as --frame says.
    #[arg(long, value_parser = parse_spawn, allow_hyphen_values = true, conflicts_with = "camera")]
    spawn: Option<Pose>,
    /// Without a pose: where the head starts. outside: outside the
    /// scene's bounds with the whole scene in view (any size, any offset
    /// from the origin); inside: standing on the floor at the bounds'
    /// centre; spawn: the scene's own spawn, else its first camera.
    #[arg(long = "frame", value_enum, default_value_t = Framing::Outside)]
    framing: Framing,
    /// Start at a camera of the glTF file (its index or name): the eyes at
    /// the camera, facing its heading. The file's cameras are viewpoints
    /// either way.
    #[arg(long)]
    camera: Option<String>,
    /// A further viewpoint, x,y,z,yaw, or a file of `[[viewpoint]]`
    /// entries (as F8 in `view` appends to vergence-viewpoints.toml)
    /// (repeatable): the right stick click cycles spawn → viewpoints → the
    /// scene's cameras → spawn.
    #[arg(long, allow_hyphen_values = true)]
    viewpoint: Vec<String>,
    /// Smooth-move speed of the left stick, m/s.
    #[arg(long, default_value_t = 2.0)]
    move_speed: f64,
    /// Snap-turn angle of the right stick, degrees.
    #[arg(long, default_value_t = 30.0)]
    snap_turn: f64,
    /// Turn smoothly at this rate (degrees/s) instead of snap turns.
    #[arg(long)]
    smooth_turn: Option<f64>,
    /// Smooth move goes where the head looks (head) or the left hand points (hand).
    #[arg(long, default_value = "head", value_parser = parse_move_direction)]
    move_direction: MoveDirection,
    /// A desktop window showing the submitted eye images: left, right,
    /// both, cropped (the left eye, hidden area masked) or off. Default:
    /// left when a display is there. Keys in it switch optimizations (H
    /// lists them); closing it ends the run.
    #[arg(long, value_enum)]
    mirror: Option<vergence::targets::mirror::MirrorMode>,
    /// Write the mirror window's last presented image as PNG at the end.
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Where F2 in the window writes the current --opt list as a config
    /// file for --config (default: vergence-live.toml).
    #[arg(long)]
    save_config: Option<PathBuf>,
    /// The overlay in the mirror window (frame-time graph against the
    /// budget, GPU ms per pass, what was drawn, the --opt list); F3 shows
    /// and hides it. Only the window shows it, never the headset.
    #[arg(long, value_enum, default_value_t = vergence::targets::hud::OverlayMode::On)]
    overlay: vergence::targets::hud::OverlayMode,
    /// The in-headset panel (OpenXR): the menu button opens it in front of
    /// you; point at a button and pull the trigger to pick a tool, switch
    /// an optimization or close it. `off`: the menu button cycles the
    /// tools instead.
    #[arg(long, value_enum, default_value_t = vergence::targets::panel::PanelMode::On)]
    panel: vergence::targets::panel::PanelMode,
    /// A kiosk file (see manifests/kiosk/demo.toml): the scenes on offer
    /// (N in the mirror window moves to the next), their spawns and
    /// viewpoints, the optimizations and allowed toggles, reconnecting,
    /// returning to the spawn when nobody moves, a rotating log file.
    #[arg(long, conflicts_with_all = ["scene", "spawn", "viewpoint"])]
    kiosk: Option<PathBuf>,
    /// Let the OpenXR runtime print its own messages to this terminal
    /// (Monado prints several dozen lines per session; by default they are
    /// kept out, as OXR_NO_PRINTING_STDERR=1 does; setting that variable
    /// yourself overrides both).
    #[arg(long)]
    runtime_log: bool,
    /// Rehearse a visit without a headset: play this script of timed head
    /// and controller states (TOML, see manifests/rehearse/visit.toml)
    /// into Monado's remote driver from the session's first focus, and end
    /// the run when it ends. Needs --xr openxr with monado-service started
    /// with P_OVERRIDE_ACTIVE_CONFIG=remote.
    #[arg(long)]
    rehearse: Option<PathBuf>,
    /// Drive Monado's remote driver's controllers from the mirror window's
    /// keys (W A S D walk, J L turn, I aims a teleport, Space is the
    /// trigger, G the grip, M the menu, C the stick click, the arrow keys
    /// turn the right hand). Needs --xr openxr, a mirror window and
    /// monado-service started with P_OVERRIDE_ACTIVE_CONFIG=remote.
    #[arg(long, conflicts_with = "rehearse")]
    desk_controllers: bool,
}

#[derive(clap::Args)]
struct ViewCli {
    /// factory[:N], cad:N, a .gltf/.glb file or a scene manifest (.toml).
    #[arg(long, default_value = "factory")]
    scene: String,
    /// HMD profile whose stereo rig is rendered.
    #[arg(long, default_value = DEFAULT_PROFILE)]
    hmd: String,
    /// Where the camera starts: x,y,z (metres), yaw, pitch, roll (degrees).
    #[arg(long, value_parser = vergence::cli::parse_pose, allow_hyphen_values = true)]
    pose: Option<Pose>,
    /// Without a pose: where the head starts. outside: outside the
    /// scene's bounds with the whole scene in view (any size, any offset
    /// from the origin); inside: standing on the floor at the bounds'
    /// centre; spawn: the scene's own spawn, else its first camera.
    #[arg(long = "frame", value_enum, default_value_t = Framing::Outside)]
    framing: Framing,
    /// End after N presented frames (default: until the window closes).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    frames: Option<u64>,
    /// Write the window's last presented image as PNG (after the last of
    /// --frames, or when the window is closed).
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Which eyes the window shows.
    #[arg(long, value_enum, default_value_t = vergence::targets::window::Eyes::Both)]
    eyes: vergence::targets::window::Eyes,
    /// Where F2 writes the current --opt list as a config file for
    /// --config (default: vergence-live.toml).
    #[arg(long)]
    save_config: Option<PathBuf>,
    /// The overlay in the window (frame-time graph against the budget, GPU
    /// ms per pass, what was drawn, the --opt list); F3 shows and hides it.
    #[arg(long, value_enum, default_value_t = vergence::targets::hud::OverlayMode::On)]
    overlay: vergence::targets::hud::OverlayMode,
    #[command(flatten)]
    frame: FrameOpts,
}

/// A `--viewpoint` value: x,y,z,yaw, or a file of `[[viewpoint]]` entries.
fn viewpoint_arg(v: &str) -> anyhow::Result<Vec<Pose>> {
    match parse_spawn(v) {
        Ok(pose) => Ok(vec![pose]),
        Err(why) if std::path::Path::new(v).exists() || v.ends_with(".toml") => {
            let kept = vergence::targets::keep_pose::read_viewpoints(std::path::Path::new(v))
                .map_err(|e| {
                    anyhow::anyhow!("invalid --viewpoint {v}: {e} (and not x,y,z,yaw: {why})")
                })?;
            Ok(kept.into_iter().map(|(_, pose)| pose).collect())
        }
        Err(why) => anyhow::bail!("invalid --viewpoint {v}: {why}"),
    }
}

fn parse_spawn(s: &str) -> Result<Pose, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{p}' is not a number"))
        })
        .collect::<Result<_, _>>()?;
    if v.len() != 4 {
        return Err(format!("expected 4 numbers x,y,z,yaw, got {}", v.len()));
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err("spawn values must be finite".into());
    }
    Ok(Pose::from_euler_deg(
        DVec3::new(v[0], v[1], v[2]),
        v[3],
        0.0,
        0.0,
    ))
}

fn parse_move_direction(s: &str) -> Result<MoveDirection, String> {
    match s {
        "head" => Ok(MoveDirection::Head),
        "hand" => Ok(MoveDirection::Hand),
        _ => Err(format!("'{s}': expected head or hand")),
    }
}

/// `vergence render`.
fn render_command(a: RenderArgs) -> anyhow::Result<()> {
    let config = a.frame.config()?;
    let rig = a
        .rig
        .as_deref()
        .map(vergence::view::RigFile::load)
        .transpose()?;
    let job = RenderJob {
        scene: a.scene,
        hmd: a.hmd,
        rig,
        pose: a.pose,
        camera: a.camera,
        framing: a.framing,
        config,
        size: a.frame.size(),
        out: a.out,
        frames: a.frames,
        distorted: a.preview.map(|PreviewMode::Distorted| a.distortion),
        head_turn_deg_s: a.head_turn,
    };
    if job.config.simulator.timewarp.is_some() {
        vergence::bench::timewarp::check(&job)?;
    }
    let (mut stats, loaded, mut outputs) = headless::render_to_dir_keeping(&job)?;
    if job.config.simulator.timewarp.is_some() {
        let t = vergence::bench::timewarp::measure(&job, &loaded, &mut outputs)?;
        println!(
            "timewarp={} ({:?}) at {} deg/s: {} frames warped, FLIP mean {:.4} (worst {:.4}), holes {:.3} %, border {:.3} %, warp {:.3} ms GPU vs render {:.3} ms",
            t.k,
            t.variant,
            t.head_turn_deg_s,
            t.frames_warped,
            t.flip_mean,
            t.flip_max,
            100.0 * t.holes_fraction,
            100.0 * t.border_fraction,
            t.warp_gpu_ms.median,
            t.render_gpu_ms.median
        );
        stats.validation_messages += t.validation_messages;
        stats.timewarp = Some(t);
    }
    // The images, rig.json, the timewarp's images and stats.json
    // land together or not at all.
    headless::write_stats(&mut outputs, &job, &stats)?;
    outputs.commit()?;
    println!(
        "rendered {} at {}x{} per eye ({}, {}x MSAA): {} draw calls, {} instances, {} triangles; wrote {}",
        stats.scene.name,
        stats.resolution[0],
        stats.resolution[1],
        stats.config.frame.stereo.name(),
        stats.config.frame.msaa,
        stats.draw_calls,
        stats.instances_drawn,
        stats.triangles,
        job.out.display()
    );
    if stats.frames > 1 {
        let floors = stats.floor_gpu_ms.map(|f| {
            format!(
                ", floors: clear {:.3} ms, full-screen triangle {:.3} ms",
                f.clear.median, f.fullscreen_triangle.median
            )
        });
        println!(
            "{} frames: GPU {:.3} ms median ({:.3} p95), CPU batch+record+submit {:.3} ms median{}",
            stats.frames,
            stats.gpu_frame_ms.median,
            stats.gpu_frame_ms.p95,
            stats.cpu_frame_ms.median,
            floors.unwrap_or_default()
        );
    }
    if stats.validation_messages > 0 {
        anyhow::bail!(
            "{} Vulkan validation messages (see log)",
            stats.validation_messages
        );
    }
    Ok(())
}

/// `vergence run`.
fn run_command(a: RunCli) -> anyhow::Result<()> {
    let mut config = a.frame.config()?;
    config.refuse_timewarp("run")?;
    let kiosk = a
        .kiosk
        .as_deref()
        .map(vergence::targets::kiosk::Kiosk::load)
        .transpose()?;
    let mut viewpoints = Vec::new();
    for v in &a.viewpoint {
        viewpoints.extend(viewpoint_arg(v)?);
    }
    let (mut scene, mut spawn) = (a.scene, a.spawn);
    let (mut reconnect, mut mirror) = (a.reconnect, a.mirror);
    if let (Some(k), Some(path)) = (&kiosk, a.kiosk.as_deref()) {
        k.check_scenes(path)?;
    }
    if let Some(k) = &kiosk {
        config.apply_opts(&k.opt, &cull_names())?;
        config.validate()?;
        let first = &k.scenes[0];
        scene = first.scene.clone();
        spawn = first.spawn;
        viewpoints = first.viewpoints.clone();
        reconnect |= k.reconnect;
        mirror = mirror.or(k.mirror);
        if let Some(log) = &k.log {
            vergence::targets::kiosk::start_log(log)?;
        }
    }
    if config.effort.rdm_auto
        || config.effort.foveation == vergence::view::foveation::Level::Lens(0)
    {
        // Only the headless fallback profile has a lens; a
        // runtime's views carry none.
        let profile = (a.xr == XrMode::Headless)
            .then(|| HmdProfile::load(&a.hmd_fallback))
            .transpose()?;
        config.resolve_lens(profile.as_ref())?;
    }
    let rehearse = a
        .rehearse
        .as_deref()
        .map(vergence::targets::rehearse::Script::load)
        .transpose()?
        .map(std::sync::Arc::new);
    let args = RunArgs {
        rehearse,
        desk_controllers: a.desk_controllers,
        scene,
        hmd_fallback: a.hmd_fallback,
        xr: a.xr,
        frames: a.frames,
        seconds: a.seconds,
        stats_out: a.stats_out,
        config,
        size: a.frame.size(),
        capture: a.capture,
        reconnect,
        spawn,
        framing: a.framing,
        viewpoints,
        camera: a.camera,
        interact: Settings {
            move_speed: a.move_speed,
            snap_turn_deg: a.snap_turn,
            smooth_turn_deg_s: a.smooth_turn,
            move_direction: a.move_direction,
            panel: a.panel == vergence::targets::panel::PanelMode::On,
            ..Settings::default()
        },
        mirror,
        screenshot: a.screenshot,
        save_config: a.save_config,
        kiosk,
        overlay: a.overlay == vergence::targets::hud::OverlayMode::On,
    };
    let stats = vergence::targets::run::run(&args)?;
    report_run(&stats)
}

/// The run's one-line summary; an error when validation spoke.
fn report_run(stats: &vergence::targets::session::RunStats) -> anyhow::Result<()> {
    tracing::info!(
        "ran {} {}: {} frames submitted; {}",
        stats.scene.as_ref().map_or("?", |s| s.name.as_str()),
        stats.mode,
        stats.frames_submitted,
        stats.exit
    );
    println!(
        "ran {} {} on {}: {} frames submitted ({} missed display periods), GPU {:.3} ms median, CPU {:.3} ms median; {}",
        stats.scene.as_ref().map_or("?", |s| s.name.as_str()),
        stats.mode,
        stats.system,
        stats.frames_submitted,
        stats.missed_display_periods,
        stats.summary.gpu_frame_ms.median,
        stats.summary.cpu_frame_ms.median,
        stats.exit
    );
    if stats.validation_messages + stats.xr_validation_messages > 0 {
        anyhow::bail!(
            "{} Vulkan and {} OpenXR validation messages (see log)",
            stats.validation_messages,
            stats.xr_validation_messages
        );
    }
    Ok(())
}

/// `vergence view`.
fn view_command(a: ViewCli) -> anyhow::Result<()> {
    a.frame.config()?.refuse_timewarp("view")?;
    let args = vergence::targets::view::ViewArgs {
        scene: a.scene,
        hmd: a.hmd,
        pose: a.pose,
        framing: a.framing,
        config: a.frame.config()?,
        size: a.frame.size(),
        frames: a.frames,
        screenshot: a.screenshot,
        eyes: a.eyes,
        save_config: a.save_config,
        overlay: a.overlay == vergence::targets::hud::OverlayMode::On,
    };
    let s = vergence::targets::view::view(&args)?;
    println!(
        "viewed {} frames at {}x{} per eye in a {}x{} window ({}); opt {}",
        s.frames,
        s.eye_size[0],
        s.eye_size[1],
        s.window_size[0],
        s.window_size[1],
        s.present_mode,
        s.opt
    );
    if s.validation_messages > 0 {
        anyhow::bail!(
            "{} Vulkan validation messages (see log)",
            s.validation_messages
        );
    }
    Ok(())
}

/// `scan`: a simulated scanner over the scene from `stations` stations of
/// `rays` rays each, written as a point file. The output's kind, the
/// rays' total and the output path are checked before scanning; a scan
/// that hits nothing writes nothing.
fn scan(
    scene: &str,
    (stations, rays): (u32, u32),
    noise: f64,
    seed: u64,
    out: &std::path::Path,
) -> anyhow::Result<()> {
    if !vergence::scene::point_files::writes(out) {
        anyhow::bail!(
            "--out {}: a point file ends in .las, .laz or .e57",
            out.display()
        );
    }
    let total = u64::from(stations) * u64::from(rays);
    if total > MAX_SCAN_RAYS {
        anyhow::bail!(
            "--stations {stations} × --rays {rays} = {total} rays, over the {MAX_SCAN_RAYS}-ray limit of one scan"
        );
    }
    let (s, _) = headless::load_scene(scene)?;
    // Refused before scanning: a folder, a device, or the scene itself (a
    // point file read as this scene's input).
    vergence::fsio::prepare_output(out)?;
    let settings = vergence::interact::scan::ScanSettings {
        stations,
        rays_per_station: rays,
        range_noise_m: noise,
        seed,
        ..Default::default()
    };
    let started = std::time::Instant::now();
    let cloud = vergence::interact::scan::scan(&s, &settings);
    let scanned = started.elapsed().as_secs_f64();
    if cloud.is_empty() {
        anyhow::bail!(
            "scan of {}: no ray hit the scene; nothing written to {}",
            s.name,
            out.display()
        );
    }
    vergence::scene::point_files::write_file(out, &cloud)?;
    println!(
        "scanned {} from {stations} stations × {rays} rays: {} points in {scanned:.2} s; wrote {}",
        s.name,
        cloud.len(),
        out.display()
    );
    Ok(())
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(a) => render_command(a)?,
        Command::Run(a) => run_command(a)?,
        Command::View(a) => view_command(a)?,
        Command::CullBench(args) => cull_bench(&args)?,
        Command::RasterFloors(args) => raster_floors(&args)?,
        Command::Bench {
            plan,
            check,
            out,
            frames,
            frames_in_flight,
        } => bench(&plan, &out, frames, frames_in_flight, check)?,
        Command::Tune {
            budget_ms,
            max_flip,
            max_flicker,
            reference_supersample,
            scene,
            hmd,
            scale,
            frames,
            path_seeds,
            foveated,
            gaze,
            gaze_latency_ms,
            out,
        } => tune(
            vergence::bench::tune::TuneGoal {
                budget_ms,
                max_flip,
                max_flicker,
                foveated,
            },
            &scene,
            &hmd,
            (scale, reference_supersample),
            (frames, path_seeds, (gaze, gaze_latency_ms)),
            &out,
        )?,
        Command::Compare {
            reference,
            test,
            ppd,
            json,
            heatmap,
        } => compare(&reference, &test, ppd, json, heatmap)?,
        Command::Inspect {
            scene,
            write_octree,
        } => {
            let (s, ms) = headless::load_scene_with(&scene, write_octree)?;
            inspect(&s, ms);
            if write_octree {
                octree_written(&scene, &s)?;
            }
        }
        Command::Scan {
            scene,
            stations,
            rays,
            noise,
            seed,
            out,
        } => scan(&scene, (stations, rays), noise, seed, &out)?,
        Command::Lens { hmd, json } => {
            let profile = HmdProfile::load(&hmd)?;
            let report = vergence::bench::lens::report(&profile)?;
            print!("{}", report.markdown());
            if let Some(path) = json {
                headless::write_json(&path, &report)?;
            }
        }
    }
    Ok(())
}

fn compare(
    reference: &std::path::Path,
    test: &std::path::Path,
    ppd: Option<f32>,
    json: bool,
    heatmap: Option<PathBuf>,
) -> anyhow::Result<()> {
    use vergence::bench::metrics;
    let open = |p: &std::path::Path| -> anyhow::Result<image::RgbaImage> {
        let bytes = vergence::fsio::read_bounded(p, vergence::fsio::MAX_IMAGE_FILE_BYTES)
            .map_err(|e| anyhow::anyhow!("{}: cannot read image: {e}", p.display()))?;
        vergence::scene::image_decode::decode_rgba8(&bytes)
            .map_err(|e| anyhow::anyhow!("{}: cannot decode image: {e}", p.display()))
    };
    let (a, b) = (open(reference)?, open(test)?);
    // Where the heat map goes, checked before any work: never over an
    // input (the output helper refuses any file this process read).
    let heat = heatmap.unwrap_or_else(|| test.with_extension("flip.png"));
    vergence::fsio::prepare_output(&heat)
        .map_err(|e| anyhow::anyhow!("{e} (the heat map; choose another --heatmap)"))?;
    if a.dimensions() != b.dimensions() {
        anyhow::bail!(
            "{} is {}x{} but {} is {}x{}; compare needs equal sizes",
            reference.display(),
            a.width(),
            a.height(),
            test.display(),
            b.width(),
            b.height()
        );
    }
    let ppd = ppd.unwrap_or(metrics::DESKTOP_PPD);
    let f = metrics::flip(&a, &b, ppd)?;
    let psnr = metrics::psnr(&a, &b);
    let ssim = metrics::ssim(&a, &b);
    headless::save_png(&f.heatmap(), &heat)?;
    if json {
        println!(
            "{}",
            serde_json::json!({
                "flip_mean": f.mean, "flip_p99": f.p99, "flip_max": f.max,
                "psnr_db": if psnr.is_finite() { Some(psnr) } else { None },
                "ssim": ssim, "ppd": ppd, "heatmap": heat,
            })
        );
    } else {
        println!(
            "FLIP mean {:.5}, p99 {:.5}, max {:.5} (ppd {ppd}); PSNR {psnr:.2} dB; SSIM {ssim:.5}; heat map {}",
            f.mean,
            f.p99,
            f.max,
            heat.display()
        );
    }
    Ok(())
}

use vergence::bench::plan::cull_names;

/// Runs a plan with a progress bar; on Ctrl-C writes what finished and
/// fails.
fn run_bench(
    plan: &vergence::bench::plan::Plan,
    out: &std::path::Path,
) -> anyhow::Result<vergence::bench::runner::BenchResults> {
    use std::sync::Arc;
    vergence::quit::install();
    let ctx = Arc::new(vergence::gpu::Context::new_headless(
        vergence::gpu::Validation::from_env(),
    )?);
    let bar = indicatif::ProgressBar::new(0);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {elapsed} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    // Without a terminal (a log, CI) the bar draws nothing: one line per
    // finished step instead.
    let plain = !std::io::IsTerminal::is_terminal(&std::io::stderr());
    let started = std::time::Instant::now();
    let results = vergence::bench::runner::run_plan(&ctx, plan, out, &mut |done, total, label| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        bar.set_message(label.to_string());
        if plain {
            let s = started.elapsed().as_secs();
            eprintln!("bench: {done}/{total} {label} ({s} s)");
        }
    });
    bar.finish_and_clear();
    let results = results?;
    vergence::bench::report::write_all(out, &results)?;
    let finished: usize = results.groups.iter().map(|g| g.results.len()).sum();
    if let Some(e) = &results.error {
        anyhow::bail!(
            "{e} (wrote the {finished} finished configurations to {})",
            out.display()
        );
    }
    if !results.complete {
        anyhow::bail!(
            "interrupted: wrote the {} finished configurations to {}",
            results
                .groups
                .iter()
                .map(|g| g.results.len())
                .sum::<usize>(),
            out.display()
        );
    }
    if results.validation_messages > 0 {
        anyhow::bail!(
            "{} Vulkan validation messages (see log)",
            results.validation_messages
        );
    }
    Ok(results)
}

fn bench(
    plan: &str,
    out: &std::path::Path,
    frames: Option<u32>,
    frames_in_flight: Option<u32>,
    check: bool,
) -> anyhow::Result<()> {
    let mut plan = vergence::bench::plan::Plan::resolve(plan)?;
    if let Some(n) = frames_in_flight {
        plan.frames_in_flight = n;
    }
    if let Some(n) = frames {
        plan.frames = n;
        plan.error_frames = plan.error_frames.min(n);
    }
    plan.check_inputs()
        .map_err(|m| anyhow::anyhow!("invalid --plan: {m}"))?;
    if check {
        println!(
            "plan {}: {} scenes, {} profiles, {} configurations: ok",
            plan.name,
            plan.scenes.len(),
            plan.hmds.len(),
            plan.configs.len()
        );
        return Ok(());
    }
    if out.is_file() {
        anyhow::bail!("invalid --out: {} is a file, not a folder", out.display());
    }
    let results = run_bench(&plan, out)?;
    for g in &results.groups {
        println!("{}", vergence::bench::tables::group_title(g));
        for r in &g.results {
            println!(
                "  {:28} GPU {:8.3} ms{}{}  FLIP {}",
                r.name,
                r.gpu_frame_ms.p50,
                r.gpu_speedup
                    .map(|s| format!(" ({s:.2}x)"))
                    .unwrap_or_default(),
                r.gpu_speedup_range
                    .map(|[lo, hi]| format!(" [{lo:.2}-{hi:.2}x over {} runs]", r.runs.len()))
                    .unwrap_or_default(),
                r.error
                    .map_or("ref".into(), |e| format!("{:.4}", e.flip_mean))
            );
        }
    }
    println!(
        "wrote {}/report.md, report.html, results.json, results.csv",
        out.display()
    );
    Ok(())
}

fn tune(
    goal: vergence::bench::tune::TuneGoal,
    scene: &str,
    hmd: &str,
    scale: (f64, u32),
    (frames, path_seeds, gaze): (u32, Vec<u64>, (vergence::bench::plan::GazeKind, f64)),
    out: &std::path::Path,
) -> anyhow::Result<()> {
    use vergence::bench::tune;
    let mut plan = tune::plan(scene, hmd, scale, frames, Some(goal.budget_ms));
    plan.path_seeds = path_seeds;
    (plan.gaze, plan.gaze_latency_ms) = gaze;
    plan.validate()
        .map_err(|m| anyhow::anyhow!("invalid tune settings: {m}"))?;
    plan.check_inputs()
        .map_err(|m| anyhow::anyhow!("invalid tune settings: {m}"))?;
    let dir = out.with_extension("bench");
    // Every output name up front, before anything is measured.
    if dir == out {
        anyhow::bail!(
            "invalid --out: {} would be both the config file and its measurement folder {}; use another extension (e.g. .toml)",
            out.display(),
            dir.display()
        );
    }
    vergence::fsio::prepare_output(out)?;
    if vergence::fsio::same_file(out, std::path::Path::new(scene)) {
        anyhow::bail!(
            "invalid --out: {} is the scene being tuned; vergence never writes over an input",
            out.display()
        );
    }
    if dir.is_file() {
        anyhow::bail!(
            "invalid --out: the measurement folder {} of {} is a file",
            dir.display(),
            out.display()
        );
    }
    let mut results = run_bench(&plan, &dir)?;
    let choice = tune::choose(&results, &goal)?;
    for line in &choice.why {
        println!("  {line}");
    }
    println!(
        "chose {} (`{}`): {}",
        choice.chosen.name,
        choice.chosen.opt,
        if goal.max_flip.is_some() {
            "the fastest within the budget and the error cap"
        } else {
            "the least FLIP error within the budget"
        }
    );
    vergence::fsio::write_bytes(out, tune::config_file(&choice, &goal, &results).as_bytes())?;
    // The reports name the choice, its limits and every candidate's fit.
    results.choice = Some(tune::summary(&choice, &goal));
    vergence::bench::report::write_all(&dir, &results)?;
    println!(
        "wrote {} (use: vergence run --config {}); measurements in {}",
        out.display(),
        out.display(),
        dir.display()
    );
    Ok(())
}

fn raster_floors(args: &vergence::bench::raster_floors::RasterFloorsArgs) -> anyhow::Result<()> {
    let ctx = vergence::gpu::Context::new_headless(vergence::gpu::Validation::from_env())?;
    let report = vergence::bench::raster_floors::run(&ctx, args)?;
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        print!("{}", report.to_table());
    }
    Ok(())
}

fn cull_bench(args: &vergence::bench::cull::CullBenchArgs) -> anyhow::Result<()> {
    let profile = HmdProfile::load(args.hmd.as_deref().unwrap_or(DEFAULT_PROFILE))?;
    let scene = vergence::scene::factory::generate(args.instances, args.seed)?;
    let bounds = scene.world_aabbs();
    drop(scene);
    let report = vergence::bench::cull::run(args, &bounds, &profile.eyes())?;
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        print!("{}", report.to_table());
    }
    Ok(())
}

/// Writes `text` to stdout; a reader that stopped reading (`| head`) ends
/// the output quietly instead of as an error.
fn print_to_stdout(text: &str) {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    let _ = out.write_all(text.as_bytes()).and_then(|()| out.flush());
}

/// `inspect`'s lines for a point cloud: its size and its octree (read
/// from the cache, or built and whether the cache was written).
fn inspect_points(o: &mut String, cloud: &vergence::scene::points::PointCloud) {
    use std::fmt::Write as _;
    use vergence::scene::octree::CacheUse;
    let _ = writeln!(o, "points      {}", cloud.len());
    let Some(t) = &cloud.octree else {
        return;
    };
    if let Some(CacheUse::Read(p)) = &t.cache {
        let _ = writeln!(
            o,
            "octree      {} nodes, read from {} in {:.1} ms",
            t.nodes.len(),
            p.display(),
            t.build_ms
        );
        return;
    }
    let _ = writeln!(
        o,
        "octree      {} nodes, built in {:.1} ms ({:.1} M points/s)",
        t.nodes.len(),
        t.build_ms,
        cloud.len() as f64 / (t.build_ms.max(1e-6) * 1e3)
    );
    match &t.cache {
        Some(CacheUse::Written(p)) => {
            let _ = writeln!(o, "octree cache written to {}", p.display());
        }
        Some(CacheUse::NotUsed(why)) => {
            let _ = writeln!(o, "octree cache not used: {why}");
        }
        _ => {}
    }
}

/// `inspect`'s lines for the first 20 meshes and materials.
fn inspect_meshes(o: &mut String, s: &Scene) {
    use std::fmt::Write as _;
    for (i, m) in s.meshes.iter().enumerate().take(20) {
        let tris: usize = m
            .primitives
            .iter()
            .map(|&p| s.primitives[p as usize].triangles())
            .sum();
        let _ = writeln!(
            o,
            "  mesh {i:3} {:24} {} primitives, {tris} triangles",
            vergence::error::one_safe_line(&m.name),
            m.primitives.len()
        );
    }
    if s.meshes.len() > 20 {
        let _ = writeln!(o, "  ... {} more meshes", s.meshes.len() - 20);
    }
    for (i, m) in s.materials.iter().enumerate().take(20) {
        let _ = writeln!(
            o,
            "  material {i:3} {:24} {:?}{}{}",
            vergence::error::one_safe_line(&m.name),
            m.alpha_mode,
            if m.double_sided { " double-sided" } else { "" },
            if m.unlit { " unlit" } else { "" }
        );
    }
}

fn inspect(s: &Scene, load_ms: f64) {
    use std::fmt::Write as _;
    let mut o = String::new();
    let c = headless::SceneCounts::of(s);
    let (lo, hi) = s.bounds();
    let _ = writeln!(o, "scene       {}", c.name);
    let _ = writeln!(o, "loaded in   {load_ms:.1} ms");
    let _ = writeln!(o, "nodes       {}", c.nodes);
    let _ = writeln!(o, "meshes      {} ({} primitives)", c.meshes, c.primitives);
    let _ = writeln!(
        o,
        "triangles   {} (instanced), {} (unique)",
        c.triangles,
        s.primitives.iter().map(|p| p.triangles()).sum::<usize>()
    );
    let _ = writeln!(o, "materials   {}", c.materials);
    let _ = writeln!(o, "textures    {}", c.textures);
    let _ = writeln!(o, "instances   {}", c.instances);
    let _ = writeln!(
        o,
        "bounds      min [{:.3}, {:.3}, {:.3}] max [{:.3}, {:.3}, {:.3}]",
        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
    );
    let _ = writeln!(o, "features    {:?}", c.features);
    if let Some(cloud) = &s.points {
        inspect_points(&mut o, cloud);
    }
    let support = |e: &str| match vergence::scene::gltf_load::support(e) {
        Some((level, note)) => format!("{level:?}: {note}"),
        None => "not supported (ignored when only used)".to_string(),
    };
    for (label, list) in [
        ("extensions used", &s.extensions_used),
        ("extensions required", &s.extensions_required),
    ] {
        let _ = writeln!(o, "{label:<11} {}", list.len());
        for e in list {
            let _ = writeln!(o, "  {e:32} {}", support(e));
        }
    }
    if s.scene_names.len() > 1 {
        let _ = writeln!(o, "scenes      {}", s.scene_names.join(", "));
    }
    for c in &s.cameras {
        let p = c.pose.position;
        let _ = writeln!(
            o,
            "  camera {:3} {:24} at [{:.3}, {:.3}, {:.3}]{}",
            c.index,
            vergence::error::one_safe_line(&c.name),
            p.x,
            p.y,
            p.z,
            c.yfov.map_or(" orthographic".into(), |f| format!(
                ", yfov {:.1}°",
                f.to_degrees()
            ))
        );
    }
    if let Some(sun) = &s.sun {
        let _ = writeln!(
            o,
            "sun         towards [{:.3}, {:.3}, {:.3}], colour {:?}",
            sun.direction.x, sun.direction.y, sun.direction.z, sun.color
        );
    }
    inspect_meshes(&mut o, s);
    // Names come from the file: no control character reaches the terminal.
    let safe: String = o
        .lines()
        .map(|l| vergence::error::one_safe_line(l) + "\n")
        .collect();
    print_to_stdout(&safe);
}

/// Keeps an OpenXR runtime's own printing (Monado's: instance, devices,
/// Vulkan extensions, several dozen lines per session) out of `run`'s
/// terminal unless `--runtime-log` asks for it or the variable is set.
/// Called before any thread starts, as setting the environment must be.
fn quiet_runtime(cli: &Cli) {
    const QUIET: &str = "OXR_NO_PRINTING_STDERR";
    if let Command::Run(a) = &cli.command {
        if !a.runtime_log && std::env::var_os(QUIET).is_none() {
            std::env::set_var(QUIET, "1");
        }
    }
}

fn main() -> ExitCode {
    use tracing_subscriber::layer::SubscriberExt as _;
    use tracing_subscriber::util::SubscriberInitExt as _;
    use tracing_subscriber::Layer as _;
    let stderr = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "warn,winit=error".into()),
        );
    // `run --kiosk` with a [log]: vergence's own events at info and above
    // also go to the rotating log file (nothing is formatted without one).
    let kiosk_log = tracing_subscriber::fmt::layer()
        .with_ansi(false)
        .with_writer(vergence::targets::kiosk::LogWriter::default)
        .with_filter(tracing_subscriber::filter::filter_fn(|m| {
            vergence::targets::kiosk::logging()
                && *m.level() <= tracing::Level::INFO
                && m.target().starts_with("vergence")
        }));
    tracing_subscriber::registry()
        .with(stderr)
        .with(kiosk_log)
        .init();
    let cli = Cli::parse();
    quiet_runtime(&cli);
    match run(cli).context("vergence") {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {:#}", e.root_cause_chain());
            ExitCode::FAILURE
        }
    }
}

trait RootChain {
    fn root_cause_chain(&self) -> String;
}

impl RootChain for anyhow::Error {
    /// The causes after the top-level context, joined with ": ", each
    /// left out when the one before already ends with its text (an error
    /// whose message includes its source: "Is a directory (os error 21)"
    /// once, not twice). Line breaks become spaces: one error, one line;
    /// other control characters (from a file's text or a path) are
    /// escaped, so an error cannot drive the terminal. I/O errors read as
    /// [`vergence::error::plain`] words, without error numbers.
    fn root_cause_chain(&self) -> String {
        let mut parts: Vec<String> = Vec::new();
        for e in self.chain().skip(1) {
            let raw = e.to_string();
            let text = match e.downcast_ref::<std::io::Error>() {
                Some(io) => vergence::error::plain(io),
                None => raw.clone(),
            };
            if parts
                .last()
                .is_some_and(|p| p.ends_with(&raw) || p.ends_with(&text))
            {
                continue;
            }
            parts.push(text);
        }
        let line = vergence::error::without_os_error_numbers(&parts.join(": "));
        vergence::error::one_safe_line(&line)
    }
}
