//! A foveated image error: FLIP and the temporal error as the eye sees them
//! where it looks, not uniformly over the lens.
//!
//! **Acuity.** Geisler and Perry ("A real-time foveated multiresolution
//! system for low-bandwidth video communication", SPIE Human Vision and
//! Electronic Imaging III, 1998, eq. 1) fit the contrast threshold of a
//! grating of spatial frequency f (cycles per degree) at eccentricity e
//! (degrees) as `CT(f, e) = CT0 · exp(α f (e + e2) / e2)`, with
//! `α = 0.106`, `e2 = 2.3°` and `CT0 = 1/64`. The highest frequency seen
//! at all is where `CT = 1`:
//!
//! `f_c(e) = e2 · ln(1 / CT0) / (α (e + e2))`
//!
//! (39 cycles/degree at the fovea, 7 at 11°, 2.1 at 40°).
//!
//! **Foveation.** Their system shows each pixel from the level of a
//! multiresolution pyramid whose band limit matches `f_c` at the pixel's
//! eccentricity from the gaze, blending neighbouring levels so no seam
//! shows. This does the same to the reference and to the test image: level
//! k is the image low-passed to `1 / 2^(k+1)` cycles per pixel (the
//! Burt–Adelson binomial kernel `[1 4 6 4 1] / 16`, applied "à trous" with
//! its taps `2^(k−1)` pixels apart, in linear light, at full resolution), and
//! a pixel with `f_c(e)` cycles/degree at `ppd` pixels/degree sits at the
//! fractional level `log2(ppd / (2 f_c(e)))`, at least 0.
//!
//! **The error.** FLIP is evaluated on each level's pair at the display's
//! pixels per degree; per pixel the errors are made non-increasing with the
//! level (a running minimum: a coarser eye never sees more error) and
//! blended at the pixel's fractional level. So with the gaze everywhere
//! (eccentricity 0, or a display coarser than the fovea) it is FLIP
//! exactly, it never exceeds FLIP, and it does not grow with eccentricity.
//! The temporal error (`bench::flicker`) is foveated the same way: the
//! sequences are low-passed per level, since shimmer of detail finer than
//! the eye resolves there does not reach it.

use super::{flicker, metrics};
use crate::error::Result;
use crate::targets::downsample::{to_linear, to_srgb8};
use crate::view::Fov;

/// Geisler and Perry's spatial-frequency decay constant α.
const ALPHA: f64 = 0.106;
/// Their half-resolution eccentricity e2, degrees.
const E2_DEG: f64 = 2.3;
/// Their minimum contrast threshold CT0.
const CT0: f64 = 1.0 / 64.0;
/// Most pyramid levels used (level 6 keeps 1/128 cycles per pixel).
pub const MAX_LEVEL: usize = 6;

/// The highest spatial frequency the eye resolves at eccentricity `e_deg`
/// degrees, in cycles per degree (see the module).
pub fn cutoff_cpd(e_deg: f64) -> f64 {
    E2_DEG * (1.0 / CT0).ln() / (ALPHA * (e_deg.max(0.0) + E2_DEG))
}

/// The fractional pyramid level a pixel at eccentricity `e_deg` takes on a
/// display of `ppd` pixels per degree: 0 where the display is no finer than
/// the eye there, capped at [`MAX_LEVEL`].
pub fn level(e_deg: f64, ppd: f64) -> f32 {
    (ppd / (2.0 * cutoff_cpd(e_deg)))
        .log2()
        .clamp(0.0, MAX_LEVEL as f64) as f32
}

/// Per pixel of a `width` × `height` eye image with field of view `fov`,
/// its eccentricity in degrees from the gaze at `gaze_ndc` (NDC, +y down):
/// the angle between the pixel centre's ray and the gaze's (the image is
/// linear in the FOV's tangents).
pub fn eccentricity(width: u32, height: u32, fov: &Fov, gaze_ndc: [f64; 2]) -> Vec<f32> {
    let [tl, tr, tu, td] = fov.tangents();
    let along = |a: f64, b: f64, t: f64| a + t * (b - a);
    let gaze = [
        along(tl, tr, (gaze_ndc[0] + 1.0) / 2.0),
        along(tu, td, (gaze_ndc[1] + 1.0) / 2.0),
    ];
    let mut out = Vec::with_capacity((width * height) as usize);
    for y in 0..height {
        let ty = along(tu, td, (y as f64 + 0.5) / height as f64);
        for x in 0..width {
            let tx = along(tl, tr, (x as f64 + 0.5) / width as f64);
            out.push(angle_deg([tx, ty], gaze) as f32);
        }
    }
    out
}

/// The angle in degrees between the rays through tangents `a` and `b`.
fn angle_deg(a: [f64; 2], b: [f64; 2]) -> f64 {
    let (u, v) = ([a[0], a[1], 1.0], [b[0], b[1], 1.0]);
    let dot = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let cross = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
    sin.atan2(dot).to_degrees()
}

/// An image in linear light, three channels per pixel.
#[derive(Clone)]
struct Linear {
    width: usize,
    height: usize,
    rgb: Vec<f32>,
}

impl Linear {
    fn of(img: &image::RgbaImage) -> Linear {
        let lut: Vec<f32> = (0..=255u8).map(|v| to_linear(v) as f32).collect();
        let rgb = img
            .pixels()
            .flat_map(|p| [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]])
            .collect();
        Linear {
            width: img.width() as usize,
            height: img.height() as usize,
            rgb,
        }
    }

    fn srgb(&self) -> image::RgbaImage {
        let (w, h) = (self.width as u32, self.height as u32);
        image::RgbaImage::from_fn(w, h, |x, y| {
            let i = 3 * (y as usize * self.width + x as usize);
            let c = |k: usize| to_srgb8(self.rgb[i + k] as f64);
            image::Rgba([c(0), c(1), c(2), 255])
        })
    }

    /// The next pyramid level: the binomial kernel with taps `step`
    /// pixels apart, along rows then columns, edges clamped.
    fn blurred(&self, step: usize) -> Linear {
        const TAPS: [(isize, f32); 5] = [
            (-2, 1.0 / 16.0),
            (-1, 4.0 / 16.0),
            (0, 6.0 / 16.0),
            (1, 4.0 / 16.0),
            (2, 1.0 / 16.0),
        ];
        let (w, h) = (self.width, self.height);
        let pass = |src: &[f32], along_x: bool| -> Vec<f32> {
            let mut out = vec![0.0f32; src.len()];
            for y in 0..h {
                for x in 0..w {
                    for (d, k) in TAPS {
                        let off = d * step as isize;
                        let (sx, sy) = if along_x {
                            ((x as isize + off).clamp(0, w as isize - 1) as usize, y)
                        } else {
                            (x, (y as isize + off).clamp(0, h as isize - 1) as usize)
                        };
                        let (o, s) = (3 * (y * w + x), 3 * (sy * w + sx));
                        for c in 0..3 {
                            out[o + c] += k * src[s + c];
                        }
                    }
                }
            }
            out
        };
        let rows = pass(&self.rgb, true);
        Linear {
            width: w,
            height: h,
            rgb: pass(&rows, false),
        }
    }
}

/// The levels 0..=`top` of `img` as sRGB images (level 0 is `img`).
fn pyramid(img: &image::RgbaImage, top: usize) -> Vec<image::RgbaImage> {
    let mut levels = vec![img.clone()];
    let mut current = Linear::of(img);
    for k in 1..=top {
        current = current.blurred(1 << (k - 1));
        levels.push(current.srgb());
    }
    levels
}

/// `img` with the pixels `hidden` marks opaque black.
fn blacked_out(img: &image::RgbaImage, hidden: &[bool]) -> image::RgbaImage {
    let mut out = img.clone();
    for (p, _) in out.pixels_mut().zip(hidden).filter(|(_, &h)| h) {
        *p = image::Rgba([0, 0, 0, 255]);
    }
    out
}

/// The highest level any pixel `hidden` does not mark needs.
fn top_level(levels: &[f32], hidden: &[bool]) -> usize {
    let visible = levels
        .iter()
        .zip(hidden.iter().chain(std::iter::repeat(&false)))
        .filter(|(_, &h)| !h);
    let top = visible.map(|(l, _)| *l).fold(0.0f32, f32::max);
    (top.ceil() as usize).min(MAX_LEVEL)
}

/// Per pixel: the per-level maps made non-increasing in the level (a
/// running minimum), blended at the pixel's fractional level.
fn blend(maps: &[Vec<f32>], levels: &[f32]) -> Vec<f32> {
    let mut running = maps[0].clone();
    let mut monotone = vec![running.clone()];
    for m in &maps[1..] {
        for (r, v) in running.iter_mut().zip(m) {
            *r = r.min(*v);
        }
        monotone.push(running.clone());
    }
    let top = monotone.len() - 1;
    levels
        .iter()
        .enumerate()
        .map(|(i, &l)| {
            let l = l.clamp(0.0, top as f32);
            let (k, t) = (l.floor() as usize, l.fract());
            let lo = monotone[k][i];
            let hi = monotone[(k + 1).min(top)][i];
            lo + t * (hi - lo)
        })
        .collect()
}

/// The foveated FLIP map of `test` against `reference` (the same size) at
/// `ppd` pixels per degree, each pixel at its pyramid level `levels` (from
/// [`level`]); `full` is FLIP's own map of the pair when already computed
/// (level 0). Only levels up to the highest a pixel `hidden` does not mark
/// needs are evaluated.
pub fn flip_map(
    reference: &image::RgbaImage,
    test: &image::RgbaImage,
    (ppd, levels, hidden): (f32, &[f32], &[bool]),
    full: Option<&[f32]>,
) -> Result<Vec<f32>> {
    let top = top_level(levels, hidden);
    let (r, t) = (pyramid(reference, top), pyramid(test, top));
    let mut maps = Vec::with_capacity(top + 1);
    for (k, (a, b)) in r.iter().zip(&t).enumerate() {
        match full.filter(|_| k == 0) {
            Some(map) => maps.push(map.to_vec()),
            None => maps.push(metrics::flip(a, b, ppd)?.errors),
        }
    }
    Ok(blend(&maps, levels))
}

/// The foveated temporal error per pixel ([`flicker::per_pixel`] of each
/// level's sequences, blended as [`flip_map`] blends). The pixels `hidden`
/// marks are blacked out in every frame first, so the blur of the coarse
/// levels carries nothing from where the lens shows nothing into what it
/// shows.
pub fn flicker_map(
    test: &[image::RgbaImage],
    reference: &[image::RgbaImage],
    levels: &[f32],
    hidden: &[bool],
) -> Result<Vec<f32>> {
    let top = top_level(levels, hidden);
    let per_level = |frames: &[image::RgbaImage]| -> Vec<Vec<image::RgbaImage>> {
        let pyramids: Vec<_> = frames
            .iter()
            .map(|f| pyramid(&blacked_out(f, hidden), top))
            .collect();
        (0..=top)
            .map(|k| pyramids.iter().map(|p| p[k].clone()).collect())
            .collect()
    };
    let (t, r) = (per_level(test), per_level(reference));
    let maps = t
        .iter()
        .zip(&r)
        .map(|(a, b)| flicker::per_pixel(a, b))
        .collect::<Result<Vec<_>>>()?;
    Ok(blend(&maps, levels))
}

#[cfg(test)]
mod tests;
