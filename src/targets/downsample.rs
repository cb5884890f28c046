//! A supersampled reference brought to the eye size: each output pixel is
//! the mean, in linear light, of the k × k block of the larger image it
//! covers (a box filter: the integral of the image over the output pixel's
//! area, which is what an ideal display pixel integrates). The channels
//! are decoded from sRGB to linear light first and the mean encoded back
//! (IEC 61966-2-1 transfer), as an sRGB MSAA resolve averages samples in
//! linear light (Vulkan spec, "Multisample Resolve Operations"); alpha is
//! averaged as stored.

/// sRGB-encoded 8-bit value to linear light (IEC 61966-2-1).
pub(crate) fn to_linear(v: u8) -> f64 {
    let c = v as f64 / 255.0;
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light to the nearest sRGB-encoded 8-bit value.
pub(crate) fn to_srgb8(l: f64) -> u8 {
    let l = l.clamp(0.0, 1.0);
    let c = if l <= 0.003_130_8 {
        l * 12.92
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    };
    (c * 255.0).round() as u8
}

/// `img` reduced by `k` per axis: each output pixel the linear-light mean
/// of its k × k block (see the module). The output is
/// `width / k` × `height / k` (rows and columns past a whole block are
/// dropped); `k` of 0 or 1 returns the image unchanged.
pub fn box_linear(img: &image::RgbaImage, k: u32) -> image::RgbaImage {
    if k <= 1 {
        return img.clone();
    }
    let lut: Vec<f64> = (0..=255u8).map(to_linear).collect();
    let (w, h) = (img.width() / k, img.height() / k);
    let n = (k * k) as f64;
    image::RgbaImage::from_fn(w, h, |x, y| {
        let mut sum = [0.0f64; 4];
        for dy in 0..k {
            for dx in 0..k {
                let p = img.get_pixel(x * k + dx, y * k + dy);
                for c in 0..3 {
                    sum[c] += lut[p[c] as usize];
                }
                sum[3] += p[3] as f64;
            }
        }
        image::Rgba([
            to_srgb8(sum[0] / n),
            to_srgb8(sum[1] / n),
            to_srgb8(sum[2] / n),
            (sum[3] / n).round() as u8,
        ])
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_transfer_round_trips_every_value() {
        for v in 0..=255u8 {
            assert_eq!(to_srgb8(to_linear(v)), v);
        }
    }

    #[test]
    fn black_and_white_average_to_linear_grey_not_srgb_grey() {
        // Half black, half white: 0.5 in linear light is sRGB 188, not 128.
        let img = image::RgbaImage::from_fn(2, 2, |x, _| {
            let v = if x == 0 { 0 } else { 255 };
            image::Rgba([v, v, v, 255])
        });
        assert_eq!(box_linear(&img, 2).get_pixel(0, 0).0, [188, 188, 188, 255]);
    }

    proptest! {
        /// Against brute force: every output pixel is the linear-light
        /// mean of its block, computed here without the table.
        #[test]
        fn each_pixel_is_its_blocks_linear_mean(
            k in 1u32..5,
            bw in 1u32..5,
            bh in 1u32..5,
            extra in 0u32..3,
            seed in 0u32..10_000,
        ) {
            let (w, h) = (bw * k + extra % k.max(1), bh * k + extra % k.max(1));
            let img = image::RgbaImage::from_fn(w, h, |x, y| {
                let v = |c: u32| ((x * 31 + y * 17 + c * 7 + seed).wrapping_mul(2_654_435_761) >> 24) as u8;
                image::Rgba([v(0), v(1), v(2), v(3)])
            });
            let out = box_linear(&img, k);
            prop_assert_eq!(out.dimensions(), (bw, bh));
            for y in 0..bh {
                for x in 0..bw {
                    let mut want = [0.0f64; 4];
                    for dy in 0..k {
                        for dx in 0..k {
                            let p = img.get_pixel(x * k + dx, y * k + dy);
                            for c in 0..3 {
                                let s = p[c] as f64 / 255.0;
                                want[c] += if s <= 0.04045 { s / 12.92 } else { ((s + 0.055) / 1.055).powf(2.4) };
                            }
                            want[3] += p[3] as f64;
                        }
                    }
                    let got = out.get_pixel(x, y);
                    let n = (k * k) as f64;
                    for c in 0..3 {
                        // The output is the code nearest the mean: the mean
                        // lies between its neighbours' values.
                        let m = want[c] / n;
                        let (lo, hi) = (got[c].saturating_sub(1), got[c].saturating_add(1));
                        prop_assert!(
                            to_linear(lo) - 1e-12 <= m && m <= to_linear(hi) + 1e-12,
                            "{} decodes to {}, mean {}", got[c], to_linear(got[c]), m
                        );
                    }
                    prop_assert_eq!(got[3], (want[3] / n).round() as u8);
                }
            }
        }
    }
}
