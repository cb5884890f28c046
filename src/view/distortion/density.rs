//! Sampling density of a lens: how many eye-image pixels the panel reads
//! per panel pixel, where, and what that leaves unread.
//!
//! The map panel pixel → eye-image pixel is the forward map of
//! [`super::Lens`] (green channel) scaled by the two images' sizes; its
//! Jacobian J, by central differences of one panel pixel, gives the linear
//! density √|det J| (eye pixels per panel pixel along a side: above 1 the
//! eye image is over-rendered there, below 1 it is under-sampled). This is
//! the quantity Vlachos ("Advanced VR Rendering", GDC 2015) plots to argue
//! for radial density masking: where the density exceeds √2, dropping half
//! of the eye pixels (every other 2×2 quad) still leaves at least one eye
//! pixel per panel pixel.

use super::{eye_uv, Lens};
use crate::view::Fov;

/// One ring of the visible lens (lens radius from `r_inner` to `r_outer`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Ring {
    /// Inner lens radius.
    pub r_inner: f64,
    /// Outer lens radius.
    pub r_outer: f64,
    /// Angle of the inner edge from the lens axis, degrees (green).
    pub deg_inner: f64,
    /// Angle of the outer edge, degrees.
    pub deg_outer: f64,
    /// Panel pixels sampled in the ring.
    pub panel_pixels: u64,
    /// Mean linear density (eye pixels per panel pixel along a side).
    pub density_mean: f64,
    /// Smallest linear density in the ring.
    pub density_min: f64,
    /// Largest linear density in the ring.
    pub density_max: f64,
}

/// The density figures of one view.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Density {
    /// Panel pixels (width, height).
    pub panel: [u32; 2],
    /// Eye-image pixels (width, height).
    pub eye: [u32; 2],
    /// Linear density at the lens centre.
    pub centre_density: f64,
    /// Rings from the centre out.
    pub rings: Vec<Ring>,
    /// Eye pixels per visible panel pixel over the whole lens (area ratio).
    pub over_render: f64,
    /// Fraction of the eye image no visible panel pixel reads (green).
    pub eye_unread_fraction: f64,
    /// The smallest eye-image NDC radius beyond which every visible panel
    /// pixel reads at a density of at least √2 (the `rdm=R` radius that
    /// masks only over-rendered pixels); None when there is none below 1.5.
    pub rdm_radius: Option<f64>,
    /// The smallest eye-image NDC radius beyond which every visible panel
    /// pixel reads at a density of at least 2 (where 2×2 shading still
    /// gives every panel pixel its own shade: `foveation=auto`); None when
    /// there is none below 1.5.
    pub coarse_radius: Option<f64>,
}

/// Rings reported per view.
pub const RINGS: usize = 10;

/// The linear density at panel uv `uv` (green), or None outside the lens.
pub fn linear_density(lens: &Lens, fov: &Fov, eye: [u32; 2], uv: [f64; 2]) -> Option<f64> {
    let [pw, ph] = lens.panel.map(f64::from);
    let (hx, hy) = (1.0 / pw, 1.0 / ph);
    let map = |p: [f64; 2]| -> Option<[f64; 2]> {
        let t = lens.tangent_of_panel(p, 1)?;
        let e = eye_uv(fov, t);
        Some([e[0] * eye[0] as f64, e[1] * eye[1] as f64])
    };
    let (xp, xm) = (map([uv[0] + hx, uv[1]])?, map([uv[0] - hx, uv[1]])?);
    let (yp, ym) = (map([uv[0], uv[1] + hy])?, map([uv[0], uv[1] - hy])?);
    let dx = [(xp[0] - xm[0]) * 0.5, (xp[1] - xm[1]) * 0.5];
    let dy = [(yp[0] - ym[0]) * 0.5, (yp[1] - ym[1]) * 0.5];
    Some((dx[0] * dy[1] - dx[1] * dy[0]).abs().sqrt())
}

/// One visible panel sample: a panel pixel whose ray lands inside the eye
/// image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The panel pixel's centre, panel uv.
    pub panel_uv: [f64; 2],
    /// Where it reads the eye image, NDC (x right, y down, −1..1).
    pub eye_ndc: [f64; 2],
    /// The linear density there ([`linear_density`]).
    pub density: f64,
}

/// Calls `f` with every `stride`-th panel pixel (per axis) of `lens` that
/// reads inside an eye image of `eye` pixels over `fov` (green channel).
pub fn for_each_visible(
    lens: &Lens,
    fov: &Fov,
    eye: [u32; 2],
    stride: u32,
    mut f: impl FnMut(Sample),
) {
    let stride = stride.max(1) as usize;
    let [pw, ph] = lens.panel;
    for y in (0..ph).step_by(stride) {
        for x in (0..pw).step_by(stride) {
            let uv = [(x as f64 + 0.5) / pw as f64, (y as f64 + 0.5) / ph as f64];
            let Some(t) = lens.tangent_of_panel(uv, 1) else {
                continue;
            };
            let e = eye_uv(fov, t);
            if !(0.0..=1.0).contains(&e[0]) || !(0.0..=1.0).contains(&e[1]) {
                continue;
            }
            let Some(density) = linear_density(lens, fov, eye, uv) else {
                continue;
            };
            f(Sample {
                panel_uv: uv,
                eye_ndc: [e[0] * 2.0 - 1.0, e[1] * 2.0 - 1.0],
                density,
            });
        }
    }
}

/// The half-angle, degrees, of the inset (`--opt inset`) this lens needs
/// around the eye image's centre: outside the inset the wide view, at
/// `wide_scale` of the eye's resolution per axis, reads
/// `wide_scale` × the density — at least one wide-view pixel per panel
/// pixel wherever that product is at least 1, so the panel shows nothing
/// the full render would have added. The inset must therefore cover every
/// visible panel pixel where `wide_scale × density < 1`: the answer is the
/// largest tangent offset (per axis, as `view::inset` sizes its square of
/// tangents) from the image centre of such a pixel, as an angle; 0 when
/// the wide view suffices everywhere.
pub fn inset_half_angle_deg(
    lens: &Lens,
    fov: &Fov,
    eye: [u32; 2],
    wide_scale: f64,
    stride: u32,
) -> f64 {
    let centre = super::tangent_of_eye(fov, [0.5, 0.5]);
    let mut widest = 0.0f64;
    for_each_visible(lens, fov, eye, stride, |s| {
        if s.density * wide_scale < 1.0 {
            let uv = [(s.eye_ndc[0] + 1.0) * 0.5, (s.eye_ndc[1] + 1.0) * 0.5];
            let t = super::tangent_of_eye(fov, uv);
            widest = widest
                .max((t[0] - centre[0]).abs())
                .max((t[1] - centre[1]).abs());
        }
    });
    widest.atan().to_degrees()
}

/// The density figures of `lens` for an eye image of `eye` pixels over
/// `fov`, sampling every `stride`-th panel and eye pixel.
pub fn density(lens: &Lens, fov: &Fov, eye: [u32; 2], stride: u32) -> Density {
    let stride = stride.max(1);
    let mut rings: Vec<Ring> = (0..RINGS)
        .map(|i| {
            let (a, b) = (
                lens.r_max * i as f64 / RINGS as f64,
                lens.r_max * (i + 1) as f64 / RINGS as f64,
            );
            let deg = |r: f64| {
                let (g, _) = lens.radial.radius(1, r);
                (g * lens.tangent[0]).atan().to_degrees()
            };
            Ring {
                r_inner: a,
                r_outer: b,
                deg_inner: deg(a),
                deg_outer: deg(b),
                panel_pixels: 0,
                density_mean: 0.0,
                density_min: f64::MAX,
                density_max: 0.0,
            }
        })
        .collect();
    // Per visible panel sample: its eye NDC radius and density.
    let mut samples: Vec<(f64, f64)> = Vec::new();
    let (mut area_sum, mut visible) = (0.0, 0u64);
    for_each_visible(lens, fov, eye, stride, |s| {
        let q = lens.lens_of_panel(s.panel_uv);
        let r = q[0].hypot(q[1]);
        let k = ((r / lens.r_max * RINGS as f64) as usize).min(RINGS - 1);
        let d = s.density;
        let ring = &mut rings[k];
        ring.panel_pixels += 1;
        ring.density_mean += d;
        ring.density_min = ring.density_min.min(d);
        ring.density_max = ring.density_max.max(d);
        area_sum += d * d;
        visible += 1;
        samples.push((s.eye_ndc[0].hypot(s.eye_ndc[1]), d));
    });
    for ring in &mut rings {
        if ring.panel_pixels > 0 {
            ring.density_mean /= ring.panel_pixels as f64;
        } else {
            ring.density_min = 0.0;
        }
    }
    let (mut read, mut total) = (0u64, 0u64);
    for y in (0..eye[1]).step_by(stride as usize) {
        for x in (0..eye[0]).step_by(stride as usize) {
            let uv = [
                (x as f64 + 0.5) / eye[0] as f64,
                (y as f64 + 0.5) / eye[1] as f64,
            ];
            total += 1;
            let t = super::tangent_of_eye(fov, uv);
            if let Some(p) = lens.panel_of_tangent(t, 1) {
                if (0.0..=1.0).contains(&p[0]) && (0.0..=1.0).contains(&p[1]) {
                    read += 1;
                }
            }
        }
    }
    // The smallest R (steps of 0.01) such that every sample at NDC radius
    // ≥ R has at least the given density.
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut suffix_min = vec![f64::MAX; samples.len() + 1];
    for i in (0..samples.len()).rev() {
        suffix_min[i] = suffix_min[i + 1].min(samples[i].1);
    }
    let radius_beyond = |density: f64| {
        (1..150).map(|i| i as f64 / 100.0).find(|&r| {
            let first = samples.partition_point(|s| s.0 < r);
            first < samples.len() && suffix_min[first] >= density
        })
    };
    let rdm_radius = radius_beyond(std::f64::consts::SQRT_2);
    let coarse_radius = radius_beyond(2.0);
    Density {
        panel: lens.panel,
        eye,
        centre_density: linear_density(lens, fov, eye, lens.centre).unwrap_or(0.0),
        rings,
        over_render: if visible > 0 {
            area_sum / visible as f64
        } else {
            0.0
        },
        eye_unread_fraction: 1.0 - read as f64 / total.max(1) as f64,
        rdm_radius,
        coarse_radius,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The inset's half-angle against brute force over the Vive's lens:
    /// every panel pixel the wide view under-samples lies inside the
    /// angle's square of tangents, and one lies on its edge; a wide view at
    /// full scale needs a smaller inset than one at half scale.
    #[test]
    fn the_inset_covers_what_the_wide_view_under_samples_and_no_more() {
        let vive = crate::view::profile::HmdProfile::load("vive").unwrap();
        for v in &vive.views {
            let lens = v.lens.as_ref().unwrap();
            let deg = inset_half_angle_deg(lens, &v.fov, v.resolution, 0.5, 4);
            assert!(deg > 1.0 && deg < 80.0, "{deg}");
            let t = deg.to_radians().tan();
            let c = super::super::tangent_of_eye(&v.fov, [0.5, 0.5]);
            let mut widest = 0.0f64;
            for_each_visible(lens, &v.fov, v.resolution, 4, |s| {
                if s.density * 0.5 < 1.0 {
                    let uv = [(s.eye_ndc[0] + 1.0) * 0.5, (s.eye_ndc[1] + 1.0) * 0.5];
                    let p = super::super::tangent_of_eye(&v.fov, uv);
                    let off = (p[0] - c[0]).abs().max((p[1] - c[1]).abs());
                    assert!(off <= t + 1e-12, "{off} outside {t}");
                    widest = widest.max(off);
                }
            });
            assert!((widest - t).abs() < 1e-9);
            let sharper = inset_half_angle_deg(lens, &v.fov, v.resolution, 0.8, 4);
            assert!(sharper < deg, "{sharper} vs {deg}");
        }
    }
    use crate::view::distortion::{panotools::Panotools, Radial};

    fn identity_lens(panel: [u32; 2]) -> Lens {
        Lens {
            radial: Radial::Panotools(Panotools {
                k: [0.0, 0.0, 0.0, 1.0],
                chroma: [1.0, 1.0, 1.0],
            }),
            centre: [0.5, 0.5],
            unit: [0.5, 0.5],
            tangent: [1.0, 1.0],
            axis: [0.0, 0.0],
            r_max: 10.0,
            panel,
        }
    }

    #[test]
    fn an_undistorting_lens_reads_one_pixel_per_pixel_at_equal_sizes() {
        let lens = identity_lens([64, 64]);
        let fov = Fov::symmetric(45f64.to_radians(), 45f64.to_radians());
        let d = density(&lens, &fov, [64, 64], 1);
        assert!((d.centre_density - 1.0).abs() < 1e-9);
        assert!((d.over_render - 1.0).abs() < 1e-9);
        assert!(d.eye_unread_fraction.abs() < 1e-9);
        assert_eq!(d.rdm_radius, None);
        // Twice the eye pixels per axis: density 2 everywhere, and every
        // radius may be masked.
        let d = density(&lens, &fov, [128, 128], 1);
        assert!((d.centre_density - 2.0).abs() < 1e-9);
        assert!((d.over_render - 4.0).abs() < 1e-9);
        assert_eq!(d.rdm_radius, Some(0.01));
        assert_eq!(d.coarse_radius, Some(0.01));
        // At √3 per axis RDM may mask everywhere, 2×2 shading nowhere.
        let d = density(&lens, &fov, [111, 111], 1);
        assert_eq!(d.rdm_radius, Some(0.01));
        assert_eq!(d.coarse_radius, None);
    }

    #[test]
    fn a_barrel_lens_over_renders_the_periphery_and_leaves_corners_unread() {
        let p = crate::view::profile::HmdProfile::load("vive").unwrap();
        let v = &p.views[0];
        let lens = v.lens.unwrap();
        let d = density(&lens, &v.fov, v.resolution, 8);
        let (first, last) = (d.rings[0], d.rings[RINGS - 1]);
        assert!(
            last.density_mean > first.density_mean * 1.1,
            "{first:?} {last:?}"
        );
        assert!(d.eye_unread_fraction > 0.05, "{}", d.eye_unread_fraction);
        assert!(d.over_render > 1.0);
    }
}
