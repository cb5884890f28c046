//! Scripted gaze: fixations and saccades a viewer's eye makes, for measuring
//! foveated techniques against a gaze that moves (the bench's
//! `gaze = "saccades"`).
//!
//! The gaze is a direction relative to the head's forward axis, as yaw and
//! pitch in degrees (positive right and up). It rests in **fixations** and
//! jumps between them in **saccades**:
//!
//! - Fixation durations are log-normal with a median of 280 ms and
//!   log-standard deviation 0.45 (mean ≈ 310 ms), kept within 100–1000 ms:
//!   scene viewing's mean fixation is about 330 ms (Rayner, "Eye movements
//!   in reading and information processing: 20 years of research",
//!   Psychological Bulletin 124(3), 1998, Table 1).
//! - Saccade amplitudes are exponential with a mean of 5° (Rayner's table
//!   gives 4° for scene viewing on a screen; a headset's wider view adds a
//!   little), at most 20°, and the gaze stays within 15° of the head's axis:
//!   larger gaze shifts are made mostly with the head (Freedman, "Coordination
//!   of the eyes and head during visual orienting", Experimental Brain
//!   Research 190, 2008), which the head path already moves.
//! - A saccade of amplitude A lasts `D = 2.2 A + 21` ms, the main sequence
//!   (Baloh et al., "Quantitative measurement of saccade amplitude,
//!   duration, and velocity", Neurology 25, 1975), along a minimum-jerk
//!   profile `s(τ) = 10τ³ − 15τ⁴ + 6τ⁵` (Flash and Hogan, Journal of
//!   Neuroscience 5(7), 1985), whose peak velocity `1.875 A / D` stays
//!   under 600°/s for every amplitude allowed.

use super::Fov;

/// Median fixation, seconds.
const FIXATION_MEDIAN_S: f64 = 0.280;
/// Log-standard deviation of fixation durations.
const FIXATION_SIGMA: f64 = 0.45;
/// Shortest and longest fixation, seconds.
const FIXATION_RANGE_S: (f64, f64) = (0.100, 1.000);
/// Mean saccade amplitude, degrees.
const AMPLITUDE_MEAN_DEG: f64 = 5.0;
/// Largest saccade amplitude, degrees.
pub const AMPLITUDE_MAX_DEG: f64 = 20.0;
/// Largest gaze angle from the head's axis, degrees.
pub const RADIUS_DEG: f64 = 15.0;

/// A saccade's duration in seconds for amplitude `a_deg` (the main
/// sequence).
pub fn saccade_s(a_deg: f64) -> f64 {
    (2.2 * a_deg + 21.0) / 1000.0
}

/// One fixation and the saccade that ends it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Step {
    /// When the fixation starts, seconds.
    start: f64,
    /// Its duration, seconds.
    fixation: f64,
    /// Where the eye rests, degrees (yaw, pitch).
    at: [f64; 2],
    /// Where the next saccade lands.
    next: [f64; 2],
}

impl Step {
    fn saccade(&self) -> f64 {
        saccade_s(distance(self.at, self.next))
    }

    fn end(&self) -> f64 {
        self.start + self.fixation + self.saccade()
    }
}

/// A gaze path: fixed at the head's axis, or scripted fixations and
/// saccades.
#[derive(Clone, Debug, PartialEq)]
pub struct GazePath {
    steps: Vec<Step>,
}

/// A deterministic generator (xorshift64*).
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let v = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d);
        ((v >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// A standard normal deviate (Box–Muller).
    fn normal(&mut self) -> f64 {
        let (u, v) = (self.unit(), self.unit());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

impl GazePath {
    /// The gaze fixed on the head's axis.
    pub fn centre() -> GazePath {
        GazePath { steps: Vec::new() }
    }

    /// Fixations and saccades from `seed`, covering `duration_s` seconds
    /// from 0 (see the module for the model).
    pub fn saccades(seed: u64, duration_s: f64) -> GazePath {
        let mut rng = Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
        let mut steps = Vec::new();
        let (mut t, mut at) = (0.0, [0.0, 0.0]);
        while t <= duration_s.max(0.0) && steps.len() < 100_000 {
            let (lo, hi) = FIXATION_RANGE_S;
            let fixation =
                (FIXATION_MEDIAN_S * (FIXATION_SIGMA * rng.normal()).exp()).clamp(lo, hi);
            let next = Self::landing(&mut rng, at);
            let step = Step {
                start: t,
                fixation,
                at,
                next,
            };
            t = step.end();
            at = next;
            steps.push(step);
        }
        GazePath { steps }
    }

    /// Where a saccade from `at` lands: an exponential amplitude in a
    /// uniform direction, shortened to stay within [`RADIUS_DEG`].
    fn landing(rng: &mut Rng, at: [f64; 2]) -> [f64; 2] {
        let amplitude = (-AMPLITUDE_MEAN_DEG * rng.unit().ln()).min(AMPLITUDE_MAX_DEG);
        let angle = std::f64::consts::TAU * rng.unit();
        let mut to = [
            at[0] + amplitude * angle.cos(),
            at[1] + amplitude * angle.sin(),
        ];
        let r = distance(to, [0.0, 0.0]);
        if r > RADIUS_DEG {
            // Back along the line towards the axis until inside.
            to = [to[0] * RADIUS_DEG / r, to[1] * RADIUS_DEG / r];
        }
        to
    }

    /// The gaze at time `t` seconds, degrees (yaw right, pitch up); before
    /// 0 the first fixation, after the path's end its last point.
    pub fn at(&self, t: f64) -> [f64; 2] {
        let Some(last) = self.steps.last() else {
            return [0.0, 0.0];
        };
        let i = self.steps.partition_point(|s| s.end() <= t);
        let Some(s) = self.steps.get(i) else {
            return last.next;
        };
        let into = t - s.start - s.fixation;
        if into <= 0.0 {
            return s.at;
        }
        let tau = (into / s.saccade()).min(1.0);
        let k = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau);
        [
            s.at[0] + k * (s.next[0] - s.at[0]),
            s.at[1] + k * (s.next[1] - s.at[1]),
        ]
    }

    /// The saccades' start times and amplitudes, in order.
    pub fn saccade_list(&self) -> Vec<(f64, f64)> {
        self.steps
            .iter()
            .map(|s| (s.start + s.fixation, distance(s.at, s.next)))
            .collect()
    }
}

/// Where gaze direction `deg` (yaw right, pitch up, degrees from the
/// view's axis) falls in an eye image with field of view `fov`, as NDC
/// (+y down): the image is linear in the tangents.
pub fn ndc(fov: &Fov, deg: [f64; 2]) -> [f64; 2] {
    let [tl, tr, tu, td] = fov.tangents();
    let (tx, ty) = (deg[0].to_radians().tan(), deg[1].to_radians().tan());
    [
        2.0 * (tx - tl) / (tr - tl) - 1.0,
        2.0 * (ty - tu) / (td - tu) - 1.0,
    ]
}

#[cfg(test)]
mod tests;
