//! Temporal anti-aliasing of the inset's wide views (`inset-taa[=A]`):
//! the math the pass (`render/passes/inset_taa.rs`) and its shader
//! (`shaders/inset_taa.comp`) follow, here without Vulkan types so it can
//! be tested against brute force.
//!
//! The wide views are drawn at a fraction of the eye's resolution, and at
//! 0.5 per axis with 4× MSAA a wide view has one sample per eye pixel: its
//! edges shimmer as the head turns, like a 1× render. Patney et al.
//! ("Towards Foveated Rendering for Gaze-Tracked Virtual Reality", ACM
//! TOG 35(6), 2016, §4) make a foveated periphery temporally stable by
//! accumulating it over frames; the accumulation here is the one of Karis
//! ("High Quality Temporal Supersampling", SIGGRAPH 2014 course *Advances
//! in Real-Time Rendering*) and Yang, Liu and Salvi ("A Survey of Temporal
//! Antialiasing Techniques", CGF 39(2), 2020, §3–4):
//!
//! 1. **Jitter** (`inset-taa-jitter`; off by default). Frame n draws the
//!    wide view with its viewport moved by a sub-pixel offset j(n)
//!    ([`jitter`]): the (2, 3) Halton sequence over [`JITTER_PHASES`]
//!    frames, centred on 0, so a still view is sampled at different points
//!    inside each pixel. Without it the samples differ only as the head
//!    moves, which is where shimmer arises; a still view then accumulates
//!    to itself.
//! 2. **Reprojection.** Each pixel's surface point (its NDC position and
//!    stored depth) is carried into the previous frame's view by
//!    [`super::reproject::reprojection`] (current view to previous view),
//!    and the history is read there through a Catmull-Rom filter
//!    ([`catmull_rom_weights`]).
//!    The depth used is the nearest of the pixel's 3×3 neighbourhood
//!    (Karis 2014), so a foreground edge carries its own motion.
//! 3. **Neighbourhood clamp.** The history colour is clamped, in YCoCg
//!    ([`to_ycocg`]), to the box spanned by the current frame's 3×3
//!    neighbourhood, narrowed to its mean ± [`VARIANCE_GAMMA`] standard
//!    deviations ([`neighbourhood_box`]; variance clipping, Salvi, "An
//!    Excursion in Temporal Supersampling", GDC 2016): what the history
//!    shows that the current frame cannot (disoccluded or moved surfaces)
//!    is pulled back to what it can, which bounds ghosting.
//!    The current frame is read the same way at the pixel centre plus
//!    the jitter, where the moved viewport put the centre's scene point,
//!    so the average is of samples at the centre, not spread over a pixel
//!    around it (which would blur the image by another pixel's box).
//! 4. **Blend.** `out = history + α (current − history)`, an exponential
//!    moving average with weight α on the new frame ([`resolve`]);
//!    without a usable history (first frame, a point that was off-screen
//!    or behind the previous eye) the current colour alone.
//!
//! Colours are linear RGB throughout (the wide views' sRGB images are
//! decoded by the sampler; the history is stored in 16-bit float).

/// The number of jitter offsets before the sequence repeats.
pub const JITTER_PHASES: u64 = 8;

/// The default weight α of the current frame in the blend: the history
/// keeps 90 % a frame, an effective window of about 1/α = 10 frames (the
/// value Karis 2014 and the survey's §4 give as common).
pub const DEFAULT_ALPHA: f64 = 0.1;

/// Frames a sequence is run before its accumulated image is measured
/// (the bench's flicker sequence): three jitter periods, after which the
/// first frame's weight in the average is (1 − α)^24 ≈ 8 % at the default
/// α.
pub const SETTLE_FRAMES: usize = 24;

/// The `index`-th element (from 1) of the van der Corput / Halton sequence
/// in `base`: the digits of `index` in `base` mirrored about the radix
/// point, in [0, 1).
pub fn halton(mut index: u64, base: u64) -> f64 {
    let b = base.max(2);
    let mut f = 1.0;
    let mut r = 0.0;
    while index > 0 {
        f /= b as f64;
        r += f * (index % b) as f64;
        index /= b;
    }
    r
}

/// Frame `frame`'s sub-pixel offset of the wide view's viewport, pixels,
/// each axis in [−0.5, 0.5): Halton (2, 3) at index `frame mod 8 + 1`,
/// less 0.5.
pub fn jitter(frame: u64) -> [f64; 2] {
    let i = frame % JITTER_PHASES + 1;
    [halton(i, 2) - 0.5, halton(i, 3) - 0.5]
}

/// The Catmull-Rom weights of the four texels around a read at fraction
/// `f` in [0, 1) past the second texel's centre (Catmull and Rom, "A Class
/// of Local Interpolating Splines", 1974; the cubic convolution kernel
/// with a = −0.5 of Keys, IEEE TASSP 29(6), 1981): the history is read
/// with them along each axis, since a bilinear read each frame blurs the
/// accumulated image a little more with every fractional move (Karis
/// 2014; Jimenez, "Filmic SMAA", SIGGRAPH 2016 course). They sum to 1
/// and give the second texel alone at f = 0.
pub fn catmull_rom_weights(f: f64) -> [f64; 4] {
    [
        f * (-0.5 + f * (1.0 - 0.5 * f)),
        1.0 + f * f * (-2.5 + 1.5 * f),
        f * (0.5 + f * (2.0 - 1.5 * f)),
        f * f * (-0.5 + 0.5 * f),
    ]
}

/// Linear RGB to YCoCg (Malvar and Sullivan, "YCoCg-R: A Color Space with
/// RGB Reversibility and Low Dynamic Range", JVT-I014, 2003): luma and
/// two chroma differences, a space in which a box of colours hugs the
/// neighbourhood's luma spread more tightly than an RGB box (Karis 2014).
pub fn to_ycocg(c: [f32; 3]) -> [f32; 3] {
    let [r, g, b] = c;
    [
        0.25 * r + 0.5 * g + 0.25 * b,
        0.5 * r - 0.5 * b,
        -0.25 * r + 0.5 * g - 0.25 * b,
    ]
}

/// YCoCg back to linear RGB (the inverse of [`to_ycocg`]).
pub fn from_ycocg(c: [f32; 3]) -> [f32; 3] {
    let [y, co, cg] = c;
    [y + co - cg, y + cg, y - co - cg]
}

/// The half-width of the variance box, standard deviations: Salvi 2016
/// gives 1 as tight and 1.25 as a common compromise between ghosting and
/// the flicker a tighter box lets through.
pub const VARIANCE_GAMMA: f32 = 1.25;

/// The clamp box of a neighbourhood `colours` (linear RGB, the pixel
/// included), in YCoCg: per component the extremes, narrowed to the mean
/// ± [`VARIANCE_GAMMA`] standard deviations (population).
pub fn neighbourhood_box(colours: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let n = colours.len().max(1) as f32;
    let ys: Vec<[f32; 3]> = colours.iter().map(|c| to_ycocg(*c)).collect();
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for i in 0..3 {
        let mean = ys.iter().map(|y| y[i]).sum::<f32>() / n;
        let var = ys.iter().map(|y| y[i] * y[i]).sum::<f32>() / n - mean * mean;
        let sigma = var.max(0.0).sqrt();
        for y in &ys {
            lo[i] = lo[i].min(y[i]);
            hi[i] = hi[i].max(y[i]);
        }
        lo[i] = lo[i].max(mean - VARIANCE_GAMMA * sigma);
        hi[i] = hi[i].min(mean + VARIANCE_GAMMA * sigma);
    }
    (lo, hi)
}

/// `c` clamped per component to the box `[lo, hi]`.
pub fn clamp_box(c: [f32; 3], lo: [f32; 3], hi: [f32; 3]) -> [f32; 3] {
    [0, 1, 2].map(|i| c[i].max(lo[i]).min(hi[i]))
}

/// One pixel's resolve: the history (None when unusable) clamped in YCoCg
/// to the [`neighbourhood_box`] of `neighbourhood` and `current` (the
/// current frame's 3×3 around the pixel), widened to hold `current`
/// itself, then blended with `current` at weight `alpha`; linear RGB in
/// and out. A history equal to `current` is kept whatever its
/// neighbours.
pub fn resolve(
    history: Option<[f32; 3]>,
    current: [f32; 3],
    neighbourhood: &[[f32; 3]],
    alpha: f32,
) -> [f32; 3] {
    let Some(h) = history else {
        return current;
    };
    let all: Vec<[f32; 3]> = neighbourhood
        .iter()
        .chain(std::iter::once(&current))
        .copied()
        .collect();
    let (lo, hi) = neighbourhood_box(&all);
    // Never narrower than the pixel's own colour: a thin feature whose
    // pixel lies outside its neighbourhood's spread is kept.
    let own = to_ycocg(current);
    let lo = [0, 1, 2].map(|i| lo[i].min(own[i]));
    let hi = [0, 1, 2].map(|i| hi[i].max(own[i]));
    let clamped = from_ycocg(clamp_box(to_ycocg(h), lo, hi));
    [0, 1, 2].map(|i| clamped[i] + alpha * (current[i] - clamped[i]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The radical inverse by brute force: the base-b digits of `index`,
    /// most significant first, read as a fraction least significant first.
    fn radical_inverse(index: u64, base: u64) -> f64 {
        let mut digits = Vec::new();
        let mut i = index;
        while i > 0 {
            digits.push(i % base);
            i /= base;
        }
        digits
            .iter()
            .enumerate()
            .map(|(k, &d)| d as f64 / (base as f64).powi(k as i32 + 1))
            .sum()
    }

    #[test]
    fn halton_starts_as_published() {
        let b2: Vec<f64> = (1..=4).map(|i| halton(i, 2)).collect();
        assert_eq!(b2, vec![0.5, 0.25, 0.75, 0.125]);
        let b3: Vec<f64> = (1..=3).map(|i| halton(i, 3)).collect();
        let want = [1.0 / 3.0, 2.0 / 3.0, 1.0 / 9.0];
        for (g, w) in b3.iter().zip(want) {
            assert!((g - w).abs() < 1e-15);
        }
        assert_eq!(halton(0, 2), 0.0);
    }

    #[test]
    fn jitter_is_centred_and_distinct() {
        let js: Vec<[f64; 2]> = (0..JITTER_PHASES).map(jitter).collect();
        for (i, a) in js.iter().enumerate() {
            assert!(a.iter().all(|v| (-0.5..0.5).contains(v)));
            for b in &js[i + 1..] {
                assert_ne!(a, b, "two phases share an offset");
            }
        }
        // The mean over a period lies within a sixteenth of a pixel of 0
        // on both axes (the 8 base-2 phases average 57/128, 7/128 below
        // the centre; the base-3 ones 1/2).
        for axis in 0..2 {
            let mean: f64 = js.iter().map(|j| j[axis]).sum::<f64>() / js.len() as f64;
            assert!(mean.abs() <= 1.0 / 16.0 + 1e-12, "axis {axis} mean {mean}");
        }
        assert_eq!(jitter(3), jitter(3 + JITTER_PHASES));
    }

    #[test]
    fn no_history_is_the_current_colour() {
        let c = [0.2, 0.4, 0.9];
        assert_eq!(resolve(None, c, &[[0.0; 3]; 9], 0.1), c);
    }

    #[test]
    fn a_thin_feature_keeps_its_history() {
        // A bright pixel among dark neighbours lies outside their spread;
        // its own history (the same colour) is kept, not eroded.
        let bright = [1.0; 3];
        let out = resolve(Some(bright), bright, &[[0.0; 3]; 8], 0.1);
        assert_eq!(out, bright);
    }

    #[test]
    fn a_history_outside_the_neighbourhood_is_pulled_in() {
        // Current frame all black around a black pixel; a white history
        // (a surface that has moved away) is clamped to black.
        let black = [0.0; 3];
        let out = resolve(Some([1.0; 3]), black, &[black; 9], 0.1);
        for v in out {
            assert!(v.abs() < 1e-6, "{out:?}");
        }
    }

    /// The Keys cubic kernel (a = −0.5) at distance `x`, by its
    /// piecewise definition.
    fn keys(x: f64) -> f64 {
        let x = x.abs();
        if x < 1.0 {
            1.5 * x.powi(3) - 2.5 * x * x + 1.0
        } else if x < 2.0 {
            -0.5 * x.powi(3) + 2.5 * x * x - 4.0 * x + 2.0
        } else {
            0.0
        }
    }

    #[test]
    fn catmull_rom_interpolates_at_texel_centres() {
        assert_eq!(catmull_rom_weights(0.0), [0.0, 1.0, 0.0, 0.0]);
    }

    proptest! {
        #[test]
        fn catmull_rom_is_the_keys_kernel(f in 0f64..1.0) {
            let w = catmull_rom_weights(f);
            // Texels at -1, 0, 1, 2 from the second; the read at f.
            for (k, wk) in w.iter().enumerate() {
                prop_assert!((wk - keys(f - (k as f64 - 1.0))).abs() < 1e-12);
            }
            prop_assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            // It reproduces a linear ramp exactly (first-order accuracy).
            let ramp: f64 = w.iter().enumerate().map(|(k, wk)| wk * (k as f64 - 1.0)).sum();
            prop_assert!((ramp - f).abs() < 1e-12);
        }

        #[test]
        fn halton_matches_the_radical_inverse(i in 0u64..100_000, base in 2u64..8) {
            prop_assert!((halton(i, base) - radical_inverse(i, base)).abs() < 1e-12);
        }

        #[test]
        fn ycocg_round_trips(r in 0f32..4.0, g in 0f32..4.0, b in 0f32..4.0) {
            let back = from_ycocg(to_ycocg([r, g, b]));
            for (x, y) in back.iter().zip([r, g, b]) {
                prop_assert!((x - y).abs() < 1e-5);
            }
        }

        #[test]
        fn the_resolve_blends_the_clamped_history_with_the_current(
            h in proptest::array::uniform3(0f32..1.0),
            c in proptest::array::uniform3(0f32..1.0),
            n in proptest::collection::vec(proptest::array::uniform3(0f32..1.0), 8),
            alpha in 0.01f32..1.0,
        ) {
            let out = resolve(Some(h), c, &n, alpha);
            // Brute force: the extremes over the current pixel and its
            // neighbours, in YCoCg, and the mean and deviation in f64.
            let ys: Vec<[f32; 3]> = n.iter().chain(std::iter::once(&c)).map(|x| to_ycocg(*x)).collect();
            let g = VARIANCE_GAMMA as f64;
            let stat = |i: usize| {
                let v: Vec<f64> = ys.iter().map(|y| y[i] as f64).collect();
                let mean = v.iter().sum::<f64>() / v.len() as f64;
                let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
                (mean, sd)
            };
            let own = to_ycocg(c);
            let lo = [0, 1, 2].map(|i| {
                let (m, sd) = stat(i);
                ys.iter().map(|y| y[i]).fold(f32::INFINITY, f32::min).max((m - g * sd) as f32).min(own[i])
            });
            let hi = [0, 1, 2].map(|i| {
                let (m, sd) = stat(i);
                ys.iter().map(|y| y[i]).fold(f32::NEG_INFINITY, f32::max).min((m + g * sd) as f32).max(own[i])
            });
            // The box holds the mean and lies within the extremes.
            for i in 0..3 {
                prop_assert!(lo[i] <= stat(i).0 as f32 + 1e-5 && stat(i).0 as f32 <= hi[i] + 1e-5);
            }
            // alpha = 1 would be the current colour; the distance to it
            // shrinks by (1 - alpha) from the clamped history's.
            let hc = from_ycocg(clamp_box(to_ycocg(h), lo, hi));
            let yh = to_ycocg(hc);
            for i in 0..3 {
                prop_assert!(yh[i] >= lo[i] - 1e-4 && yh[i] <= hi[i] + 1e-4, "component {} {} not in [{}, {}]", i, yh[i], lo[i], hi[i]);
            }
            for i in 0..3 {
                let want = hc[i] + alpha * (c[i] - hc[i]);
                prop_assert!((out[i] - want).abs() < 1e-5);
            }
        }

        #[test]
        fn a_history_inside_the_box_is_kept(
            c in proptest::array::uniform3(0.2f32..0.8),
            alpha in 0.01f32..1.0,
        ) {
            // A neighbourhood spanning black to white contains any grey
            // history: the clamp leaves it, and the output is the plain
            // moving average.
            let h = [0.5; 3];
            let n = [[0.0; 3], [1.0; 3]];
            let out = resolve(Some(h), c, &n, alpha);
            for i in 0..3 {
                prop_assert!((out[i] - (h[i] + alpha * (c[i] - h[i]))).abs() < 1e-5);
            }
        }
    }
}
