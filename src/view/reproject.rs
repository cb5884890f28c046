//! Reprojection of a rendered eye image to a new eye pose, the
//! application-side picture of what runtimes do for a missed frame
//! (asynchronous timewarp / reprojection).
//!
//! With P the reverse-Z infinite projection of [`super::projection`] and V
//! a view matrix, a pixel of the old image at NDC (x, y) with stored depth
//! z (= n/−z_view) is the clip-space point (x, y, z, 1) of the old view;
//! P is invertible (it sends view z to clip w and view w to clip z), so the
//! point's clip coordinates in the new view are
//!
//!   c' = P · V_new · V_old⁻¹ · P⁻¹ · (x, y, z, 1),
//!
//! and its new NDC c'.xyz / c'.w. A sky pixel (z = 0, infinitely far)
//! unprojects to w = 0, a direction, which the view change only rotates:
//! the same matrix handles it. The rotation-only variant drops the
//! translation of V_new · V_old⁻¹, which makes the map a homography of the
//! image plane independent of depth (exact for a pure head turn, and for
//! any point at infinity).
//!
//! Both are computed in f64 relative to the old eye's position, so the
//! f32 matrix a shader receives carries no world-sized translation.

use super::projection::reverse_z_infinite;
use super::View;
use glam::{DMat4, DVec3, DVec4};

/// The view matrix of `eye` relative to `origin`.
fn view(eye: &View, origin: DVec3) -> DMat4 {
    let rot = DMat4::from_quat(eye.pose.orientation.conjugate());
    rot * DMat4::from_translation(-(eye.pose.position - origin))
}

/// The clip-to-clip matrix taking the old view's (NDC x, NDC y, depth, 1)
/// to the new view's clip coordinates (with depth: rotation and
/// translation).
pub fn reprojection(old: &View, new: &View, near: f64) -> DMat4 {
    let origin = old.pose.position;
    let p_old = reverse_z_infinite(&old.fov, near);
    let p_new = reverse_z_infinite(&new.fov, near);
    p_new * view(new, origin) * view(old, origin).inverse() * p_old.inverse()
}

/// The same map without the translation between the two eyes (rotation
/// only): a homography of the image plane.
pub fn rotation_only(old: &View, new: &View, near: f64) -> DMat4 {
    let moved = View {
        pose: crate::view::Pose {
            position: old.pose.position,
            orientation: new.pose.orientation,
        },
        fov: new.fov,
    };
    reprojection(old, &moved, near)
}

/// Where `m` sends the old view's NDC point (x, y) at depth `z`: the new
/// NDC (x, y, depth), or None behind the new eye.
pub fn apply(m: &DMat4, x: f64, y: f64, z: f64) -> Option<DVec3> {
    let c = *m * DVec4::new(x, y, z, 1.0);
    if c.w <= 0.0 {
        return None;
    }
    Some(c.truncate() / c.w)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::view::{Fov, Pose};
    use glam::DQuat;
    use proptest::prelude::*;

    fn ndc_of(v: &View, near: f64, p: DVec3) -> Option<DVec3> {
        let m = reverse_z_infinite(&v.fov, near) * view(v, DVec3::ZERO);
        let c = m * p.extend(1.0);
        (c.w > 0.0).then(|| c.truncate() / c.w)
    }

    fn eye(x: f64, y: f64, z: f64, yaw: f64, pitch: f64) -> View {
        View {
            pose: Pose::from_euler_deg(DVec3::new(x, y, z), yaw, pitch, 0.0),
            fov: Fov {
                left: -0.9,
                right: 0.8,
                up: 0.85,
                down: -0.95,
            },
        }
    }

    #[test]
    fn the_same_view_is_the_identity() {
        let v = eye(1e6, 2.0, -3e5, 30.0, -10.0);
        let m = reprojection(&v, &v, 0.05);
        for (x, y, z) in [(0.3, -0.2, 0.5), (-1.0, 1.0, 0.0), (0.0, 0.0, 1.0)] {
            let p = apply(&m, x, y, z).unwrap();
            assert!((p - DVec3::new(x, y, z)).abs().max_element() < 1e-9, "{p}");
        }
    }

    proptest! {
        /// Against brute force: a world point projected into the old view
        /// and reprojected lands where projecting it into the new view puts it.
        #[test]
        fn a_world_point_lands_where_the_new_view_sees_it(
            px in -5.0f64..5.0, py in -2.0f64..3.0, pz in -30.0f64..-1.0,
            dx in -0.1f64..0.1, dy in -0.05f64..0.05, yaw in -20.0f64..20.0, pitch in -10.0f64..10.0,
        ) {
            let near = 0.05;
            let (a, b) = (eye(0.0, 1.7, 0.0, 0.0, 0.0), eye(dx, 1.7 + dy, 0.0, yaw, pitch));
            let p = DVec3::new(px, py, pz);
            let (Some(old), Some(new)) = (ndc_of(&a, near, p), ndc_of(&b, near, p)) else {
                return Ok(());
            };
            let got = apply(&reprojection(&a, &b, near), old.x, old.y, old.z).unwrap();
            prop_assert!((got - new).abs().max_element() < 1e-9, "{got} vs {new}");
        }

        /// A point at infinity (depth 0) moves with the rotation alone, and
        /// rotation-only agrees with the full map there.
        #[test]
        fn directions_follow_the_rotation_only(x in -0.9f64..0.9, y in -0.9f64..0.9,
                                              yaw in -30.0f64..30.0, dx in -0.1f64..0.1) {
            let (a, b) = (eye(0.0, 0.0, 0.0, 0.0, 0.0), eye(dx, 0.0, 0.3, yaw, 5.0));
            let full = apply(&reprojection(&a, &b, 0.05), x, y, 0.0);
            let rot = apply(&rotation_only(&a, &b, 0.05), x, y, 0.0);
            match (full, rot) {
                (Some(f), Some(r)) => prop_assert!((f - r).abs().max_element() < 1e-9),
                (None, None) => {}
                other => prop_assert!(false, "{other:?}"),
            }
        }
    }

    #[test]
    fn a_pure_yaw_shifts_the_image_centre_by_the_turn() {
        // Turning left by θ moves what was straight ahead to the right, to
        // the tangent tan θ.
        let a = View {
            pose: Pose::default(),
            fov: Fov::symmetric(0.8, 0.8),
        };
        let b = View {
            pose: Pose {
                position: DVec3::ZERO,
                orientation: DQuat::from_rotation_y(0.1),
            },
            fov: a.fov,
        };
        let p = apply(&rotation_only(&a, &b, 0.05), 0.0, 0.0, 0.0).unwrap();
        let t = 0.1f64.tan();
        let expect = t / 0.8f64.tan();
        assert!((p.x - expect).abs() < 1e-12, "{} vs {expect}", p.x);
    }
}
