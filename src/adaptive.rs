//! Adaptive quality: a controller that picks the render scale of the next
//! frame (and with the inset, below the lowest scale, the wide view's
//! scale) from the GPU times of the last ones, so a frame stays inside the
//! headset's display period. It follows the rules of Valve's The Lab
//! renderer (`ValveSoftware/the_lab_renderer`,
//! `Assets/TheLabRenderer/Scripts/ValveCamera.cs`,
//! `InitializeAdaptiveQualityScale` and `UpdateAdaptiveQuality`), written
//! afresh here:
//!
//! - **Levels** are render scales (per axis) from `min` to `max`, each level
//!   drawing `step` % more pixels than the one below it:
//!   s(k+1) = sqrt(1 + step/100) · s(k). The starting (default) level is
//!   the first whose scale is at least 1. (The Lab adds a copy of the lowest
//!   level as a hint for the compositor's interleaved reprojection; vergence
//!   has no such hint, so the copy is left out.)
//! - **Thresholds**, with B the frame budget: low = 0.70 B, extrapolation =
//!   0.85 B, high = 0.90 B. The GPU times of the last 12 frames are kept.
//! - With n frames since the last change (counting the current one):
//!   - **critical** (n ≥ 3): the last frame over high → down two levels;
//!   - **sustained** (n ≥ 5): the last three frames over high → down two
//!     (kept as The Lab has it, though checked after the critical rule it
//!     can only fire where that one does: it never changes the outcome);
//!   - **predicted** (n ≥ 4): the last frame over the extrapolation
//!     threshold and last + Δ over high, with Δ = last − previous, or, when
//!     n ≥ 5, the larger of that and (last − the one before previous) / 2
//!     → down two;
//!   - **headroom** (n ≥ 5): the last three frames under low → up one.
//! - Levels clamp to the range (The Lab's special case "from 2 to 1" keeps
//!   its drops out of the reprojection-hint copy, which vergence does not
//!   have: here that is plain clamping at 0); a rule that would not change
//!   the level does not count as a change.
//! - The count n starts at the first frame, as if a change had happened
//!   just before it: the rules wait 3 to 5 frames of history.
//! - **The inset's rung** (the optional "inset scale" rung; not in
//!   The Lab, which has no inset): with `inset`, levels are added below the
//!   lowest render scale that keep that scale and shrink the inset's wide
//!   view instead, by factors on its scale F of c^-k, c = sqrt(1 + step/100),
//!   k = K … 1, K the largest with c^-K ≥ [`MIN_WIDE_FACTOR`]. Each such
//!   level draws step % fewer wide-view pixels than the one above it, the
//!   gaze region keeps its size, and the controller's rules and their
//!   order are unchanged: the rung acts only where the render scale can
//!   fall no further, and going up it restores the periphery first.
//!   Where the renderer can draw the wide view at one sample frame by frame
//!   (two scopes over MSAA, not `inset-wide-1x`), the first level below the
//!   lowest scale is the other optional rung, MSAA: the wide view at one
//!   sample (on the H200 that pass costs 3.36 ms instead of 5.62 at 4× on
//!   factory:100000, more than two 15 % steps), and the factor levels
//!   below it keep one sample.

/// The smallest render scale (per axis) of `--opt aq`.
pub const MIN_SCALE: f64 = 0.65;
/// The largest render scale (per axis): the targets are made at this size.
pub const MAX_SCALE: f64 = 1.4;
/// Each level draws this many per cent more pixels than the one below.
pub const STEP_PCT: f64 = 15.0;

/// The smallest factor the inset's rung puts on the wide view's scale F
/// (a quarter of its pixels).
pub const MIN_WIDE_FACTOR: f64 = 0.5;

/// Frames of GPU time the controller keeps.
pub const HISTORY: usize = 12;
/// Share of the budget under which three frames in a row step up.
pub const LOW: f64 = 0.70;
/// Share of the budget over which the last frame is extrapolated.
pub const EXTRAPOLATION: f64 = 0.85;
/// Share of the budget over which frames step down.
pub const HIGH: f64 = 0.90;

/// Which rule changed the level.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Reason {
    /// The last frame was over the high threshold.
    Critical,
    /// The last three frames were over the high threshold.
    Sustained,
    /// The last frame was over the extrapolation threshold and its trend
    /// crosses the high one.
    Predicted,
    /// The last three frames were under the low threshold.
    Headroom,
}

/// A level change.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Change {
    /// The level before.
    pub from: usize,
    /// The level now.
    pub to: usize,
    /// Its render scale (per axis).
    pub scale: f64,
    /// The rule that fired.
    pub reason: Reason,
}

/// What one level of the ladder renders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Level {
    /// The render scale (per axis).
    pub scale: f64,
    /// The factor on the inset's wide-view scale (1 above the inset's
    /// rung).
    pub wide_factor: f64,
    /// The inset's wide view is drawn at one sample (the MSAA rung and the
    /// levels below it).
    pub wide_one_sample: bool,
}

/// The controller's state.
#[derive(Clone, Debug)]
pub struct AdaptiveQuality {
    /// The ladder, lowest first.
    ladder: Vec<Level>,
    default: usize,
    level: usize,
    budget_ms: f64,
    history: [f64; HISTORY],
    pos: usize,
    frame: u64,
    last_change: u64,
}

/// The inset rung's factors on the wide view's scale, smallest first:
/// c^-K … c^-1 with c = sqrt(1 + `step_pct`/100) and K the largest with
/// c^-K ≥ `min`; None when `min` is not in (0, 1] or the step is not
/// usable. Empty when `min` is 1.
pub fn wide_rung_factors(min: f64, step_pct: f64) -> Option<Vec<f64>> {
    let usable = min.is_finite() && step_pct.is_finite();
    if !usable || min <= 0.0 || min > 1.0 || step_pct <= 0.0 {
        return None;
    }
    let shrink = 1.0 / (1.0 + step_pct / 100.0).sqrt();
    let mut out = Vec::new();
    let mut f = shrink;
    // The same relative tolerance as `levels`: a factor landing on `min`
    // up to rounding is kept.
    while f >= min * (1.0 - 1e-9) {
        out.push(f);
        f *= shrink;
    }
    out.reverse();
    Some(out)
}

/// The render scales from `min` to `max` (per axis), each drawing `step_pct`
/// % more pixels than the previous; None when the range or step is not
/// usable (non-finite, min ≤ 0, min > max, step ≤ 0).
pub fn levels(min: f64, max: f64, step_pct: f64) -> Option<Vec<f64>> {
    let usable = min.is_finite() && max.is_finite() && step_pct.is_finite();
    if !usable || min <= 0.0 || min > max || step_pct <= 0.0 {
        return None;
    }
    let grow = (1.0 + step_pct / 100.0).sqrt();
    let mut out = vec![min];
    let mut s = min * grow;
    // A relative tolerance keeps a top level that lands on `max` up to
    // rounding (0.65 · 1.15^(k/2) for the default range).
    while s <= max * (1.0 + 1e-9) {
        out.push(s);
        s *= grow;
    }
    Some(out)
}

impl AdaptiveQuality {
    /// A controller for frames of `budget_ms` over `scales` (increasing;
    /// see [`levels`]), starting at the first scale of at least 1 (else the
    /// highest); None without scales.
    pub fn new(budget_ms: f64, scales: Vec<f64>) -> Option<AdaptiveQuality> {
        let default = scales
            .iter()
            .position(|&s| s >= 1.0)
            .unwrap_or(scales.len().checked_sub(1)?);
        Some(AdaptiveQuality {
            ladder: scales
                .into_iter()
                .map(|scale| Level {
                    scale,
                    wide_factor: 1.0,
                    wide_one_sample: false,
                })
                .collect(),
            default,
            level: default,
            budget_ms,
            history: [0.0; HISTORY],
            pos: 0,
            frame: 0,
            last_change: 0,
        })
    }

    /// Adds the inset's rung: a level below the lowest for each factor of
    /// `factors` (increasing, each in (0, 1); see [`wide_rung_factors`]) at the
    /// lowest render scale with that factor on the wide view's scale, and
    /// with `msaa_rung` first (above those) a level at the lowest scale
    /// with the wide view at one sample, which the levels below keep. The
    /// default level keeps its scale; the current level moves with it.
    pub fn with_wide_rungs(mut self, factors: &[f64], msaa_rung: bool) -> AdaptiveQuality {
        debug_assert!(
            factors.iter().all(|&f| f > 0.0 && f < 1.0) && factors.windows(2).all(|w| w[0] < w[1]),
            "the inset rung's factors increase within (0, 1): {factors:?}"
        );
        let scale = self.ladder[0].scale;
        let mut wide = factors.to_vec();
        if msaa_rung {
            wide.push(1.0);
        }
        let k = wide.len();
        self.ladder.splice(
            0..0,
            wide.into_iter().map(|wide_factor| Level {
                scale,
                wide_factor,
                wide_one_sample: msaa_rung,
            }),
        );
        self.default += k;
        self.level += k;
        self
    }

    /// The ladder, lowest first (a scale repeats on the inset's rungs).
    pub fn ladder(&self) -> &[Level] {
        &self.ladder
    }

    /// What the current level renders.
    pub fn current(&self) -> Level {
        self.ladder[self.level]
    }

    /// The current factor on the inset's wide-view scale (1 unless the
    /// controller is on the inset's rung).
    pub fn wide_factor(&self) -> f64 {
        self.current().wide_factor
    }

    /// Whether the current level draws the inset's wide view at one sample
    /// (the MSAA rung and the levels below it).
    pub fn wide_one_sample(&self) -> bool {
        self.current().wide_one_sample
    }

    /// The starting level.
    pub fn default_level(&self) -> usize {
        self.default
    }

    /// The current level.
    pub fn level(&self) -> usize {
        self.level
    }

    /// Changes the frame budget (the runtime's display period changed).
    pub fn set_budget_ms(&mut self, budget_ms: f64) {
        self.budget_ms = budget_ms;
    }

    /// The frame budget, milliseconds.
    pub fn budget_ms(&self) -> f64 {
        self.budget_ms
    }

    /// The current render scale (per axis).
    pub fn scale(&self) -> f64 {
        self.current().scale
    }

    /// The GPU time of frame `ago` frames back (0: the last one given).
    fn past(&self, ago: usize) -> f64 {
        self.history[(self.pos + HISTORY - ago) % HISTORY]
    }

    /// Takes the GPU milliseconds of the frame just finished and returns the
    /// level change the rules make, if any.
    pub fn update(&mut self, gpu_ms: f64) -> Option<Change> {
        self.frame += 1;
        self.pos = (self.pos + 1) % HISTORY;
        self.history[self.pos] = gpu_ms;
        let (f0, f1, f2) = (self.past(0), self.past(1), self.past(2));
        let (low, extra, high) = (
            LOW * self.budget_ms,
            EXTRAPOLATION * self.budget_ms,
            HIGH * self.budget_ms,
        );
        let since = |n: u64| self.frame >= self.last_change + n;
        let down = self.level.saturating_sub(2);
        let predicted = || {
            let mut delta = f0 - f1;
            if since(5) {
                delta = delta.max((f0 - f2) * 0.5);
            }
            f0 > extra && f0 + delta > high
        };
        let rule = if since(3) && f0 > high {
            Some((down, Reason::Critical))
        } else if since(5) && f0 > high && f1 > high && f2 > high {
            Some((down, Reason::Sustained))
        } else if since(4) && predicted() {
            Some((down, Reason::Predicted))
        } else if since(5) && f0 < low && f1 < low && f2 < low {
            Some((self.level + 1, Reason::Headroom))
        } else {
            None
        };
        let (to, reason) = rule?;
        let to = to.min(self.ladder.len() - 1);
        if to == self.level {
            return None;
        }
        let from = self.level;
        self.level = to;
        self.last_change = self.frame;
        Some(Change {
            from,
            to,
            scale: self.ladder[to].scale,
            reason,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const B: f64 = 10.0;

    fn controller() -> AdaptiveQuality {
        AdaptiveQuality::new(B, levels(0.65, 1.4, 15.0).unwrap()).unwrap()
    }

    /// Feeds `times` and returns (frame number from 1, change) for each
    /// change.
    fn run(aq: &mut AdaptiveQuality, times: &[f64]) -> Vec<(usize, Change)> {
        times
            .iter()
            .enumerate()
            .filter_map(|(i, &t)| aq.update(t).map(|c| (i + 1, c)))
            .collect()
    }

    #[test]
    fn levels_grow_by_the_pixel_step_and_start_at_one() {
        let s = levels(0.65, 1.4, 15.0).unwrap();
        assert!((s[0] - 0.65).abs() < 1e-12);
        for w in s.windows(2) {
            assert!((w[1] * w[1] / (w[0] * w[0]) - 1.15).abs() < 1e-9, "{w:?}");
        }
        assert!(*s.last().unwrap() <= 1.4 + 1e-9);
        assert!(s.last().unwrap() * 1.15f64.sqrt() > 1.4);
        let aq = controller();
        let d = aq.default_level();
        assert!(aq.ladder()[d].scale >= 1.0 && aq.ladder()[d - 1].scale < 1.0);
        for bad in [
            (0.0, 1.4, 15.0),
            (1.5, 1.4, 15.0),
            (0.65, 1.4, 0.0),
            (f64::NAN, 1.4, 15.0),
        ] {
            assert!(levels(bad.0, bad.1, bad.2).is_none(), "{bad:?}");
        }
    }

    #[test]
    fn wide_rung_factors_shrink_by_the_pixel_step_down_to_the_minimum() {
        let f = wide_rung_factors(MIN_WIDE_FACTOR, 15.0).unwrap();
        assert_eq!(f.len(), 9, "{f:?}");
        assert!((f[8] * f[8] * 1.15 - 1.0).abs() < 1e-12);
        for w in f.windows(2) {
            assert!((w[1] * w[1] / (w[0] * w[0]) - 1.15).abs() < 1e-9, "{w:?}");
        }
        assert!(f[0] >= MIN_WIDE_FACTOR && f[0] / 1.15f64.sqrt() < MIN_WIDE_FACTOR);
        assert_eq!(wide_rung_factors(1.0, 15.0).unwrap(), Vec::<f64>::new());
        for bad in [
            (0.0, 15.0),
            (1.5, 15.0),
            (0.5, 0.0),
            (f64::NAN, 15.0),
            (0.5, f64::INFINITY),
        ] {
            assert!(wide_rung_factors(bad.0, bad.1).is_none(), "{bad:?}");
        }
    }

    #[test]
    fn the_inset_rung_sits_below_the_lowest_scale_and_is_left_first() {
        let plain = controller();
        let f = wide_rung_factors(MIN_WIDE_FACTOR, STEP_PCT).unwrap();
        let mut aq = controller().with_wide_rungs(&f, false);
        let k = f.len();
        assert_eq!(aq.ladder().len(), plain.ladder().len() + k);
        assert_eq!(
            aq.ladder()[aq.default_level()],
            plain.ladder()[plain.default_level()]
        );
        assert_eq!(aq.level(), aq.default_level());
        assert_eq!(aq.wide_factor(), 1.0);
        for (i, l) in aq.ladder().iter().enumerate() {
            let (s, w) = (l.scale, l.wide_factor);
            if i < k {
                assert_eq!((s, w), (plain.ladder()[0].scale, f[i]));
            } else {
                assert_eq!((s, w), (plain.ladder()[i - k].scale, 1.0));
            }
        }
        // Frames over budget: down two levels every three frames, through
        // the render scales and then the rung, to its smallest factor.
        run(&mut aq, &[B; 60]);
        assert_eq!(aq.level(), 0);
        assert_eq!(aq.wide_factor(), f[0]);
        // Cheap frames: up one level every five, the periphery first.
        let ups = run(&mut aq, &[0.1 * B; 5 * 9]);
        assert_eq!(ups.len(), k, "{ups:?}");
        assert_eq!(aq.scale(), plain.ladder()[0].scale);
        assert_eq!(aq.wide_factor(), 1.0);
        run(&mut aq, &[0.1 * B; 5]);
        assert!(aq.scale() > plain.ladder()[0].scale);
    }

    #[test]
    fn the_msaa_rung_comes_first_below_the_lowest_scale_and_the_factors_keep_it() {
        let plain = controller();
        let f = wide_rung_factors(MIN_WIDE_FACTOR, STEP_PCT).unwrap();
        let mut aq = controller().with_wide_rungs(&f, true);
        let k = f.len();
        assert_eq!(aq.ladder().len(), plain.ladder().len() + k + 1);
        assert_eq!(aq.default_level(), plain.default_level() + k + 1);
        assert!(!aq.wide_one_sample());
        for i in 0..aq.ladder().len() {
            aq.level = i;
            let (s, w, one) = (aq.scale(), aq.wide_factor(), aq.wide_one_sample());
            match i {
                i if i < k => assert_eq!((s, w, one), (plain.ladder()[0].scale, f[i], true)),
                i if i == k => {
                    assert_eq!(
                        (s, w, one),
                        (plain.ladder()[0].scale, 1.0, true),
                        "the MSAA rung"
                    )
                }
                i => assert_eq!((s, w, one), (plain.ladder()[i - k - 1].scale, 1.0, false)),
            }
        }
    }

    proptest! {
        #[test]
        fn wide_rung_factors_match_the_count_from_logarithms(
            min in 0.02f64..1.0,
            step in 1.0f64..100.0,
        ) {
            let f = wide_rung_factors(min, step).unwrap();
            let c = (1.0 + step / 100.0).sqrt();
            // K = the largest k with c^-k ≥ min, i.e. k ≤ ln(1/min) / ln c.
            let k = ((1.0 / min).ln() / c.ln() + 1e-9).floor() as usize;
            prop_assert_eq!(f.len(), k);
            for (i, &x) in f.iter().enumerate() {
                let want = c.powi(-((k - i) as i32));
                prop_assert!((x - want).abs() <= 1e-9 * want, "{} {}", x, want);
                prop_assert!(x >= min * (1.0 - 1e-9) && x < 1.0);
            }
        }
    }

    #[test]
    fn cheap_frames_step_up_one_level_every_five_frames() {
        let mut aq = controller();
        let start = aq.level();
        let changes = run(&mut aq, &[5.0; 16]);
        let frames: Vec<usize> = changes.iter().map(|c| c.0).collect();
        assert_eq!(frames, vec![5, 10, 15]);
        for (i, (_, c)) in changes.iter().enumerate() {
            assert_eq!(
                (c.from, c.to, c.reason),
                (start + i, start + i + 1, Reason::Headroom)
            );
        }
    }

    #[test]
    fn frames_between_the_thresholds_change_nothing() {
        let mut aq = controller();
        // 70 % to 85 %, flat: neither headroom nor a rising trend.
        assert!(run(&mut aq, &[8.0; 40]).is_empty());
        let mut aq = controller();
        assert!(run(&mut aq, &[7.5, 8.4, 7.2, 8.0, 7.6, 8.3, 7.1, 8.4, 7.9, 7.3]).is_empty());
    }

    #[test]
    fn one_critical_frame_drops_two_levels_but_not_right_after_a_change() {
        let mut aq = controller();
        let start = aq.level();
        let mut times = vec![8.0; 9];
        times.push(9.5);
        let changes = run(&mut aq, &times);
        assert_eq!(changes.len(), 1, "{changes:?}");
        let (frame, c) = changes[0];
        assert_eq!(
            (frame, c.from, c.to, c.reason),
            (10, start, start - 2, Reason::Critical)
        );
        // Two more critical frames right after: too soon (n < 3), then one
        // counts again.
        let later = run(&mut aq, &[9.5, 9.5, 9.5]);
        assert_eq!(later.len(), 1, "{later:?}");
        assert_eq!(later[0].0, 3, "the third frame after the change: {later:?}");
        assert_eq!(later[0].1.reason, Reason::Critical);
    }

    #[test]
    fn a_rising_trend_over_the_extrapolation_threshold_drops_two_levels() {
        let mut aq = controller();
        let start = aq.level();
        // 80 %, 80 %, then 88 %: under high, over 85 %, and 88 + 8 > 90.
        let changes = run(&mut aq, &[8.0, 8.0, 8.0, 8.0, 8.0, 8.8]);
        assert_eq!(changes.len(), 1, "{changes:?}");
        assert_eq!(changes[0].1.reason, Reason::Predicted);
        assert_eq!(changes[0].1.to, start - 2);
        // Flat at 86 %: over 85 % but the trend stays under 90 %.
        let mut aq = controller();
        assert!(run(&mut aq, &[8.6; 20]).is_empty());
    }

    #[test]
    fn drops_clamp_at_the_lowest_level() {
        // At level 1 "down two" clamps to 0; at level 0 nothing drops.
        let mut aq = AdaptiveQuality::new(B, vec![0.5, 0.7]).unwrap();
        assert_eq!(aq.level(), 1, "no scale reaches 1: the highest");
        let changes = run(&mut aq, &[9.5, 9.5, 9.5, 9.5, 9.5]);
        assert_eq!(changes.len(), 1, "{changes:?}");
        assert_eq!((changes[0].0, changes[0].1.to), (3, 0));
        assert!(run(&mut aq, &[9.5; 10]).is_empty(), "nothing below 0");
    }

    #[test]
    fn drops_are_two_levels_clamped_at_zero() {
        for start in 1..6 {
            // The first scale of at least 1 is level `start`: it starts there.
            let scales: Vec<f64> = (0..8)
                .map(|i| 1.0 + 0.1 * (i as f64 - start as f64))
                .collect();
            let mut aq = AdaptiveQuality::new(B, scales).unwrap();
            assert_eq!(aq.level(), start);
            let changes = run(&mut aq, &[8.0, 8.0, 9.5]);
            assert_eq!(changes.len(), 1, "from {start}: {changes:?}");
            let c = changes[0].1;
            assert_eq!(
                (c.from, c.to),
                (start, start.saturating_sub(2)),
                "from {start}"
            );
        }
        assert!(AdaptiveQuality::new(B, Vec::new()).is_none());
    }

    proptest! {
        #[test]
        fn levels_stay_in_range_and_changes_keep_their_distance(
            times in prop::collection::vec(0.0f64..20.0, 1..300),
        ) {
            let mut aq = controller();
            let mut last: Option<usize> = None;
            for (i, &t) in times.iter().enumerate() {
                if let Some(c) = aq.update(t) {
                    prop_assert!(c.to < aq.ladder().len());
                    prop_assert!(c.from != c.to);
                    // Frames since the last change, the start counting as one.
                    let gap = last.map_or(i + 1, |l| i - l);
                    if c.reason != Reason::Headroom {
                        prop_assert_eq!(c.to, c.from.saturating_sub(2), "drops are two levels");
                    }
                    match c.reason {
                        Reason::Headroom => prop_assert!(c.to == c.from + 1 && gap >= 5 && t < LOW * B),
                        Reason::Critical => prop_assert!(gap >= 3 && t > HIGH * B),
                        Reason::Sustained => prop_assert!(gap >= 5),
                        Reason::Predicted => prop_assert!(gap >= 4 && t > EXTRAPOLATION * B && t <= HIGH * B),
                    }
                    last = Some(i);
                }
                prop_assert!(aq.level() < aq.ladder().len());
            }
        }
    }
}
