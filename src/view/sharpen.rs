//! Range-limited sharpening of the temporally upsampled periphery
//! (`inset-sharpen[=S]`): the math the composite (`shaders/inset_composite.comp`,
//! filter 2) applies to the eye-sized history of `inset-taau`, here
//! without Vulkan types so it can be tested against brute force.
//!
//! The accumulated history is softer than the reference: each frame's
//! estimate is a Gaussian-weighted mean ([`super::taau`]) and the history
//! is resampled through the Catmull-Rom filter every frame it moves. A
//! soft edge that slides by a third of a pixel changes a few pixels a
//! little where the reference changes one pixel more, and the bench's
//! flicker counts what changes beyond the reference (`src/bench/flicker.rs`).
//! Sharpening at presentation, not in the history (which would feed back
//! into every later frame), takes part of that softness back:
//!
//! `out = clamp(c + S (c − m), lo, hi)`
//!
//! with `m` the mean of the pixel's four edge neighbours and `lo`, `hi` the
//! least and greatest of the pixel and those four, per channel in linear
//! light. `c − m = −¼ ∇²c` with ∇² the five-point discrete Laplacian, so
//! before the clamp this is Laplacian sharpening, the unsharp mask of
//! Gonzalez and Woods (*Digital Image Processing*, 4th ed., §3.6): gain 1
//! at zero frequency, 1 + S at an axis' Nyquist frequency, 1 + 2 S at the
//! diagonal one. The clamp to the cross's range is what AMD's contrast-
//! adaptive sharpening does to stay free of ringing (Lottes, "FidelityFX
//! CAS", GPUOpen 2019; RCAS in FidelityFX Super Resolution 1.0): the
//! output never leaves the values already around the pixel, so no halo
//! and no overshoot that the next frame could flip.
//!
//! Tested below: bounded by the cross; flat and affine images unchanged;
//! a step blurred by a Gaussian of at least 0.4 pixel, at any sub-pixel
//! position, sharpened with S ≤ 1 stays monotone and is no farther from
//! the area-sampled step than before (1 + S at Nyquist
//! overshoots sharper edges, which is why the default is 1). The bench on
//! lavapipe chose the default: on the garage at inset=0.7, S = 0.5 and 1
//! gave flicker 0.000131 and 0.000121 (inset-taau alone 0.000144, the
//! baseline 0.000113), and S = 2 and 4 gave 0.000125 and 0.000149 in a
//! trial build (docs/techniques/inset.md, "Sharpening the upsampled periphery").

/// The default strength S.
pub const DEFAULT_STRENGTH: f64 = 1.0;

/// The strengths `inset-sharpen=S` accepts.
pub const STRENGTH_RANGE: (f64, f64) = (0.1, 2.0);

/// How far, in eye pixels, the sharpening reads from the pixel: its four
/// edge neighbours, one pixel away.
pub const READ_REACH_EYE_PX: f64 = 1.0;

/// One channel of a pixel `c` sharpened with strength `s` against its
/// four edge neighbours `n`: `clamp(c + s (c − mean(n)), min, max)` over
/// the pixel and `n`.
pub fn sharpen(c: f64, n: [f64; 4], s: f64) -> f64 {
    let m = (n[0] + n[1] + n[2] + n[3]) / 4.0;
    let lo = n.iter().fold(c, |a, &b| a.min(b));
    let hi = n.iter().fold(c, |a, &b| a.max(b));
    (c + s * (c - m)).clamp(lo, hi)
}

/// A one-channel image of `width` (rows of it) sharpened with strength
/// `s`, neighbours past the border clamped to it, as the shader reads
/// them.
pub fn sharpen_image(img: &[f64], width: usize, s: f64) -> Vec<f64> {
    let height = img.len() / width.max(1);
    let at = |x: i64, y: i64| {
        let x = x.clamp(0, width as i64 - 1) as usize;
        let y = y.clamp(0, height as i64 - 1) as usize;
        img[y * width + x]
    };
    (0..height * width)
        .map(|i| {
            let (x, y) = ((i % width) as i64, (i / width) as i64);
            let n = [at(x - 1, y), at(x + 1, y), at(x, y - 1), at(x, y + 1)];
            sharpen(at(x, y), n, s)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Pixel i's share of [i, i + 1] right of a step at `pos`.
    fn area_step(n: usize, pos: f64) -> Vec<f64> {
        (0..n)
            .map(|i| (i as f64 + 1.0 - pos).clamp(0.0, 1.0))
            .collect()
    }

    /// The standard normal's distribution function (Abramowitz and Stegun
    /// 7.1.26 for erf, error under 1.5e-7).
    fn phi(x: f64) -> f64 {
        let z = x.abs() / std::f64::consts::SQRT_2;
        let t = 1.0 / (1.0 + 0.3275911 * z);
        let poly = t
            * (0.254829592
                + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
        let erf = 1.0 - poly * (-z * z).exp();
        0.5 * (1.0 + erf.copysign(x))
    }

    /// A step at `pos` blurred by a Gaussian of `sigma` pixels, each
    /// pixel's mean over its area (brute force over 200 points).
    fn blurred_step(n: usize, pos: f64, sigma: f64) -> Vec<f64> {
        (0..n)
            .map(|i| {
                (0..200)
                    .map(|k| phi((i as f64 + (k as f64 + 0.5) / 200.0 - pos) / sigma))
                    .sum::<f64>()
                    / 200.0
            })
            .collect()
    }

    fn l1(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum()
    }

    proptest! {
        #[test]
        fn stays_within_the_cross(c in -2.0f64..2.0, n in prop::array::uniform4(-2.0f64..2.0),
                                  s in 0.0f64..4.0) {
            let out = sharpen(c, n, s);
            let lo = n.iter().fold(c, |a, &b| a.min(b));
            let hi = n.iter().fold(c, |a, &b| a.max(b));
            prop_assert!(out >= lo && out <= hi, "{out} outside [{lo}, {hi}]");
        }

        #[test]
        fn leaves_affine_images_alone(a in -1.0f64..1.0, bx in -0.2f64..0.2, by in -0.2f64..0.2,
                                      s in 0.0f64..2.0) {
            let (w, h) = (7usize, 5usize);
            let img: Vec<f64> = (0..w * h)
                .map(|i| a + bx * (i % w) as f64 + by * (i / w) as f64)
                .collect();
            let out = sharpen_image(&img, w, s);
            // Away from the border, whose clamped neighbours bend the plane.
            for y in 1..h - 1 {
                for x in 1..w - 1 {
                    let i = y * w + x;
                    prop_assert!((out[i] - img[i]).abs() < 1e-12, "{} vs {}", out[i], img[i]);
                }
            }
        }

        #[test]
        fn takes_a_soft_step_back_toward_the_sharp_one(pos in 5.0f64..6.0, sigma in 0.4f64..2.0,
                                                       s in 0.0f64..=1.0) {
            let n = 12;
            let soft = blurred_step(n, pos, sigma);
            let sharp = area_step(n, pos);
            let out = sharpen_image(&soft, n, s);
            let (before, after) = (l1(&soft, &sharp), l1(&out, &sharp));
            prop_assert!(after <= before + 1e-9, "{after} > {before}");
            // Still a step: no pixel turned back (not so for every
            // monotone row: a kink can be pushed past its neighbour).
            for pair in out.windows(2) {
                prop_assert!(pair[1] >= pair[0] - 1e-12, "{out:?}");
            }
        }
    }

    #[test]
    fn zero_strength_is_the_identity() {
        let img: Vec<f64> = (0..30).map(|i| ((i * 7919) % 13) as f64 / 13.0).collect();
        assert_eq!(sharpen_image(&img, 6, 0.0), img);
    }

    #[test]
    fn steepens_a_soft_step() {
        // The brute force above in one case, with a margin: a one-pixel
        // blur comes back about a third of the way.
        let (soft, sharp) = (blurred_step(12, 5.5, 1.0), area_step(12, 5.5));
        let out = sharpen_image(&soft, 12, DEFAULT_STRENGTH);
        assert!(l1(&out, &sharp) < 0.8 * l1(&soft, &sharp));
    }

    #[test]
    fn a_stronger_setting_overshoots_a_sharp_step() {
        // Why S stays at most 1 by default: at S = 2 a nearly sharp edge
        // (sigma 0.3) ends farther from the area-sampled step than it began.
        let (soft, sharp) = (blurred_step(12, 5.33, 0.3), area_step(12, 5.33));
        let out = sharpen_image(&soft, 12, 2.0);
        assert!(l1(&out, &sharp) > l1(&soft, &sharp));
    }
}
