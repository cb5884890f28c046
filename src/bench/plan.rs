//! Benchmark plans (`manifests/bench/*.toml`): scenes × HMD profiles ×
//! resolution scales × optimization sets, measured along a deterministic
//! head path.

use crate::config::RenderConfig;
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// One optimization set of a plan.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct PlanConfig {
    /// Name in reports (unique within the plan).
    pub name: String,
    /// `--opt` list, applied over the defaults (multiview, 4× MSAA, no
    /// culling, every optimization off).
    #[serde(default)]
    pub opt: String,
    /// Frames in flight for this configuration (default: the plan's).
    #[serde(default)]
    pub frames_in_flight: Option<u32>,
    /// Record the forward draws on this many threads into secondary
    /// command buffers (`--record-threads`; default: straight into the
    /// primary).
    #[serde(default)]
    pub record_threads: Option<u32>,
    /// How per-draw data reaches the shaders (`--per-draw`; default push).
    #[serde(default)]
    pub per_draw: Option<crate::config::PerDraw>,
}

/// A benchmark plan.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    /// The folder the plan's relative paths (scenes, HMD profiles)
    /// resolve against: the plan file's own (None: the working folder).
    #[serde(skip)]
    pub base: Option<PathBuf>,
    /// Plan name.
    pub name: String,
    /// Scenes (`factory:N`, a glTF file or a scene manifest).
    pub scenes: Vec<String>,
    /// HMD profiles (names or paths).
    pub hmds: Vec<String>,
    /// Per-eye resolution scales relative to each profile's resolution.
    #[serde(default = "one_scale")]
    pub scales: Vec<f64>,
    /// Warm-up frames per configuration (not measured).
    #[serde(default = "default_warmup")]
    pub warmup: u32,
    /// Before its warm-up frames, each configuration renders its first
    /// view for at least this many milliseconds, unmeasured: a GPU that
    /// idled while the previous configuration's images were compared
    /// takes a few hundred ms to reach its clocks again (on the H200,
    /// 250–300 ms of frames at 3–5× their steady time).
    #[serde(default = "default_spin_up_ms")]
    pub spin_up_ms: u32,
    /// Measured frames per configuration.
    pub frames: u32,
    /// Frames (evenly spaced over the measured ones) whose images are
    /// compared with the reference.
    #[serde(default = "default_error_frames")]
    pub error_frames: u32,
    /// Frames of the temporal-error sequence (the first measured view
    /// turning by a third of a pixel a frame), rendered by the reference
    /// and by each configuration after its timing; 0 turns the measure
    /// off (see `bench::flicker`).
    #[serde(default = "default_flicker_frames")]
    pub flicker_frames: u32,
    /// The frame budget in milliseconds that frames over budget are
    /// counted against and `aq` holds frames to (default: the HMD
    /// profile's refresh period).
    #[serde(default)]
    pub budget_ms: Option<f64>,
    /// Seed of the head path.
    #[serde(default)]
    pub path_seed: u64,
    /// Several head paths (at most 8 distinct seeds): every scene, profile
    /// and scale is measured along each, one group per seed, and the
    /// reports give each figure's spread over them. Empty (the default):
    /// `path_seed` alone.
    #[serde(default)]
    pub path_seeds: Vec<u64>,
    /// Where the eye looks: `centre` (the default: the techniques keep
    /// their configured centre, the foveated error looks at the image
    /// centre) or `saccades` (scripted fixations and saccades,
    /// [`crate::view::gaze_path`]: the inset follows the gaze as reported
    /// `gaze_latency_ms` earlier, and the foveated error is measured where
    /// the eye truly looks).
    #[serde(default)]
    pub gaze: GazeKind,
    /// The eye tracker's latency in ms (0 to 500, default 0): how old the
    /// gaze the techniques follow is.
    #[serde(default)]
    pub gaze_latency_ms: f64,
    /// The head path: `walk` (default) walks through the scene at standing
    /// height; `orbit` circles outside its bounds looking at its centre
    /// (the whole scene in view).
    #[serde(default)]
    pub path: PathKind,
    /// `--opt` list of the image reference: full quality, every
    /// optimization off.
    #[serde(default = "default_reference")]
    pub reference: String,
    /// The reference rendered at this many times the eye size per axis
    /// (1 to 4) and reduced to it by a box filter in linear light
    /// (`targets::downsample`): a converged image for the error and the
    /// temporal error to be measured against, so that the baseline's own
    /// aliasing counts too. 1 (the default): at the eye size.
    #[serde(default = "one")]
    pub reference_supersample: u32,
    /// Name of the configuration speed-ups are relative to (default: the
    /// first).
    #[serde(default)]
    pub baseline: Option<String>,
    /// Frames in flight of every configuration that does not set its own
    /// (1 to 3; `bench --frames-in-flight` overrides it).
    #[serde(default = "default_frames_in_flight")]
    pub frames_in_flight: u32,
    /// Times each configuration's frames are timed (1 to 10, default 1):
    /// with more, the reports give each median's and speed-up's range over
    /// the runs (the speed-up from the baseline's fastest run over the
    /// configuration's slowest to its slowest over the fastest), the
    /// run-to-run spread a single run cannot show. Images
    /// and errors come from the first run.
    #[serde(default = "one")]
    pub repeats: u32,
    /// The optimization sets.
    pub configs: Vec<PlanConfig>,
}

/// Most runs `repeats` asks for.
pub const MAX_REPEATS: u32 = 10;

/// A plan's gaze path.
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
#[serde(rename_all = "lowercase")]
pub enum GazeKind {
    /// The gaze on the image centre.
    #[default]
    Centre,
    /// Scripted fixations and saccades.
    Saccades,
}

/// Most head paths `path_seeds` names.
pub const MAX_PATH_SEEDS: usize = 8;

fn one_scale() -> Vec<f64> {
    vec![1.0]
}
fn one() -> u32 {
    1
}
fn default_warmup() -> u32 {
    5
}
fn default_flicker_frames() -> u32 {
    6
}
fn default_spin_up_ms() -> u32 {
    500
}
fn default_error_frames() -> u32 {
    2
}
fn default_frames_in_flight() -> u32 {
    RenderConfig::default().submission.frames_in_flight
}
fn default_reference() -> String {
    "two-pass".into()
}

/// Largest per-eye dimension a scale may produce.
pub const MAX_EYE_PIXELS: u32 = 8192;
/// Smallest per-eye dimension a scale may produce.
pub const MIN_EYE_PIXELS: u32 = 16;
/// Longest image folder name of a group (scene, profile and scale).
pub const MAX_GROUP_DIR_BYTES: usize = 200;
/// Longest configuration name (it becomes part of image file names).
pub const MAX_CONFIG_NAME_CHARS: usize = 64;

/// The shipped plans, usable by name from any folder.
pub const BUILTIN: &[(&str, &str)] = &[
    ("smoke", include_str!("../../manifests/bench/smoke.toml")),
    (
        "default",
        include_str!("../../manifests/bench/default.toml"),
    ),
    ("scale", include_str!("../../manifests/bench/scale.toml")),
    (
        "in-flight",
        include_str!("../../manifests/bench/in-flight.toml"),
    ),
    (
        "submission",
        include_str!("../../manifests/bench/submission.toml"),
    ),
];

/// The shipped plans' folder in the source tree this binary was built
/// from.
pub fn shipped_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("manifests/bench")
}

/// Where plans are found by name: the source tree's plan folder
/// ([`shipped_dir`]) while it exists, else `manifests/bench` under the
/// working folder (a copy of the repository run from its root, as on a
/// machine the release binary was carried to).
pub fn plans_dir() -> Option<PathBuf> {
    [shipped_dir(), PathBuf::from("manifests/bench")]
        .into_iter()
        .find(|d| d.is_dir())
}

/// The plans usable by name: those in [`plans_dir`], else the built-in
/// ones.
pub fn shipped_names() -> Vec<String> {
    let mut names = plans_dir()
        .map(|d| crate::fsio::list_files(&d, "toml"))
        .unwrap_or_default();
    if names.is_empty() {
        names = BUILTIN.iter().map(|b| b.0.to_string()).collect();
    }
    names.sort();
    names
}

/// The kind of head path a plan's frames follow.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PathKind {
    /// Through the scene at standing height ([`super::cull::head_path`]).
    #[default]
    Walk,
    /// Outside the scene's bounds, looking at it ([`super::cull::orbit_path`]).
    Orbit,
}

impl Plan {
    /// The head paths' seeds: `path_seeds`, or `path_seed` alone.
    pub fn seeds(&self) -> Vec<u64> {
        if self.path_seeds.is_empty() {
            vec![self.path_seed]
        } else {
            self.path_seeds.clone()
        }
    }

    /// The refresh rate frames are budgeted at: `budget_ms`'s, else the
    /// profile's.
    pub fn refresh_hz(&self, profile: &crate::view::profile::HmdProfile) -> f64 {
        match self.budget_ms {
            Some(b) => 1000.0 / b,
            None => profile.refresh_hz,
        }
    }

    /// A plan file, or a shipped plan by name: any plan in the shipped
    /// plans' folder ([`plans_dir`]: `manifests/bench/NAME.toml` of the
    /// source tree this binary was built from, or of the working folder),
    /// else one of the plans built into the binary (`smoke`, `default`, `scale`, `in-flight`,
    /// `submission`). A folder of that name (a bench's output folder) does
    /// not hide a plan name; anything else there is read as the plan.
    pub fn resolve(name_or_path: &str) -> Result<Plan> {
        let path = Path::new(name_or_path);
        // Anything there but a folder is read (and refused with its reason
        // when it is not a regular file).
        if path.exists() && !path.is_dir() {
            return Plan::load(path);
        }
        let by_name = !name_or_path.contains(['/', '\\']) && !name_or_path.is_empty();
        if by_name {
            if let Some(dir) = plans_dir() {
                let shipped = dir.join(format!("{name_or_path}.toml"));
                if shipped.is_file() {
                    return Plan::load(&shipped);
                }
            }
        }
        match BUILTIN.iter().find(|(n, _)| *n == name_or_path) {
            Some((n, text)) => {
                let mut plan = Plan::parse(n, text)?;
                plan.base = plans_dir();
                Ok(plan)
            }
            None => Err(Error::config(
                "--plan",
                format!(
                    "{name_or_path}: no such file, and not a shipped plan ({})",
                    shipped_names().join(", ")
                ),
            )),
        }
    }

    /// Reads and validates a plan file; its relative paths resolve against
    /// its folder.
    pub fn load(path: &Path) -> Result<Plan> {
        let text = crate::fsio::read_text(path, crate::fsio::MAX_TEXT_FILE_BYTES)
            .map_err(|e| Error::config("--plan", format!("{}: {e}", path.display())))?;
        let mut plan = Plan::parse(&path.display().to_string(), &text)?;
        plan.base = Some(
            path.parent()
                .filter(|p| !p.as_os_str().is_empty())
                .map_or_else(|| PathBuf::from("."), Path::to_path_buf),
        );
        Ok(plan)
    }

    /// A scene or HMD profile entry of the plan as it is loaded: a path
    /// relative to the plan's folder when a file is there, else the entry
    /// as written (a generated scene such as `factory:N`, a profile name).
    pub fn input_path(&self, entry: &str) -> String {
        match &self.base {
            Some(base) if Path::new(entry).is_relative() => {
                let at = base.join(entry);
                if at.is_file() {
                    at.to_string_lossy().into_owned()
                } else {
                    entry.to_string()
                }
            }
            _ => entry.to_string(),
        }
    }

    /// Parses and validates plan text; `origin` names it in errors.
    pub fn parse(origin: &str, text: &str) -> Result<Plan> {
        let plan: Plan = toml::from_str(text).map_err(|e| {
            // The line the parser stopped at, when it says where.
            let at = e.span().map_or(String::new(), |span| {
                let start = span.start.min(text.len());
                let line = text[..start].matches('\n').count();
                let shown = text.lines().nth(line).unwrap_or("").trim();
                let shown: String = shown
                    .chars()
                    .take(80)
                    .map(|c| if c.is_control() { '?' } else { c })
                    .collect();
                format!("line {} `{shown}`: ", line + 1)
            });
            Error::config("--plan", format!("{origin}: {at}{}", e.message()))
        })?;
        plan.validate()
            .map_err(|m| Error::config("--plan", format!("{origin}: {m}")))?;
        Ok(plan)
    }

    /// Checks the plan's lists are not empty and its numbers are within
    /// their ranges.
    fn validate_numbers(&self) -> std::result::Result<(), String> {
        if self.scenes.is_empty() || self.hmds.is_empty() || self.configs.is_empty() {
            return Err("scenes, hmds and configs must each list at least one entry".into());
        }
        if self.scales.is_empty() {
            return Err("scales must list at least one value".into());
        }
        if let Some(s) = self
            .scales
            .iter()
            .find(|s| !(s.is_finite() && **s > 0.0 && **s <= 4.0))
        {
            return Err(format!("scale {s} must be in (0, 4]"));
        }
        if self.frames == 0 || self.frames > 100_000 {
            return Err(format!("frames = {} must be in 1..=100000", self.frames));
        }
        if !(1..=4).contains(&self.reference_supersample) {
            return Err(format!(
                "reference_supersample = {} must be 1 to 4",
                self.reference_supersample
            ));
        }
        if self.path_seeds.len() > MAX_PATH_SEEDS {
            return Err(format!(
                "path_seeds has {} seeds; at most {MAX_PATH_SEEDS}",
                self.path_seeds.len()
            ));
        }
        let mut seeds = self.path_seeds.clone();
        seeds.sort_unstable();
        seeds.dedup();
        if seeds.len() != self.path_seeds.len() {
            return Err("path_seeds repeats a seed".into());
        }
        if !(self.gaze_latency_ms.is_finite() && (0.0..=500.0).contains(&self.gaze_latency_ms)) {
            return Err(format!(
                "gaze_latency_ms = {} must be 0 to 500",
                self.gaze_latency_ms
            ));
        }
        if !(1..=MAX_REPEATS).contains(&self.repeats) {
            return Err(format!(
                "repeats = {} must be 1 to {MAX_REPEATS}",
                self.repeats
            ));
        }
        if self.flicker_frames == 1 || self.flicker_frames > 120 {
            return Err(format!(
                "flicker_frames = {} must be 0 (off) or 2 to 120",
                self.flicker_frames
            ));
        }
        if let Some(b) = self.budget_ms {
            if !(b.is_finite() && b > 0.0 && b <= 60_000.0) {
                return Err(format!("budget_ms = {b} must be in (0, 60000]"));
            }
        }
        if self.spin_up_ms > 60_000 {
            return Err(format!(
                "spin_up_ms = {} must be at most 60000",
                self.spin_up_ms
            ));
        }
        if self.warmup > 10_000 {
            return Err(format!("warmup = {} must be at most 10000", self.warmup));
        }
        if self.error_frames == 0 {
            return Err(
                "error_frames must be at least 1 (image error needs a compared frame)".into(),
            );
        }
        if self.error_frames > self.frames {
            return Err(format!(
                "error_frames = {} exceeds frames = {}",
                self.error_frames, self.frames
            ));
        }
        Ok(())
    }

    /// Checks the plan: its numbers within their ranges, every
    /// configuration's name and options, the reference and the baseline.
    pub fn validate(&self) -> std::result::Result<(), String> {
        self.validate_numbers()?;
        let mut names = std::collections::BTreeSet::new();
        let mut files = std::collections::BTreeSet::new();
        for c in &self.configs {
            check_config_name(&c.name, &mut names, &mut files)?;
            self.check_timewarp_lead(c)?;
        }
        let reference = self
            .reference_config()
            .map_err(|e| format!("reference: {e}"))?;
        if self.reference_supersample > 1 && reference.effort.aq {
            return Err(format!(
                "reference_supersample = {} renders the reference at a fixed size, which aq in the reference would change: leave aq out of it",
                self.reference_supersample
            ));
        }
        if let Some(b) = &self.baseline {
            if !names.contains(b.as_str()) {
                return Err(format!("baseline '{b}' is not a config name"));
            }
        }
        // The empty-frame floor is drawn with the baseline's renderer and a
        // CPU visible list, which a gpu-cull renderer does not take.
        let base = self.baseline_name();
        if let Some(c) = self.configs.iter().find(|c| c.name == base) {
            if self.config_for(c).is_ok_and(|r| r.culling.gpu_cull) {
                return Err(format!(
                    "baseline '{base}' culls on the GPU (gpu-cull), but the bench draws its empty-frame floor with the baseline's CPU visible list: make a CPU-culled config the baseline"
                ));
            }
        }
        Ok(())
    }

    /// With timewarp, every compared frame is warped from each of the K - 1
    /// frames before it, so that many must precede the first.
    fn check_timewarp_lead(&self, c: &PlanConfig) -> std::result::Result<(), String> {
        let config = self
            .config_for(c)
            .map_err(|e| format!("config '{}': {e}", c.name))?;
        let (Some(tw), Some(&first)) = (
            config.simulator.timewarp,
            self.error_frame_indices().first(),
        ) else {
            return Ok(());
        };
        if self.warmup + first >= tw.k - 1 {
            return Ok(());
        }
        Err(format!(
            "config '{}': timewarp={} warps each compared frame from the {} frames before it, but the first compared frame has {} before it: raise warmup to at least {}",
            c.name,
            tw.k,
            tw.k - 1,
            self.warmup + first,
            tw.k - 1 - first
        ))
    }

    /// Checks what [`Plan::validate`] cannot see from the text alone,
    /// before anything is measured: every scene names a loadable source
    /// ([`crate::scene::Scene::check_spec`]), every HMD profile loads, and
    /// every profile × scale gives a per-eye size within
    /// [`MIN_EYE_PIXELS`]..=[`MAX_EYE_PIXELS`] that FLIP can evaluate at
    /// the profile's pixels per degree. Errors name the scene or profile.
    pub fn check_inputs(&self) -> std::result::Result<(), String> {
        for s in &self.scenes {
            crate::scene::Scene::check_spec(&self.input_path(s))
                .map_err(|e| format!("scene {s}: {e}"))?;
        }
        for h in &self.hmds {
            let p = crate::view::profile::HmdProfile::load(&self.input_path(h))
                .map_err(|e| e.to_string())?;
            if p.views.len() != 2 {
                return Err(format!(
                    "HMD profile {h}: the renderer needs exactly 2 views, it has {}",
                    p.views.len()
                ));
            }
            for &scale in &self.scales {
                for scene in &self.scenes {
                    // The group's image folder name (runner.rs), one path
                    // component: it must fit the usual 255-byte limit.
                    let group = format!("{}-{}-{}", sanitize(scene), sanitize(&p.name), scale);
                    if group.len() > MAX_GROUP_DIR_BYTES {
                        return Err(format!(
                            "scene {scene} with HMD profile {h}: the image folder name would be {} bytes, over {MAX_GROUP_DIR_BYTES}; use a shorter path or profile name",
                            group.len()
                        ));
                    }
                }
                let [w, h_px] = p.views[0].resolution;
                let px = |v: u32| (v as f64 * scale).round();
                let (sw, sh) = (px(w), px(h_px));
                let range = MIN_EYE_PIXELS as f64..=MAX_EYE_PIXELS as f64;
                if !(range.contains(&sw) && range.contains(&sh)) {
                    return Err(format!(
                        "HMD profile {h}: scale {scale} gives {sw}x{sh} px per eye (from {w}x{h_px}); each side must be within {MIN_EYE_PIXELS}..={MAX_EYE_PIXELS}"
                    ));
                }
                let fov = &p.views[0].fov;
                let ppd = (super::metrics::headset_ppd(sw as u32, fov.left, fov.right) as f64)
                    .max(super::metrics::MIN_FLIP_PPD);
                super::metrics::check_flip(sw as u32, sh as u32, ppd as f32).map_err(|m| {
                    format!("HMD profile {h} at scale {scale} ({sw}x{sh} px, {ppd:.0} pixels per degree): {m}")
                })?;
            }
        }
        Ok(())
    }

    /// The renderer configuration of `c`: its `--opt` list over the
    /// defaults, with its frames in flight (or the plan's).
    pub fn config_for(&self, c: &PlanConfig) -> Result<RenderConfig> {
        let mut config = self.with_frames_in_flight(&c.opt, c.frames_in_flight)?;
        config.submission.record_threads = c.record_threads;
        config.submission.per_draw = c.per_draw.unwrap_or_default();
        config.validate()?;
        Ok(config)
    }

    /// The image reference's renderer configuration (the plan's frames in
    /// flight; they change timing, not pixels).
    pub fn reference_config(&self) -> Result<RenderConfig> {
        let c = self.with_frames_in_flight(&self.reference, None)?;
        c.refuse_timewarp("reference")?;
        Ok(c)
    }

    fn with_frames_in_flight(&self, opt: &str, own: Option<u32>) -> Result<RenderConfig> {
        let mut c = RenderConfig::default();
        c.apply_opts(opt, &cull_names())?;
        c.submission.frames_in_flight = own.unwrap_or(self.frames_in_flight);
        c.validate()?;
        Ok(c)
    }

    /// The baseline configuration's name.
    pub fn baseline_name(&self) -> &str {
        self.baseline
            .as_deref()
            .unwrap_or_else(|| self.configs[0].name.as_str())
    }

    /// Indices (into the measured frames) of the frames compared with the
    /// reference: evenly spaced, the last measured frame always included.
    pub fn error_frame_indices(&self) -> Vec<u32> {
        let (n, k) = (self.frames, self.error_frames);
        (1..=k)
            .map(|i| (i as u64 * n as u64 / k as u64) as u32 - 1)
            .collect()
    }
}

/// A name made safe for a file name.
pub fn sanitize(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

pub use crate::config::cull_names;

/// The renderer configuration an `--opt` list gives over the defaults.
pub fn config_from_opt(opt: &str) -> Result<RenderConfig> {
    let mut c = RenderConfig::default();
    c.apply_opts(opt, &cull_names())?;
    c.validate()?;
    Ok(c)
}

/// A configuration's name: non-empty, short, without separators or
/// control characters, not `reference`, not repeated, and not giving an
/// image file name (NAME.png, NAME.flip.png, NAME.flicker.png) another
/// configuration or the reference also writes.
fn check_config_name<'a>(
    name: &'a str,
    names: &mut std::collections::BTreeSet<&'a str>,
    files: &mut std::collections::BTreeSet<String>,
) -> std::result::Result<(), String> {
    if name.trim().is_empty() || name.contains(['/', '\\', ',']) {
        return Err(format!(
            "config name '{name}' must be non-empty without / \\ or ,"
        ));
    }
    if name.chars().count() > MAX_CONFIG_NAME_CHARS || name.chars().any(char::is_control) {
        return Err(format!(
            "config name {:?} must be at most {MAX_CONFIG_NAME_CHARS} characters without control characters (it names image files and report rows)",
            name.chars().take(80).collect::<String>()
        ));
    }
    if name == "reference" {
        return Err("config name 'reference' is reserved for the image reference".into());
    }
    if !names.insert(name) {
        return Err(format!("config name '{name}' appears twice"));
    }
    let stem = sanitize(name);
    for file in [
        stem.clone(),
        format!("{stem}.flip"),
        format!("{stem}.flicker"),
    ] {
        if file == "reference" || !files.insert(file.clone()) {
            return Err(format!(
                "config name '{name}' gives the image file name {file}.png, which another configuration or the reference also writes"
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const MIN: &str = r#"
name = "t"
scenes = ["factory:10"]
hmds = ["monado-sim"]
frames = 4
[[configs]]
name = "a"
opt = "two-pass"
"#;

    #[test]
    fn minimal_plan_gets_defaults() {
        let p = Plan::parse("t", MIN).unwrap();
        assert_eq!(p.scales, vec![1.0]);
        assert_eq!(p.reference, "two-pass");
        assert_eq!(p.baseline_name(), "a");
        assert_eq!(p.error_frame_indices(), vec![1, 3]);
    }

    #[test]
    fn bad_plans_are_named() {
        for (edit, want, says) in [
            ("frames = 4", "frames = 0", "frames = 0 must be"),
            ("opt = \"two-pass\"", "opt = \"warp-drive\"", "warp-drive"),
            ("hmds = [\"monado-sim\"]", "hmds = []", "at least one entry"),
            (
                "frames = 4",
                "frames = 4\nscales = [0.0]",
                "scale 0 must be",
            ),
            (
                "frames = 4",
                "frames = 4\nbaseline = \"zz\"",
                "baseline 'zz'",
            ),
            (
                "frames = 4",
                "frames = 4\nerror_frames = 9",
                "exceeds frames",
            ),
            ("frames = 4", "frames = 4\nerror_frames = 0", "at least 1"),
            ("frames = 4", "frames = 4\ncolour = 1", "colour"),
            (
                "opt = \"two-pass\"",
                "opt = \"multiview,superfrustum,gpu-cull\"",
                "culls on the GPU",
            ),
            ("name = \"a\"", "name = \"reference\"", "reserved"),
            (
                "frames = 4",
                "frames = 4\nframes_in_flight = 4",
                "--frames-in-flight",
            ),
            (
                "opt = \"two-pass\"",
                "opt = \"two-pass\"\nframes_in_flight = 0",
                "config 'a'",
            ),
            (
                "opt = \"two-pass\"",
                "opt = \"two-pass\"\nrecord_threads = 0",
                "--record-threads",
            ),
            (
                "opt = \"two-pass\"",
                "opt = \"two-pass\"\nper_draw = \"uniform\"",
                "per_draw",
            ),
            (
                "opt = \"two-pass\"",
                "opt = \"two-pass,superfrustum,gpu-cull\"\nper_draw = \"ssbo\"",
                "cannot be combined with gpu-cull",
            ),
            (
                "opt = \"two-pass\"",
                "opt = \"two-pass\"\n[[configs]]\nname = \"a b\"\n[[configs]]\nname = \"a_b\"",
                "which another configuration or the reference also writes",
            ),
            (
                "opt = \"two-pass\"",
                "opt = \"two-pass\"\n[[configs]]\nname = \"x\"\n[[configs]]\nname = \"x.flip\"",
                "x.flip.png, which another configuration",
            ),
        ] {
            let text = MIN.replace(edit, want);
            assert_ne!(text, MIN, "{want}");
            let err = Plan::parse("t", &text).unwrap_err().to_string();
            assert!(
                err.contains("--plan") && err.contains("t:") && err.contains(says),
                "{want}: {err}"
            );
        }
    }

    #[test]
    fn shipped_plans_parse() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("manifests/bench");
        for name in ["smoke", "default", "scale", "in-flight", "submission"] {
            let p = Plan::load(&dir.join(format!("{name}.toml"))).unwrap();
            assert_eq!(p.name, name);
        }
    }
}
