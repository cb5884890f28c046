//! HMD profiles: TOML files describing a headset's views (eye poses in head
//! space, FOV angles, recommended resolution) and refresh rate. A profile is
//! named by a path or by the stem of a file in `manifests/hmd/`; the shipped
//! profiles are also embedded in the binary so it runs without the source tree.

use super::{Fov, HiddenArea, Pose, StereoRig};
use crate::error::{Error, Result};
use glam::{DQuat, DVec3};
use serde::Deserialize;
use std::path::Path;
use std::sync::Arc;

/// Profiles shipped in `manifests/hmd/`, embedded at build time.
pub const BUILTIN: &[(&str, &str)] = &[
    (
        "monado-sim",
        include_str!("../../manifests/hmd/monado-sim.toml"),
    ),
    (
        "valve-index",
        include_str!("../../manifests/hmd/valve-index.toml"),
    ),
    ("quest-3", include_str!("../../manifests/hmd/quest-3.toml")),
    ("vive", include_str!("../../manifests/hmd/vive.toml")),
    (
        "rift-dk1",
        include_str!("../../manifests/hmd/rift-dk1.toml"),
    ),
    (
        "pimax-wide",
        include_str!("../../manifests/hmd/pimax-wide.toml"),
    ),
];

/// Lowest refresh rate a profile may give (Hz).
pub const MIN_REFRESH_HZ: f64 = 1.0;
/// Highest refresh rate a profile may give (Hz).
pub const MAX_REFRESH_HZ: f64 = 1000.0;

/// The profile used when none is given.
pub const DEFAULT_PROFILE: &str = "valve-index";

/// FOV angles as written in a profile (radians, like `XrFovf`).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FovToml {
    left: f64,
    right: f64,
    up: f64,
    down: f64,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ViewToml {
    #[serde(deserialize_with = "super::strict::exact")]
    position: [f64; 3],
    #[serde(deserialize_with = "super::strict::exact")]
    orientation: [f64; 4],
    fov: FovToml,
    #[serde(deserialize_with = "super::strict::exact")]
    resolution: [u32; 2],
    /// Hidden-area triangle list in tangent space (optional).
    #[serde(default, deserialize_with = "super::strict::points")]
    hidden_area: Option<Vec<[f64; 2]>>,
    /// The lens ([`super::distortion`]), optional.
    lens: Option<super::distortion::LensToml>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ProfileToml {
    name: String,
    refresh_hz: f64,
    views: Vec<ViewToml>,
}

/// One view of a profile, in head space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProfileView {
    /// Eye pose relative to the head.
    pub pose: Pose,
    /// The view's FOV.
    pub fov: Fov,
    /// Recommended per-eye image size in pixels (width, height).
    pub resolution: [u32; 2],
    /// The lens, when the profile has a `[views.lens]` table.
    pub lens: Option<super::distortion::Lens>,
}

/// A parsed and validated HMD profile.
#[derive(Clone, Debug, PartialEq)]
pub struct HmdProfile {
    /// Profile name (from the file).
    pub name: String,
    /// Display refresh rate in Hz.
    pub refresh_hz: f64,
    /// Views, left eye first.
    pub views: Vec<ProfileView>,
    /// Per view, the hidden-area mesh in tangent space: the profile's
    /// `hidden_area` triangle list, else the lens-ellipse default of
    /// [`super::lens`].
    pub hidden_areas: Arc<Vec<HiddenArea>>,
}

impl HmdProfile {
    /// Loads a profile by built-in name, by name of a file in
    /// `manifests/hmd/`, or by path.
    pub fn load(name_or_path: &str) -> Result<HmdProfile> {
        let path = Path::new(name_or_path);
        let looks_like_path = name_or_path.ends_with(".toml") || name_or_path.contains('/');
        if looks_like_path || path.exists() {
            let text =
                crate::fsio::read_text(path, crate::fsio::MAX_TEXT_FILE_BYTES).map_err(|e| {
                    Error::Profile {
                        name: name_or_path.into(),
                        message: format!("cannot read file: {e}"),
                    }
                })?;
            return Self::parse(name_or_path, &text);
        }
        let local = Path::new("manifests/hmd").join(format!("{name_or_path}.toml"));
        if local.exists() {
            let origin = local.display().to_string();
            let text =
                crate::fsio::read_text(&local, crate::fsio::MAX_TEXT_FILE_BYTES).map_err(|e| {
                    Error::Profile {
                        name: origin.clone(),
                        message: format!("cannot read file: {e}"),
                    }
                })?;
            return Self::parse(&origin, &text);
        }
        match BUILTIN.iter().find(|(n, _)| *n == name_or_path) {
            Some((n, text)) => Self::parse(n, text),
            None => Err(Error::Profile {
                name: name_or_path.into(),
                message: format!(
                    "unknown profile (not a file, not in manifests/hmd/); known: {}",
                    BUILTIN
                        .iter()
                        .map(|(n, _)| *n)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            }),
        }
    }

    /// Parses and validates a profile's TOML text; `origin` names it in errors.
    pub fn parse(origin: &str, text: &str) -> Result<HmdProfile> {
        let err = |message: String| Error::Profile {
            name: origin.into(),
            message,
        };
        let raw: ProfileToml =
            toml::from_str(text).map_err(|e| err(format!("malformed profile: {}", e.message())))?;
        if !(raw.refresh_hz.is_finite()
            && (MIN_REFRESH_HZ..=MAX_REFRESH_HZ).contains(&raw.refresh_hz))
        {
            let hz = raw.refresh_hz;
            let shown = if hz == 0.0 || (1e-3..1e6).contains(&hz.abs()) {
                format!("{hz}")
            } else {
                format!("{hz:e}")
            };
            return Err(err(format!(
                "refresh_hz = {shown} must be in [{MIN_REFRESH_HZ}, {MAX_REFRESH_HZ}]"
            )));
        }
        if raw.views.is_empty() || raw.views.len() > 4 {
            return Err(err(format!(
                "needs 1 to 4 [[views]], found {}",
                raw.views.len()
            )));
        }
        let mut views = Vec::new();
        let mut hidden_areas = Vec::new();
        for (i, v) in raw.views.iter().enumerate() {
            let fov = Fov {
                left: v.fov.left,
                right: v.fov.right,
                up: v.fov.up,
                down: v.fov.down,
            };
            fov.validate()
                .map_err(|m| err(format!("views[{i}]: {m}")))?;
            let [x, y, z, w] = v.orientation;
            let pose = Pose {
                position: DVec3::from_array(v.position),
                orientation: DQuat::from_xyzw(x, y, z, w),
            };
            pose.validate()
                .map_err(|m| err(format!("views[{i}]: {m}")))?;
            let [rw, rh] = v.resolution;
            if rw == 0 || rh == 0 || rw > 16384 || rh > 16384 {
                return Err(err(format!(
                    "views[{i}]: resolution {rw}x{rh} must be within 1..=16384"
                )));
            }
            let hidden_area = match &v.hidden_area {
                None => super::lens::default_hidden_area(&fov),
                Some(list) => super::hidden_area_from_points(list)
                    .map_err(|m| err(format!("views[{i}]: {m}")))?,
            };
            let lens = v
                .lens
                .as_ref()
                .map(|l| l.lens(v.resolution))
                .transpose()
                .map_err(|m| err(format!("views[{i}].{m}")))?;
            views.push(ProfileView {
                pose,
                fov,
                resolution: v.resolution,
                lens,
            });
            hidden_areas.push(hidden_area);
        }
        Ok(HmdProfile {
            name: raw.name,
            refresh_hz: raw.refresh_hz,
            views,
            hidden_areas: Arc::new(hidden_areas),
        })
    }

    /// The stereo rig for a head pose in world space, carrying the
    /// profile's hidden-area meshes.
    pub fn rig(&self, head: Pose) -> StereoRig {
        let mut rig = StereoRig::from_head(head, &self.eyes());
        rig.hidden_area = Some(self.hidden_areas.clone());
        rig
    }

    /// The views' eye poses (head space) and FOVs.
    pub fn eyes(&self) -> Vec<(Pose, Fov)> {
        self.views.iter().map(|v| (v.pose, v.fov)).collect()
    }

    /// Inter-pupillary distance: distance between the first two eye positions.
    pub fn ipd(&self) -> f64 {
        match self.views.as_slice() {
            [a, b, ..] => a.pose.position.distance(b.pose.position),
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_profile_parses() {
        for (name, _) in BUILTIN {
            let p = HmdProfile::load(name).unwrap();
            assert_eq!(p.views.len(), 2, "{name}");
            assert!(p.ipd() > 0.05 && p.ipd() < 0.08, "{name}");
        }
    }

    #[test]
    fn monado_profile_matches_runtime_facts() {
        let p = HmdProfile::load("monado-sim").unwrap();
        assert_eq!(p.views[0].fov.right, 0.7418);
        assert_eq!(p.views[1].pose.position.x, 0.0315);
    }

    #[test]
    fn unknown_and_malformed_profiles_are_errors() {
        let e = HmdProfile::load("no-such-headset").unwrap_err().to_string();
        assert!(
            e.contains("no-such-headset") && e.contains("unknown profile"),
            "{e}"
        );
        let e = HmdProfile::parse("bad.toml", "name = 1")
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.toml") && e.contains("malformed"), "{e}");
        let text = include_str!("../../manifests/hmd/monado-sim.toml")
            .replace("right = 0.7418", "right = -0.9");
        let e = HmdProfile::parse("flipped.toml", &text)
            .unwrap_err()
            .to_string();
        assert!(e.contains("fov.right"), "{e}");
    }
}
