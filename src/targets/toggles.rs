//! Live toggles: keys of the desktop window (`view`, and `run`'s mirror)
//! that switch an optimization while the loop runs. Each key press gives a
//! new [`RenderConfig`]; the loop rebuilds the renderer with it (the window,
//! the session and the scene stay) and the frame records show it from the
//! next frame on. The current `--opt` string is printed on every change
//! and a key writes it to a config file that `--config` reads.

use crate::config::{Culling, Mffr, RenderConfig, StereoMode};
use crate::cull::Strategy;
use crate::error::Result;
use crate::view::foveation::Level;
use std::path::{Path, PathBuf};
use winit::keyboard::KeyCode;

/// An optimization a key switches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Toggle {
    /// Multiview ↔ two-pass.
    Stereo,
    /// none → each culling strategy in turn → none.
    Cull,
    /// The HMD stencil mask on/off.
    StencilMask,
    /// Foveation off → low → medium → high → off.
    Foveation,
    /// Radial density masking on/off (default radius).
    Rdm,
    /// Monoscopic far-field rendering on/off.
    Mffr,
    /// MSAA 4× ↔ 1×.
    Msaa,
    /// GPU-driven culling on/off (needs a culling strategy).
    GpuCull,
    /// Hierarchical-Z occlusion culling on/off (needs GPU culling).
    Occlusion,
    /// Level of detail on/off at the default error bound (needs GPU
    /// culling).
    Lod,
    /// Multi-resolution foveated rendering (`inset`) on/off.
    Inset,
    /// Adaptive quality (`aq`) on/off (`run` only: `view` refuses it).
    Aq,
}

impl Toggle {
    /// Every toggle, in key order (keys 1 to 9, then 0, F6, F7).
    pub const ALL: [Toggle; 12] = [
        Toggle::Stereo,
        Toggle::Cull,
        Toggle::StencilMask,
        Toggle::Foveation,
        Toggle::Rdm,
        Toggle::Mffr,
        Toggle::Msaa,
        Toggle::GpuCull,
        Toggle::Occlusion,
        Toggle::Lod,
        Toggle::Inset,
        Toggle::Aq,
    ];

    /// The name used in kiosk files and messages.
    pub fn name(self) -> &'static str {
        match self {
            Toggle::Stereo => "stereo",
            Toggle::Cull => "cull",
            Toggle::StencilMask => "stencil-mask",
            Toggle::Foveation => "foveation",
            Toggle::Rdm => "rdm",
            Toggle::Mffr => "mffr",
            Toggle::Msaa => "msaa",
            Toggle::GpuCull => "gpu-cull",
            Toggle::Occlusion => "occlusion",
            Toggle::Lod => "lod",
            Toggle::Inset => "inset",
            Toggle::Aq => "aq",
        }
    }

    /// Its key's name in the listing: the digit, or the function key.
    pub fn key_label(self) -> String {
        match Toggle::ALL.iter().position(|t| *t == self).unwrap_or(0) {
            i @ 0..=9 => ((i + 1) % 10).to_string(),
            i => format!("F{}", i - 4),
        }
    }

    /// Its key: the digit of its place in [`Toggle::ALL`] (F6, F7 after 0).
    pub fn key(self) -> KeyCode {
        const KEYS: [KeyCode; 12] = [
            KeyCode::Digit1,
            KeyCode::Digit2,
            KeyCode::Digit3,
            KeyCode::Digit4,
            KeyCode::Digit5,
            KeyCode::Digit6,
            KeyCode::Digit7,
            KeyCode::Digit8,
            KeyCode::Digit9,
            KeyCode::Digit0,
            KeyCode::F6,
            KeyCode::F7,
        ];
        KEYS[Toggle::ALL.iter().position(|t| *t == self).unwrap_or(0)]
    }

    fn describe(self) -> &'static str {
        match self {
            Toggle::Stereo => "stereo mode: multiview / two-pass",
            Toggle::Cull => "culling: none, then each strategy in turn",
            Toggle::StencilMask => "HMD stencil mask on / off",
            Toggle::Foveation => "foveation: off, low, medium, high",
            Toggle::Rdm => "radial density masking on / off",
            Toggle::Mffr => "monoscopic far-field rendering on / off",
            Toggle::Msaa => "MSAA: 4x / 1x",
            Toggle::GpuCull => "GPU-driven culling on / off (needs a strategy)",
            Toggle::Occlusion => "occlusion culling on / off (needs GPU culling)",
            Toggle::Lod => "level of detail on / off (needs GPU culling)",
            Toggle::Inset => "multi-resolution foveated rendering (inset) on / off",
            Toggle::Aq => "adaptive quality on / off (run only)",
        }
    }

    /// What this toggle shows for `config`: a short label of its current
    /// setting and whether the optimization is on (the panel's buttons).
    pub fn state(self, c: &RenderConfig) -> (String, bool) {
        match self {
            Toggle::Stereo => (
                c.frame.stereo.name().to_string(),
                c.frame.stereo == StereoMode::Multiview,
            ),
            Toggle::Cull => (
                format!("cull: {}", c.culling.cull.name()),
                c.culling.cull != Culling::None,
            ),
            Toggle::StencilMask => ("stencil mask".into(), c.effort.stencil_mask),
            Toggle::Foveation => (
                match c.effort.foveation {
                    Level::Off => "foveation".to_string(),
                    Level::Low => "fov: low".into(),
                    Level::Medium => "fov: medium".into(),
                    Level::High => "fov: high".into(),
                    Level::Lens(_) => "fov: lens".into(),
                },
                c.effort.foveation != Level::Off,
            ),
            Toggle::Rdm => ("RDM".into(), c.effort.rdm.is_some()),
            Toggle::Mffr => ("MFFR".into(), c.effort.mffr.is_some()),
            Toggle::Msaa => (format!("MSAA {}x", c.frame.msaa), c.frame.msaa > 1),
            Toggle::GpuCull => ("GPU cull".into(), c.culling.gpu_cull),
            Toggle::Occlusion => ("occlusion".into(), c.culling.occlusion),
            Toggle::Lod => ("LOD".into(), c.culling.lod.is_some()),
            Toggle::Inset => ("inset".into(), c.effort.inset.is_some()),
            Toggle::Aq => ("AQ".into(), c.effort.aq),
        }
    }

    /// `config` with this optimization switched (not yet validated).
    pub fn apply(self, config: &RenderConfig) -> RenderConfig {
        let mut c = config.clone();
        match self {
            Toggle::Stereo => {
                c.frame.stereo = match c.frame.stereo {
                    StereoMode::Multiview => StereoMode::TwoPass,
                    StereoMode::TwoPass => StereoMode::Multiview,
                }
            }
            Toggle::Cull => {
                let order: Vec<Culling> = std::iter::once(Culling::None)
                    .chain(Strategy::ALL.iter().map(|s| Culling::Strategy(*s)))
                    .collect();
                let at = order.iter().position(|x| *x == c.culling.cull).unwrap_or(0);
                c.culling.cull = order[(at + 1) % order.len()];
                if c.culling.cull == Culling::None {
                    // GPU culling runs a strategy: it goes off with culling,
                    // and what runs inside it too.
                    c.culling.gpu_cull = false;
                    c.culling.occlusion = false;
                    c.culling.lod = None;
                    c.culling.lod_cache = false;
                }
            }
            Toggle::StencilMask => c.effort.stencil_mask = !c.effort.stencil_mask,
            Toggle::Foveation => {
                c.effort.foveation = match c.effort.foveation {
                    Level::Off => Level::Low,
                    Level::Low => Level::Medium,
                    Level::Medium => Level::High,
                    Level::High | Level::Lens(_) => Level::Off,
                }
            }
            Toggle::Rdm => {
                c.effort.rdm = match c.effort.rdm {
                    Some(_) => None,
                    None => Some(crate::config::DEFAULT_RDM_RADIUS),
                }
            }
            Toggle::Mffr => {
                c.effort.mffr = match c.effort.mffr {
                    Some(_) => None,
                    None => Some(Mffr::default()),
                }
            }
            Toggle::Msaa => c.frame.msaa = if c.frame.msaa == 1 { 4 } else { 1 },
            Toggle::GpuCull => {
                c.culling.gpu_cull = !c.culling.gpu_cull;
                if !c.culling.gpu_cull {
                    // Both run inside GPU culling: they go off with it.
                    c.culling.occlusion = false;
                    c.culling.lod = None;
                    c.culling.lod_cache = false;
                }
            }
            Toggle::Occlusion => c.culling.occlusion = !c.culling.occlusion,
            Toggle::Lod => {
                c.culling.lod = match c.culling.lod {
                    Some(_) => None,
                    None => Some(crate::view::lod::DEFAULT_BOUND_PX),
                };
                c.culling.lod_cache = c.culling.lod.is_some() && c.culling.lod_cache;
            }
            Toggle::Inset => {
                c.effort.inset = match c.effort.inset {
                    Some(_) => None,
                    None => Some(crate::config::Inset::default()),
                }
            }
            Toggle::Aq => c.effort.aq = !c.effort.aq,
        }
        c
    }
}

impl std::str::FromStr for Toggle {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Toggle, String> {
        Toggle::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown toggle '{s}' (known: {})",
                    Toggle::ALL.map(|t| t.name()).join(", ")
                )
            })
    }
}

/// What a key does besides moving the fly camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeyAction {
    /// Switch an optimization.
    Toggle(Toggle),
    /// Print the key listing (F1 or H).
    Help,
    /// Print the current `--opt` string (P).
    Print,
    /// Write the current `--opt` string to the config file (F2).
    Save,
}

/// The action of `key`, if it has one.
pub fn action(key: KeyCode) -> Option<KeyAction> {
    match key {
        KeyCode::F1 | KeyCode::KeyH => Some(KeyAction::Help),
        KeyCode::KeyP => Some(KeyAction::Print),
        KeyCode::F2 => Some(KeyAction::Save),
        k => Toggle::ALL
            .into_iter()
            .find(|t| t.key() == k)
            .map(KeyAction::Toggle),
    }
}

/// The key listing (printed on F1/H, and in docs/guide.md).
pub fn help(allowed: &[Toggle], save_to: &Path) -> String {
    let mut s = String::from("keys:\n");
    for t in Toggle::ALL.iter() {
        if allowed.contains(t) {
            s.push_str(&format!("  {:<8} {}\n", t.key_label(), t.describe()));
        }
    }
    s.push_str("  P        print the current --opt string\n");
    s.push_str(&format!(
        "  F2       write it to {} (read it with --config)\n",
        save_to.display()
    ));
    s.push_str("  F1, H    this listing\n");
    s.push_str("  Escape   quit (closing the window does too)");
    s
}

/// One switch made while running, as `--stats-out` lists it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ToggleEvent {
    /// The first frame rendered with the new configuration.
    pub frame: u64,
    /// The toggle's name.
    pub toggle: String,
    /// The `--opt` string from that frame on.
    pub opt: String,
}

/// One switch refused while running (not allowed here, or an invalid
/// combination), as `--stats-out` lists it and the kiosk log says it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RefusedToggle {
    /// The frame the key was pressed before.
    pub frame: u64,
    /// The toggle's name.
    pub toggle: String,
    /// Why it was refused.
    pub why: String,
}

/// The live configuration of a window's loop and what its keys did.
#[derive(Debug)]
pub struct LiveConfig {
    /// The configuration the loop renders with.
    pub config: RenderConfig,
    /// Toggles the keys may use (all but a kiosk's restrictions).
    pub allowed: Vec<Toggle>,
    /// Where F2 writes the config file.
    pub save_to: PathBuf,
    /// Every switch made, in order.
    pub events: Vec<ToggleEvent>,
    /// Every switch refused, in order.
    pub refused: Vec<RefusedToggle>,
    /// Added to the loop's frame numbers in `events` and `refused`: the
    /// frames of the run before this loop (a kiosk's earlier scenes), so
    /// they count over the whole run as `--stats-out`'s frames do.
    pub frame_base: u64,
    /// More lines for the key listing (a kiosk's N for the next scene).
    pub extra_help: Option<String>,
}

/// Where F2 writes by default.
pub const DEFAULT_SAVE_PATH: &str = "vergence-live.toml";

impl LiveConfig {
    /// Starts from `config` with every toggle allowed.
    pub fn new(config: RenderConfig, save_to: Option<PathBuf>) -> LiveConfig {
        LiveConfig {
            config,
            allowed: Toggle::ALL.to_vec(),
            save_to: save_to.unwrap_or_else(|| PathBuf::from(DEFAULT_SAVE_PATH)),
            events: Vec::new(),
            refused: Vec::new(),
            frame_base: 0,
            extra_help: None,
        }
    }

    /// The config file text for the current configuration.
    pub fn file_text(&self) -> String {
        format!(
            "# Written by vergence's live toggles (F2); use with --config.\nopt = {:?}\n",
            self.config.opt_string()
        )
    }

    /// Handles the keys `pressed` this frame; `next_frame` is the index of
    /// the next frame the loop renders. Returns the new configuration when
    /// a toggle changed it (the caller rebuilds its renderer with it). A
    /// toggle that would give an invalid combination is refused with one
    /// line on stderr; everything else prints one line on stdout.
    pub fn handle(&mut self, pressed: &[KeyCode], next_frame: u64) -> Option<RenderConfig> {
        let mut changed = false;
        for &key in pressed {
            match action(key) {
                None => {}
                Some(KeyAction::Help) => {
                    println!("{}", help(&self.allowed, &self.save_to));
                    if let Some(more) = &self.extra_help {
                        println!("{more}");
                    }
                }
                Some(KeyAction::Print) => println!("opt: {}", self.config.opt_string()),
                Some(KeyAction::Save) => match self.save() {
                    Ok(()) => println!(
                        "wrote {} (opt = \"{}\"; use: --config {})",
                        self.save_to.display(),
                        self.config.opt_string(),
                        self.save_to.display()
                    ),
                    Err(e) => eprintln!("vergence: cannot write the config file: {e}"),
                },
                Some(KeyAction::Toggle(t)) => changed |= self.switch(t, next_frame).is_some(),
            }
        }
        changed.then(|| self.config.clone())
    }

    /// Switches `t` (a key or a panel button) from frame `next_frame` on:
    /// the new configuration, or None when `t` is not allowed here or would
    /// give an invalid combination (refused with one line on stderr; a
    /// switch prints one line on stdout).
    pub fn switch(&mut self, t: Toggle, next_frame: u64) -> Option<RenderConfig> {
        let frame = self.frame_base + next_frame;
        if !self.allowed.contains(&t) {
            eprintln!("vergence: the {} toggle is not allowed here", t.name());
            self.refuse(t, frame, "not allowed here".into());
            return None;
        }
        let next = t.apply(&self.config);
        match next.validate() {
            Ok(()) => {
                self.config = next;
                let opt = self.config.opt_string();
                println!("opt: {opt} ({} switched)", t.name());
                tracing::info!("live toggle {} at frame {frame}: {opt}", t.name());
                self.events.push(ToggleEvent {
                    frame,
                    toggle: t.name().into(),
                    opt,
                });
                Some(self.config.clone())
            }
            Err(e) => {
                eprintln!("vergence: {} not switched: {e}", t.name());
                self.refuse(t, frame, e.to_string());
                None
            }
        }
    }

    /// Records a refused switch and says it in the log (the kiosk log
    /// too).
    fn refuse(&mut self, t: Toggle, frame: u64, why: String) {
        tracing::info!("live toggle {} refused at frame {frame}: {why}", t.name());
        self.refused.push(RefusedToggle {
            frame,
            toggle: t.name().into(),
            why,
        });
    }

    /// Goes back to `old` after the loop could not render with the last
    /// switch (its renderer failed to build): the switch leaves the log.
    pub fn revert(&mut self, old: RenderConfig, why: &crate::error::Error) {
        eprintln!(
            "vergence: cannot render with {} ({why}); back to {}",
            self.config.opt_string(),
            old.opt_string()
        );
        self.events.pop();
        self.config = old;
    }

    /// Writes the config file.
    pub fn save(&self) -> Result<()> {
        crate::fsio::write_bytes(&self.save_to, self.file_text().as_bytes())
    }
}

/// Checks a toggle list (kiosk files): names known, none twice.
pub fn parse_list(names: &[String]) -> std::result::Result<Vec<Toggle>, String> {
    let mut out: Vec<Toggle> = Vec::new();
    for n in names {
        let t: Toggle = n.parse()?;
        if out.contains(&t) {
            return Err(format!("toggle '{n}' is listed twice"));
        }
        out.push(t);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_toggle_has_its_own_key_and_flips_back() {
        let keys: Vec<KeyCode> = Toggle::ALL.iter().map(|t| t.key()).collect();
        for (i, k) in keys.iter().enumerate() {
            assert!(!keys[..i].contains(k));
            assert_eq!(action(*k), Some(KeyAction::Toggle(Toggle::ALL[i])));
        }
        let start = RenderConfig::default();
        for t in [
            Toggle::Stereo,
            Toggle::StencilMask,
            Toggle::Rdm,
            Toggle::Mffr,
            Toggle::Msaa,
        ] {
            let once = t.apply(&start);
            assert_ne!(once, start, "{t:?}");
            assert_eq!(t.apply(&once), start, "{t:?} twice");
        }
        let mut c = start.clone();
        for _ in 0..4 {
            c = Toggle::Foveation.apply(&c);
        }
        assert_eq!(c, start, "four foveation steps come back");
        let mut c = start.clone();
        for _ in 0..=Strategy::ALL.len() {
            c = Toggle::Cull.apply(&c);
        }
        assert_eq!(c, start, "the culling cycle comes back to none");
    }

    #[test]
    fn a_toggle_is_logged_from_the_next_frame_and_invalid_ones_are_refused() {
        let mut live = LiveConfig::new(RenderConfig::default(), None);
        assert_eq!(live.handle(&[KeyCode::KeyW], 5), None);
        // GPU culling without a strategy is invalid: refused.
        assert_eq!(live.handle(&[KeyCode::Digit8], 5), None);
        let c = live.handle(&[KeyCode::Digit3], 7).expect("changed");
        assert!(c.effort.stencil_mask);
        assert_eq!(
            live.events,
            vec![ToggleEvent {
                frame: 7,
                toggle: "stencil-mask".into(),
                opt: "multiview,msaa4,none,stencil-mask".into()
            }]
        );
        live.allowed = vec![Toggle::Msaa];
        // A later scene of a kiosk: frames count on over the run.
        live.frame_base = 100;
        assert_eq!(live.handle(&[KeyCode::Digit3], 8), None, "not allowed");
        let refused: Vec<(u64, &str)> = live
            .refused
            .iter()
            .map(|r| (r.frame, r.toggle.as_str()))
            .collect();
        assert_eq!(refused, [(5, "gpu-cull"), (108, "stencil-mask")]);
        assert!(
            live.refused[0].why.contains("gpu-cull"),
            "{:?}",
            live.refused
        );
        assert_eq!(live.refused[1].why, "not allowed here");
        assert!(live
            .file_text()
            .contains("opt = \"multiview,msaa4,none,stencil-mask\""));
        assert!(help(&live.allowed, &live.save_to).contains("MSAA"));
        assert!(!help(&live.allowed, &live.save_to).contains("stencil"));
    }

    #[test]
    fn occlusion_and_lod_need_gpu_culling_and_go_off_with_it() {
        let mut live = LiveConfig::new(RenderConfig::default(), None);
        assert_eq!(live.handle(&[KeyCode::Digit9], 1), None, "no GPU culling");
        assert_eq!(live.handle(&[KeyCode::Digit0], 1), None, "no GPU culling");
        live.handle(&[KeyCode::Digit2], 1).expect("a strategy");
        live.handle(&[KeyCode::Digit8], 2).expect("GPU culling");
        let c = live.handle(&[KeyCode::Digit9], 3).expect("occlusion");
        assert!(c.culling.occlusion);
        let c = live.handle(&[KeyCode::Digit0], 4).expect("LOD");
        assert_eq!(c.culling.lod, Some(crate::view::lod::DEFAULT_BOUND_PX));
        assert!(c.opt_string().contains("occlusion") && c.opt_string().contains("lod"));
        assert_eq!(Toggle::Lod.apply(&c).culling.lod, None, "LOD flips back");
        let off = live.handle(&[KeyCode::Digit8], 5).expect("GPU culling off");
        assert!(!off.culling.gpu_cull && !off.culling.occlusion && off.culling.lod.is_none());
        assert!(help(&Toggle::ALL, &live.save_to).contains("  0        level of detail"));
        assert!(help(&Toggle::ALL, &live.save_to).contains("  F7       adaptive quality"));
        assert_eq!(Toggle::Inset.key(), KeyCode::F6);
    }

    #[test]
    fn toggle_lists_parse() {
        let ok = parse_list(&["msaa".into(), "cull".into()]).unwrap();
        assert_eq!(ok, vec![Toggle::Msaa, Toggle::Cull]);
        assert!(parse_list(&["warp".into()])
            .unwrap_err()
            .contains("unknown toggle"));
        assert!(parse_list(&["msaa".into(), "msaa".into()])
            .unwrap_err()
            .contains("twice"));
    }
}
