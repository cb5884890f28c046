//! The desk overlay (`--overlay on`, F3 toggles it): what the current
//! configuration costs, drawn over the window's image only — the frame-time
//! graph (CPU, GPU, wait) against the headset's budget, GPU ms per pass,
//! what was drawn, the active `--opt` list and the keys. Laid out with egui
//! on the CPU; `gpu::ui_layer` draws it.

use crate::gpu::ui_layer::UiFrame;
use crate::render::driver::FrameResult;
use std::collections::VecDeque;

/// `--overlay`: whether the window starts with the overlay shown.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum OverlayMode {
    /// Shown (F3 hides it).
    #[default]
    On,
    /// Hidden (F3 shows it).
    Off,
}

/// The key that shows and hides the overlay.
pub const KEY: winit::keyboard::KeyCode = winit::keyboard::KeyCode::F3;
/// The key that measures the current frame's image error (`view`).
pub const MEASURE_KEY: winit::keyboard::KeyCode = winit::keyboard::KeyCode::F4;
/// The key that shows and hides the error's heat map.
pub const HEATMAP_KEY: winit::keyboard::KeyCode = winit::keyboard::KeyCode::F5;

/// The short key listing the overlay shows.
pub const KEYS: &str = "0-9, F6, F7 switch an optimization (H lists them) · P print --opt · F2 save it · F3 overlay · F4 image error · F5 heat map · F8 keep this pose · Esc quit";

/// The key listing of `run`'s mirror (F4 stops the loop for two renders).
pub const KEYS_MIRROR: &str = "0-9, F6, F7 switch an optimization (H lists them) · P print --opt · F2 save it · F3 overlay · F4 image error of the last frame · F5 heat map · Esc quit";

/// Longest side of the heat map texture, pixels.
pub const HEATMAP_SIDE: u32 = 512;

/// Frames the graph shows.
pub const HISTORY: usize = 240;

/// One frame's times for the graph.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Times {
    /// CPU ms: in `run`, as `--stats-out`'s `cpu_ms` (the frame loop from
    /// the end of the pacing wait to the submission, the wait for a frame
    /// slot excluded); in `view`, the frame's own work (cull, batch,
    /// record, submit).
    pub cpu: f64,
    /// GPU ms (the passes' timestamps).
    pub gpu: f64,
    /// Wait ms: in `run`, as `--stats-out`'s `wait_ms` (xrWaitFrame's,
    /// 0 headless); in `view`, the wait for a frame slot.
    pub wait: f64,
}

/// The mean times of every frame the overlay showed, for `--stats-out`
/// (`mirror.overlay`): in `run` they are the means of the same frames'
/// records.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct OverlayFigures {
    /// The first frame shown (its index in the frame records).
    pub first_frame: u64,
    /// Frames shown.
    pub frames: u64,
    /// Mean CPU ms.
    pub cpu_ms_mean: f64,
    /// Mean GPU ms.
    pub gpu_ms_mean: f64,
    /// Mean wait ms.
    pub wait_ms_mean: f64,
}

impl OverlayFigures {
    /// These figures and a later session's `b` together: the frames of
    /// both, the means weighted by their frames.
    pub fn merged(&self, b: &OverlayFigures) -> OverlayFigures {
        let n = (self.frames + b.frames).max(1) as f64;
        let w = |x: f64, y: f64| (x * self.frames as f64 + y * b.frames as f64) / n;
        OverlayFigures {
            first_frame: self.first_frame.min(b.first_frame),
            frames: self.frames + b.frames,
            cpu_ms_mean: w(self.cpu_ms_mean, b.cpu_ms_mean),
            gpu_ms_mean: w(self.gpu_ms_mean, b.gpu_ms_mean),
            wait_ms_mean: w(self.wait_ms_mean, b.wait_ms_mean),
        }
    }
}

/// The overlay's state across frames.
pub struct Hud {
    ctx: egui::Context,
    history: VecDeque<Times>,
    /// Every frame shown: the first one's index, the count and the sums
    /// of CPU, GPU and wait ms.
    shown: Option<(u64, u64, [f64; 3])>,
    last: Option<FrameResult>,
    /// Whether it is drawn.
    pub visible: bool,
    started: std::time::Instant,
    /// The last image error measured, and its heat map as a texture.
    error: Option<(
        crate::targets::error_probe::ErrorReport,
        egui::TextureHandle,
    )>,
    /// Whether the heat map is shown under the error.
    pub show_heatmap: bool,
}

/// What the overlay shows besides the measured frames.
pub struct HudInfo<'a> {
    /// The current `--opt` list.
    pub opt: &'a str,
    /// The frame budget (ms) of the profile's refresh rate.
    pub budget_ms: f64,
    /// The key listing.
    pub keys: &'a str,
}

/// The colours of the three series and the budget line.
const CPU: egui::Color32 = egui::Color32::from_rgb(90, 170, 255);
const GPU: egui::Color32 = egui::Color32::from_rgb(255, 160, 40);
const WAIT: egui::Color32 = egui::Color32::from_rgb(170, 170, 170);
const BUDGET: egui::Color32 = egui::Color32::from_rgb(230, 60, 60);

impl Hud {
    /// A hidden or shown overlay.
    pub fn new(visible: bool) -> Hud {
        Hud {
            ctx: egui::Context::default(),
            history: VecDeque::with_capacity(HISTORY),
            shown: None,
            last: None,
            visible,
            started: std::time::Instant::now(),
            error: None,
            show_heatmap: true,
        }
    }

    /// Shows `report` (its FLIP mean, and its heat map while
    /// [`Hud::show_heatmap`]); the previous one's texture is retired.
    pub fn set_error(&mut self, report: crate::targets::error_probe::ErrorReport) {
        // Shown at most 300 points wide: a 512-pixel copy is plenty, and
        // stays within every texture size limit.
        let h = if report.heatmap.width() > HEATMAP_SIDE || report.heatmap.height() > HEATMAP_SIDE {
            let scale =
                HEATMAP_SIDE as f64 / report.heatmap.width().max(report.heatmap.height()) as f64;
            image::imageops::resize(
                &report.heatmap,
                ((report.heatmap.width() as f64 * scale) as u32).max(1),
                ((report.heatmap.height() as f64 * scale) as u32).max(1),
                image::imageops::FilterType::Triangle,
            )
        } else {
            report.heatmap.clone()
        };
        let h = &h;
        let image = egui::ColorImage::from_rgba_unmultiplied(
            [h.width() as usize, h.height() as usize],
            h.as_raw(),
        );
        let texture = self
            .ctx
            .load_texture("flip-heatmap", image, egui::TextureOptions::LINEAR);
        self.error = Some((report, texture));
    }

    /// The last measured error's FLIP mean.
    pub fn error_mean(&self) -> Option<f64> {
        self.error.as_ref().map(|(r, _)| r.flip_mean)
    }

    /// Adds a finished frame with its own times (`view`).
    pub fn push(&mut self, r: &FrameResult) {
        let t = Times {
            cpu: r.cpu_ms(),
            gpu: r.gpu_ms(),
            wait: r.stats.cpu_ms.wait,
        };
        self.push_times(r.index, t);
        self.set_last(r);
    }

    /// Shows finished frame `r`'s counts and passes (its times come with
    /// [`Hud::push_times`]).
    pub fn set_last(&mut self, r: &FrameResult) {
        self.last = Some(r.clone());
    }

    /// Adds frame `index`'s times to the graph and the means.
    pub fn push_times(&mut self, index: u64, t: Times) {
        if self.history.len() == HISTORY {
            self.history.pop_front();
        }
        self.history.push_back(t);
        let (_, n, sums) = self.shown.get_or_insert((index, 0, [0.0; 3]));
        *n += 1;
        for (s, v) in sums.iter_mut().zip([t.cpu, t.gpu, t.wait]) {
            *s += v;
        }
    }

    /// The means of every frame shown (None before the first).
    pub fn figures(&self) -> Option<OverlayFigures> {
        let (first_frame, frames, [cpu, gpu, wait]) = self.shown?;
        let n = frames.max(1) as f64;
        Some(OverlayFigures {
            first_frame,
            frames,
            cpu_ms_mean: cpu / n,
            gpu_ms_mean: gpu / n,
            wait_ms_mean: wait / n,
        })
    }

    /// The frame times kept for the graph, oldest first.
    pub fn history(&self) -> impl Iterator<Item = &Times> {
        self.history.iter()
    }

    /// Lays out the overlay for a window of `size` pixels (None when it
    /// is hidden).
    pub fn frame(&mut self, size: [u32; 2], info: &HudInfo) -> Option<UiFrame> {
        if !self.visible {
            return None;
        }
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(size[0] as f32, size[1] as f32),
            )),
            time: Some(self.started.elapsed().as_secs_f64()),
            ..egui::RawInput::default()
        };
        let history: Vec<Times> = self.history.iter().copied().collect();
        let last = self.last.clone();
        let error = self.error.as_ref().map(|(r, t)| {
            let means = (r.flip_mean, r.flip_foveated_mean);
            (means, r.opt.clone(), t.id(), t.size_vec2())
        });
        let heat = self.show_heatmap;
        let output = self.ctx.run(input, |ctx| {
            egui::Area::new(egui::Id::new("vergence-hud"))
                .fixed_pos(egui::pos2(8.0, 8.0))
                .show(ctx, |ui| {
                    egui::Frame::NONE
                        .fill(egui::Color32::from_black_alpha(220))
                        .inner_margin(8.0)
                        .corner_radius(4.0)
                        .show(ui, |ui| {
                            if compact(size) {
                                compact_panel(ui, &history, info, size);
                                if let Some(((mean, foveated), ..)) = &error {
                                    let text = format!("F4: FLIP {mean:.4} ({foveated:.4} foveated)");
                                    ui.label(egui::RichText::new(text).small());
                                }
                                return;
                            }
                            panel(ui, &history, last.as_ref(), info);
                            if let Some(((mean, foveated), opt, id, size)) = &error {
                                ui.label(format!(
                                    "image error (F4): FLIP mean {mean:.4} ({foveated:.4} foveated) vs two-pass 4x, for {opt}"
                                ));
                                if heat {
                                    let w = 300.0f32.min(size.x);
                                    let scaled = egui::vec2(w, w * size.y / size.x.max(1.0));
                                    ui.image((*id, scaled));
                                }
                            }
                        });
                });
        });
        let pixels_per_point = output.pixels_per_point;
        let primitives = self.ctx.tessellate(output.shapes, pixels_per_point);
        Some(UiFrame {
            primitives,
            textures: output.textures_delta,
            pixels_per_point,
        })
    }
}

/// Windows below this width or height get the compact overlay: the full
/// panel (about 360 × 400 pixels) would hide most of the eye image.
const COMPACT_BELOW: [u32; 2] = [800, 600];

/// Whether a window of `size` pixels gets the compact overlay.
fn compact(size: [u32; 2]) -> bool {
    size[0] < COMPACT_BELOW[0] || size[1] < COMPACT_BELOW[1]
}

/// The mean CPU, GPU and wait times over `history`.
fn means(history: &[Times]) -> [f64; 3] {
    let n = history.len().max(1) as f64;
    let mean = |f: fn(&Times) -> f64| history.iter().map(f).sum::<f64>() / n;
    [mean(|t| t.cpu), mean(|t| t.gpu), mean(|t| t.wait)]
}

/// The overlay of a small window: the options and the times on two small
/// lines, at most half the window wide (F3 still hides it).
fn compact_panel(ui: &mut egui::Ui, history: &[Times], info: &HudInfo, size: [u32; 2]) {
    ui.set_max_width(size[0] as f32 * 0.5);
    ui.visuals_mut().override_text_color = Some(egui::Color32::from_gray(235));
    ui.label(
        egui::RichText::new(info.opt)
            .small()
            .color(egui::Color32::WHITE),
    );
    let [cpu, gpu, wait] = means(history);
    ui.label(
        egui::RichText::new(format!(
            "CPU {cpu:.2} GPU {gpu:.2} wait {wait:.2} / {:.2} ms",
            info.budget_ms
        ))
        .small(),
    );
}

fn panel(ui: &mut egui::Ui, history: &[Times], last: Option<&FrameResult>, info: &HudInfo) {
    ui.set_max_width(360.0);
    ui.visuals_mut().override_text_color = Some(egui::Color32::from_gray(235));
    ui.label(
        egui::RichText::new(format!("vergence  {}", info.opt))
            .strong()
            .color(egui::Color32::WHITE),
    );
    let [cpu, gpu, wait] = means(history);
    ui.label(format!(
        "CPU {cpu:.2}  GPU {gpu:.2}  wait {wait:.2} ms   budget {:.2} ms",
        info.budget_ms
    ));
    graph(ui, history, info.budget_ms);
    if let Some(r) = last {
        let s = &r.stats;
        ui.label(format!(
            "drawn: {} instances, {} triangles, {} draws",
            s.instances_drawn, s.triangles, s.draw_calls
        ));
        for (pass, ms) in &s.gpu_ms {
            ui.label(format!("  {pass:<14} {ms:7.3} ms"));
        }
    }
    ui.label(egui::RichText::new(info.keys).small());
}

/// The last [`HISTORY`] frames' CPU, GPU and wait times as lines over the
/// budget (a red line), scaled to twice the budget or the largest time.
fn graph(ui: &mut egui::Ui, history: &[Times], budget: f64) {
    let (rect, _) = ui.allocate_exact_size(egui::vec2(340.0, 90.0), egui::Sense::hover());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 2.0, egui::Color32::from_black_alpha(120));
    let top = history
        .iter()
        .map(|t| t.cpu.max(t.gpu).max(t.wait))
        .fold(2.0 * budget, f64::max)
        .max(1e-3);
    let y = |ms: f64| rect.bottom() - (ms / top) as f32 * rect.height();
    let x = |i: usize| rect.left() + i as f32 / (HISTORY - 1) as f32 * rect.width();
    let line = |points: Vec<egui::Pos2>, colour| {
        painter.add(egui::Shape::line(points, egui::Stroke::new(1.5, colour)));
    };
    line(
        vec![
            egui::pos2(rect.left(), y(budget)),
            egui::pos2(rect.right(), y(budget)),
        ],
        BUDGET,
    );
    let start = HISTORY - history.len();
    for (f, colour) in [
        ((|t: &Times| t.wait) as fn(&Times) -> f64, WAIT),
        (|t: &Times| t.cpu, CPU),
        (|t: &Times| t.gpu, GPU),
    ] {
        let points = history
            .iter()
            .enumerate()
            .map(|(i, t)| egui::pos2(x(start + i), y(f(t))))
            .collect();
        line(points, colour);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hidden_overlay_draws_nothing_and_a_shown_one_draws_its_panel() {
        let info = HudInfo {
            opt: "multiview,msaa4",
            budget_ms: 11.1,
            keys: "F3 overlay",
        };
        let mut hud = Hud::new(false);
        assert!(hud.frame([640, 480], &info).is_none());
        hud.visible = true;
        // The first frame brings the font atlas (egui sizes a new area
        // before it draws it); the next draws the panel.
        let first = hud.frame([640, 480], &info).expect("shown");
        assert!(!first.textures.set.is_empty());
        let f = hud.frame([640, 480], &info).expect("shown");
        assert!(!f.primitives.is_empty());
        // A full-size heat map (valve-index: 2016×2240, beyond egui's
        // 2048-pixel texture limit) is shown from a 512-pixel copy.
        hud.set_error(crate::targets::error_probe::ErrorReport {
            flip_mean: 0.01,
            flip_foveated_mean: 0.005,
            heatmap: image::RgbaImage::new(2016, 2240),
            opt: "multiview".into(),
        });
        let f = hud.frame([640, 480], &info).expect("shown");
        let side = f
            .textures
            .set
            .iter()
            .map(|(_, d)| d.image.width().max(d.image.height()))
            .max()
            .unwrap_or(0);
        assert!(side > 0 && side <= HEATMAP_SIDE as usize, "{side}");
        // Everything lies inside the window, in its top-left part.
        for p in &f.primitives {
            assert!(p.clip_rect.min.x >= 0.0 && p.clip_rect.min.y >= 0.0);
        }
    }

    /// The area the overlay's triangles cover (their bounding box), as a
    /// share of a window of `size` pixels.
    fn covered_share(hud: &mut Hud, size: [u32; 2], info: &HudInfo) -> f32 {
        hud.frame(size, info);
        let f = hud.frame(size, info).expect("shown");
        let mut min = egui::pos2(f32::MAX, f32::MAX);
        let mut max = egui::pos2(f32::MIN, f32::MIN);
        for p in &f.primitives {
            if let egui::epaint::Primitive::Mesh(m) = &p.primitive {
                for v in &m.vertices {
                    min = min.min(v.pos);
                    max = max.max(v.pos);
                }
            }
        }
        let area = (max.x - min.x).max(0.0) * (max.y - min.y).max(0.0);
        area / (size[0] * size[1]) as f32
    }

    #[test]
    fn a_small_window_keeps_most_of_its_image() {
        let info = HudInfo {
            opt: "multiview,superfrustum,stencil-mask,foveation=high,msaa4",
            budget_ms: 11.1,
            keys: "F3 overlay  F4 error  F8 keep viewpoint  Esc quit",
        };
        let mut hud = Hud::new(true);
        for size in [[320, 240], [640, 360], [799, 700]] {
            let share = covered_share(&mut hud, size, &info);
            assert!(share > 0.0 && share <= 0.15, "{size:?}: {share}");
        }
        // A large window has the whole panel: graph and all.
        let large = covered_share(&mut hud, [1920, 1080], &info);
        assert!(large * 1920.0 * 1080.0 > 340.0 * 90.0, "{large}");
    }

    #[test]
    fn the_graph_keeps_the_last_frames_only() {
        let mut hud = Hud::new(true);
        let r = FrameResult {
            index: 0,
            started: std::time::Instant::now(),
            interval_ms: None,
            cull_ms: 0.5,
            motion_ms: 0.0,
            cull: None,
            fov: [crate::view::Fov {
                left: -1.0,
                right: 1.0,
                up: 1.0,
                down: -1.0,
            }; 2],
            stats: crate::render::FrameStats::default(),
            aq: None,
        };
        for _ in 0..HISTORY + 17 {
            hud.push(&r);
        }
        assert_eq!(hud.history().count(), HISTORY);
        assert!(hud.history().all(|t| (t.cpu - 0.5).abs() < 1e-12));
    }
}
