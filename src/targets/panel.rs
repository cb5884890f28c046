//! The in-headset panel's contents: a fixed grid of buttons (the trigger's
//! tools, the live toggles, close) over a status line, laid out in panel
//! coordinates so the hand's ray ([`crate::interact::panel`]) and the
//! drawing agree on where each button is, and drawn with egui into the
//! panel's image (`targets::xr_panel` submits it as a quad layer).

use super::toggles::Toggle;
use crate::config::RenderConfig;
use crate::gpu::ui_layer::UiFrame;
use crate::interact::Tool;

/// `run --panel`: whether the menu button opens the in-headset panel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum PanelMode {
    /// The menu button opens and closes the panel.
    #[default]
    On,
    /// No panel: the menu button cycles the trigger's tools.
    Off,
}

/// The panel image's size in pixels (the quad's aspect, 0.64 × 0.40 m).
pub const SIZE_PX: [u32; 2] = [1024, 640];
/// Longest selection line, characters (it stays left of the close button).
const SELECTION_CHARS: usize = 56;

/// The panel's line for what the select tool named: the node (or mesh)
/// name, its material, the distance; cut to [`SELECTION_CHARS`] with an
/// ellipsis.
pub fn selection_line(p: &crate::interact::Picked) -> String {
    let name = p.node.as_deref().unwrap_or(&p.mesh);
    let line = format!(
        "selected: {name} ({}, {}), {:.2} m away",
        p.mesh, p.material, p.distance_m
    );
    if line.chars().count() <= SELECTION_CHARS {
        return line;
    }
    let mut cut: String = line.chars().take(SELECTION_CHARS - 1).collect();
    cut.push('…');
    cut
}

/// Pixels per egui point: the layout is in points of half a pixel's
/// density, so text stays legible at arm's length.
const PIXELS_PER_POINT: f32 = 2.0;

/// What a panel button does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Button {
    /// Puts a tool on the trigger.
    Tool(Tool),
    /// Switches an optimization (as its key does on the desk).
    Toggle(Toggle),
    /// Closes the panel.
    Close,
}

impl Button {
    /// Its name in the frame records (`panel_button` events).
    pub fn name(self) -> String {
        match self {
            Button::Tool(t) => format!("tool:{}", t.name()),
            Button::Toggle(t) => format!("toggle:{}", t.name()),
            Button::Close => "close".into(),
        }
    }
}

/// Panel coordinates of a rectangle: left, top, right, bottom, 0..1 from
/// the top-left corner.
pub type Rect = [f64; 4];

/// Every button and its rectangle: the tools in one row, the toggles in
/// two rows of six, close at the bottom right.
pub fn layout() -> Vec<(Button, Rect)> {
    let (m, gap) = (0.03, 0.015);
    let row = |top: f64, bottom: f64, n: usize| {
        let w = (1.0 - 2.0 * m - gap * (n - 1) as f64) / n as f64;
        (0..n).map(move |i| {
            let l = m + i as f64 * (w + gap);
            [l, top, l + w, bottom]
        })
    };
    let mut out: Vec<(Button, Rect)> = Tool::ALL
        .iter()
        .zip(row(0.22, 0.38, 3))
        .map(|(t, r)| (Button::Tool(*t), r))
        .collect();
    let toggles: Vec<Rect> = row(0.44, 0.60, 6).chain(row(0.63, 0.79, 6)).collect();
    out.extend(
        Toggle::ALL
            .iter()
            .zip(toggles)
            .map(|(t, r)| (Button::Toggle(*t), r)),
    );
    out.push((Button::Close, [0.72, 0.84, 1.0 - m, 0.96]));
    out
}

/// The button at panel coordinates `uv`, if any.
pub fn button_at(uv: [f64; 2]) -> Option<Button> {
    layout()
        .into_iter()
        .find(|(_, r)| (r[0]..=r[2]).contains(&uv[0]) && (r[1]..=r[3]).contains(&uv[1]))
        .map(|(b, _)| b)
}

/// The centre of `button`'s rectangle (where a test aims).
pub fn centre_of(button: Button) -> Option<[f64; 2]> {
    layout()
        .into_iter()
        .find(|(b, _)| *b == button)
        .map(|(_, r)| [(r[0] + r[2]) * 0.5, (r[1] + r[3]) * 0.5])
}

/// What the panel shows this frame.
pub struct PanelState<'a> {
    /// The trigger's tool.
    pub tool: Tool,
    /// The configuration the frames render with.
    pub config: &'a RenderConfig,
    /// Toggles allowed here (a kiosk's list; the others are greyed out).
    pub allowed: &'a [Toggle],
    /// Where each hand's ray meets the panel.
    pub pointers: [Option<[f64; 2]>; 2],
    /// Last finished frame's GPU and CPU milliseconds, and the budget.
    pub times_ms: Option<(f64, f64, f64)>,
    /// What the select tool last named (one line), if anything.
    pub selected: Option<String>,
}

/// Background (linear RGBA, premultiplied): the image is cleared to it
/// and egui paints over it.
pub const BACKGROUND: [f32; 4] = [0.012, 0.012, 0.016, 0.92];
/// A button whose option is on (or the current tool).
pub const ON: egui::Color32 = egui::Color32::from_rgb(40, 110, 200);
/// A button whose option is off.
pub const OFF: egui::Color32 = egui::Color32::from_rgb(62, 62, 72);
/// A toggle not allowed here.
pub const DISABLED: egui::Color32 = egui::Color32::from_rgb(35, 35, 38);
/// The outline of the button a ray points at.
pub const HOVER: egui::Color32 = egui::Color32::from_rgb(255, 210, 0);
/// The pointer dot (the rays' magenta).
pub const POINTER: egui::Color32 = egui::Color32::from_rgb(255, 0, 255);

/// The panel's egui context (its own, apart from the desk overlay's).
pub struct PanelUi {
    ctx: egui::Context,
    started: std::time::Instant,
}

impl Default for PanelUi {
    fn default() -> Self {
        PanelUi::new()
    }
}

impl PanelUi {
    /// A fresh context.
    pub fn new() -> PanelUi {
        let ctx = egui::Context::default();
        ctx.set_pixels_per_point(PIXELS_PER_POINT);
        PanelUi {
            ctx,
            started: std::time::Instant::now(),
        }
    }

    /// Lays out and tessellates one frame of the panel.
    pub fn frame(&mut self, state: &PanelState) -> UiFrame {
        let pts = egui::vec2(
            SIZE_PX[0] as f32 / PIXELS_PER_POINT,
            SIZE_PX[1] as f32 / PIXELS_PER_POINT,
        );
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, pts)),
            time: Some(self.started.elapsed().as_secs_f64()),
            ..egui::RawInput::default()
        };
        let at = |uv: [f64; 2]| egui::pos2(uv[0] as f32 * pts.x, uv[1] as f32 * pts.y);
        let rect = |r: &Rect| egui::Rect::from_min_max(at([r[0], r[1]]), at([r[2], r[3]]));
        let hovered: Vec<Button> = state
            .pointers
            .iter()
            .flatten()
            .filter_map(|uv| button_at(*uv))
            .collect();
        let output = self.ctx.run(input, |ctx| {
            let painter = ctx.layer_painter(egui::LayerId::background());
            let text = egui::Color32::from_gray(240);
            let font = |size: f32| egui::FontId::proportional(size);
            painter.text(
                at([0.03, 0.05]),
                egui::Align2::LEFT_CENTER,
                "vergence",
                font(18.0),
                egui::Color32::WHITE,
            );
            painter.text(
                at([0.03, 0.13]),
                egui::Align2::LEFT_CENTER,
                state.config.opt_string(),
                font(11.0),
                text,
            );
            if let Some((gpu, cpu, budget)) = state.times_ms {
                painter.text(
                    at([0.97, 0.05]),
                    egui::Align2::RIGHT_CENTER,
                    format!("GPU {gpu:.2} ms  CPU {cpu:.2} ms  budget {budget:.2} ms"),
                    font(11.0),
                    text,
                );
            }
            for (button, r) in layout() {
                let (label, fill) = match button {
                    Button::Tool(t) => {
                        (t.name().to_string(), if t == state.tool { ON } else { OFF })
                    }
                    Button::Toggle(t) => {
                        let (label, on) = t.state(state.config);
                        let fill = if !state.allowed.contains(&t) {
                            DISABLED
                        } else if on {
                            ON
                        } else {
                            OFF
                        };
                        (label, fill)
                    }
                    Button::Close => ("close".to_string(), OFF),
                };
                let r = rect(&r);
                painter.rect_filled(r, 4.0, fill);
                if hovered.contains(&button) {
                    painter.rect_stroke(
                        r,
                        4.0,
                        egui::Stroke::new(2.0, HOVER),
                        egui::StrokeKind::Inside,
                    );
                }
                painter.text(
                    r.center(),
                    egui::Align2::CENTER_CENTER,
                    label,
                    font(13.0),
                    text,
                );
            }
            if let Some(sel) = &state.selected {
                painter.text(
                    at([0.03, 0.855]),
                    egui::Align2::LEFT_CENTER,
                    sel,
                    font(11.0),
                    text,
                );
            }
            painter.text(
                at([0.03, 0.93]),
                egui::Align2::LEFT_CENTER,
                "menu: close   trigger: press",
                font(11.0),
                egui::Color32::from_gray(170),
            );
            for uv in state.pointers.iter().flatten() {
                painter.circle_filled(at(*uv), 4.0, POINTER);
            }
        });
        let pixels_per_point = output.pixels_per_point;
        let primitives = self.ctx.tessellate(output.shapes, pixels_per_point);
        UiFrame {
            primitives,
            textures: output.textures_delta,
            pixels_per_point,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buttons_do_not_overlap_and_stay_on_the_panel() {
        let l = layout();
        assert_eq!(l.len(), Tool::ALL.len() + Toggle::ALL.len() + 1);
        for (i, (a, ra)) in l.iter().enumerate() {
            assert!(ra[0] >= 0.0 && ra[1] >= 0.0 && ra[2] <= 1.0 && ra[3] <= 1.0);
            assert!(ra[0] < ra[2] && ra[1] < ra[3], "{a:?}");
            for (b, rb) in &l[i + 1..] {
                let apart = ra[2] < rb[0] || rb[2] < ra[0] || ra[3] < rb[1] || rb[3] < ra[1];
                assert!(apart, "{a:?} overlaps {b:?}");
            }
            assert_eq!(button_at(centre_of(*a).expect("laid out")), Some(*a));
        }
        assert_eq!(button_at([0.5, 0.05]), None, "the title is no button");
    }

    #[test]
    fn a_long_selection_is_cut_to_stay_left_of_close() {
        let p = crate::interact::Picked {
            instance: 3,
            node: Some("a very long node name from a plant's CAD export, level 7".into()),
            path: None,
            mesh: "m".into(),
            material: "steel".into(),
            extras: None,
            point: [0.0; 3],
            distance_m: 2.0,
        };
        let line = selection_line(&p);
        assert_eq!(line.chars().count(), SELECTION_CHARS);
        assert!(line.ends_with('…') && line.starts_with("selected: a very long"));
        let short = crate::interact::Picked { node: None, ..p };
        assert_eq!(
            selection_line(&short),
            "selected: m (m, steel), 2.00 m away"
        );
    }

    #[test]
    fn every_button_is_drawn_and_the_frame_has_text() {
        let config = RenderConfig::default();
        let mut ui = PanelUi::new();
        let f = ui.frame(&PanelState {
            tool: Tool::Measure,
            config: &config,
            allowed: &Toggle::ALL,
            pointers: [None, centre_of(Button::Close)],
            times_ms: Some((3.0, 1.0, 11.1)),
            selected: None,
        });
        assert_eq!(f.pixels_per_point, PIXELS_PER_POINT);
        assert!(!f.textures.set.is_empty(), "the font atlas comes first");
        let vertices: usize = f
            .primitives
            .iter()
            .map(|p| match &p.primitive {
                egui::epaint::Primitive::Mesh(m) => m.vertices.len(),
                egui::epaint::Primitive::Callback(_) => 0,
            })
            .sum();
        // Twelve buttons of at least one quad each, their labels and the
        // status text.
        assert!(vertices > 12 * 4 * 4, "{vertices} vertices");
    }
}
