//! Monoscopic far-field rendering (after Oculus' "hybrid mono rendering",
//! Oculus developer blog, 2016): beyond a split distance D the two eyes see
//! (nearly) the same image, so the far field is rendered once from a centre
//! camera and composited into both eyes; only the near field is rendered in
//! stereo.
//!
//! Split distance: a point at distance d straight ahead appears shifted
//! between the eyes by the disparity `ipd / d` in tangent units, i.e.
//! `ipd · W / (d · (tan r − tan l))` pixels for an image W pixels wide. It
//! falls below one pixel beyond `D = ipd · W / (tan r − tan l)`, the
//! automatic split.
//!
//! Centre camera: at the midpoint of the eyes with the head's orientation;
//! its FOV is the union of the eyes' frusta expressed in head space (each
//! eye's corner directions rotated by its orientation relative to the head,
//! then divided by −z), so canted eyes are covered too.

use super::{Fov, Pose, StereoRig, View};
use glam::{DQuat, DVec3};

/// The automatic split distance for `rig` at `width` pixels per eye: where
/// the disparity of a point straight ahead falls below one pixel.
pub fn auto_split(rig: &StereoRig, width: u32) -> f64 {
    let (Some(a), Some(b)) = (rig.views.first(), rig.views.get(1)) else {
        return f64::INFINITY;
    };
    let ipd = a.pose.position.distance(b.pose.position);
    let [l, r, _, _] = a.fov.tangents();
    (ipd * width as f64 / (r - l)).max(0.1)
}

/// The centre camera covering both eyes, or None when the union reaches
/// 90° or more on a side (no finite tangent).
pub fn centre_view(rig: &StereoRig) -> Option<View> {
    let head = rig.head;
    let inv = head.orientation.inverse();
    let (mut l, mut r, mut u, mut d) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
    );
    for v in &rig.views {
        let rel: DQuat = inv * v.pose.orientation;
        let [tl, tr, tu, td] = v.fov.tangents();
        for (x, y) in [(tl, tu), (tr, tu), (tl, td), (tr, td)] {
            let dir = rel * DVec3::new(x, y, -1.0);
            if dir.z >= -1e-6 {
                return None;
            }
            let (tx, ty) = (dir.x / -dir.z, dir.y / -dir.z);
            l = l.min(tx);
            r = r.max(tx);
            u = u.max(ty);
            d = d.min(ty);
        }
    }
    let n = rig.views.len().max(1) as f64;
    let centre = rig.views.iter().map(|v| v.pose.position).sum::<DVec3>() / n;
    let fov = Fov {
        left: l.atan(),
        right: r.atan(),
        up: u.atan(),
        down: d.atan(),
    };
    fov.validate().ok()?;
    Some(View {
        pose: Pose {
            position: centre,
            orientation: head.orientation,
        },
        fov,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::profile::HmdProfile;

    #[test]
    fn auto_split_is_where_disparity_reaches_one_pixel() {
        let p = HmdProfile::load("valve-index").unwrap();
        let rig = p.rig(Pose::default());
        let d = auto_split(&rig, 2016);
        let [l, r, _, _] = rig.views[0].fov.tangents();
        let disparity_px = p.ipd() / d * 2016.0 / (r - l);
        assert!((disparity_px - 1.0).abs() < 1e-9, "{disparity_px}");
        assert!(d > 30.0 && d < 80.0, "{d} m for the Index");
    }

    #[test]
    fn centre_view_covers_every_eye_corner() {
        for name in ["valve-index", "quest-3", "monado-sim"] {
            let p = HmdProfile::load(name).unwrap();
            let head = Pose::from_euler_deg(DVec3::new(1.0, 1.7, -3.0), 30.0, -10.0, 5.0);
            let rig = p.rig(head);
            let c = centre_view(&rig).expect("finite union");
            let [cl, cr, cu, cd] = c.fov.tangents();
            let inv = c.pose.orientation.inverse();
            for v in &rig.views {
                let [tl, tr, tu, td] = v.fov.tangents();
                for (x, y) in [(tl, tu), (tr, tu), (tl, td), (tr, td)] {
                    let dir = inv * (v.pose.orientation * DVec3::new(x, y, -1.0));
                    let (tx, ty) = (dir.x / -dir.z, dir.y / -dir.z);
                    assert!(
                        tx >= cl - 1e-9 && tx <= cr + 1e-9 && ty >= cd - 1e-9 && ty <= cu + 1e-9,
                        "{name}"
                    );
                }
            }
            let mid = (rig.views[0].pose.position + rig.views[1].pose.position) * 0.5;
            assert!((c.pose.position - mid).length() < 1e-12);
        }
    }

    #[test]
    fn a_union_reaching_90_degrees_has_no_centre_view() {
        let p = HmdProfile::load("pimax-wide").unwrap();
        let rig = p.rig(Pose::default());
        let c = centre_view(&rig);
        if let Some(c) = c {
            assert!(c.fov.validate().is_ok());
        }
    }
}
