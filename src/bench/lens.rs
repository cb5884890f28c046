//! `vergence lens`: a profile's lens sampling density as a table (per
//! view, per ring of the visible lens) and JSON, answering whether the
//! barrel sampling is dense enough to mask regions out
//! ([`crate::view::distortion::density`]).

use crate::error::{Error, Result};
use crate::view::distortion::density::{density, Density};
use crate::view::profile::HmdProfile;
use std::fmt::Write as _;

/// Density figures of every view of a profile.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LensReport {
    /// Profile name.
    pub profile: String,
    /// The lens model per view.
    pub model: Vec<String>,
    /// Per view, left first.
    pub views: Vec<Density>,
    /// What `--opt inset` and `--opt lms` derive from these lenses.
    pub derived: Derived,
}

/// The values the renderer derives from a profile's lenses (besides
/// `rdm=auto` and `foveation=auto`, which each view's figures give).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Derived {
    /// `inset`'s half-angle at the default wide-view scale, degrees
    /// ([`crate::view::distortion::density::inset_half_angle_deg`], largest
    /// over the views, within 1–80°).
    pub inset_half_angle_deg: f64,
    /// The wide-view scale it was derived for.
    pub inset_wide_scale: f64,
    /// `lms`'s fitted coefficients ([`crate::view::lms::fit`]).
    pub lms: crate::view::lms::Coefficients,
    /// The LMS image's share of the eye image's pixels (first view).
    pub lms_pixel_fraction: f64,
}

/// Panel and eye pixels sampled per axis step (every pixel is 1).
pub const STRIDE: u32 = 2;

/// The most samples the report takes per view: a profile may declare a
/// panel and eye image of up to the largest sizes it allows, and the
/// report's figures (means, rings, radii) need no more than this.
pub const MAX_SAMPLES: u64 = 1 << 20;

/// The sampling stride for a view whose panel and eye image have `panel`
/// and `eye` pixels: [`STRIDE`], or coarser so neither is sampled more
/// than [`MAX_SAMPLES`] times.
pub fn sample_stride(panel: [u32; 2], eye: [u32; 2]) -> u32 {
    let area = |p: [u32; 2]| p[0] as u64 * p[1] as u64;
    let most = area(panel).max(area(eye));
    let need = (most as f64 / MAX_SAMPLES as f64).sqrt().ceil() as u32;
    need.max(STRIDE)
}

/// The report for `profile`; one error naming it when a view has no lens.
pub fn report(profile: &HmdProfile) -> Result<LensReport> {
    let mut views = Vec::new();
    let mut model = Vec::new();
    for (i, v) in profile.views.iter().enumerate() {
        let lens = v.lens.as_ref().ok_or_else(|| Error::Profile {
            name: profile.name.clone(),
            message: format!("views[{i}] has no [views.lens] table"),
        })?;
        model.push(lens.radial.name().to_string());
        views.push(density(
            lens,
            &v.fov,
            v.resolution,
            sample_stride(lens.panel, v.resolution),
        ));
    }
    let wide = crate::view::inset::DEFAULT_WIDE_SCALE;
    let lenses: Vec<_> = profile
        .views
        .iter()
        .filter_map(|v| v.lens.as_ref().map(|l| (l, &v.fov, v.resolution)))
        .collect();
    let inset = lenses
        .iter()
        .map(|&(l, f, e)| {
            let stride = sample_stride(l.panel, e).max(4);
            crate::view::distortion::density::inset_half_angle_deg(l, f, e, wide, stride)
        })
        .fold(0.0f64, f64::max)
        .clamp(1.0, 80.0);
    let lms_stride = lenses
        .iter()
        .map(|&(l, _, e)| sample_stride(l.panel, e).max(4))
        .max()
        .unwrap_or(4);
    let lms = crate::view::lms::fit(&lenses, lms_stride);
    let first = profile.views.first().map_or([1, 1], |v| v.resolution);
    Ok(LensReport {
        profile: profile.name.clone(),
        model,
        views,
        derived: Derived {
            inset_half_angle_deg: inset,
            inset_wide_scale: wide,
            lms,
            lms_pixel_fraction: crate::view::lms::Layout::new(&lms, first).pixel_fraction(),
        },
    })
}

impl LensReport {
    /// The report as Markdown tables.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        for (i, (d, model)) in self.views.iter().zip(&self.model).enumerate() {
            let _ = writeln!(
                s,
                "### {} view {i} ({model}): panel {}x{}, eye image {}x{}\n",
                self.profile, d.panel[0], d.panel[1], d.eye[0], d.eye[1]
            );
            let _ = writeln!(
                s,
                "| lens radius | degrees off axis | panel px | eye px per panel px (mean / min / max) |"
            );
            let _ = writeln!(s, "|---|---|---:|---:|");
            for r in &d.rings {
                let _ = writeln!(
                    s,
                    "| {:.2}–{:.2} | {:.1}–{:.1} | {} | {:.2} / {:.2} / {:.2} |",
                    r.r_inner,
                    r.r_outer,
                    r.deg_inner,
                    r.deg_outer,
                    r.panel_pixels,
                    r.density_mean,
                    r.density_min,
                    r.density_max
                );
            }
            let _ = writeln!(
                s,
                "\ncentre density {:.2}; over-rendering {:.2}× (eye pixels per visible panel pixel); \
                 {:.1} % of the eye image is never read; masking every other quad (RDM) loses \
                 nothing beyond NDC radius {}\n",
                d.centre_density,
                d.over_render,
                100.0 * d.eye_unread_fraction,
                d.rdm_radius
                    .map_or("— (nowhere dense enough)".to_string(), |r| format!("{r:.2}"))
            );
        }
        let d = &self.derived;
        let _ = writeln!(
            s,
            "derived: `inset` half-angle ±{:.1}° (the wide view at {} per axis reads under one \
             pixel per panel pixel inside it); `lms` coefficients left {:.3}, right {:.3}, up \
             {:.3}, down {:.3} (the LMS image has {:.1} % of the eye image's pixels)",
            d.inset_half_angle_deg,
            d.inset_wide_scale,
            d.lms.left,
            d.lms.right,
            d.lms.up,
            d.lms.down,
            100.0 * d.lms_pixel_fraction
        );
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Whatever sizes a profile declares (up to the largest a profile
        /// may), neither image is sampled more than MAX_SAMPLES times
        /// (plus one row and column of rounding), and the usual sizes keep
        /// the fine stride.
        #[test]
        fn the_stride_bounds_the_samples(pw in 1u32..=16384, ph in 1u32..=16384, ew in 1u32..=16384, eh in 1u32..=16384) {
            let s = sample_stride([pw, ph], [ew, eh]) as u64;
            prop_assert!(s >= STRIDE as u64);
            for [w, h] in [[pw, ph], [ew, eh]] {
                let samples = (w as u64).div_ceil(s) * (h as u64).div_ceil(s);
                prop_assert!(samples <= MAX_SAMPLES + 2 * 16384 / s + 1, "{samples} at stride {s}");
            }
        }
    }

    #[test]
    fn usual_panels_keep_the_fine_stride() {
        assert_eq!(sample_stride([1080, 1200], [1080, 1200]), STRIDE);
        // 4.5 M eye pixels: every third pixel per axis, about 0.5 M.
        assert_eq!(sample_stride([1440, 1600], [2016, 2240]), 3);
    }

    #[test]
    fn the_report_has_every_view_and_ring_and_refuses_a_profile_without_a_lens() {
        let vive = HmdProfile::load("vive").unwrap();
        let r = report(&vive).unwrap();
        assert_eq!(r.views.len(), 2);
        assert_eq!(r.model, ["dpoly3", "dpoly3"]);
        let md = r.markdown();
        for d in &r.views {
            assert_eq!(d.rings.len(), crate::view::distortion::density::RINGS);
            // Every visible panel pixel sampled falls in exactly one ring.
            let sampled: u64 = d.rings.iter().map(|g| g.panel_pixels).sum();
            assert!(sampled > 0);
            assert!(md.contains(&format!("{:.2}", d.centre_density)));
        }
        assert_eq!(md.matches("| lens radius |").count(), 2);
        assert!(md.contains("derived: `inset` half-angle"));
        assert!(r.derived.lms.left > 0.0 && r.derived.lms_pixel_fraction < 1.0);
        let e = report(&HmdProfile::load("valve-index").unwrap())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("valve-index") && e.contains("[views.lens]"),
            "{e}"
        );
    }
}
