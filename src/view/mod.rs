//! Pure view math: poses, FOV tangents, projections, frusta, superfrusta,
//! cones and foveation rate images. Nothing here knows about Vulkan or
//! OpenXR: every rig (a runtime, an HMD profile, a test) is expressed as
//! poses plus four FOV angles per view.

pub mod cone;
pub mod distortion;
pub mod foveation;
pub mod frustum;
pub mod gaze_path;
pub mod inset;
pub mod inset_hole;
pub mod lanczos;
pub mod lens;
pub mod lms;
pub mod lod;
pub mod mffr;
pub mod profile;
pub mod projection;
pub mod reproject;
pub mod sharpen;
pub(crate) mod strict;
pub mod superfrustum;
pub mod taa;
pub mod taau;

use glam::{DQuat, DVec3};

/// Field of view of one view as four signed angles in radians, in OpenXR's
/// `XrFovf` convention: `left` and `down` are usually negative, `right` and
/// `up` positive; the view looks down -Z with +X right and +Y up.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fov {
    /// Angle of the left edge (radians, negative to the left of the axis).
    pub left: f64,
    /// Angle of the right edge (radians, positive to the right).
    pub right: f64,
    /// Angle of the top edge (radians, positive up).
    pub up: f64,
    /// Angle of the bottom edge (radians, negative down).
    pub down: f64,
}

impl Fov {
    /// A symmetric FOV with the given horizontal and vertical half-angles.
    pub fn symmetric(half_h: f64, half_v: f64) -> Self {
        Fov {
            left: -half_h,
            right: half_h,
            up: half_v,
            down: -half_v,
        }
    }

    /// Tangents of the four angles: (left, right, up, down), signed.
    pub fn tangents(&self) -> [f64; 4] {
        [
            self.left.tan(),
            self.right.tan(),
            self.up.tan(),
            self.down.tan(),
        ]
    }

    /// Checks that the angles are finite, inside (-90°, 90°) and that each
    /// pair spans a non-empty range.
    pub fn validate(&self) -> Result<(), String> {
        let lim = std::f64::consts::FRAC_PI_2;
        for (name, a) in [
            ("left", self.left),
            ("right", self.right),
            ("up", self.up),
            ("down", self.down),
        ] {
            if !a.is_finite() || a.abs() >= lim {
                return Err(format!(
                    "fov.{name} = {a} is not an angle inside (-90°, 90°)"
                ));
            }
        }
        if self.right <= self.left {
            return Err(format!(
                "fov.right ({}) must be greater than fov.left ({})",
                self.right, self.left
            ));
        }
        if self.up <= self.down {
            return Err(format!(
                "fov.up ({}) must be greater than fov.down ({})",
                self.up, self.down
            ));
        }
        Ok(())
    }
}

/// A rigid transform in double precision: where a head or eye is and where it
/// looks. Orientation is a unit quaternion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Position in metres.
    pub position: DVec3,
    /// Orientation as a unit quaternion.
    pub orientation: DQuat,
}

impl Default for Pose {
    fn default() -> Self {
        Pose {
            position: DVec3::ZERO,
            orientation: DQuat::IDENTITY,
        }
    }
}

impl Pose {
    /// Composes `self` (parent) with `child` expressed in the parent's space.
    pub fn compose(&self, child: &Pose) -> Pose {
        Pose {
            position: self.position + self.orientation * child.position,
            orientation: (self.orientation * child.orientation).normalize(),
        }
    }

    /// A head pose from a position and yaw/pitch/roll in degrees (yaw about
    /// +Y, then pitch about +X, then roll about -Z), the CLI's `--pose`.
    pub fn from_euler_deg(position: DVec3, yaw: f64, pitch: f64, roll: f64) -> Pose {
        let q = DQuat::from_rotation_y(yaw.to_radians())
            * DQuat::from_rotation_x(pitch.to_radians())
            * DQuat::from_rotation_z(roll.to_radians());
        Pose {
            position,
            orientation: q,
        }
    }

    /// Yaw, pitch and roll in degrees such that
    /// [`Pose::from_euler_deg`] gives this orientation back (intrinsic
    /// Y, then X, then Z; pitch within ±90°).
    pub fn to_euler_deg(&self) -> (f64, f64, f64) {
        let (y, x, z) = self.orientation.normalize().to_euler(glam::EulerRot::YXZ);
        (y.to_degrees(), x.to_degrees(), z.to_degrees())
    }

    /// This pose as a `--pose` value: `x,y,z,yaw,pitch,roll` (metres to
    /// the micrometre, degrees to a millionth).
    pub fn pose_arg(&self) -> String {
        let (yaw, pitch, roll) = self.to_euler_deg();
        let p = self.position;
        format!(
            "{:.6},{:.6},{:.6},{yaw:.6},{pitch:.6},{roll:.6}",
            p.x, p.y, p.z
        )
    }

    /// Rejects poses the math cannot use: non-finite components or an
    /// orientation whose norm is not within 1e-3 of one.
    pub fn validate(&self) -> Result<(), String> {
        if !self.position.is_finite() {
            return Err(format!("pose position {:?} is not finite", self.position));
        }
        let q = self.orientation;
        if !q.is_finite() {
            return Err(format!("pose orientation {q:?} is not finite"));
        }
        if (q.length() - 1.0).abs() > 1e-3 {
            return Err(format!(
                "pose orientation {q:?} is not a unit quaternion (norm {})",
                q.length()
            ));
        }
        Ok(())
    }

    /// The view direction (-Z of the pose) in world space.
    pub fn forward(&self) -> DVec3 {
        self.orientation * DVec3::NEG_Z
    }
}

/// One rendered view: a world-space eye pose and its FOV.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Eye pose in world space.
    pub pose: Pose,
    /// The eye's four FOV angles.
    pub fov: Fov,
}

/// The part of one view the lens hides (XR_KHR_visibility_mask's
/// `XR_VISIBILITY_MASK_TYPE_HIDDEN_TRIANGLE_MESH_KHR`): triangles whose
/// vertices lie on the view's z = -1 plane, i.e. in tangent space, the same
/// space as [`Fov::tangents`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HiddenArea {
    /// Vertices (x, y) on the z = -1 plane.
    pub vertices: Vec<[f32; 2]>,
    /// Triangle list indices into `vertices`.
    pub indices: Vec<u32>,
}

/// A head and its views (left first), as delivered by a runtime or built
/// from an HMD profile.
#[derive(Clone, Debug, PartialEq)]
pub struct StereoRig {
    /// Head pose in world space.
    pub head: Pose,
    /// Per-view world poses and FOVs, left eye first.
    pub views: Vec<View>,
    /// Per-view hidden-area meshes from the runtime (None: not offered).
    pub hidden_area: Option<std::sync::Arc<Vec<HiddenArea>>>,
}

/// A rig as stored in `rig.json` (`vergence run --capture`), readable by
/// `vergence render --rig`: world poses as position and (x, y, z, w)
/// quaternion, FOV angles in radians.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigFile {
    /// Head pose.
    pub head: PoseFile,
    /// Views, left first.
    pub views: Vec<ViewFile>,
}

/// A pose in a [`RigFile`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseFile {
    /// Position in metres.
    #[serde(deserialize_with = "strict::exact")]
    pub position: [f64; 3],
    /// Orientation quaternion (x, y, z, w).
    #[serde(deserialize_with = "strict::exact")]
    pub orientation: [f64; 4],
}

/// A view in a [`RigFile`].
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewFile {
    /// Eye pose in world space.
    pub pose: PoseFile,
    /// FOV angles.
    pub fov: Fov,
    /// The view's hidden-area triangle list in tangent space, when the
    /// rig had one (so `render --rig ... --opt stencil-mask` masks what
    /// the captured frame masked).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "strict::points"
    )]
    pub hidden_area: Option<Vec<[f64; 2]>>,
}

/// Most points a hidden-area triangle list may have (4096 triangles).
pub const MAX_HIDDEN_AREA_POINTS: usize = 3 * 4096;

/// Checks a hidden-area triangle list (a multiple of 3 finite points, at
/// most [`MAX_HIDDEN_AREA_POINTS`]) and builds its mesh.
pub fn hidden_area_from_points(list: &[[f64; 2]]) -> Result<HiddenArea, String> {
    if !list.len().is_multiple_of(3) || list.len() > MAX_HIDDEN_AREA_POINTS {
        return Err(format!(
            "hidden_area has {} points; it is a triangle list (a multiple of 3, at most {MAX_HIDDEN_AREA_POINTS})",
            list.len()
        ));
    }
    if let Some(p) = list
        .iter()
        .find(|p| !(p[0].is_finite() && p[1].is_finite() && p[0].abs() <= 1e3 && p[1].abs() <= 1e3))
    {
        return Err(format!(
            "hidden_area point {p:?} is not finite or beyond ±1000 (tangent space)"
        ));
    }
    Ok(HiddenArea {
        vertices: list.iter().map(|p| [p[0] as f32, p[1] as f32]).collect(),
        indices: (0..list.len() as u32).collect(),
    })
}

impl From<&Pose> for PoseFile {
    fn from(p: &Pose) -> PoseFile {
        PoseFile {
            position: p.position.to_array(),
            orientation: p.orientation.to_array(),
        }
    }
}

impl PoseFile {
    /// The pose, validated.
    pub fn pose(&self) -> Result<Pose, String> {
        let p = Pose {
            position: DVec3::from_array(self.position),
            orientation: DQuat::from_array(self.orientation),
        };
        p.validate()?;
        Ok(p)
    }
}

impl RigFile {
    /// Of a rig.
    pub fn of(rig: &StereoRig) -> RigFile {
        RigFile {
            head: PoseFile::from(&rig.head),
            views: rig
                .views
                .iter()
                .enumerate()
                .map(|(i, v)| ViewFile {
                    pose: PoseFile::from(&v.pose),
                    fov: v.fov,
                    hidden_area: rig.hidden_area.as_deref().and_then(|h| h.get(i)).map(|h| {
                        h.indices
                            .iter()
                            .filter_map(|&k| h.vertices.get(k as usize))
                            .map(|p| [p[0] as f64, p[1] as f64])
                            .collect()
                    }),
                })
                .collect(),
        }
    }

    /// Parses and validates rig JSON text; `origin` names it in errors.
    pub fn parse(origin: &str, text: &str) -> crate::Result<StereoRig> {
        let err = |m: String| crate::Error::config("--rig", format!("{origin}: {m}"));
        let file: RigFile =
            serde_json::from_str(text).map_err(|e| err(format!("not a rig file: {e}")))?;
        file.rig().map_err(err)
    }

    /// Reads (bounded, [`crate::fsio`]) and validates a rig file.
    pub fn load(path: &std::path::Path) -> crate::Result<StereoRig> {
        let text =
            crate::fsio::read_text(path, crate::fsio::MAX_TEXT_FILE_BYTES).map_err(|source| {
                crate::Error::Io {
                    path: path.to_path_buf(),
                    source,
                }
            })?;
        RigFile::parse(&path.display().to_string(), &text)
    }

    /// The rig it describes, validated (finite unit poses, valid FOVs).
    pub fn rig(&self) -> Result<StereoRig, String> {
        if self.views.is_empty() || self.views.len() > 4 {
            return Err(format!("needs 1 to 4 views, found {}", self.views.len()));
        }
        let with_area = self
            .views
            .iter()
            .filter(|v| v.hidden_area.is_some())
            .count();
        if with_area != 0 && with_area != self.views.len() {
            return Err("either every view has a hidden_area or none has".into());
        }
        let hidden_area = if with_area == 0 {
            None
        } else {
            Some(std::sync::Arc::new(
                self.views
                    .iter()
                    .enumerate()
                    .map(|(i, v)| {
                        hidden_area_from_points(v.hidden_area.as_deref().unwrap_or_default())
                            .map_err(|m| format!("view {i}: {m}"))
                    })
                    .collect::<Result<Vec<_>, String>>()?,
            ))
        };
        let views = self
            .views
            .iter()
            .enumerate()
            .map(|(i, v)| {
                v.fov.validate().map_err(|m| format!("view {i}: {m}"))?;
                Ok(View {
                    pose: v.pose.pose().map_err(|m| format!("view {i}: {m}"))?,
                    fov: v.fov,
                })
            })
            .collect::<Result<Vec<View>, String>>()?;
        Ok(StereoRig {
            head: self.head.pose().map_err(|m| format!("head: {m}"))?,
            views,
            hidden_area,
        })
    }
}

impl StereoRig {
    /// Builds world-space views from a head pose and per-eye poses given in
    /// head space.
    pub fn from_head(head: Pose, eyes: &[(Pose, Fov)]) -> StereoRig {
        let views = eyes
            .iter()
            .map(|(p, fov)| View {
                pose: head.compose(p),
                fov: *fov,
            })
            .collect();
        StereoRig {
            head,
            views,
            hidden_area: None,
        }
    }
}

/// The least gap [`frame_bounds`] leaves between the eye and the framed
/// sphere, metres: five times the default near plane (0.05 m), so a small
/// scene is drawn whole rather than clipped away.
pub const MIN_FRAMING_CLEARANCE_M: f64 = 0.25;

/// A head pose that frames an axis-aligned box: looking down -Z (pitched
/// down by `pitch_deg`) from far enough that a sphere around the box fits in
/// the narrower half-angle of `fov`.
pub fn frame_bounds(lo: DVec3, hi: DVec3, fov: &Fov, pitch_deg: f64) -> Pose {
    let center = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let half = [-fov.left, fov.right, fov.up, -fov.down]
        .into_iter()
        .fold(f64::INFINITY, f64::min)
        .max(0.05);
    // The sphere fits the narrower half-angle at r / sin(half) (5 %
    // margin); a small scene (a scan a few centimetres across) would sit
    // that close, inside the near plane: it stays at least
    // MIN_FRAMING_CLEARANCE_M beyond its own radius.
    let distance = (radius / half.sin() * 1.05).max(radius + MIN_FRAMING_CLEARANCE_M);
    let orientation = DQuat::from_rotation_x(pitch_deg.to_radians());
    let position = center - orientation * DVec3::NEG_Z * distance;
    Pose {
        position,
        orientation,
    }
}

/// A head pose looking down -Z, pitched by `pitch_deg` (negative: down),
/// from where every corner of the box `lo`..`hi` lies inside `fov` with a
/// 5 % margin, as close as that allows ([`frame_points`] of the corners).
pub fn frame_box(lo: DVec3, hi: DVec3, fov: &Fov, pitch_deg: f64) -> Pose {
    let corners = (0..8).map(|k| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    });
    frame_points(corners, (lo + hi) * 0.5, fov, pitch_deg)
}

/// A head pose looking down -Z, pitched by `pitch_deg` (negative: down),
/// aimed at `center`, from where every one of `points` lies inside `fov`
/// with a 5 % margin, as close as that allows (the points themselves, not
/// a sphere or box around them, are fitted: a flat site seen from above
/// fills the view) and at least [`MIN_FRAMING_CLEARANCE_M`] in front of
/// the nearest point.
///
/// With the orientation R and a point x, the point lies at w = Rᵀ(x − c)
/// in the view's axes once the eye sits at distance D behind c, at depth
/// D − w_z; it is inside the right edge when w_x ≤ tan(right)·(D − w_z),
/// i.e. D ≥ w_z + w_x / tan(right), and likewise for the other three
/// edges: D is the largest of these bounds over the points.
pub fn frame_points(
    points: impl IntoIterator<Item = DVec3>,
    center: DVec3,
    fov: &Fov,
    pitch_deg: f64,
) -> Pose {
    let orientation = DQuat::from_rotation_x(pitch_deg.to_radians());
    let inverse = orientation.inverse();
    // The tangents shrunk by the margin, each at least a little open.
    let t = |a: f64| (a.tan() / 1.05).abs().max(0.05);
    let (tl, tr, tu, td) = (t(fov.left), t(fov.right), t(fov.up), t(fov.down));
    let mut distance: f64 = 0.0;
    let mut nearest: f64 = 0.0;
    for x in points {
        // View axes: x right, y up, z toward the viewer.
        let w = inverse * (x - center);
        nearest = nearest.max(w.z);
        distance = distance
            .max(w.z + w.x / tr)
            .max(w.z - w.x / tl)
            .max(w.z + w.y / tu)
            .max(w.z - w.y / td);
    }
    let distance = distance.max(nearest + MIN_FRAMING_CLEARANCE_M);
    Pose {
        position: center - orientation * DVec3::NEG_Z * distance,
        orientation,
    }
}

#[cfg(test)]
mod framing_tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Every corner of the fitted box is in front of the eye and inside
        /// the field of view, and the fit is tight (some corner within the
        /// margin of an edge, or the box at the clearance).
        #[test]
        fn the_fitted_box_is_in_view_and_tight(
            size in prop::array::uniform3(1e-2f64..1e4),
            offset in prop::array::uniform3(-1e6f64..1e6),
            pitch in -80.0f64..0.0,
            half in 0.3f64..1.2,
        ) {
            let lo = DVec3::from(offset);
            let hi = lo + DVec3::from(size);
            let fov = Fov { left: -half, right: half * 0.9, up: half * 0.8, down: -half };
            let pose = frame_box(lo, hi, &fov, pitch);
            let inverse = pose.orientation.inverse();
            let mut tight = false;
            for k in 0..8 {
                let x = DVec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                );
                let v = inverse * (x - pose.position);
                let depth = -v.z;
                prop_assert!(depth >= MIN_FRAMING_CLEARANCE_M - 1e-6 * (1.0 + depth));
                let (h, u) = (v.x / depth, v.y / depth);
                let eps = 1e-9 * (1.0 + pose.position.length());
                prop_assert!(h <= fov.right.tan() + eps && h >= fov.left.tan() - eps);
                prop_assert!(u <= fov.up.tan() + eps && u >= fov.down.tan() - eps);
                let edge = |a: f64, t: f64| (a - t / 1.05).abs() < 1e-6 * (1.0 + t.abs());
                tight |= edge(h, fov.right.tan()) || edge(h, fov.left.tan())
                    || edge(u, fov.up.tan()) || edge(u, fov.down.tan())
                    || (depth - MIN_FRAMING_CLEARANCE_M).abs() < 1e-6 * (1.0 + depth);
            }
            prop_assert!(tight);
        }
    }

    proptest! {
        /// Yaw, pitch and roll give the orientation back (the `--pose`
        /// value's round trip is tested in `cli`).
        #[test]
        fn euler_angles_and_the_pose_argument_round_trip(
            yaw in -180.0f64..180.0,
            pitch in -89.0f64..89.0,
            roll in -179.0f64..179.0,
            x in -1e5f64..1e5,
        ) {
            let p = Pose::from_euler_deg(DVec3::new(x, 1.6, -x), yaw, pitch, roll);
            let (a, b, c) = p.to_euler_deg();
            let q = Pose::from_euler_deg(p.position, a, b, c);
            prop_assert!(p.orientation.dot(q.orientation).abs() > 1.0 - 1e-12);
        }
    }

    proptest! {
        /// The framed sphere lies beyond the clearance and inside the
        /// narrower half-angle, from a millimetre to a kilometre.
        #[test]
        fn the_framed_sphere_is_clear_of_the_eye_and_in_view(
            size in 1e-3f64..1e3,
            half_deg in 10.0f64..60.0,
        ) {
            let a = half_deg.to_radians();
            let fov = Fov { left: -a, right: a, up: a, down: -a };
            let lo = DVec3::new(4.0, -2.0, 7.0);
            let hi = lo + DVec3::new(size, size * 0.5, size * 0.25);
            let pose = frame_bounds(lo, hi, &fov, 0.0);
            let centre = (lo + hi) * 0.5;
            let radius = (hi - lo).length() * 0.5;
            let distance = (centre - pose.position).length();
            prop_assert!(distance - radius >= MIN_FRAMING_CLEARANCE_M - 1e-9);
            prop_assert!((radius / distance).asin() <= half_deg.to_radians() + 1e-9);
        }
    }
}
