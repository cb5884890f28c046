//! The Lanczos-3 resampling of the temporally upsampled history
//! (`inset-taau-lanczos`): the weights the upsampling shader
//! (`shaders/inset_taau.comp`) reads the previous frame's history with,
//! here without Vulkan types so they can be tested against brute force.
//!
//! `inset-taau` reads the history where each pixel's surface point lay
//! in the previous frame, through the Catmull-Rom filter
//! ([`super::taa::catmull_rom_weights`]). While the head turns, that read
//! lands between texels every frame, and the history, which keeps about
//! ten frames, has been resampled that many times: a cubic's response
//! falls well short of 1 at half the Nyquist frequency, so the repeated
//! reads soften the edges the bench's flicker then counts as they slide
//! (`src/bench/flicker.rs`; [`super::sharpen`] takes part of it back at
//! presentation). The Lanczos window of three lobes keeps its response
//! near 1 much closer to Nyquist (Duchon, "Lanczos Filtering in One and
//! Two Dimensions", Journal of Applied Meteorology 18(8), 1979; Turkowski,
//! "Filters for Common Resampling Tasks", *Graphics Gems*, 1990):
//!
//! `L(x) = sinc(x) sinc(x / 3)` for |x| < 3, else 0, `sinc(x) = sin(πx) / (πx)`,
//!
//! read over the six texels around the position along each axis (6×6 in
//! all), the weights divided by their sum so a flat image stays flat
//! (Lanczos-3 sums to 1 only at texel centres). At a texel centre it gives
//! that texel alone, like Catmull-Rom, so a still view reads its history
//! unchanged.
//!
//! Its negative lobes overshoot at edges; the history read is clamped to
//! the frame's neighbourhood box before it is blended, as with
//! Catmull-Rom.

/// How many texels the read spans per axis: 2 × the window's three lobes.
pub const TAPS: usize = 6;

/// The Lanczos window of three lobes at `x` (texels): sinc(x) sinc(x / 3)
/// inside |x| < 3, 0 outside; 1 at x = 0.
pub fn lanczos3(x: f64) -> f64 {
    if x.abs() >= 3.0 {
        return 0.0;
    }
    if x.abs() < 1e-9 {
        return 1.0;
    }
    let px = std::f64::consts::PI * x;
    3.0 * px.sin() * (px / 3.0).sin() / (px * px)
}

/// The normalized Lanczos-3 weights of the six texels around a read at
/// fraction `f` in [0, 1) past the third texel's centre, per axis: texel
/// i (0..6) lies at offset i − 2 from the third, at distance f + 2 − i
/// from the read. They sum to 1 and give the third texel alone at f = 0.
pub fn weights(f: f64) -> [f64; TAPS] {
    let mut w = [0.0; TAPS];
    for (i, v) in w.iter_mut().enumerate() {
        *v = lanczos3(f + 2.0 - i as f64);
    }
    let sum: f64 = w.iter().sum();
    w.map(|v| v / sum)
}

/// The five linearly interpolated reads per axis that give the six
/// [`weights`] at fraction `f`: (offset from the third texel's centre,
/// weight). The two middle texels (offsets 0 and 1), whose weights are
/// both non-negative, are read as one at their weighted position, which
/// a bilinear sampler interpolates exactly; the others are read at their
/// centres. The shader reads 5×5 texels instead of 6×6 this way.
pub fn merged(f: f64) -> [(f64, f64); 5] {
    let w = weights(f);
    let mid = w[2] + w[3];
    [
        (-2.0, w[0]),
        (-1.0, w[1]),
        (w[3] / mid, mid),
        (2.0, w[4]),
        (3.0, w[5]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The Lanczos-3 kernel straight from its definition, as a product of
    /// two normalized sincs.
    fn brute(x: f64) -> f64 {
        let sinc = |t: f64| match t == 0.0 {
            true => 1.0,
            false => (std::f64::consts::PI * t).sin() / (std::f64::consts::PI * t),
        };
        match x.abs() < 3.0 {
            true => sinc(x) * sinc(x / 3.0),
            false => 0.0,
        }
    }

    #[test]
    fn at_a_texel_centre_the_read_is_that_texel() {
        for (w, want) in weights(0.0).iter().zip([0.0, 0.0, 1.0, 0.0, 0.0, 0.0]) {
            assert!((w - want).abs() < 1e-15, "{:?}", weights(0.0));
        }
        assert_eq!(lanczos3(0.0), 1.0);
        for n in [-3.0, -2.0, -1.0, 1.0, 2.0, 3.0, 4.5] {
            assert!(lanczos3(n).abs() < 1e-15, "L({n}) = {}", lanczos3(n));
        }
    }

    #[test]
    fn the_lobes_alternate_in_sign() {
        // Positive inside one texel, negative from 1 to 2, positive from 2 to 3.
        assert!(lanczos3(0.5) > 0.0 && lanczos3(-0.5) > 0.0);
        assert!(lanczos3(1.5) < 0.0 && lanczos3(-1.5) < 0.0);
        assert!(lanczos3(2.5) > 0.0 && lanczos3(-2.5) > 0.0);
    }

    /// A row's value at `x` (texel centres at integers), read linearly
    /// between its two nearest texels, clamped to the row as the sampler
    /// clamps to the edge.
    fn linear_read(row: &[f64], x: f64) -> f64 {
        let i = x.floor();
        let t = x - i;
        let at = |k: f64| row[(k.max(0.0) as usize).min(row.len() - 1)];
        at(i) * (1.0 - t) + at(i + 1.0) * t
    }

    proptest! {
        /// Against the six texels read one by one: the five merged reads
        /// give the same value for any row, near its ends too.
        #[test]
        fn five_linear_reads_are_the_six_taps(
            row in proptest::collection::vec(0f64..1.0, 8),
            f in 0f64..1.0,
            third in 0usize..8,
        ) {
            let clamped = |k: i64| row[k.clamp(0, row.len() as i64 - 1) as usize];
            let six: f64 = weights(f)
                .iter()
                .enumerate()
                .map(|(i, w)| w * clamped(third as i64 + i as i64 - 2))
                .sum();
            let five: f64 = merged(f)
                .iter()
                .map(|(o, w)| w * linear_read(&row, third as f64 + o))
                .sum();
            prop_assert!((six - five).abs() < 1e-12, "six {six}, five {five}");
        }

        #[test]
        fn the_kernel_is_its_definition(x in -4.0f64..4.0) {
            prop_assert!((lanczos3(x) - brute(x)).abs() < 1e-12);
        }

        #[test]
        fn weights_sum_to_one_and_mirror(f in 0f64..1.0) {
            let w = weights(f);
            prop_assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            // Reading at f from the left is reading at 1 − f from the right.
            let m = weights(1.0 - f);
            for i in 0..TAPS {
                // Texel i at distance f + 2 − i; read at 1 − f, texel
                // 5 − i lies at the opposite distance.
                prop_assert!((w[i] - m[TAPS - 1 - i]).abs() < 1e-12, "{w:?} {m:?}");
            }
        }

        /// Against brute force: the weights are the kernel at each texel's
        /// distance, renormalized.
        #[test]
        fn weights_are_the_kernel_renormalized(f in 0f64..1.0) {
            let raw: Vec<f64> = (0..TAPS).map(|i| brute(f + 2.0 - i as f64)).collect();
            let sum: f64 = raw.iter().sum();
            for (w, r) in weights(f).iter().zip(&raw) {
                prop_assert!((w - r / sum).abs() < 1e-12);
            }
        }

        /// A linear ramp is read back within 0.025 texel of its value
        /// (renormalized Lanczos-3 is not exactly linear-reproducing: at
        /// worst 0.02), and a read at f of samples of a sinusoid at a
        /// quarter of the sampling rate keeps at least 97 % of its
        /// amplitude (about 100 %) where Catmull-Rom keeps less (88 % at
        /// worst, f = ½): ten reads keep 29 % of it through Catmull-Rom.
        #[test]
        fn ramps_hold_and_mid_frequencies_keep_their_contrast(f in 0.05f64..0.95) {
            let w = weights(f);
            let ramp: f64 = (0..TAPS).map(|i| w[i] * (i as f64 - 2.0)).sum();
            prop_assert!((ramp - f).abs() < 0.025, "ramp read {ramp} at {f}");
            // Worst case over the sinusoid's phase: the response's modulus.
            let omega = std::f64::consts::FRAC_PI_2;
            let gain = |taps: &[f64], first: f64| {
                let (mut re, mut im) = (0.0, 0.0);
                for (i, t) in taps.iter().enumerate() {
                    let d = first + i as f64 - f;
                    re += t * (omega * d).cos();
                    im += t * (omega * d).sin();
                }
                (re * re + im * im).sqrt()
            };
            let lanczos = gain(&w, -2.0);
            let cubic = gain(&crate::view::taa::catmull_rom_weights(f), -1.0);
            prop_assert!(lanczos >= 0.97, "gain {lanczos} at {f}");
            prop_assert!(lanczos > cubic, "Lanczos {lanczos} vs Catmull-Rom {cubic} at {f}");
        }
    }
}
