//! Reverse-Z projection with an infinite far plane, built directly from the
//! four FOV tangents (no symmetric-FOV assumption, no matrix inversion).
//!
//! Derivation (view space looks down -Z, Vulkan NDC has +Y down and depth in
//! [0, 1]): a point (x, y, z) projects to the image plane at
//! `tx = x / -z`, `ty = y / -z`. Mapping `tx ∈ [l, r]` to `[-1, 1]` gives
//! `x_ndc = (2 tx - (r + l)) / (r - l)`; multiplying by `w = -z` yields the
//! clip row `x_c = (2 x + (r + l) z) / (r - l)`. The same for y, negated for
//! Vulkan's downward Y: `y_c = -(2 y + (u + d) z) / (u - d)`. Reverse-Z with
//! the far plane at infinity stores `z_ndc = n / -z`, i.e. `z_c = n`: depth is
//! 1 at the near plane and tends to 0 at infinity, which spreads float
//! precision evenly in log-depth (Reed, "Depth Precision Visualized", 2015;
//! Upchurch & Desbrun, "Tightening the Precision of Perspective Rendering",
//! 2012).

use super::{Fov, Pose};
use glam::{DMat4, DVec3, DVec4, Mat4};

/// Reverse-Z, infinite-far projection for `fov` with near plane `near`
/// (metres, > 0). Depth test must be GREATER with depth cleared to 0.
pub fn reverse_z_infinite(fov: &Fov, near: f64) -> DMat4 {
    let [l, r, u, d] = fov.tangents();
    DMat4::from_cols(
        DVec4::new(2.0 / (r - l), 0.0, 0.0, 0.0),
        DVec4::new(0.0, -2.0 / (u - d), 0.0, 0.0),
        DVec4::new((r + l) / (r - l), -(u + d) / (u - d), 0.0, -1.0),
        DVec4::new(0.0, 0.0, near, 0.0),
    )
}

/// View matrix of an eye relative to `origin` (camera-relative rendering):
/// world positions are expressed relative to `origin` in f64 before any f32
/// conversion, so a scene 1e7 m from the world origin keeps millimetre
/// precision near the viewer.
pub fn view_relative(eye: &Pose, origin: DVec3) -> DMat4 {
    let rot = DMat4::from_quat(eye.orientation.conjugate());
    rot * DMat4::from_translation(-(eye.position - origin))
}

/// The f32 view-projection matrix used on the GPU for one eye, relative to
/// `origin`.
pub fn view_projection_f32(eye: &Pose, fov: &Fov, near: f64, origin: DVec3) -> Mat4 {
    (reverse_z_infinite(fov, near) * view_relative(eye, origin)).as_mat4()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn project(m: &DMat4, p: DVec3) -> DVec3 {
        let c = *m * p.extend(1.0);
        c.truncate() / c.w
    }

    #[test]
    fn fov_edges_map_to_ndc_edges() {
        let fov = Fov {
            left: -0.9,
            right: 0.5,
            up: 0.7,
            down: -0.3,
        };
        let m = reverse_z_infinite(&fov, 0.05);
        let [l, r, u, d] = fov.tangents();
        let z = -3.0;
        let left = project(&m, DVec3::new(l * 3.0, 0.0, z));
        let right = project(&m, DVec3::new(r * 3.0, 0.0, z));
        let top = project(&m, DVec3::new(0.0, u * 3.0, z));
        let bottom = project(&m, DVec3::new(0.0, d * 3.0, z));
        assert!((left.x + 1.0).abs() < 1e-12 && (right.x - 1.0).abs() < 1e-12);
        // Vulkan: +Y is down, so the top edge maps to -1.
        assert!((top.y + 1.0).abs() < 1e-12 && (bottom.y - 1.0).abs() < 1e-12);
    }

    #[test]
    fn reverse_z_depth_is_one_at_near_and_zero_at_infinity() {
        let fov = Fov::symmetric(0.8, 0.8);
        let m = reverse_z_infinite(&fov, 1e-5);
        assert!((project(&m, DVec3::new(0.0, 0.0, -1e-5)).z - 1.0).abs() < 1e-9);
        let far = project(&m, DVec3::new(0.0, 0.0, -1e12)).z;
        assert!(far > 0.0 && far < 1e-16);
    }

    #[test]
    fn near_90_degree_half_angles_stay_finite() {
        let a = 89.9f64.to_radians();
        let m = reverse_z_infinite(&Fov::symmetric(a, a), 0.01);
        assert!(m.is_finite());
    }

    #[test]
    fn camera_relative_keeps_precision_far_from_origin() {
        let origin = DVec3::new(1e7, 0.0, -1e7);
        let eye = Pose {
            position: origin + DVec3::new(0.0, 1.7, 0.0),
            ..Pose::default()
        };
        let vp = view_projection_f32(&eye, &Fov::symmetric(0.8, 0.8), 0.05, origin);
        // A point 1 mm right of the view axis, 2 m ahead, must land right of centre.
        let p = glam::Vec4::new(0.001, 1.7, -2.0, 1.0);
        let c = vp * p;
        assert!(c.x / c.w > 0.0);
    }
}
