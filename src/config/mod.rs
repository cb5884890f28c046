//! `RenderConfig`: one field per optimization, parsed from the CLI (`--stereo`,
//! `--msaa`, `--opt LIST`) and from config files. The `--opt` names are
//! declared as data in [`options`].

pub mod options;

use crate::cull::Strategy;
use crate::error::{Error, Result};

/// How the two eyes are rendered.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum StereoMode {
    /// One render pass with view mask 0b11 over 2-layer images (VK_KHR_multiview).
    #[default]
    Multiview,
    /// One render pass per eye: the naive baseline.
    TwoPass,
}

impl StereoMode {
    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            StereoMode::Multiview => "multiview",
            StereoMode::TwoPass => "two-pass",
        }
    }
}

/// Which instances a frame draws: all of them, or those a culling
/// strategy keeps. Written as its `--opt` name (`none` or the strategy's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Culling {
    /// Every instance (`none`).
    #[default]
    None,
    /// The instances the strategy keeps.
    Strategy(Strategy),
}

impl Culling {
    /// The `--opt` name.
    pub fn name(&self) -> &'static str {
        match self {
            Culling::None => "none",
            Culling::Strategy(s) => s.name(),
        }
    }

    /// The strategy (None for `none`).
    pub fn strategy(&self) -> Option<Strategy> {
        match self {
            Culling::None => None,
            Culling::Strategy(s) => Some(*s),
        }
    }
}

impl std::fmt::Display for Culling {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Culling {
    type Err = crate::cull::CullError;
    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        match s.trim() {
            "none" => Ok(Culling::None),
            other => other.parse().map(Culling::Strategy),
        }
    }
}

impl serde::Serialize for Culling {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// Everything that changes how a frame is rendered, grouped by the part
/// of the renderer that reads it; each group's keys stay at the top level
/// of the JSON reports.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct RenderConfig {
    /// The frame: stereo mode, samples, near plane and section plane.
    #[serde(flatten)]
    pub frame: FrameConfig,
    /// Culling: the strategy, draw distance, GPU culling, occlusion and level of detail.
    #[serde(flatten)]
    pub culling: CullingConfig,
    /// Where the frame spends less: the masks, foveation, the far field, the inset, lens-matched shading, the sky after the resolve and adaptive quality.
    #[serde(flatten)]
    pub effort: EffortConfig,
    /// Point clouds: the budget, the point size, the pipeline and eye-dome lighting.
    #[serde(flatten)]
    pub points: PointsConfig,
    /// Submission: frames in flight, recording threads and per-draw data.
    #[serde(flatten)]
    pub submission: SubmissionConfig,
    /// The simulator: timewarp measured against rendered frames.
    #[serde(flatten)]
    pub simulator: SimulatorConfig,
}

/// The frame: stereo mode, samples, near plane and section plane.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FrameConfig {
    /// Stereo mode.
    pub stereo: StereoMode,
    /// MSAA samples (1 or 4).
    pub msaa: u32,
    /// Near plane in metres (reverse-Z, infinite far plane).
    pub near: f64,
    /// A section plane `n · x + d = 0` as (n.x, n.y, n.z, d) with a unit
    /// normal `n` (`--section`): geometry on its positive side is clipped
    /// by the scene shaders and culling skips instances wholly beyond it.
    /// In a headset the section tool replaces it at run time.
    pub section: Option<[f64; 4]>,
}

impl Default for FrameConfig {
    fn default() -> Self {
        FrameConfig {
            stereo: StereoMode::Multiview,
            msaa: 4,
            near: 0.05,
            section: None,
        }
    }
}

/// Culling: the strategy, draw distance, GPU culling, occlusion and level of detail.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CullingConfig {
    /// Culling (`none` draws every instance).
    pub cull: Culling,
    /// Draw distance in metres for distance culling (None: unlimited).
    pub draw_distance: Option<f64>,
    /// GPU-driven culling (`gpu-cull`): a compute pass tests every instance
    /// against the strategy's volumes and writes the visible lists and the
    /// indirect draws; the CPU records the same commands whatever the
    /// instance count.
    pub gpu_cull: bool,
    /// Two-phase hierarchical-Z occlusion culling on the GPU (`occlusion`,
    /// with `gpu-cull`): draw what was visible last frame, build a depth
    /// pyramid per eye, draw what it shows became visible.
    pub occlusion: bool,
    /// Level of detail on the GPU (`lod`, `lod=PX`, with `gpu-cull`): each
    /// instance draws the coarsest level of its meshes' simplified chains
    /// whose error projects to at most this many pixels, and none when the
    /// whole instance does (None: off).
    pub lod: Option<f64>,
    /// With `lod`: keep the chains in `FILE.lodcache` next to a scene
    /// loaded from a file, and read them from there when the content
    /// matches (`lod-cache`).
    #[serde(default)]
    pub lod_cache: bool,
}

impl Default for CullingConfig {
    fn default() -> Self {
        CullingConfig {
            cull: Culling::None,
            draw_distance: None,
            gpu_cull: false,
            occlusion: false,
            lod: None,
            lod_cache: false,
        }
    }
}

/// Where the frame spends less: the masks, foveation, the far field, the inset, lens-matched shading, the sky after the resolve and adaptive quality.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct EffortConfig {
    /// HMD stencil mask: the hidden-area mesh is written to stencil first and
    /// every later draw is stencil-tested (`stencil-mask`).
    pub stencil_mask: bool,
    /// Foveated rendering level (`foveation=off|low|medium|high`).
    pub foveation: crate::view::foveation::Level,
    /// Gaze centre for foveation in NDC (`gaze=X:Y`, +y down; default the
    /// image centre).
    pub gaze: [f32; 2],
    /// Radial density masking: NDC radius beyond which every other 2×2
    /// quad is skipped (`rdm`, `rdm=R`; None: off).
    pub rdm: Option<f32>,
    /// Reconstruct the skipped quads (`rdm-nofill` turns it off, to measure
    /// the fill's cost).
    pub rdm_fill: bool,
    /// `rdm=auto`: the RDM radius is still to be derived from the HMD
    /// profile's lens ([`RenderConfig::resolve_lens`]); a renderer refuses
    /// a configuration where it is not.
    pub rdm_auto: bool,
    /// Monoscopic far-field rendering (`mffr`, `mffr=D`, `mffr-depth-shift`).
    pub mffr: Option<Mffr>,
    /// Multi-resolution foveated rendering (`inset`, `inset=F`,
    /// `inset-fov=DEG`): each eye as a wide view over its FOV at scale F
    /// per axis and a full-density inset around the gaze, composited.
    #[serde(default)]
    pub inset: Option<Inset>,
    /// Lens-matched shading (`lms`, `lms=K`, `lms-emulated`): each eye
    /// drawn per quadrant with clip-space w scaling into a smaller image,
    /// resampled to the eye image.
    #[serde(default)]
    pub lms: Option<Lms>,
    /// Draw the sky once per pixel after the MSAA resolve instead of at
    /// every sample inside the forward scope (`resolved-sky`; the same
    /// image up to rounding, see `render::passes::resolved_sky`).
    pub resolved_sky: bool,
    /// Adaptive quality (`aq`): each frame's render scale follows the GPU
    /// times of the last ones against the frame budget (The Lab's rules,
    /// `crate::adaptive`); the targets are made once at the largest scale
    /// and only the rendered area changes; with `inset`, levels below the
    /// lowest scale shrink the wide view (the inset's rung).
    #[serde(default)]
    pub aq: bool,
    /// `aq-scale-only`: with `aq` and `inset`, the controller moves the
    /// render scale only, without the inset's rung below the lowest scale
    /// (`crate::adaptive::AdaptiveQuality::with_wide_rungs`).
    #[serde(default)]
    pub aq_scale_only: bool,
    /// The frame budget of `aq` in milliseconds (`--budget-ms`; None: the
    /// runtime's display period, or the HMD profile's refresh rate).
    #[serde(default)]
    pub budget_ms: Option<f64>,
}

impl Default for EffortConfig {
    fn default() -> Self {
        EffortConfig {
            stencil_mask: false,
            foveation: crate::view::foveation::Level::Off,
            gaze: [0.0, 0.0],
            rdm: None,
            rdm_fill: true,
            rdm_auto: false,
            mffr: None,
            inset: None,
            lms: None,
            resolved_sky: false,
            aq: false,
            aq_scale_only: false,
            budget_ms: None,
        }
    }
}

/// Point clouds: the budget, the point size, the pipeline and eye-dome lighting.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PointsConfig {
    /// The most points of a point cloud drawn per frame
    /// (`points-budget=N`): its octree's nodes fill it nearest-first.
    pub points_budget: u64,
    /// A point's side in pixels at 2 m (`point-size=PX`, 1 to 16; farther
    /// points shrink as 1 / distance, to one pixel).
    pub point_size: f64,
    /// Draw a point cloud as one-pixel point primitives (the fallback for
    /// devices without 64-bit atomics) even where the compute rasterizer
    /// runs (`points-pipeline`).
    pub points_pipeline: bool,
    /// Eye-dome lighting of a point cloud's pixels (`edl[=S]`, strength S
    /// from 0.01 to 10, default [`DEFAULT_EDL_STRENGTH`]): each darkens by
    /// how far its neighbours lie in front of it
    /// (`shaders/points_composite.frag`); needs the compute rasterizer.
    pub edl: Option<f64>,
}

impl Default for PointsConfig {
    fn default() -> Self {
        PointsConfig {
            points_budget: DEFAULT_POINTS_BUDGET,
            point_size: 1.0,
            points_pipeline: false,
            edl: None,
        }
    }
}

/// Submission: frames in flight, recording threads and per-draw data.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SubmissionConfig {
    /// Frames the CPU may prepare while the GPU still renders earlier ones
    /// (`--frames-in-flight`, 1..=3; 1 waits for each frame before the next).
    pub frames_in_flight: u32,
    /// Record the forward views' draws into this many secondary command
    /// buffers, in parallel on as many threads, and execute them from the
    /// frame's primary one (`--record-threads N`; None: draws go straight
    /// into the primary command buffer on the calling thread).
    pub record_threads: Option<u32>,
    /// How each draw's own data (its material and where its instances start
    /// in the visible list) reaches the shaders (`--per-draw`).
    pub per_draw: PerDraw,
}

impl Default for SubmissionConfig {
    fn default() -> Self {
        SubmissionConfig {
            frames_in_flight: 2,
            record_threads: None,
            per_draw: PerDraw::Push,
        }
    }
}

/// The simulator: timewarp measured against rendered frames.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct SimulatorConfig {
    /// The timewarp simulation (`timewarp=K`, `timewarp-rotation`,
    /// `timewarp-fill`; `render --frames` and bench plans): every K-th frame is the
    /// source that the frames between are reprojected from, and each
    /// reprojection is compared with the frame truly rendered there.
    pub timewarp: Option<Timewarp>,
}

/// How per-draw data reaches the scene shaders (`--per-draw`).
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "kebab-case")]
pub enum PerDraw {
    /// Push constants written before each draw (`vkCmdPushConstants`).
    #[default]
    Push,
    /// One record per draw in a uniform buffer, selected by a dynamic
    /// offset (`vkCmdBindDescriptorSets` before each draw).
    Ubo,
    /// One record per draw in a storage buffer, indexed by the draw's
    /// `firstInstance` (`gl_BaseInstance`); nothing is bound per draw.
    Ssbo,
}

impl PerDraw {
    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            PerDraw::Push => "push",
            PerDraw::Ubo => "ubo",
            PerDraw::Ssbo => "ssbo",
        }
    }
}

/// One `--opt` error when any of `others` is on: `message` with `{}`
/// replaced by the names of those that are, joined by commas.
fn refuse_with(message: &str, others: &[(bool, &str)]) -> Result<()> {
    let on: Vec<&str> = others
        .iter()
        .filter_map(|(on, name)| on.then_some(*name))
        .collect();
    if on.is_empty() {
        return Ok(());
    }
    Err(Error::config(
        "--opt",
        message.replace("{}", &on.join(", ")),
    ))
}

/// Multi-resolution foveated rendering's settings (`inset[=F]`,
/// `inset-fov=DEG`; geometry in [`crate::view::inset`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Inset {
    /// The wide view's scale per axis (0.1 to 1).
    pub wide_scale: f64,
    /// The inset's half-angle around the gaze, degrees (1 to 80).
    pub half_angle_deg: f64,
    /// Whether `inset-fov=DEG` set the half-angle; otherwise a profile with
    /// lenses derives it ([`RenderConfig::resolve_lens`]).
    #[serde(default)]
    pub fov_given: bool,
    /// `inset-views=4` (which, like `inset-fov=`, turns `inset` on):
    /// under multiview, draw the four views (both eyes'
    /// inset and wide views) in one multiview scope where the device's
    /// maxMultiviewViewCount is at least 4. The default, `inset-views=2`,
    /// draws the wide views and the insets in two scopes: on the H200 it
    /// is the faster (8.46 against 12.43 ms on factory:100000,
    /// `bench/results/2026-12-03-h200-inset-four-view.md`), because one
    /// scope gives every view the render area of the widest and the
    /// inset views the whole list.
    #[serde(default)]
    pub four_views: bool,
    /// `inset-wide-1x` (which turns `inset` on): the wide views are drawn
    /// at one sample per pixel (their own pipelines) while the insets keep
    /// the frame's MSAA — where the eye looks stays 4×, the periphery,
    /// upsampled from a quarter of the pixels anyway, drops the dearest
    /// part of its cost (on the H200 the wide views' pass is about 5.6 ms
    /// at 4× and 3.4 ms at 1× on factory:100000). Two scopes only.
    #[serde(default)]
    pub wide_1x: bool,
    /// `inset-composite` (which turns `inset` on): composite the eye image
    /// here even where the runtime takes the four views itself
    /// (`XR_VARJO_quad_views`; `run --xr openxr` submits them as they are
    /// there by default).
    #[serde(default)]
    pub composite: bool,
    /// `inset-wide-all` (which turns `inset` on): the wide views also draw
    /// the instances wholly under the inset's core, which the composite
    /// never shows (by default they are skipped: the wide views' hole,
    /// [`crate::view::inset_hole`]; with `gpu-cull,lod` the wide views'
    /// levels stay at their own density either way). The eye image is the
    /// same; what it is for is measuring what the hole saves.
    #[serde(default)]
    pub wide_all: bool,
    /// `inset-taa[=A]` (which turns `inset` on): temporal anti-aliasing of
    /// the wide views with weight A (0.01 to 1, default
    /// [`crate::view::taa::DEFAULT_ALPHA`]) on each new frame: a compute
    /// pass blends each frame into a history reprojected with the wide
    /// views' depth and clamped to the current neighbourhood
    /// ([`crate::view::taa`]); the composite reads the history. Two scopes
    /// only, and not with `aq` (its changing sizes would restart the
    /// history).
    #[serde(default)]
    pub taa: Option<f64>,
    /// `inset-taa-jitter` (which turns `inset-taa` on): the wide viewport
    /// also moves by a sub-pixel Halton offset each frame, so a still view
    /// is supersampled over frames too. Off by default: on lavapipe's
    /// bench frames it cost FLIP and flicker against the unjittered
    /// accumulation (docs/techniques/inset.md, "Wide views accumulated over frames").
    #[serde(default)]
    pub taa_jitter: bool,
    /// `inset-taau` (which turns `inset-taa` and its jitter on): temporal
    /// upsampling, the history kept at the eye's resolution, each frame's
    /// jittered wide samples accumulated where they lie in it
    /// ([`crate::view::taau`]); the composite reads the history pixel for
    /// pixel. Not with `inset-catmull-rom` (nothing is upsampled in the
    /// composite then).
    #[serde(default)]
    pub taau: bool,
    /// `inset-catmull-rom` (which turns `inset` on): the composite reads
    /// the wide view through a Catmull-Rom filter (4×4 texels, clamped to
    /// the nearest 2×2's range) instead of bilinearly. Sharper: less FLIP
    /// over the periphery; but it shows the wide view's own aliasing more,
    /// so a moving periphery flickers more (docs/techniques/inset.md, "The wide view's
    /// upsampling"). Off by default.
    #[serde(default)]
    pub catmull_rom: bool,
    /// `inset-sharpen[=S]` (which turns `inset-taau` on): the composite
    /// sharpens the upsampled periphery with strength S (0.1 to 2, default
    /// [`crate::view::sharpen::DEFAULT_STRENGTH`]), clamped to each
    /// pixel's cross of neighbours ([`crate::view::sharpen`]); the history
    /// itself stays as accumulated. Off by default.
    #[serde(default)]
    pub sharpen: Option<f64>,
    /// `inset-taau-lanczos` (which turns `inset-taau` on): the upsampling
    /// reads the previous frame's history through the Lanczos-3 filter
    /// (6×6 texels, [`crate::view::lanczos`]) instead of Catmull-Rom
    /// (4×4), so the edges it carries soften less each frame the head
    /// turns. Off by default.
    #[serde(default)]
    pub taau_lanczos: bool,
}

impl Inset {
    /// These settings with `inset-taau` on (and with it `inset-taa`, at
    /// its weight if given, and its jitter).
    fn with_taau(self) -> Inset {
        Inset {
            taa: Some(self.taa.unwrap_or(crate::view::taa::DEFAULT_ALPHA)),
            taa_jitter: true,
            taau: true,
            ..self
        }
    }

    /// How far, in wide texels, the passes that read the wide views reach
    /// from a pixel's position: [`crate::view::taau::READ_REACH`] with
    /// `inset-taau`, else [`crate::view::inset_hole::read_reach`] of the
    /// composite's filter and `inset-taa`. The wide views' hole keeps that
    /// margin drawn.
    pub fn read_reach(&self) -> f64 {
        match self.taau {
            // The sharpening reads the history one eye pixel (the wide
            // scale's share of a wide texel) beyond the pixel.
            true if self.sharpen.is_some() => {
                crate::view::taau::READ_REACH
                    + crate::view::sharpen::READ_REACH_EYE_PX * self.wide_scale
            }
            true => crate::view::taau::READ_REACH,
            false => crate::view::inset_hole::read_reach(self.catmull_rom, self.taa.is_some()),
        }
    }
}

impl Default for Inset {
    fn default() -> Self {
        Inset {
            wide_scale: crate::view::inset::DEFAULT_WIDE_SCALE,
            half_angle_deg: crate::view::inset::DEFAULT_HALF_ANGLE_DEG,
            fov_given: false,
            four_views: false,
            wide_1x: false,
            composite: false,
            wide_all: false,
            taa: None,
            taa_jitter: false,
            taau: false,
            catmull_rom: false,
            sharpen: None,
            taau_lanczos: false,
        }
    }
}

/// Lens-matched shading's settings (`lms`, `lms=K`, `lms-emulated`;
/// geometry in [`crate::view::lms`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Lms {
    /// `lms=K`: one coefficient on every side; None: fitted to the HMD
    /// profile's lens, else [`crate::view::lms::DEFAULT_COEFFICIENT`].
    pub coefficient: Option<f64>,
    /// `lms-emulated`: scale w in the vertex shaders even where
    /// VK_NV_clip_space_w_scaling is offered.
    pub emulated: bool,
    /// The coefficients in use, once resolved for the profile
    /// ([`RenderConfig::resolve_lens`]); None until then.
    #[serde(skip)]
    pub resolved: Option<crate::view::lms::Coefficients>,
}

impl Lms {
    /// The coefficients frames draw with: the resolved ones, else `lms=K`'s,
    /// else the default.
    pub fn coefficients(&self) -> crate::view::lms::Coefficients {
        self.resolved.unwrap_or_else(|| {
            crate::view::lms::Coefficients::uniform(
                self.coefficient
                    .unwrap_or(crate::view::lms::DEFAULT_COEFFICIENT),
            )
        })
    }
}

/// The default point budget per frame (Potree's VR examples draw a few
/// million per eye; the H200 rasterizes 88 M points for both eyes in
/// 0.55 ms, see docs/techniques/points.md, "Measured").
pub const DEFAULT_POINTS_BUDGET: u64 = 20_000_000;
/// Eye-dome lighting's strength without a value (`edl`): Potree's default
/// (k = 300 × 0.4 in `shaders/points_composite.frag`).
pub const DEFAULT_EDL_STRENGTH: f64 = 0.4;

/// Most threads `--record-threads` accepts.
pub const MAX_RECORD_THREADS: u32 = 64;

/// The timewarp simulation's settings.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Timewarp {
    /// Render every K-th frame (2..=MAX_TIMEWARP_K).
    pub k: u32,
    /// How the frames between are reprojected.
    pub variant: TimewarpVariant,
}

/// How the timewarp simulation reprojects the frames between sources.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TimewarpVariant {
    /// The rotation-only homography, no depth (`timewarp-rotation`).
    Rotation,
    /// Rotation and translation with depth; holes left black (the default).
    Depth,
    /// Rotation and translation with depth; holes filled from the
    /// background (`timewarp-fill`).
    Fill,
}

/// Largest K `timewarp=K` accepts.
pub const MAX_TIMEWARP_K: u32 = 16;

/// Most frames in flight `--frames-in-flight` accepts.
pub const MAX_FRAMES_IN_FLIGHT: u32 = 3;

/// Monoscopic far-field settings.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Mffr {
    /// Split distance in metres (None: where disparity falls below 1 px).
    pub split: Option<f64>,
    /// Shift the far field per eye by its disparity at the split distance.
    pub depth_shift: bool,
    /// One far image per eye, each re-rendered from its eye every other
    /// frame (the other eye's is reused).
    pub alternate_eye: bool,
    /// Draw every visible instance in both the near and the far passes
    /// instead of splitting them by depth (`mffr-no-split`; to measure what
    /// the split saves).
    pub no_split: bool,
}

/// Nearest far-field split `mffr=D` accepts (metres; nearer would leave the
/// near field empty and draw everything flat).
pub const MIN_MFFR_SPLIT_M: f64 = 0.1;
/// Farthest far-field split `mffr=D` accepts (metres).
pub const MAX_MFFR_SPLIT_M: f64 = 1e6;

/// What an `--opt` entry sets and to what, for finding two entries of one
/// list that disagree; None for entries that only switch something on.
fn opt_slot(item: &str, cull_names: &[&str]) -> Option<(&'static str, String)> {
    let value = |prefix: &str| item[prefix.len()..].trim().to_string();
    Some(match item {
        "multiview" | "two-pass" => ("stereo mode", item.to_string()),
        "msaa" | "msaa4" => ("MSAA sample count", "4".into()),
        "no-msaa" => ("MSAA sample count", "1".into()),
        "foveation" => ("foveation level", "medium".into()),
        f if f.starts_with("foveation=") => ("foveation level", value("foveation=")),
        g if g.starts_with("gaze=") => ("gaze centre", value("gaze=")),
        r if r.starts_with("rdm=") => ("radial density masking radius", value("rdm=")),
        "lod" => (
            "LOD error bound",
            crate::view::lod::DEFAULT_BOUND_PX.to_string(),
        ),
        l if l.starts_with("lod=") => ("LOD error bound", value("lod=")),
        m if m.starts_with("mffr=") => ("far-field split distance", value("mffr=")),
        t if t.starts_with("timewarp=") => ("timewarp interval", value("timewarp=")),
        "timewarp-rotation" | "timewarp-fill" => ("timewarp variant", item.to_string()),
        c if cull_names.contains(&c) => ("culling strategy", c.to_string()),
        _ => return None,
    })
}

/// Largest LOD error bound `lod=PX` accepts, in pixels.
pub const MAX_LOD_BOUND_PX: f64 = 64.0;

/// Default radial-density-masking radius (NDC).
pub const DEFAULT_RDM_RADIUS: f32 = 0.55;

impl RenderConfig {
    /// Validates value ranges.
    pub fn validate(&self) -> Result<()> {
        if !matches!(self.frame.msaa, 1 | 4) {
            return Err(Error::config(
                "--msaa",
                format!("{} (supported: 1, 4)", self.frame.msaa),
            ));
        }
        if !(1..=MAX_FRAMES_IN_FLIGHT).contains(&self.submission.frames_in_flight) {
            return Err(Error::config(
                "--frames-in-flight",
                format!(
                    "{} (supported: 1 to {MAX_FRAMES_IN_FLIGHT})",
                    self.submission.frames_in_flight
                ),
            ));
        }
        options::check_rules(self)?;
        if let Some(b) = self.effort.budget_ms {
            if !(b.is_finite() && b > 0.0 && b <= 1000.0) {
                return Err(Error::config(
                    "--budget-ms",
                    format!("{b} (supported: more than 0, at most 1000)"),
                ));
            }
        }
        if let Some(n) = self.submission.record_threads {
            if !(1..=MAX_RECORD_THREADS).contains(&n) {
                return Err(Error::config(
                    "--record-threads",
                    format!("{n} (supported: 1 to {MAX_RECORD_THREADS})"),
                ));
            }
        }
        let submission =
            self.submission.record_threads.is_some() || self.submission.per_draw != PerDraw::Push;
        if submission && (self.culling.gpu_cull || self.effort.mffr.is_some()) {
            return Err(Error::config(
                "--record-threads/--per-draw",
                "parallel recording and per-draw ubo/ssbo data apply to CPU-culled forward draws: they cannot be combined with gpu-cull or mffr",
            ));
        }
        if let Some(p) = self.frame.section {
            let n = glam::DVec3::new(p[0], p[1], p[2]);
            if !(p.iter().all(|v| v.is_finite()) && (n.length() - 1.0).abs() < 1e-6) {
                return Err(Error::config(
                    "--section",
                    format!("{p:?} is not a plane with a unit normal"),
                ));
            }
        }
        if !(self.frame.near.is_finite() && self.frame.near > 0.0) {
            return Err(Error::config(
                "near plane",
                format!("{} must be a positive number", self.frame.near),
            ));
        }
        Ok(())
    }

    /// Applies a comma-separated `--opt` list (e.g. `multiview,superfrustum`).
    /// Names it does not know are an error naming them, and so are two
    /// entries of one list that set the same thing differently
    /// (`multiview,two-pass`, `foveation=low,foveation=high`, two culling
    /// strategies); repeating an entry is allowed. A later list (`--opt`
    /// after a `--config` file's) still overrides an earlier one.
    pub fn apply_opts(&mut self, list: &str, cull_names: &[&str]) -> Result<()> {
        // (what an entry sets, the value it sets, the entry), per list.
        let mut claimed: Vec<(&'static str, String, &str)> = Vec::new();
        for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            if let Some((slot, value)) = opt_slot(item, cull_names) {
                match claimed.iter().find(|(s, ..)| *s == slot) {
                    Some((_, v, prev)) if *v != value => {
                        return Err(Error::config(
                            "--opt",
                            format!(
                                "'{item}' conflicts with '{prev}' (both set the {slot}); keep one"
                            ),
                        ))
                    }
                    Some(_) => {}
                    None => claimed.push((slot, value, item)),
                }
            }
            options::apply(self, item, cull_names)?;
        }
        Ok(())
    }
}

impl RenderConfig {
    /// Resolves `rdm=auto` and `foveation=auto` for `profile` (None: a
    /// runtime's views, which carry no lens). Foveation's full-rate radius
    /// becomes the largest, over the views, of the NDC radius beyond which
    /// the lens reads at least 2 eye pixels per panel pixel (2×2 shading
    /// there still shades every panel pixel apart). RDM's radius becomes the largest, over the views, of
    /// the NDC radius beyond which the lens reads at least √2 eye pixels
    /// per panel pixel ([`crate::view::distortion::density`]), so masking
    /// every other quad there drops only over-rendered pixels. One error
    /// when the profile has no lens or the lens is nowhere dense enough.
    pub fn resolve_lens(
        &mut self,
        profile: Option<&crate::view::profile::HmdProfile>,
    ) -> Result<()> {
        use crate::view::foveation::Level;
        let foveation_auto = self.effort.foveation == Level::Lens(0);
        self.resolve_lms(profile);
        self.resolve_inset(profile);
        if !self.effort.rdm_auto && !foveation_auto {
            return Ok(());
        }
        let what = if self.effort.rdm_auto {
            "rdm=auto"
        } else {
            "foveation=auto"
        };
        let no_lens = |name: &str| {
            Error::config(
                "--opt",
                format!("{what} derives its radius from the HMD profile's lens, and {name} has no [views.lens] table; give rdm=R or a foveation level"),
            )
        };
        let profile = profile.ok_or_else(|| no_lens("the OpenXR runtime's view"))?;
        let (mut rdm, mut coarse) = (0.0f64, 0.0f64);
        for v in &profile.views {
            let lens = v.lens.as_ref().ok_or_else(|| no_lens(&profile.name))?;
            let d = crate::view::distortion::density::density(lens, &v.fov, v.resolution, 4);
            if self.effort.rdm_auto {
                let r = d.rdm_radius.ok_or_else(|| {
                    Error::config(
                        "--opt",
                        format!("rdm=auto: the {} lens reads under √2 eye pixels per panel pixel everywhere, so no radius masks only over-rendered pixels", profile.name),
                    )
                })?;
                rdm = rdm.max(r);
            }
            if foveation_auto {
                let r = d.coarse_radius.ok_or_else(|| {
                    Error::config(
                        "--opt",
                        format!("foveation=auto: the {} lens reads under 2 eye pixels per panel pixel everywhere, so 2×2 shading would coarsen what the panel shows; give foveation=low|medium|high", profile.name),
                    )
                })?;
                coarse = coarse.max(r);
            }
        }
        if self.effort.rdm_auto {
            self.effort.rdm = Some(rdm as f32);
            self.effort.rdm_auto = false;
        }
        if foveation_auto {
            self.effort.foveation = Level::Lens(((coarse * 1000.0).round() as u16).max(1));
        }
        Ok(())
    }

    /// Derives the inset's half-angle from `profile`'s lenses when every
    /// view has one and `inset-fov=DEG` gave none: the largest over the
    /// views of [`crate::view::distortion::density::inset_half_angle_deg`]
    /// at the wide view's scale, within 1–80°. Otherwise the constant
    /// default ([`crate::view::inset::DEFAULT_HALF_ANGLE_DEG`]) stays.
    fn resolve_inset(&mut self, profile: Option<&crate::view::profile::HmdProfile>) {
        let (Some(inset), Some(profile)) = (self.effort.inset.as_mut(), profile) else {
            return;
        };
        if inset.fov_given || profile.views.iter().any(|v| v.lens.is_none()) {
            return;
        }
        let deg = profile
            .views
            .iter()
            .filter_map(|v| {
                let lens = v.lens.as_ref()?;
                Some(crate::view::distortion::density::inset_half_angle_deg(
                    lens,
                    &v.fov,
                    v.resolution,
                    inset.wide_scale,
                    4,
                ))
            })
            .fold(0.0f64, f64::max);
        inset.half_angle_deg = deg.clamp(1.0, 80.0);
    }

    /// Resolves `lms`'s coefficients: `lms=K`'s on every side, else fitted
    /// to `profile`'s lenses ([`crate::view::lms::fit`]) when every view
    /// has one, else the default.
    fn resolve_lms(&mut self, profile: Option<&crate::view::profile::HmdProfile>) {
        use crate::view::lms;
        let Some(l) = self.effort.lms.as_mut() else {
            return;
        };
        let lenses: Option<Vec<_>> = profile.map(|p| {
            p.views
                .iter()
                .filter_map(|v| v.lens.as_ref().map(|lens| (lens, &v.fov, v.resolution)))
                .collect()
        });
        let fitted = match (l.coefficient, lenses) {
            (None, Some(views))
                if !views.is_empty() && Some(views.len()) == profile.map(|p| p.views.len()) =>
            {
                Some(lms::fit(&views, 4))
            }
            _ => None,
        };
        l.resolved = Some(fitted.unwrap_or_else(|| l.coefficients()));
    }

    /// Frames this configuration must draw before its image stops
    /// depending on where it started: with `inset-taa` the history's
    /// [`crate::view::taa::SETTLE_FRAMES`], else 0 (every frame stands
    /// alone).
    pub fn settle_frames(&self) -> usize {
        match self.effort.inset.and_then(|i| i.taa) {
            Some(_) => crate::view::taa::SETTLE_FRAMES,
            None => 0,
        }
    }

    /// One error when this configuration has a technique a scene with a
    /// point cloud cannot draw with yet (the points are rasterized into the
    /// eye images at full size, once per frame).
    pub fn refuse_for_points(&self) -> Result<()> {
        refuse_with(
            "a scene with a point cloud rasterizes its points into the full-size eye images; {} is not built for points yet: leave it out",
            &[
                (self.effort.lms.is_some(), "lms"),
                (self.effort.inset.is_some(), "inset"),
                (self.effort.mffr.is_some(), "mffr"),
                (self.effort.aq, "aq"),
                (self.simulator.timewarp.is_some(), "timewarp"),
                (self.submission.record_threads.is_some(), "--record-threads"),
            ],
        )
    }

    /// One error when `timewarp` is set for `command`, which does not
    /// measure it (only `render --frames` does).
    pub fn refuse_timewarp(&self, command: &str) -> Result<()> {
        match self.simulator.timewarp {
            Some(_) => Err(Error::config(
                "--opt",
                format!("timewarp is measured by `vergence render --frames N --opt timewarp=K` and by bench plan configurations; `{command}` does not run it"),
            )),
            None => Ok(()),
        }
    }

    /// The `--opt` list that sets this configuration's optimizations
    /// (stereo mode, MSAA, culling and every technique that is on), as
    /// the live toggles show it and write it to a config file: applied to
    /// [`RenderConfig::default`] with the same frames in flight, near plane
    /// and draw distance, it gives this configuration back.
    pub fn opt_string(&self) -> String {
        options::print(self)
    }
}

/// Names `--opt` accepts for culling: `none` plus every strategy.
pub fn cull_names() -> Vec<&'static str> {
    std::iter::once("none")
        .chain(Strategy::ALL.iter().map(|s| s.name()))
        .collect()
}

/// A config file as `vergence tune` writes it (`opt = "..."`), read by
/// `render --config` and `run --config`.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConfigFile {
    /// The `--opt` list.
    pub opt: String,
}

impl ConfigFile {
    /// Reads and checks a config file: size-bounded, known keys only, and
    /// an `--opt` list that applies and validates.
    pub fn load(path: &std::path::Path) -> Result<ConfigFile> {
        let text = crate::fsio::read_text(path, crate::fsio::MAX_TEXT_FILE_BYTES)
            .map_err(|e| Error::config("--config", format!("{}: {e}", path.display())))?;
        let file: ConfigFile = toml::from_str(&text).map_err(|e| {
            Error::config("--config", format!("{}: {}", path.display(), e.message()))
        })?;
        let mut c = RenderConfig::default();
        c.apply_opts(&file.opt, &cull_names())
            .and_then(|()| c.validate())
            .map_err(|e| Error::config("--config", format!("{}: {e}", path.display())))?;
        Ok(file)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::foveation::Level;

    #[test]
    fn the_opt_string_gives_the_configuration_back() {
        let names = cull_names();
        for list in [
            "",
            "two-pass,no-msaa",
            "superfrustum,gpu-cull,stencil-mask,foveation=high,gaze=0.25:-0.5",
            "conical,rdm=0.4,rdm-nofill",
            "mffr=12.5,mffr-depth-shift,mffr-alternate-eye,mffr-no-split",
            "round-robin,mffr,rdm,foveation=low",
            "superfrustum,lms",
            "two-pass,lms=0.25,lms-emulated",
            "superfrustum,inset=0.6,inset-fov=15",
            "inset,inset-views=4",
            "inset-views=4,inset-views=2",
            "inset-wide-1x",
            "two-pass,inset=0.4,inset-wide-1x",
            "inset,inset-composite",
            "inset,inset-wide-all,inset-wide-1x",
            "multiview,inset,aq,aq-scale-only",
            "inset-taa",
            "two-pass,inset=0.7,inset-wide-1x,inset-taa=0.25",
            "inset-taa-jitter",
            "inset-taa=0.2,inset-taa-jitter",
            "inset-taau",
            "inset=0.7,inset-wide-1x,inset-taa=0.2,inset-taau",
            "inset-sharpen",
            "inset=0.7,inset-wide-1x,inset-taa=0.05,inset-sharpen=0.5",
            "inset-taau,inset-sharpen=1.5",
            "inset-taau-lanczos",
            "inset=0.7,inset-wide-1x,inset-sharpen,inset-taau-lanczos",
            "inset-taau-lanczos,inset-taa=0.05,inset-sharpen=0.5",
            "point-size=3,edl",
            "edl=1.5,points-budget=5000",
        ] {
            let mut c = RenderConfig::default();
            c.apply_opts(list, &names).unwrap();
            let opt = c.opt_string();
            let mut back = RenderConfig::default();
            back.apply_opts(&opt, &names).unwrap();
            assert_eq!(back, c, "{list} -> {opt}");
        }
        assert_eq!(RenderConfig::default().opt_string(), "multiview,msaa4,none");
    }

    /// A profile with lenses sets the inset's half-angle and lms's
    /// coefficients; `inset-fov=` and `lms=` keep theirs; a profile
    /// without lenses keeps the defaults.
    #[test]
    fn lenses_derive_the_inset_angle_and_the_lms_coefficients() {
        use crate::view::profile::HmdProfile;
        let vive = HmdProfile::load("vive").unwrap();
        let index = HmdProfile::load("valve-index").unwrap();
        let resolved = |opt: &str, p: &HmdProfile| {
            let mut c = RenderConfig::default();
            c.apply_opts(opt, &cull_names()).unwrap();
            c.resolve_lens(Some(p)).unwrap();
            c
        };
        let c = resolved("inset,lms", &vive);
        let deg = c.effort.inset.unwrap().half_angle_deg;
        assert!(deg > 1.0 && deg <= 80.0 && deg != crate::view::inset::DEFAULT_HALF_ANGLE_DEG);
        let k = c.effort.lms.unwrap().coefficients();
        assert!(k.left > 0.0 && k.left < crate::view::lms::DEFAULT_COEFFICIENT);
        // The opt string does not freeze derived values.
        assert_eq!(c.opt_string(), "multiview,msaa4,none,inset,lms");
        let c = resolved("inset,inset-fov=15,lms=0.2", &vive);
        assert_eq!(c.effort.inset.unwrap().half_angle_deg, 15.0);
        assert_eq!(
            c.effort.lms.unwrap().coefficients(),
            crate::view::lms::Coefficients::uniform(0.2)
        );
        let c = resolved("inset,lms", &index);
        assert_eq!(
            c.effort.inset.unwrap().half_angle_deg,
            crate::view::inset::DEFAULT_HALF_ANGLE_DEG
        );
        assert_eq!(
            c.effort.lms.unwrap().coefficients(),
            crate::view::lms::Coefficients::uniform(crate::view::lms::DEFAULT_COEFFICIENT)
        );
    }

    #[test]
    fn effort_options_parse_and_bad_values_name_themselves() {
        let mut c = RenderConfig::default();
        c.apply_opts("stencil-mask,foveation=high,gaze=0.25:-0.5", &["none"])
            .unwrap();
        assert!(c.effort.stencil_mask);
        assert_eq!(c.effort.foveation, Level::High);
        assert_eq!(c.effort.gaze, [0.25, -0.5]);
        c.apply_opts("rdm=0.4,rdm-nofill", &["none"]).unwrap();
        assert_eq!((c.effort.rdm, c.effort.rdm_fill), (Some(0.4), false));
        for (list, says) in [
            (
                "multiview,two-pass",
                "'two-pass' conflicts with 'multiview'",
            ),
            ("msaa4,no-msaa", "MSAA sample count"),
            ("foveation=low,foveation=high", "foveation level"),
            ("none,per-eye", "culling strategy"),
            ("mffr=2,mffr=3", "far-field split"),
        ] {
            let e = RenderConfig::default()
                .apply_opts(list, &["none", "per-eye"])
                .unwrap_err()
                .to_string();
            assert!(e.contains("--opt") && e.contains(says), "{list}: {e}");
        }
        let mut c = RenderConfig::default();
        c.apply_opts(
            "foveation,foveation=medium,msaa,msaa4,two-pass,two-pass",
            &["none"],
        )
        .unwrap();
        assert_eq!(
            (c.effort.foveation, c.frame.msaa, c.frame.stereo),
            (Level::Medium, 4, StereoMode::TwoPass)
        );
        c.apply_opts("multiview", &["none"]).unwrap();
        assert_eq!(
            c.frame.stereo,
            StereoMode::Multiview,
            "a later list overrides"
        );
        for bad in [
            "mffr=1e-46",
            "foveation=extreme",
            "gaze=2:0",
            "gaze=0.1",
            "gaze=a:b",
            "rdm=2",
            "rdm=x",
        ] {
            let e = RenderConfig::default()
                .apply_opts(bad, &["none"])
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("--opt") && e.contains(bad.split('=').nth(1).unwrap()),
                "{e}"
            );
        }
    }

    #[test]
    fn rdm_auto_takes_its_radius_from_the_lens_density() {
        use crate::view::distortion::density::{density, Density};
        use crate::view::profile::HmdProfile;
        let auto = || {
            let mut c = RenderConfig::default();
            c.apply_opts("rdm=auto", &cull_names()).unwrap();
            c
        };
        assert!(auto().opt_string().contains("rdm=auto"));
        let vive = HmdProfile::load("vive").unwrap();
        let mut c = auto();
        c.resolve_lens(Some(&vive)).unwrap();
        assert!(!c.effort.rdm_auto);
        // The largest of the views' radii, each from the density figures.
        let largest = |p: &HmdProfile, pick: fn(&Density) -> Option<f64>| {
            p.views
                .iter()
                .map(|v| pick(&density(v.lens.as_ref().unwrap(), &v.fov, v.resolution, 4)).unwrap())
                .fold(0.0, f64::max)
        };
        let expect = largest(&vive, |d| d.rdm_radius);
        assert_eq!(c.effort.rdm, Some(expect as f32));
        assert!((0.6..0.9).contains(&expect), "{expect}");
        let e = auto()
            .resolve_lens(Some(&HmdProfile::load("valve-index").unwrap()))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("valve-index") && e.contains("[views.lens]"),
            "{e}"
        );
        let e = auto().resolve_lens(None).unwrap_err().to_string();
        assert!(e.contains("OpenXR"), "{e}");
        // foveation=auto: 2×2 beyond where the lens reads two eye pixels
        // per panel pixel.
        let fov_auto = || {
            let mut c = RenderConfig::default();
            c.apply_opts("foveation=auto", &cull_names()).unwrap();
            c
        };
        assert_eq!(fov_auto().effort.foveation, Level::Lens(0));
        assert!(fov_auto().opt_string().contains("foveation=auto"));
        let dk1 = HmdProfile::load("rift-dk1").unwrap();
        let mut c = fov_auto();
        c.resolve_lens(Some(&dk1)).unwrap();
        let expect = largest(&dk1, |d| d.coarse_radius);
        assert_eq!(
            c.effort.foveation,
            Level::Lens((expect * 1000.0).round() as u16)
        );
        assert_eq!(c.effort.foveation.size_at(0.0), 1);
        assert_eq!(c.effort.foveation.size_at(expect as f32 + 0.01), 2);
        // Coarser shading needs more density than masking: the Vive's
        // 2×2 ring starts beyond its RDM radius.
        let mut c = fov_auto();
        c.apply_opts("rdm=auto", &cull_names()).unwrap();
        c.resolve_lens(Some(&vive)).unwrap();
        let Level::Lens(r) = c.effort.foveation else {
            panic!("{:?}", c.effort.foveation)
        };
        assert!(
            f32::from(r) / 1000.0 >= c.effort.rdm.unwrap(),
            "{r} {:?}",
            c.effort.rdm
        );
        // A lens that reads one eye pixel per panel pixel: no 2×2 ring.
        let flat = HmdProfile::parse(
            "flat",
            "name = \"flat\"\nrefresh_hz = 60.0\n[[views]]\nposition = [0.0, 0.0, 0.0]\n\
             orientation = [0.0, 0.0, 0.0, 1.0]\nfov = { left = -0.785, right = 0.785, up = 0.785, down = -0.785 }\n\
             resolution = [64, 64]\n[views.lens]\nmodel = \"panotools\"\nk = [0.0, 0.0, 0.0, 1.0]\n\
             chroma = [1.0, 1.0, 1.0]\ncentre = [0.5, 0.5]\nunit = [0.5, 0.5]\ntangent = [1.0, 1.0]\n",
        )
        .unwrap();
        let e = fov_auto()
            .resolve_lens(Some(&flat))
            .unwrap_err()
            .to_string();
        assert!(e.contains("under 2 eye pixels"), "{e}");
        // A plain radius after auto wins, and needs no lens.
        let mut c = RenderConfig::default();
        c.apply_opts("rdm=auto", &cull_names()).unwrap();
        c.apply_opts("rdm=0.4", &cull_names()).unwrap();
        assert!(!c.effort.rdm_auto && c.effort.rdm == Some(0.4));
        c.resolve_lens(None).unwrap();
    }
}
