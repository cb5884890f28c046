//! Image-error metrics against a reference frame: FLIP (Andersson et al.,
//! "FLIP: A Difference Evaluator for Alternating Images", HPG 2020; the
//! `flip-rs` port of the reference implementation) and PSNR.

use crate::error::{Error, Result};

/// Smallest pixels-per-degree FLIP is evaluated at: below it FLIP's
/// filters degenerate (a few pixels wide), so reduced-resolution runs use it.
pub const MIN_FLIP_PPD: f64 = 10.0;

/// Pixels per degree of a typical desktop monitor (FLIP's default), for
/// images that are not viewed in a headset.
pub const DESKTOP_PPD: f32 = flip_rs::DEFAULT_PPD;

/// Pixels per degree of a headset view: horizontal pixels over the
/// horizontal FOV in degrees.
pub fn headset_ppd(width_px: u32, fov_left: f64, fov_right: f64) -> f32 {
    (width_px as f64 / (fov_right - fov_left).to_degrees()) as f32
}

/// FLIP result for one image pair.
#[derive(Clone, Debug)]
pub struct FlipResult {
    /// Mean FLIP error (0 = identical, 1 = maximal).
    pub mean: f32,
    /// 99th percentile of the per-pixel error (unweighted).
    pub p99: f32,
    /// Largest per-pixel error.
    pub max: f32,
    /// Per-pixel error map, row-major.
    pub errors: Vec<f32>,
    /// Width of the map.
    pub width: u32,
    /// Height of the map.
    pub height: u32,
}

fn rgb(img: &image::RgbaImage) -> Result<flip_rs::RgbImage<u8>> {
    let px: Vec<u8> = img.pixels().flat_map(|p| [p[0], p[1], p[2]]).collect();
    flip_rs::RgbImage::new(img.width() as usize, img.height() as usize, px)
        .map_err(|e| Error::config("image", format!("{}x{} px: {e}", img.width(), img.height())))
}

/// Checks that FLIP can evaluate a `width`×`height` image at `ppd`
/// (flip-rs's limits: kernels of at most 8193 taps, at most 2^34 filter
/// additions), so a plan is refused before measuring rather than after.
pub fn check_flip(width: u32, height: u32, ppd: f32) -> std::result::Result<(), String> {
    use std::f32::consts::PI;
    if !(ppd.is_finite() && ppd > 0.0) {
        return Err(format!(
            "FLIP needs a positive pixels-per-degree, got {ppd}"
        ));
    }
    // flip-rs filters.rs: the spatial and feature filter radii.
    let radius = (3.0 * (0.04 / (2.0 * (PI * PI))).sqrt() * ppd).ceil();
    let feature = (3.0 * 0.5 * 0.082 * ppd).ceil();
    if radius.max(feature) > 4096.0 {
        return Err(format!(
            "FLIP at {ppd:.0} pixels per degree needs filter kernels over its 8193-tap limit (a narrower FOV or a larger image raises it)"
        ));
    }
    let work = (width as u64 * height as u64)
        .saturating_mul(16 * (2 * radius as u64 + 1) + 14 * (2 * feature as u64 + 1));
    if work > 1 << 34 {
        return Err(format!(
            "FLIP of {width}x{height} px at {ppd:.0} pixels per degree needs {work} filter additions, over its 2^34 limit"
        ));
    }
    Ok(())
}

/// LDR FLIP between a reference and a test image of the same size (sRGB).
pub fn flip(reference: &image::RgbaImage, test: &image::RgbaImage, ppd: f32) -> Result<FlipResult> {
    if reference.dimensions() != test.dimensions() {
        return Err(Error::config(
            "images",
            format!(
                "sizes differ: {:?} vs {:?}",
                reference.dimensions(),
                test.dimensions()
            ),
        ));
    }
    let (w, h) = reference.dimensions();
    check_flip(w, h, ppd).map_err(|m| Error::config("FLIP", m))?;
    let map = flip_rs::ldr_flip(&rgb(reference)?, &rgb(test)?, ppd)
        .map_err(|e| Error::config("FLIP", format!("{w}x{h} px at {ppd} ppd: {e}")))?;
    let stats = map.statistics();
    let errors = map.pixels().to_vec();
    let p99 = percentile_99(&errors);
    let max = errors.iter().copied().fold(0.0f32, f32::max);
    Ok(FlipResult {
        mean: stats.mean,
        p99,
        max,
        errors,
        width: reference.width(),
        height: reference.height(),
    })
}

/// The 99th percentile of `values` by nearest rank (the value at index
/// ⌈0.99·n⌉, clamped to the last): defined for every non-empty image,
/// where flip-rs's unweighted percentile refuses images under 100 pixels.
pub fn percentile_99(values: &[f32]) -> f32 {
    if values.is_empty() {
        return 0.0;
    }
    let mut v = values.to_vec();
    v.sort_by(f32::total_cmp);
    let i = ((v.len() as f64 * 0.99).ceil() as usize).min(v.len() - 1);
    v[i]
}

impl FlipResult {
    /// The error map as a heat-map image (magma colour map).
    pub fn heatmap(&self) -> image::RgbaImage {
        magma(self.width, self.height, &self.errors)
    }
}

/// `values` in [0, 1] (rows of `width`) through the magma colour map.
pub fn magma(width: u32, height: u32, values: &[f32]) -> image::RgbaImage {
    let map = flip_rs::ErrorMap::new(width as usize, height as usize, values.to_vec());
    let colors = map
        .and_then(|m| m.colorize())
        .map(|c| c.into_pixels())
        .unwrap_or_default();
    image::RgbaImage::from_fn(width, height, |x, y| {
        let i = 3 * (y * width + x) as usize;
        let c = |k: usize| {
            (colors.get(i + k).copied().unwrap_or(0.0).clamp(0.0, 1.0) * 255.0).round() as u8
        };
        image::Rgba([c(0), c(1), c(2), 255])
    })
}

/// Peak signal-to-noise ratio in dB over RGB (infinite for identical images).
pub fn psnr(reference: &image::RgbaImage, test: &image::RgbaImage) -> f64 {
    let mut se = 0.0f64;
    let mut n = 0usize;
    for (a, b) in reference.pixels().zip(test.pixels()) {
        for c in 0..3 {
            let d = a[c] as f64 - b[c] as f64;
            se += d * d;
            n += 1;
        }
    }
    if se == 0.0 || n == 0 {
        return f64::INFINITY;
    }
    10.0 * (255.0f64 * 255.0 / (se / n as f64)).log10()
}

/// Mean structural similarity (Wang, Bovik, Sheikh & Simoncelli, "Image
/// Quality Assessment: From Error Visibility to Structural Similarity",
/// IEEE TIP 2004) on luma `Y' = 0.2126 R + 0.7152 G + 0.0722 B` of the
/// stored (sRGB-encoded) values, over 8×8 windows with stride 4 and the
/// paper's constants C1 = (0.01·255)², C2 = (0.03·255)². 1 = identical.
pub fn ssim(reference: &image::RgbaImage, test: &image::RgbaImage) -> f64 {
    let (w, h) = reference.dimensions();
    if test.dimensions() != (w, h) || w < 8 || h < 8 {
        return if reference == test { 1.0 } else { 0.0 };
    }
    let luma = |img: &image::RgbaImage| -> Vec<f64> {
        img.pixels()
            .map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64)
            .collect()
    };
    let (a, b) = (luma(reference), luma(test));
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    let mut sum = 0.0;
    let mut windows = 0usize;
    for y0 in (0..=h - 8).step_by(4) {
        for x0 in (0..=w - 8).step_by(4) {
            let (mut ma, mut mb, mut va, mut vb, mut cov) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for y in y0..y0 + 8 {
                for x in x0..x0 + 8 {
                    let i = (y * w + x) as usize;
                    ma += a[i];
                    mb += b[i];
                }
            }
            ma /= 64.0;
            mb /= 64.0;
            for y in y0..y0 + 8 {
                for x in x0..x0 + 8 {
                    let i = (y * w + x) as usize;
                    let (da, db) = (a[i] - ma, b[i] - mb);
                    va += da * da;
                    vb += db * db;
                    cov += da * db;
                }
            }
            va /= 63.0;
            vb /= 63.0;
            cov /= 63.0;
            sum += ((2.0 * ma * mb + c1) * (2.0 * cov + c2))
                / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            windows += 1;
        }
    }
    sum / windows.max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ssim_is_one_for_identical_images_and_drops_with_noise() {
        let a = image::RgbaImage::from_fn(64, 64, |x, y| {
            image::Rgba([(x * 4) as u8, (y * 4) as u8, ((x ^ y) * 4) as u8, 255])
        });
        assert!((ssim(&a, &a) - 1.0).abs() < 1e-12);
        let mut b = a.clone();
        for (i, p) in b.pixels_mut().enumerate() {
            if i % 3 == 0 {
                p.0[0] = p.0[0].wrapping_add(90);
            }
        }
        let s = ssim(&a, &b);
        assert!(s < 0.9 && s > 0.0, "{s}");
    }

    #[test]
    fn identical_images_have_zero_error() {
        let a = image::RgbaImage::from_fn(32, 32, |x, y| {
            image::Rgba([(x * 8) as u8, (y * 8) as u8, 128, 255])
        });
        let r = flip(&a, &a, DESKTOP_PPD).unwrap();
        assert_eq!(r.mean, 0.0);
        assert!(psnr(&a, &a).is_infinite());
    }

    #[test]
    fn a_changed_block_shows_up() {
        let a = image::RgbaImage::from_pixel(32, 32, image::Rgba([100, 100, 100, 255]));
        let mut b = a.clone();
        for y in 8..16 {
            for x in 8..16 {
                b.put_pixel(x, y, image::Rgba([255, 0, 0, 255]));
            }
        }
        let r = flip(&a, &b, DESKTOP_PPD).unwrap();
        assert!(r.mean > 0.01 && r.max > 0.5, "{} {}", r.mean, r.max);
        assert!(psnr(&a, &b) < 30.0);
        assert!(flip(&a, &image::RgbaImage::new(8, 8), 10.0).is_err());
    }
}
