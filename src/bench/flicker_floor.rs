//! The flicker floor of a wide view: how little the inset's periphery
//! could flicker at best at its scale. The reference sequence itself is
//! put through a *perfect* wide view — each reference frame integrated
//! over the wide view's pixels (a box filter over each wide pixel's area
//! in linear light: the image an ideally antialiased render of that size
//! shows) — and read back as the composite reads it (bilinearly at
//! (p + 0.5) / eye × wide, clamped to the texel centres, or with
//! `inset-catmull-rom` through the Catmull-Rom filter clamped to the
//! nearest 2×2 range), the reference's own pixels inside the inset with
//! the feathered seam's weight (`view::inset::weight`). Its
//! [`super::flicker`] against the reference is what resampling alone adds:
//! an edge moving by a fraction of an eye pixel changes the pixels along
//! the upsampling filter's ramp, which the reference's sharper edge does
//! not. No wide view of that scale renders better than this sequence, so
//! a configuration whose floor already exceeds the baseline's flicker
//! cannot meet a cap at the baseline's flicker however well its wide view
//! is antialiased or accumulated.

use crate::targets::downsample::{to_linear, to_srgb8};
use crate::view::inset::{weight, PixelRect, FEATHER_PX};

/// A linear-light RGB image, rows of `w`.
struct Linear {
    w: u32,
    h: u32,
    px: Vec<[f64; 3]>,
}

impl Linear {
    fn of(img: &image::RgbaImage, lut: &[f64]) -> Linear {
        Linear {
            w: img.width(),
            h: img.height(),
            px: img
                .pixels()
                .map(|p| [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]])
                .collect(),
        }
    }

    /// The texel at (x, y), clamped to the image (clamp to edge).
    fn at(&self, x: i64, y: i64) -> [f64; 3] {
        let x = x.clamp(0, self.w as i64 - 1) as usize;
        let y = y.clamp(0, self.h as i64 - 1) as usize;
        self.px[y * self.w as usize + x]
    }
}

/// The weights of the source pixels [0, n) over each of `m` output pixels
/// of one axis: output pixel i covers [i, i + 1) × n / m of the source,
/// and each source pixel weighs by its overlap (box filter), the weights
/// summing to 1.
fn area_weights(n: u32, m: u32) -> Vec<Vec<(u32, f64)>> {
    let r = n as f64 / m as f64;
    (0..m)
        .map(|i| {
            let (a, b) = (i as f64 * r, (i + 1) as f64 * r);
            let mut w: Vec<(u32, f64)> = (a.floor() as u32..(b.ceil() as u32).min(n))
                .map(|k| (k, (b.min(k as f64 + 1.0) - a.max(k as f64)).max(0.0)))
                .filter(|&(_, v)| v > 0.0)
                .collect();
            let sum: f64 = w.iter().map(|&(_, v)| v).sum();
            for e in &mut w {
                e.1 /= sum;
            }
            w
        })
        .collect()
}

/// `img` integrated over the pixels of a `w`×`h` image covering it (see
/// [`area_weights`]; separable: rows, then columns).
fn area_resample(img: &Linear, w: u32, h: u32) -> Linear {
    let rows = along(img, &area_weights(img.w, w), true);
    along(&rows, &area_weights(img.h, h), false)
}

/// `img` filtered along one axis (`horizontal`, else vertical) by
/// `weights`, one list of (source index, weight) per output index.
fn along(img: &Linear, weights: &[Vec<(u32, f64)>], horizontal: bool) -> Linear {
    let (w, h) = match horizontal {
        true => (weights.len() as u32, img.h),
        false => (img.w, weights.len() as u32),
    };
    let mut px = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let (out, other) = if horizontal { (x, y) } else { (y, x) };
            let mut c = [0.0; 3];
            for &(k, v) in &weights[out as usize] {
                let p = match horizontal {
                    true => img.at(k as i64, other as i64),
                    false => img.at(other as i64, k as i64),
                };
                for j in 0..3 {
                    c[j] += v * p[j];
                }
            }
            px.push(c);
        }
    }
    Linear { w, h, px }
}

/// Catmull-Rom weights at fraction `f` (Keys 1981, a = −1/2; as
/// `view::taa::catmull_rom_weights` and the composite's shader).
fn catmull_rom(f: f64) -> [f64; 4] {
    [
        f * (-0.5 + f * (1.0 - 0.5 * f)),
        1.0 + f * f * (-2.5 + 1.5 * f),
        f * (0.5 + f * (2.0 - 1.5 * f)),
        f * f * (-0.5 + 0.5 * f),
    ]
}

/// The wide image read at eye pixel (x, y) of a `eye_w`×`eye_h` image as
/// `shaders/inset_composite.comp` reads it.
fn read(wide: &Linear, x: u32, y: u32, eye: (u32, u32), catmull: bool) -> [f64; 3] {
    let q = |p: u32, e: u32, n: u32| {
        ((p as f64 + 0.5) / e as f64 * n as f64).clamp(0.5, n as f64 - 0.5) - 0.5
    };
    let (tx, ty) = (q(x, eye.0, wide.w), q(y, eye.1, wide.h));
    let (bx, by) = (tx.floor() as i64, ty.floor() as i64);
    let (fx, fy) = (tx - tx.floor(), ty - ty.floor());
    let mut c = [0.0; 3];
    if !catmull {
        for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
            for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
                let p = wide.at(bx + dx, by + dy);
                for j in 0..3 {
                    c[j] += wx * wy * p[j];
                }
            }
        }
        return c;
    }
    let (wx, wy) = (catmull_rom(fx), catmull_rom(fy));
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    for (j, wyj) in wy.iter().enumerate() {
        for (i, wxi) in wx.iter().enumerate() {
            let p = wide.at(bx - 1 + i as i64, by - 1 + j as i64);
            for k in 0..3 {
                c[k] += wxi * wyj * p[k];
                if (1..=2).contains(&i) && (1..=2).contains(&j) {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
    }
    for k in 0..3 {
        c[k] = c[k].clamp(lo[k], hi[k]);
    }
    c
}

/// `frame` through a perfect `wide` = (width, height) view, read back as
/// the composite reads it, with the frame's own pixels under the inset
/// `rect` (see the module).
pub fn through_wide_view(
    frame: &image::RgbaImage,
    wide: (u32, u32),
    rect: Option<&PixelRect>,
    catmull: bool,
) -> image::RgbaImage {
    let lut: Vec<f64> = (0..=255u8).map(to_linear).collect();
    let src = Linear::of(frame, &lut);
    let small = area_resample(&src, wide.0.max(1), wide.1.max(1));
    let eye = (frame.width(), frame.height());
    image::RgbaImage::from_fn(eye.0, eye.1, |x, y| {
        let w = rect.map_or(0.0, |r| weight(r, x, y, FEATHER_PX) as f64);
        let own = frame.get_pixel(x, y);
        if w >= 1.0 {
            return *own;
        }
        let c = read(&small, x, y, eye, catmull);
        let s = src.at(x as i64, y as i64);
        let mix = |k: usize| to_srgb8(c[k] + w * (s[k] - c[k]));
        image::Rgba([mix(0), mix(1), mix(2), own[3]])
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Brute force: the box filter's weights are each source pixel's
        /// overlap with the output pixel, normalized.
        #[test]
        fn area_weights_are_the_overlaps(n in 1u32..64, m in 1u32..64) {
            let r = n as f64 / m as f64;
            for (i, ws) in area_weights(n, m).iter().enumerate() {
                let sum: f64 = ws.iter().map(|&(_, v)| v).sum();
                prop_assert!((sum - 1.0).abs() < 1e-9);
                for k in 0..n {
                    let overlap = ((i + 1) as f64 * r).min(k as f64 + 1.0) - (i as f64 * r).max(k as f64);
                    let got = ws.iter().find(|&&(j, _)| j == k).map_or(0.0, |&(_, v)| v);
                    prop_assert!((got - overlap.max(0.0) / r).abs() < 1e-9, "i {} k {} got {} want {}", i, k, got, overlap / r);
                }
            }
        }
    }

    fn flat(w: u32, h: u32, v: u8) -> image::RgbaImage {
        image::RgbaImage::from_pixel(w, h, image::Rgba([v, v, v, 255]))
    }

    #[test]
    fn a_flat_image_and_a_full_size_wide_view_come_back_unchanged() {
        let f = flat(20, 12, 137);
        for catmull in [false, true] {
            assert_eq!(through_wide_view(&f, (7, 5), None, catmull), f);
        }
        // A wide view as large as the eye reads each pixel at its centre.
        let g = image::RgbaImage::from_fn(16, 8, |x, y| {
            image::Rgba([(x * 13) as u8, (y * 29) as u8, 7, 255])
        });
        assert_eq!(through_wide_view(&g, (16, 8), None, false), g);
        assert_eq!(through_wide_view(&g, (16, 8), None, true), g);
    }

    #[test]
    fn a_half_size_wide_view_ramps_an_edge_and_the_inset_keeps_it_sharp() {
        // White left of column 9 (odd: it splits a wide pixel).
        let edge = image::RgbaImage::from_fn(32, 32, |x, _| {
            let v = if x < 9 { 255 } else { 0 };
            image::Rgba([v, v, v, 255])
        });
        let out = through_wide_view(&edge, (16, 16), None, false);
        let row: Vec<u8> = (6..12).map(|x| out.get_pixel(x, 4)[0]).collect();
        assert!(row.windows(2).all(|w| w[0] >= w[1]), "{row:?}");
        assert!(
            row.iter().filter(|&&v| v != 0 && v != 255).count() >= 2,
            "{row:?}"
        );
        // Under an inset covering everything deeper than the feather the
        // edge is the frame's own.
        let r = PixelRect {
            x0: 0,
            y0: 0,
            x1: 32,
            y1: 32,
        };
        let inside = through_wide_view(&edge, (16, 16), Some(&r), false);
        assert_eq!(inside.get_pixel(8, 16), edge.get_pixel(8, 16));
        assert_eq!(inside.get_pixel(9, 16), edge.get_pixel(9, 16));
    }
}
