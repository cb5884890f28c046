//! Per-view frustum planes built directly from the four FOV tangents, plus an
//! exact box–frustum intersection test used as the reference for culling.
//!
//! Everything is camera-relative: a [`PlaneSet`] stores an `origin` (the eye
//! or head position in world space) and planes expressed relative to it, so a
//! world point `p` is tested as `n · (p - origin) + d`. Subtracting the origin
//! first keeps f64 precision at 1e7 m from the world origin.

use glam::{DMat3, DVec3};

use super::{Fov, Pose, View};

/// Errors raised while building view volumes.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum VolumeError {
    /// The pose is not finite or its orientation is not a unit quaternion.
    #[error("invalid pose: {0}")]
    InvalidPose(String),
    /// The FOV angles are not usable.
    #[error("invalid fov: {0}")]
    InvalidFov(String),
    /// The near plane or draw distance is not a positive finite number, or
    /// the draw distance does not lie beyond the near plane.
    #[error("invalid clip distances: near {near}, far {far:?}")]
    InvalidClip {
        /// Near plane distance in metres.
        near: f64,
        /// Optional far plane (draw distance) in metres.
        far: Option<f64>,
    },
    /// A combined volume does not exist for these views (for example the
    /// total field of view reaches 180°, so the outer planes never meet).
    #[error("no finite combined volume: {0}")]
    NoCombinedVolume(String),
}

/// A plane `n · (p - origin) + d = 0` with unit normal `n` pointing inside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit normal pointing into the kept half-space.
    pub normal: DVec3,
    /// Offset relative to the owning volume's origin.
    pub d: f64,
}

impl Plane {
    /// Signed distance of a camera-relative point (positive inside).
    #[inline]
    pub fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) + self.d
    }

    /// Largest signed distance over a camera-relative box (the "p-vertex").
    ///
    /// Each coordinate is chosen by the sign of the normal instead of using
    /// `n · c + |n| · e`: products and sums of floats round monotonically, so
    /// a box contained in another never gets a larger value. That is what
    /// makes hierarchy results bit-identical to brute force.
    #[inline]
    pub fn max_over_box(&self, min: DVec3, max: DVec3) -> f64 {
        let n = self.normal;
        let x = if n.x >= 0.0 { max.x } else { min.x };
        let y = if n.y >= 0.0 { max.y } else { min.y };
        let z = if n.z >= 0.0 { max.z } else { min.z };
        n.x * x + n.y * y + n.z * z + self.d
    }

    /// Smallest signed distance over a camera-relative box (the "n-vertex").
    #[inline]
    pub fn min_over_box(&self, min: DVec3, max: DVec3) -> f64 {
        let n = self.normal;
        let x = if n.x >= 0.0 { min.x } else { max.x };
        let y = if n.y >= 0.0 { min.y } else { max.y };
        let z = if n.z >= 0.0 { min.z } else { max.z };
        n.x * x + n.y * y + n.z * z + self.d
    }
}

/// Up to six camera-relative planes; a box is kept when it is not entirely
/// outside any of them (the conservative plane test).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneSet {
    /// World-space origin the planes are relative to.
    pub origin: DVec3,
    /// Plane storage; only the first `len` entries are used.
    pub planes: [Plane; 6],
    /// Number of planes in use.
    pub len: usize,
}

impl PlaneSet {
    /// The planes in use.
    pub fn planes(&self) -> &[Plane] {
        &self.planes[..self.len]
    }

    /// Conservative test of a world-space box: false only when the box lies
    /// entirely outside one plane.
    #[inline]
    pub fn keeps_box(&self, min: DVec3, max: DVec3) -> bool {
        let (a, b) = (min - self.origin, max - self.origin);
        self.planes().iter().all(|p| p.max_over_box(a, b) >= 0.0)
    }

    /// Conservative test of a world-space sphere: false only when it lies
    /// entirely outside one plane (its centre farther than its radius).
    #[inline]
    pub fn keeps_sphere(&self, centre: DVec3, radius: f64) -> bool {
        let c = centre - self.origin;
        self.planes().iter().all(|p| p.distance(c) >= -radius)
    }

    /// Whether a world-space sphere lies wholly inside every plane (its
    /// centre at least its radius inside each): the opposite end of
    /// [`PlaneSet::keeps_sphere`], for what a volume certainly holds.
    #[inline]
    pub fn contains_sphere(&self, centre: DVec3, radius: f64) -> bool {
        let c = centre - self.origin;
        self.planes().iter().all(|p| p.distance(c) >= radius)
    }
}

/// Validates near and optional far distances shared by all volumes.
pub fn validate_clip(near: f64, far: Option<f64>) -> Result<(), VolumeError> {
    let near_ok = near.is_finite() && near > 0.0;
    let far_ok = far.is_none_or(|f| f.is_finite() && f > near);
    if near_ok && far_ok {
        Ok(())
    } else {
        Err(VolumeError::InvalidClip { near, far })
    }
}

/// Inward unit normals of the four side planes, in view space, built from
/// the signed tangents `[left, right, up, down]`.
///
/// Derivation: the left edge of the image is the set of view-space rays
/// `(tl·s, y, -s)`; the plane through the apex containing them has normal
/// `(1, 0, tl)` (dot product with the ray is `tl·s - tl·s = 0`), pointing
/// towards rays with `x/-z > tl`. Likewise right `(-1, 0, -tr)`, top
/// `(0, -1, -tu)`, bottom `(0, 1, td)`. These are the rows `w ± x`, `w ± y`
/// that Gribb & Hartmann ("Fast Extraction of Viewing Frustum Planes from the
/// World-View-Projection Matrix", 2001) extract from an off-axis projection,
/// written from the tangents without building or inverting a matrix.
/// Normalising divides by `hypot(1, t)`, finite for every angle below 90°.
pub fn side_normals_view(t: [f64; 4]) -> [DVec3; 4] {
    let [tl, tr, tu, td] = t;
    [
        DVec3::new(1.0, 0.0, tl) / 1.0f64.hypot(tl),
        DVec3::new(-1.0, 0.0, -tr) / 1.0f64.hypot(tr),
        DVec3::new(0.0, -1.0, -tu) / 1.0f64.hypot(tu),
        DVec3::new(0.0, 1.0, td) / 1.0f64.hypot(td),
    ]
}

/// One eye's frustum: apex at the eye, four side planes from the FOV
/// tangents, a near plane and an optional far plane (the draw distance,
/// measured along the eye's view axis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    /// The culling planes (near, left, right, top, bottom, optional far),
    /// relative to the eye position.
    pub planes: PlaneSet,
    /// World-to-view rotation columns: the eye's +X, +Y, +Z in world space.
    pub basis: DMat3,
    /// Signed FOV tangents `[left, right, up, down]`.
    pub tangents: [f64; 4],
    /// Near plane distance (metres along -Z).
    pub near: f64,
    /// Far plane distance, if distance culling is on.
    pub far: Option<f64>,
}

impl Frustum {
    /// Builds the frustum of `view`; rejects NaN or non-unit poses, bad FOVs
    /// and bad clip distances.
    pub fn from_view(view: &View, near: f64, far: Option<f64>) -> Result<Frustum, VolumeError> {
        view.fov.validate().map_err(VolumeError::InvalidFov)?;
        Frustum::from_tangents(&view.pose, view.fov.tangents(), near, far)
    }

    /// Builds the frustum from a pose and the signed tangents
    /// `[left, right, up, down]` directly (as runtimes that report tangents
    /// deliver them); rejects NaN or non-unit poses, non-finite or empty
    /// tangent ranges and bad clip distances.
    pub fn from_tangents(
        pose: &Pose,
        t: [f64; 4],
        near: f64,
        far: Option<f64>,
    ) -> Result<Frustum, VolumeError> {
        pose.validate().map_err(VolumeError::InvalidPose)?;
        let [tl, tr, tu, td] = t;
        if !t.iter().all(|x| x.is_finite()) || tr <= tl || tu <= td {
            return Err(VolumeError::InvalidFov(format!(
                "tangents {t:?} do not span a finite, non-empty range"
            )));
        }
        validate_clip(near, far)?;
        let q = pose.orientation.normalize();
        let basis = DMat3::from_quat(q);
        let mut planes = [Plane {
            normal: DVec3::ZERO,
            d: 0.0,
        }; 6];
        let fwd = -basis.z_axis;
        // Near plane: points with depth along -Z of at least `near`.
        planes[0] = Plane {
            normal: fwd,
            d: -near,
        };
        for (i, n) in side_normals_view(t).into_iter().enumerate() {
            // Side planes pass through the apex (the origin), so d = 0.
            planes[i + 1] = Plane {
                normal: basis * n,
                d: 0.0,
            };
        }
        let mut len = 5;
        if let Some(f) = far {
            planes[5] = Plane { normal: -fwd, d: f };
            len = 6;
        }
        Ok(Frustum {
            planes: PlaneSet {
                origin: pose.position,
                planes,
                len,
            },
            basis,
            tangents: t,
            near,
            far,
        })
    }

    /// The four side planes (left, right, top, bottom; through the apex,
    /// relative to it): without the near and far planes.
    pub fn side_planes(&self) -> &[Plane] {
        &self.planes.planes[1..5]
    }

    /// Eye position in world space (the apex).
    pub fn apex(&self) -> DVec3 {
        self.planes.origin
    }

    /// World-space direction of the four corner rays (not normalised; unit
    /// depth along the view axis), in the order
    /// (left-bottom, right-bottom, right-top, left-top).
    pub fn corner_rays(&self) -> [DVec3; 4] {
        let [tl, tr, tu, td] = self.tangents;
        [(tl, td), (tr, td), (tr, tu), (tl, tu)].map(|(x, y)| self.basis * DVec3::new(x, y, -1.0))
    }

    /// The eight corners relative to the apex, at depth `near` and `far_at`.
    fn corners_rel(&self, far_at: f64) -> [DVec3; 8] {
        let r = self.corner_rays();
        let mut out = [DVec3::ZERO; 8];
        for i in 0..4 {
            out[i] = r[i] * self.near;
            out[i + 4] = r[i] * far_at;
        }
        out
    }

    /// Exact intersection test of a world box with this frustum, by the
    /// separating axis theorem for two convex polytopes (Gottschalk, Lin &
    /// Manocha, "OBBTree", 1996; Eberly, "Intersection of Convex Objects: The
    /// Method of Separating Axes"): candidate axes are the 3 box face normals,
    /// the frustum's face normals, and the cross products of the 3 box edge
    /// directions with the frustum's 6 edge directions (4 corner rays, view
    /// X and Y). Boxes that only touch count as intersecting.
    ///
    /// Without a far plane the frustum is unbounded; it is truncated at
    /// `unbounded_far`, which the caller picks beyond every point of the box
    /// (the result is then exact for the infinite frustum).
    pub fn intersects_box_exact(&self, min: DVec3, max: DVec3, unbounded_far: f64) -> bool {
        let (bmin, bmax) = (min - self.apex(), max - self.apex());
        // Quick conservative rejection and full acceptance.
        let mut inside_all = true;
        for p in self.planes.planes() {
            if p.max_over_box(bmin, bmax) < 0.0 {
                return false;
            }
            if p.min_over_box(bmin, bmax) < 0.0 {
                inside_all = false;
            }
        }
        if inside_all {
            return true;
        }
        let far_at = self.far.unwrap_or(unbounded_far.max(self.near * 2.0));
        let corners = self.corners_rel(far_at);
        let rays = self.corner_rays();
        let edges = [
            rays[0],
            rays[1],
            rays[2],
            rays[3],
            self.basis.x_axis,
            self.basis.y_axis,
        ];
        let box_axes = [DVec3::X, DVec3::Y, DVec3::Z];
        let c = (bmin + bmax) * 0.5;
        let e = (bmax - bmin) * 0.5;
        let separated = |axis: DVec3| -> bool {
            let len2 = axis.length_squared();
            if len2 < 1e-24 || !len2.is_finite() {
                return false;
            }
            let a = axis / len2.sqrt();
            let bc = a.dot(c);
            let br = a.abs().dot(e);
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for v in &corners {
                let s = a.dot(*v);
                lo = lo.min(s);
                hi = hi.max(s);
            }
            bc + br < lo || bc - br > hi
        };
        for p in self.planes.planes() {
            if separated(p.normal) {
                return false;
            }
        }
        for a in box_axes {
            if separated(a) {
                return false;
            }
            for ed in edges {
                if separated(a.cross(ed)) {
                    return false;
                }
            }
        }
        true
    }
}

/// The FOV of a view, checked, as tangents; a helper for the other volumes.
pub fn checked_tangents(fov: &Fov) -> Result<[f64; 4], VolumeError> {
    fov.validate().map_err(VolumeError::InvalidFov)?;
    Ok(fov.tangents())
}
