//! Temporal upsampling of the inset's wide views to the eye's resolution
//! (`inset-taau`): the math the pass (`render/passes/inset_taa.rs` in its
//! upsampling mode) and its shader (`shaders/inset_taau.comp`) follow,
//! here without Vulkan types so it can be tested against brute force.
//!
//! `inset-taa` ([`super::taa`]) accumulates each wide view at its own
//! resolution; the composite then upsamples the result, and an edge
//! spread over the upsampling's ramp still changes pixels the reference
//! leaves alone as it moves (the bench's flicker floor,
//! `src/bench/flicker_floor.rs`, bounds every wide view of that size
//! from below). Temporal upsampling keeps the history at the eye's
//! resolution instead and lets each frame's jittered wide samples land
//! where they lie in it (Karis, "High Quality Temporal Supersampling",
//! SIGGRAPH 2014 course *Advances in Real-Time Rendering*, the
//! upsampling of Unreal Engine 4's TAAU; Yang, Liu and Salvi, "A Survey of
//! Temporal Antialiasing Techniques", CGF 39(2), 2020, §6.1; the weighted
//! accumulation of AMD's FidelityFX Super Resolution 2, GPUOpen
//! documentation, "Accumulation"):
//!
//! 1. **Samples where they lie.** Frame n's wide viewport is moved by the
//!    Halton jitter j ([`super::taa::jitter`], wide pixels), so wide texel
//!    k holds the scene point at k + ½ − j ([`sample_position`]). The eye
//!    pixel centre c lies at u = c·s in wide pixels (s = wide / eye per
//!    axis); the texel holding image position u + j is
//!    [`nearest_texel`], and the 3×3 texels around it are the frame's
//!    samples for the pixel.
//! 2. **Reconstruction.** Each sample is weighted by its distance d to c
//!    in eye pixels, w = exp(−2.29 d²) ([`sample_weight`]: Karis 2014's
//!    Gaussian fit of a Blackman-Harris window of width 3.3), and the
//!    frame's estimate is Σ w·x / Σ w ([`estimate`]) with confidence
//!    W = Σ w: a sample at the pixel centre counts fully, one a pixel away
//!    a tenth.
//! 3. **Weighted accumulation.** The history holds a colour and the
//!    weight N of the samples behind it (alpha channel). A frame adds its
//!    estimate with weight W: out = h + W / (N + W) · (x − h), and
//!    N' = min(N + W, N_max) ([`accumulate`]). N_max = W̄ / α
//!    ([`weight_cap`]), W̄ = (π / 2.29) s_x s_y the mean of W over
//!    uniformly placed samples (s_x s_y samples per eye pixel², each
//!    weighing ∫ exp(−2.29 r²) dA = π / 2.29 in all): about 1/α frames'
//!    worth of samples, so with α = 0.1 a pixel keeps about ten frames,
//!    however the jitter placed them. A pixel without history (first
//!    frame, off the previous view) starts from the estimate alone.
//! 4. **Reprojection and clamp** as in [`super::taa`]: the history is
//!    read where the pixel's surface point lay (nearest depth of the 3×3
//!    samples, Catmull-Rom filtered at the eye's resolution) and clamped
//!    in YCoCg to the samples' variance box, never narrower than the
//!    estimate.
//!
//! The reads reach at most [`READ_REACH`] wide texels from u, which the
//! wide views' hole ([`super::inset_hole`]) keeps drawn around the seam.

/// The Gaussian's exponent: Karis 2014 fits exp(−2.29 x²) to the
/// Blackman-Harris window of width 3.3 pixels used to weight TAA samples.
pub const GAUSSIAN_K: f64 = 2.29;

/// How far, in wide texels, the centres of the texels the pass reads for
/// one eye pixel lie from the pixel's unjittered position u: the 3×3
/// around the texel holding u + j, with |j| ≤ ½ per axis, lie within
/// ½ + ½ + 1 = 2 per axis.
pub const READ_REACH: f64 = 2.0;

/// A sample's weight at offset `d` (eye pixels) from the pixel centre:
/// exp(−[`GAUSSIAN_K`] |d|²), 1 at the centre.
pub fn sample_weight(d: [f64; 2]) -> f64 {
    (-GAUSSIAN_K * (d[0] * d[0] + d[1] * d[1])).exp()
}

/// The wide texel (per axis) whose area holds image position `u + j`:
/// floor(u + j), for the pixel's unjittered wide position `u` and the
/// frame's jitter `j` (wide pixels).
pub fn nearest_texel(u: [f64; 2], j: [f64; 2]) -> [i64; 2] {
    [(u[0] + j[0]).floor() as i64, (u[1] + j[1]).floor() as i64]
}

/// Where texel `k`'s sample lies in the scene, in unjittered wide pixels,
/// when the viewport was moved by `j`: k + ½ − j.
pub fn sample_position(k: [i64; 2], j: [f64; 2]) -> [f64; 2] {
    [k[0] as f64 + 0.5 - j[0], k[1] as f64 + 0.5 - j[1]]
}

/// One frame's estimate at eye pixel `p` (integer pixel, centre p + ½) of
/// eyes `eye` pixels, from a wide view of `wide` pixels drawn with jitter
/// `j`, whose texels `texel` returns (clamped to the view): the
/// [`sample_weight`]-weighted mean of the 3×3 texels around
/// [`nearest_texel`] and the weights' sum W. The mean is a convex
/// combination of the samples.
pub fn estimate(
    p: [u32; 2],
    eye: [u32; 2],
    wide: [u32; 2],
    j: [f64; 2],
    texel: impl Fn([i64; 2]) -> [f32; 3],
) -> ([f32; 3], f64) {
    let s = [0, 1].map(|a| wide[a] as f64 / eye[a].max(1) as f64);
    let u = [0, 1].map(|a| (p[a] as f64 + 0.5) * s[a]);
    let k0 = nearest_texel(u, j);
    let mut sum = [0.0f64; 3];
    let mut total = 0.0;
    for dy in -1..=1 {
        for dx in -1..=1 {
            let k = [
                (k0[0] + dx).clamp(0, wide[0] as i64 - 1),
                (k0[1] + dy).clamp(0, wide[1] as i64 - 1),
            ];
            let x = sample_position(k, j);
            let w = sample_weight([(x[0] - u[0]) / s[0], (x[1] - u[1]) / s[1]]);
            let c = texel(k);
            for (acc, v) in sum.iter_mut().zip(c) {
                *acc += w * v as f64;
            }
            total += w;
        }
    }
    let mean = sum.map(|v| (v / total.max(f64::MIN_POSITIVE)) as f32);
    (mean, total)
}

/// The history's weight cap N_max = (π / [`GAUSSIAN_K`]) s_x s_y / α for
/// wide views at `scale` = (s_x, s_y) of the eye per axis and blend
/// weight `alpha`: 1/α frames of the mean [`estimate`] weight.
pub fn weight_cap(scale: [f64; 2], alpha: f64) -> f64 {
    std::f64::consts::PI / GAUSSIAN_K * scale[0] * scale[1] / alpha.max(1e-6)
}

/// One pixel's accumulation: the (clamped) history colour `h` with weight
/// `n` (None: no usable history) and the frame's estimate `x` with weight
/// `w`; returns the new colour and weight (capped at `cap`).
pub fn accumulate(h: Option<([f32; 3], f64)>, x: [f32; 3], w: f64, cap: f64) -> ([f32; 3], f64) {
    let Some((h, n)) = h else {
        return (x, w.min(cap));
    };
    let n = n.clamp(0.0, cap);
    let beta = (w / (n + w).max(f64::MIN_POSITIVE)) as f32;
    let out = [0, 1, 2].map(|i| h[i] + beta * (x[i] - h[i]));
    (out, (n + w).min(cap))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::taa::jitter;
    use proptest::prelude::*;

    proptest! {
        /// The texels read for a pixel lie within READ_REACH of u, and the
        /// nearest texel of brute force over a wide row is among them.
        #[test]
        fn reads_stay_within_the_reach_and_hold_the_nearest_sample(
            u in proptest::array::uniform2(2.0f64..60.0),
            j in proptest::array::uniform2(-0.5f64..0.4999),
        ) {
            let k0 = nearest_texel(u, j);
            for dy in -1..=1i64 {
                for dx in -1..=1i64 {
                    let k = [k0[0] + dx, k0[1] + dy];
                    for a in 0..2 {
                        let centre = k[a] as f64 + 0.5;
                        prop_assert!((centre - u[a]).abs() <= READ_REACH + 1e-9);
                    }
                }
            }
            // Brute force: per axis, the sample nearest u over texels 0..64.
            for a in 0..2 {
                let dist = |k: i64| (k as f64 + 0.5 - j[a] - u[a]).abs();
                let best = (0..64i64)
                    .min_by(|x, y| dist(*x).total_cmp(&dist(*y)))
                    .unwrap();
                prop_assert!((best - k0[a]).abs() <= 1);
            }
        }

        /// The estimate is the brute-force weighted mean of the 3x3, lies
        /// within the samples' range, and a flat view gives its colour.
        #[test]
        fn estimate_is_the_weighted_mean_of_its_samples(
            p in proptest::array::uniform2(0u32..40),
            j in proptest::array::uniform2(-0.5f64..0.4999),
            seed in 0u32..1000,
        ) {
            let eye = [40, 40];
            let wide = [20, 20];
            let texel = |k: [i64; 2]| {
                let h = (k[0] as u32 * 7919 + k[1] as u32 * 104729 + seed).wrapping_mul(2654435761);
                [(h % 1000) as f32 / 1000.0, 0.5, 0.25]
            };
            let (m, w) = estimate(p, eye, wide, j, texel);
            let u = [0, 1].map(|a| (p[a] as f64 + 0.5) * 0.5);
            let k0 = nearest_texel(u, j);
            let (mut sum, mut total, mut lo, mut hi) = (0.0, 0.0, f32::MAX, f32::MIN);
            for ky in k0[1] - 1..=k0[1] + 1 {
                for kx in k0[0] - 1..=k0[0] + 1 {
                    let k = [kx.clamp(0, 19), ky.clamp(0, 19)];
                    let x = sample_position(k, j);
                    let d = [(x[0] - u[0]) * 2.0, (x[1] - u[1]) * 2.0];
                    let wk = (-2.29 * (d[0] * d[0] + d[1] * d[1])).exp();
                    sum += wk * texel(k)[0] as f64;
                    total += wk;
                    lo = lo.min(texel(k)[0]);
                    hi = hi.max(texel(k)[0]);
                }
            }
            prop_assert!((w - total).abs() < 1e-9);
            prop_assert!((m[0] as f64 - sum / total).abs() < 1e-5);
            prop_assert!(m[0] >= lo - 1e-6 && m[0] <= hi + 1e-6);
            let (flat, _) = estimate(p, eye, wide, j, |_| [0.3, 0.6, 0.9]);
            prop_assert!((flat[0] - 0.3).abs() < 1e-6 && (flat[2] - 0.9).abs() < 1e-6);
        }

        /// Accumulation: no history gives the estimate; the step is the
        /// share w / (n + w) of the difference; the weight stays capped;
        /// repeated equal estimates converge to them.
        #[test]
        fn accumulation_is_the_running_weighted_mean(
            h in proptest::array::uniform3(0f32..1.0),
            x in proptest::array::uniform3(0f32..1.0),
            n in 0f64..20.0,
            w in 0.05f64..1.5,
        ) {
            let cap = weight_cap([0.5, 0.5], 0.1);
            prop_assert_eq!(accumulate(None, x, w, cap).0, x);
            let (out, n2) = accumulate(Some((h, n)), x, w, cap);
            let nc = n.min(cap);
            for i in 0..3 {
                let want = h[i] as f64 + w / (nc + w) * (x[i] - h[i]) as f64;
                prop_assert!((out[i] as f64 - want).abs() < 1e-5);
            }
            prop_assert!(n2 <= cap + 1e-12);
            let mut s = (h, n);
            for _ in 0..1000 {
                s = accumulate(Some(s), x, w, cap);
            }
            for (got, want) in s.0.iter().zip(x) {
                prop_assert!((got - want).abs() < 1e-3);
            }
        }
    }

    /// The cap's W̄ against brute force: W averaged over pixels and the
    /// jitter phases is (π / 2.29) s_x s_y within the 3×3 window's
    /// truncation.
    #[test]
    fn the_mean_estimate_weight_is_the_caps_density() {
        for (eye, wide) in [([40u32, 40], [20u32, 20]), ([50, 40], [35, 28])] {
            let s = [0, 1].map(|a| wide[a] as f64 / eye[a] as f64);
            let (mut sum, mut n) = (0.0, 0);
            for frame in 0..64 {
                let j = jitter(frame);
                for y in 8..eye[1] - 8 {
                    for x in 8..eye[0] - 8 {
                        sum += estimate([x, y], eye, wide, j, |_| [0.0; 3]).1;
                        n += 1;
                    }
                }
            }
            let mean = sum / n as f64;
            let want = weight_cap(s, 1.0);
            assert!(
                (mean - want).abs() < 0.04 * want,
                "scale {s:?}: {mean} vs {want}"
            );
        }
    }

    #[test]
    fn sample_weight_is_one_at_the_centre_and_falls_off() {
        assert_eq!(sample_weight([0.0, 0.0]), 1.0);
        let a = sample_weight([0.5, 0.0]);
        let b = sample_weight([0.0, 0.5]);
        assert_eq!(a, b);
        assert!(a < 1.0 && sample_weight([1.0, 0.0]) < a);
        assert!((sample_weight([1.0, 0.0]) - (-2.29f64).exp()).abs() < 1e-12);
    }

    /// The point of upsampling over frames: a still vertical edge at a
    /// fractional eye position, seen through a wide view at half the
    /// eye's resolution. The wide view's own pixels put the edge on a
    /// wide-texel boundary (up to a whole eye pixel off); accumulating
    /// jittered point samples at the eye's resolution puts its half-way
    /// crossing within a quarter pixel of the truth.
    #[test]
    fn a_still_edge_accumulates_to_its_own_position() {
        let eye = [32u32, 4];
        let wide = [16u32, 2];
        let cap = weight_cap([0.5, 0.5], 0.1);
        for edge in [10.3f64, 11.0, 11.7, 12.5] {
            // Wide texel k, jitter j: the scene point k + 0.5 - j (wide
            // px) lies at eye x = 2 (k + 0.5 - j): white past the edge.
            let mut hist: Vec<Option<([f32; 3], f64)>> = vec![None; eye[0] as usize];
            for frame in 0..64 {
                let j = jitter(frame);
                let texel = |k: [i64; 2]| {
                    let x = 2.0 * sample_position(k, j)[0];
                    if x >= edge {
                        [1.0; 3]
                    } else {
                        [0.0; 3]
                    }
                };
                for (px, h) in hist.iter_mut().enumerate() {
                    let (x, w) = estimate([px as u32, 1], eye, wide, j, texel);
                    *h = Some(accumulate(*h, x, w, cap));
                }
            }
            let value = |px: usize| hist[px].unwrap().0[0] as f64;
            // Far from the edge: exact.
            assert!(value(2) < 1e-3 && value(29) > 0.999, "edge {edge}");
            // Monotone across it.
            for px in 1..eye[0] as usize {
                assert!(value(px) >= value(px - 1) - 1e-3, "edge {edge} at {px}");
            }
            // The half-way crossing, linearly interpolated between pixel
            // centres, against the edge's position.
            let crossing = (1..eye[0] as usize)
                .find(|&px| value(px) >= 0.5)
                .map(|px| {
                    let (a, b) = (value(px - 1), value(px));
                    px as f64 - 1.0 + 0.5 + (0.5 - a) / (b - a)
                })
                .unwrap();
            assert!(
                (crossing - edge).abs() < 0.25,
                "edge {edge}: crossing {crossing}"
            );
        }
    }
}
