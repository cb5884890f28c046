//! One frustum enclosing the frusta of two (or N) eyes, so a stereo frame is
//! culled once instead of once per eye.
//!
//! Derivation: Cass Everitt, "Combined Culling Frustum for VR" (Oculus
//! developer note): keep the outer side planes of the outermost eyes and the
//! widest top and bottom, and recede the apex behind the eyes to where the
//! outer planes meet. Taking the per-plane "largest extent" of the eyes'
//! planes is wrong for asymmetric or canted eyes (the widest plane of one eye
//! can cut through the other eye's frustum), so this module builds the
//! volume from corners instead, which holds for any rig:
//!
//! 1. Pick a combined frame: forward = normalised sum of the eyes' forward
//!    vectors, up = sum of their up vectors made orthogonal to it.
//! 2. Project every eye's four corner rays into that frame as tangents
//!    `x/depth`, `y/depth`. A central (gnomonic) projection maps each eye's
//!    cone of rays to the convex quadrilateral of its projected corners, so
//!    the bounding rectangle `[min x, max x] × [min y, max y]` of all corners
//!    contains every ray of every eye. The four side planes come from that
//!    rectangle with [`super::frustum::side_normals_view`].
//! 3. Push each plane outwards (decrease nothing, only increase `d`) until
//!    every eye apex is inside: a plane that contains the apex and all ray
//!    directions of an eye contains that eye's whole (truncated) pyramid.
//!    For a symmetric rig the left plane then passes through the left eye and
//!    the right plane through the right eye, and they meet behind the head:
//!    Everitt's receded apex.
//! 4. Near plane along the combined forward through the nearest near-plane
//!    corner; far plane (when a draw distance is set) through the farthest
//!    far-plane corner.
//!
//! If some corner ray is at or beyond 90° from the combined forward (total
//! FOV ≥ 180°, or strong outward cant), the side planes cannot meet at a
//! finite apex and construction fails; callers fall back to per-eye culling.

use glam::{DMat3, DVec3};

use super::frustum::{side_normals_view, Frustum, Plane, PlaneSet, VolumeError};

/// Rays closer than this cosine to perpendicular to the combined forward
/// make the combined volume impossible (tangent above 1e7).
const MIN_FORWARD_COS: f64 = 1e-7;

/// The combined culling volume of several eyes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Superfrustum {
    /// Culling planes (near, left, right, top, bottom, optional far),
    /// relative to the mean eye position.
    pub planes: PlaneSet,
    /// Combined frame: columns are +X, +Y, +Z (view looks down -Z).
    pub basis: DMat3,
    /// Signed tangents `[left, right, up, down]` of the combined volume.
    pub tangents: [f64; 4],
}

impl Superfrustum {
    /// Builds the volume enclosing every frustum in `eyes`. All eyes are
    /// expected to share near and far distances (the culler builds them so).
    pub fn enclosing(eyes: &[Frustum]) -> Result<Superfrustum, VolumeError> {
        if eyes.is_empty() {
            return Err(VolumeError::NoCombinedVolume("no views".into()));
        }
        let origin = eyes.iter().map(|e| e.apex()).sum::<DVec3>() / eyes.len() as f64;
        let fwd_sum: DVec3 = eyes.iter().map(|e| -e.basis.z_axis).sum();
        let up_sum: DVec3 = eyes.iter().map(|e| e.basis.y_axis).sum();
        if fwd_sum.length() < 1e-9 {
            return Err(VolumeError::NoCombinedVolume(
                "eyes look in opposite directions".into(),
            ));
        }
        let fwd = fwd_sum.normalize();
        let up = up_sum - fwd * up_sum.dot(fwd);
        if up.length() < 1e-9 {
            return Err(VolumeError::NoCombinedVolume(
                "no common up direction".into(),
            ));
        }
        let y = up.normalize();
        let z = -fwd;
        let x = y.cross(z);
        let basis = DMat3::from_cols(x, y, z);

        // Step 2: tangent rectangle over every eye's corner rays.
        let (mut tl, mut tr, mut tu, mut td) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
        );
        for e in eyes {
            for r in e.corner_rays() {
                let depth = r.dot(fwd);
                if depth.is_nan() || depth <= MIN_FORWARD_COS * r.length() {
                    return Err(VolumeError::NoCombinedVolume(format!(
                        "a corner ray is {:.3}° from the combined forward (≥ 90°)",
                        (depth / r.length()).clamp(-1.0, 1.0).acos().to_degrees()
                    )));
                }
                let (tx, ty) = (r.dot(x) / depth, r.dot(y) / depth);
                tl = tl.min(tx);
                tr = tr.max(tx);
                tu = tu.max(ty);
                td = td.min(ty);
            }
        }
        let tangents = [tl, tr, tu, td];

        // Rounding slack so touching boxes stay inside: 1 nm plus 1e-12 of
        // the rig's extent.
        let extent = eyes
            .iter()
            .map(|e| (e.apex() - origin).length())
            .fold(0.0, f64::max);
        let far_extent = eyes.iter().filter_map(|e| e.far).fold(0.0, f64::max)
            * (1.0 + tl.abs().max(tr.abs()).max(tu.abs()).max(td.abs()));
        let pad = 1e-9 + 1e-12 * (extent + far_extent);

        let mut planes = [Plane {
            normal: DVec3::ZERO,
            d: 0.0,
        }; 6];
        // Step 3: side planes pushed out over all apexes.
        for (i, n_view) in side_normals_view(tangents).into_iter().enumerate() {
            let n = basis * n_view;
            let d = eyes
                .iter()
                .map(|e| -n.dot(e.apex() - origin))
                .fold(f64::NEG_INFINITY, f64::max);
            planes[i + 1] = Plane {
                normal: n,
                d: d + pad,
            };
        }
        // Step 4: near plane through the nearest near corner.
        let near_depth = eyes
            .iter()
            .flat_map(|e| {
                e.corner_rays()
                    .map(|r| fwd.dot(e.apex() - origin + r * e.near))
            })
            .fold(f64::INFINITY, f64::min);
        planes[0] = Plane {
            normal: fwd,
            d: -near_depth + pad,
        };
        let mut len = 5;
        if eyes.iter().all(|e| e.far.is_some()) {
            let far_depth = eyes
                .iter()
                .flat_map(|e| {
                    let f = e.far.unwrap_or(0.0);
                    e.corner_rays()
                        .map(move |r| fwd.dot(e.apex() - origin + r * f))
                })
                .fold(f64::NEG_INFINITY, f64::max);
            planes[5] = Plane {
                normal: -fwd,
                d: far_depth + pad,
            };
            len = 6;
        }
        if planes[..len]
            .iter()
            .any(|p| !p.normal.is_finite() || !p.d.is_finite())
        {
            return Err(VolumeError::NoCombinedVolume("non-finite plane".into()));
        }
        Ok(Superfrustum {
            planes: PlaneSet {
                origin,
                planes,
                len,
            },
            basis,
            tangents,
        })
    }

    /// Distance behind the mean eye position, along the combined forward,
    /// where the left and right planes cross the combined axis (Everitt's
    /// receded apex); `None` when a plane is parallel to the axis.
    pub fn apex_recession(&self) -> Option<f64> {
        let fwd = -self.basis.z_axis;
        let p = self.planes.planes();
        let s = |pl: &Plane| {
            let k = pl.normal.dot(fwd);
            (k.abs() > 1e-12).then(|| pl.d / k)
        };
        Some(s(&p[1])?.max(s(&p[2])?))
    }
}
