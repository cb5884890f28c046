//! View cones: a circular cone per eye enclosing its FOV rectangle (or a
//! lens-visible circle), and one cone enclosing several eye cones (the
//! conical superfrustum). A cone test costs one dot product, one cross
//! product and a compare, against five or six plane tests for a frustum.

use glam::DVec3;

use super::frustum::{checked_tangents, VolumeError};
use super::View;

/// Half-angles at or above this (radians, just under 90°) make a cone
/// useless for culling; building one fails instead.
const MAX_HALF_ANGLE: f64 = std::f64::consts::FRAC_PI_2 - 1e-7;

/// The far end of a cone's culled volume: the volume is the cone cut by the
/// plane `normal · (x - apex) = depth`, and its far face lies within the
/// disk (`center`, `radius`) in that plane. The disk lets an enclosing cone
/// bound how far the cut volume reaches along another direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FarCap {
    /// Unit normal of the far plane, pointing away from the apex.
    pub normal: DVec3,
    /// Distance of the far plane from the apex along `normal`.
    pub depth: f64,
    /// World centre of a disk in the far plane containing the far face.
    pub center: DVec3,
    /// Radius of that disk.
    pub radius: f64,
}

impl FarCap {
    /// Largest extent along unit `a`, relative to `origin`, of the convex
    /// hull of `apex` and this cap: a linear function on a hull peaks at the
    /// apex or on the disk, where it peaks at
    /// `a · center + radius · |a - (a · n) n|`.
    pub fn reach_along(&self, a: DVec3, apex: DVec3, origin: DVec3) -> f64 {
        let tangential = (a - self.normal * a.dot(self.normal)).length();
        let disk = a.dot(self.center - origin) + self.radius * tangential;
        disk.max(a.dot(apex - origin))
    }
}

/// A convex circular cone, optionally cut by a far plane for distance
/// culling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// Apex in world space.
    pub apex: DVec3,
    /// Unit axis.
    pub axis: DVec3,
    /// Half-angle in radians, below 90°.
    pub half_angle: f64,
    /// `cos(half_angle)`.
    pub cos: f64,
    /// `sin(half_angle)`.
    pub sin: f64,
    /// Far plane of the culled volume; `None` when there is no draw
    /// distance.
    pub far: Option<FarCap>,
}

/// Angle between two non-zero vectors, accurate at small and large angles
/// (`atan2(|a × b|, a · b)`, Kahan's recommendation over `acos`).
pub fn angle_between(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

impl Cone {
    fn new(
        apex: DVec3,
        axis: DVec3,
        half_angle: f64,
        far: Option<FarCap>,
    ) -> Result<Cone, VolumeError> {
        if !(half_angle.is_finite() && half_angle > 0.0 && half_angle < MAX_HALF_ANGLE) {
            return Err(VolumeError::NoCombinedVolume(format!(
                "cone half-angle {half_angle} rad is not below 90°"
            )));
        }
        if !apex.is_finite() || !axis.is_finite() {
            return Err(VolumeError::NoCombinedVolume("non-finite cone".into()));
        }
        Ok(Cone {
            apex,
            axis,
            half_angle,
            cos: half_angle.cos(),
            sin: half_angle.sin(),
            far,
        })
    }

    /// The cone of one eye: apex at the eye, axis the best of a few
    /// candidates (centre of the FOV's tangent rectangle, mean corner
    /// direction, view axis), half-angle the largest angle from that axis
    /// to a corner ray, so the cone contains the whole rectangular frustum
    /// (the four corner rays span it and a cone is convex). With a draw
    /// distance `far` (depth along -Z) the cone is cut by the eye's far
    /// plane, and the far face (the tangent rectangle scaled by `far`) is
    /// bounded by the disk around the rectangle's centre through its corners.
    pub fn from_view(view: &View, far: Option<f64>) -> Result<Cone, VolumeError> {
        view.pose.validate().map_err(VolumeError::InvalidPose)?;
        let [tl, tr, tu, td] = checked_tangents(&view.fov)?;
        validate_far(far)?;
        let q = view.pose.orientation.normalize();
        let rays =
            [(tl, td), (tr, td), (tr, tu), (tl, tu)].map(|(x, y)| q * DVec3::new(x, y, -1.0));
        // Candidate axes: the centre of the tangent rectangle (tight for
        // moderate FOVs), the mean corner direction, and the view axis
        // (always within 90° of every corner, so a cone always exists).
        let mean_dir: DVec3 = rays.iter().map(|r| r.normalize()).sum();
        let candidates = [
            q * DVec3::new(0.5 * (tl + tr), 0.5 * (tu + td), -1.0),
            mean_dir,
            q * DVec3::NEG_Z,
        ];
        let (axis, half) = candidates
            .into_iter()
            .filter(|a| a.length() > 1e-12)
            .map(|a| {
                let a = a.normalize();
                (
                    a,
                    rays.iter()
                        .map(|r| angle_between(a, *r))
                        .fold(0.0, f64::max),
                )
            })
            .fold((q * DVec3::NEG_Z, f64::INFINITY), |best, c| {
                if c.1 < best.1 {
                    c
                } else {
                    best
                }
            });
        let apex = view.pose.position;
        let cap = far.map(|f| {
            let center = q * DVec3::new(0.5 * (tl + tr), 0.5 * (tu + td), -1.0) * f;
            let radius = rays
                .iter()
                .map(|r| (*r * f - center).length())
                .fold(0.0, f64::max);
            FarCap {
                normal: q * DVec3::NEG_Z,
                depth: f,
                center: apex + center,
                radius: radius * (1.0 + 1e-12),
            }
        });
        Cone::new(apex, axis, half + 1e-12, cap)
    }

    /// The cone of the lens-visible circle: apex at the eye, axis the view
    /// direction, the given half-angle. This is usually narrower than the FOV
    /// rectangle's cone, so it can reject what the frustum keeps; strategies
    /// using it report those misses as false negatives.
    pub fn from_lens(
        view: &View,
        lens_half_angle: f64,
        far: Option<f64>,
    ) -> Result<Cone, VolumeError> {
        view.pose.validate().map_err(VolumeError::InvalidPose)?;
        validate_far(far)?;
        let axis = view.pose.orientation.normalize() * DVec3::NEG_Z;
        let apex = view.pose.position;
        let cap = far.map(|f| FarCap {
            normal: axis,
            depth: f,
            center: apex + axis * f,
            radius: f * lens_half_angle.tan(),
        });
        Cone::new(apex, axis, lens_half_angle, cap)
    }

    /// One cone containing every cone in `cones` (the conical superfrustum).
    ///
    /// Derivation: cone `i` (apex `a_i`, direction cap `(v_i, θ_i)`) lies in
    /// cone `C` when `C` contains `a_i` and every direction of cap `i`
    /// (a convex cone is closed under adding its directions). Directions: the
    /// smallest cap containing two caps lies on the great circle through
    /// their axes with `θ = (α + θ_1 + θ_2) / 2`, `α` the angle between the
    /// axes (the spherical analogue of the smallest circle enclosing two
    /// circles); more caps are merged one at a time. Apex: start from the
    /// mean apex `m` and recede along the axis by
    /// `t = max_i(ρ_i / tan θ - h_i, 0)`, where `h_i`, `ρ_i` are the axial and
    /// radial offsets of `a_i` from `m`, so each `a_i` sits on or inside the
    /// surface. With draw distances, the far plane is perpendicular to the
    /// new axis, as deep as the farthest reach of any cut cone along it
    /// ([`FarCap::reach_along`]).
    pub fn enclosing(cones: &[Cone]) -> Result<Cone, VolumeError> {
        let first = cones
            .first()
            .ok_or_else(|| VolumeError::NoCombinedVolume("no cones".into()))?;
        let (mut axis, mut theta) = (first.axis, first.half_angle);
        for c in &cones[1..] {
            let alpha = angle_between(axis, c.axis);
            if alpha + c.half_angle <= theta {
                continue;
            }
            if alpha + theta <= c.half_angle {
                axis = c.axis;
                theta = c.half_angle;
                continue;
            }
            let new_theta = 0.5 * (alpha + theta + c.half_angle);
            if new_theta >= MAX_HALF_ANGLE {
                return Err(VolumeError::NoCombinedVolume(format!(
                    "enclosing cone half-angle {:.3}° reaches 90°",
                    new_theta.to_degrees()
                )));
            }
            let w = c.axis - axis * axis.dot(c.axis);
            let wl = w.length();
            if wl < 1e-300 {
                return Err(VolumeError::NoCombinedVolume("opposite cone axes".into()));
            }
            let beta = new_theta - theta;
            axis = (axis * beta.cos() + (w / wl) * beta.sin()).normalize();
            theta = new_theta;
        }
        // Rounding slack: a hair wider, then re-check every cap.
        theta += 1e-12;
        for c in cones {
            theta = theta.max(angle_between(axis, c.axis) + c.half_angle + 1e-12);
        }
        if theta >= MAX_HALF_ANGLE {
            return Err(VolumeError::NoCombinedVolume(format!(
                "enclosing cone half-angle {:.3}° reaches 90°",
                theta.to_degrees()
            )));
        }
        let m = cones.iter().map(|c| c.apex).sum::<DVec3>() / cones.len() as f64;
        let tan = theta.tan();
        let mut t: f64 = 0.0;
        let mut extent: f64 = 0.0;
        for c in cones {
            let off = c.apex - m;
            let h = off.dot(axis);
            let rho = off.cross(axis).length();
            t = t.max(rho / tan - h);
            extent = extent.max(off.length());
        }
        let t = t + 1e-9 + 1e-12 * extent;
        let apex = m - axis * t;
        let cap = if cones.iter().all(|c| c.far.is_some()) {
            let depth = cones
                .iter()
                .filter_map(|c| c.far.map(|f| f.reach_along(axis, c.apex, apex)))
                .fold(0.0, f64::max);
            let depth = depth * (1.0 + 1e-12) + 1e-9;
            Some(FarCap {
                normal: axis,
                depth,
                center: apex + axis * depth,
                radius: depth * theta.tan(),
            })
        } else {
            None
        };
        Cone::new(apex, axis, theta, cap)
    }

    /// Signed distance bound of a camera-relative point `d` (from the apex)
    /// to the cone: `P cos θ - L sin θ`, the distance to the plane tangent to
    /// the cone along the generatrix at `d`'s azimuth, with `L` the axial and
    /// `P` the radial component (Eberly, "Intersection of a Sphere and a
    /// Cone"; the cone is on the negative side of every tangent plane, and
    /// this bound is 1-Lipschitz in `d`). Positive outside, and for points
    /// inside with `L > 0` its negation is the distance to the surface.
    #[inline]
    pub fn surface_bound(&self, d: DVec3) -> f64 {
        let l = d.dot(self.axis);
        let p = d.cross(self.axis).length();
        p * self.cos - l * self.sin
    }

    /// Keeps a sphere (camera-relative centre `d` from the apex, radius `r`)
    /// unless it lies entirely outside a tangent plane or beyond the far
    /// plane. `slack` widens the test to absorb rounding.
    #[inline]
    pub fn keeps_sphere(&self, world_center_minus_apex: DVec3, r: f64, slack: f64) -> bool {
        if self.surface_bound(world_center_minus_apex) > r + slack {
            return false;
        }
        match self.far {
            Some(f) => f.normal.dot(world_center_minus_apex) - r <= f.depth + slack,
            None => true,
        }
    }

    /// Conservative test of a world box through its circumscribed sphere.
    pub fn keeps_box(&self, min: DVec3, max: DVec3) -> bool {
        let (a, b) = (min - self.apex, max - self.apex);
        let d = (a + b) * 0.5;
        let r = (b - a).length() * 0.5;
        self.keeps_sphere(d, r, sphere_slack(d, r))
    }
}

/// Cones start at the apex (no near plane); only the far distance, when
/// given, must be a positive finite number.
fn validate_far(far: Option<f64>) -> Result<(), VolumeError> {
    match far {
        Some(f) if !(f.is_finite() && f > 0.0) => Err(VolumeError::InvalidClip { near: 0.0, far }),
        _ => Ok(()),
    }
}

/// Rounding slack used by the per-instance cone test.
#[inline]
pub fn sphere_slack(d: DVec3, r: f64) -> f64 {
    1e-12 * (1.0 + d.length() + r)
}
