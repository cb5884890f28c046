//! Temporal error ("flicker"): what a still image metric such as FLIP
//! misses — edges that shimmer as the head moves. Along a sequence of
//! frames with small head motion, each pixel's frame-to-frame change of
//! luminance is compared with the reference sequence's change at that
//! pixel; only the excess counts:
//!
//! `flicker = mean over pixels p and frames t ≥ 1 of
//!            max(0, |ΔY_test(p, t)| − |ΔY_ref(p, t)|)`,
//! `ΔY(p, t) = Y(p, t) − Y(p, t − 1)`, `Y` the Rec. 709 luma of the sRGB
//! values in [0, 1].
//!
//! A sequence that changes exactly as the reference does scores 0, however
//! much the content moves; an aliased edge, whose pixels jump between
//! covered and not as it slides by sub-pixel steps, scores above the same
//! edge antialiased. This follows the temporal-stability measures surveyed
//! by Yang, Liu and Salvi ("A Survey of Temporal Antialiasing Techniques",
//! Computer Graphics Forum 39(2), 2020, §7: frame-to-frame differences
//! against a converged reference), restricted to what exceeds the
//! reference's own change so that real motion is not counted.

use crate::error::{Error, Result};

/// Rec. 709 luma of an sRGB-encoded pixel, in [0, 1].
fn luma(p: &image::Rgba<u8>) -> f32 {
    (0.2126 * p[0] as f32 + 0.7152 * p[1] as f32 + 0.0722 * p[2] as f32) / 255.0
}

/// Each pixel's mean excess change of `test` over `reference`
/// (equal-length sequences of equal-size frames, at least two): the
/// summand of [`flicker`] averaged over frames, in rows of the frames'
/// width. Its mean over a set of pixels is that set's flicker.
pub fn per_pixel(test: &[image::RgbaImage], reference: &[image::RgbaImage]) -> Result<Vec<f32>> {
    if test.len() != reference.len() || test.len() < 2 {
        return Err(Error::config(
            "flicker",
            format!(
                "needs two sequences of the same length (at least 2 frames), got {} and {}",
                test.len(),
                reference.len()
            ),
        ));
    }
    let dims = reference[0].dimensions();
    if test.iter().chain(reference).any(|f| f.dimensions() != dims) {
        return Err(Error::config("flicker", "frames of different sizes"));
    }
    let mut sums = vec![0.0f64; (dims.0 * dims.1) as usize];
    for t in 1..test.len() {
        let pairs = test[t]
            .pixels()
            .zip(test[t - 1].pixels())
            .zip(reference[t].pixels().zip(reference[t - 1].pixels()));
        for (sum, ((a, a0), (r, r0))) in sums.iter_mut().zip(pairs) {
            let dt = (luma(a) - luma(a0)).abs();
            let dr = (luma(r) - luma(r0)).abs();
            *sum += (dt - dr).max(0.0) as f64;
        }
    }
    let frames = (test.len() - 1) as f64;
    Ok(sums.into_iter().map(|s| (s / frames) as f32).collect())
}

/// Mean of a [`per_pixel`] map over the pixels `hidden` does not mark (all
/// when it is empty) and `keep` accepts by index; 0 when none is left.
pub fn masked_mean(map: &[f32], hidden: &[bool], keep: impl Fn(usize) -> bool) -> f64 {
    let (mut sum, mut count) = (0.0f64, 0u64);
    for (i, &v) in map.iter().enumerate() {
        if hidden.get(i).copied().unwrap_or(false) || !keep(i) {
            continue;
        }
        sum += v as f64;
        count += 1;
    }
    if count == 0 {
        0.0
    } else {
        sum / count as f64
    }
}

/// The flicker of `test` against `reference` (equal-length sequences of
/// equal-size frames, at least two), over the pixels `hidden` does not
/// mark (all when it is empty).
pub fn flicker(
    test: &[image::RgbaImage],
    reference: &[image::RgbaImage],
    hidden: &[bool],
) -> Result<f64> {
    Ok(masked_mean(&per_pixel(test, reference)?, hidden, |_| true))
}

/// A [`per_pixel`] map as an image: black where a pixel is as stable as
/// the reference, through the magma colour map to white at `full` (and
/// above), on a square-root scale so faint shimmer still shows.
pub fn heatmap(map: &[f32], width: u32, height: u32, full: f32) -> image::RgbaImage {
    let scaled: Vec<f32> = map
        .iter()
        .map(|v| (v / full.max(1e-9)).clamp(0.0, 1.0).sqrt())
        .collect();
    super::metrics::magma(width, height, &scaled)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vertical edge (white left of `x`) over a black `w`×`h` image,
    /// rendered with `s`×`s` samples per pixel (box filter).
    fn edge(x: f64, w: u32, h: u32, s: u32) -> image::RgbaImage {
        image::RgbaImage::from_fn(w, h, |px, _| {
            let mut covered = 0;
            for k in 0..s {
                let sx = px as f64 + (k as f64 + 0.5) / s as f64;
                if sx < x {
                    covered += s;
                }
            }
            let v = (255.0 * covered as f64 / (s * s) as f64).round() as u8;
            image::Rgba([v, v, v, 255])
        })
    }

    /// The edge sliding right by `step` pixels a frame.
    fn sliding(s: u32, step: f64) -> Vec<image::RgbaImage> {
        (0..12)
            .map(|t| edge(10.3 + step * t as f64, 32, 8, s))
            .collect()
    }

    #[test]
    fn identical_sequences_score_zero_even_while_they_move() {
        let a = sliding(1, 0.37);
        assert_eq!(flicker(&a, &a, &[]).unwrap(), 0.0);
    }

    #[test]
    fn an_aliased_moving_edge_flickers_more_than_its_4x_version() {
        // Reference: the edge with 64 samples per pixel (converged).
        let reference = sliding(64, 0.37);
        let one = flicker(&sliding(1, 0.37), &reference, &[]).unwrap();
        let four = flicker(&sliding(2, 0.37), &reference, &[]).unwrap();
        assert!(one > four && four >= 0.0, "1x {one}, 4x {four}");
        assert!(one > 0.005, "1x {one}");
    }

    #[test]
    fn hidden_pixels_are_left_out_and_bad_input_is_one_error() {
        let reference = sliding(64, 0.37);
        let test = sliding(1, 0.37);
        let all_hidden = vec![true; 32 * 8];
        assert_eq!(flicker(&test, &reference, &all_hidden).unwrap(), 0.0);
        assert!(flicker(&test[..1], &reference[..1], &[]).is_err());
        // Left of the edge's path nothing changes; the columns it slides
        // over carry all of it.
        let map = per_pixel(&test, &reference).unwrap();
        let total = flicker(&test, &reference, &[]).unwrap();
        let left = masked_mean(&map, &[], |i| i % 32 < 8);
        let path = masked_mean(&map, &[], |i| (10..16).contains(&(i % 32)));
        assert_eq!(left, 0.0);
        assert!(path > total && total > 0.0, "{path} {total}");
        let split = (8.0 * left + 24.0 * masked_mean(&map, &[], |i| i % 32 >= 8)) / 32.0;
        assert!((split - total).abs() < 1e-6, "{split} {total}");
        assert!(flicker(&test, &reference[..3], &[]).is_err());
        let mut odd = test.clone();
        odd[2] = image::RgbaImage::new(4, 4);
        assert!(flicker(&odd, &reference, &[])
            .unwrap_err()
            .to_string()
            .contains("sizes"));
    }
}
