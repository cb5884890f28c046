//! Where a session starts when no pose is given (`--frame`): outside the
//! scene with all of it in view (the default: looking 15° to 45° down at
//! it from where its geometry just fits the field of view, the tracking
//! origin a standing height below the eyes), standing at its centre, or at its
//! own spawn. Whatever the scene's size or where it lies — a plant
//! model kilometres across, a scan in survey coordinates hundreds of
//! kilometres from the origin — the framing comes from its bounds, so the
//! first image shows it. A point cloud's bounds are taken robustly (the
//! 0.5th to 99.5th percentile per axis), so a few stray points far away do
//! not shrink the scan to a dot.

use crate::scene::Scene;
use crate::view::profile::HmdProfile;
use crate::view::{frame_points, Fov, Pose};
use glam::DVec3;

/// The eyes' height above the tracking origin (a standing viewer).
pub const EYE_HEIGHT: f64 = 1.6;

/// How the start pose is chosen without `--pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Framing {
    /// Outside the scene's bounds, the whole scene in view.
    #[default]
    Outside,
    /// Standing on the floor at the bounds' centre, looking down -Z.
    Inside,
    /// The scene's own spawn: a generated scene's entrance, else the first
    /// camera of the glTF file, else as `outside`.
    Spawn,
}

/// How far the outside framing may look down: a site seen from above
/// fills the view where one seen from eye level is a sliver. The pitch
/// that brings the eye nearest (the scene largest) is taken.
pub const OUTSIDE_PITCHES_DEG: [f64; 4] = [-15.0, -25.0, -35.0, -45.0];

/// Points sampled for the robust bounds of a cloud.
const SAMPLES: usize = 200_000;
/// The fraction of points left out at each end of each axis.
const TAIL: f64 = 0.005;

/// The bounds the framing uses: the meshes' boxes, and a point cloud's
/// robust bounds (its points' 0.5th to 99.5th percentiles per axis, over
/// an even sample of at most 200,000 points).
pub fn framing_bounds(scene: &Scene) -> (DVec3, DVec3) {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for b in scene.world_bounds() {
        lo = lo.min(b.min);
        hi = hi.max(b.max);
    }
    if let Some(c) = scene.points.as_ref().filter(|c| !c.is_empty()) {
        let (a, b) = robust_point_bounds(&c.positions);
        lo = lo.min(c.origin + a);
        hi = hi.max(c.origin + b);
    }
    if !(lo.x <= hi.x && lo.is_finite() && hi.is_finite()) {
        return (DVec3::ZERO, DVec3::ZERO);
    }
    (lo, hi)
}

/// Points on the scene's geometry the outside framing fits into view: per
/// instance its box's corners, and for scenes of few instances (where a
/// box's empty corners — a disc's, a ring's — would push the view back)
/// an even sample of its mesh's vertices instead; a point cloud's robust
/// bounds' corners. At most about 200,000 points.
pub fn framing_samples(scene: &Scene) -> Vec<DVec3> {
    let bounds = scene.world_bounds();
    let per_instance = SAMPLES / bounds.len().max(1);
    let mut out = Vec::new();
    for (inst, b) in scene.instances.iter().zip(&bounds) {
        let mesh = &scene.meshes[inst.mesh as usize];
        let vertices: usize = mesh
            .primitives
            .iter()
            .map(|&p| scene.primitives[p as usize].positions.len())
            .sum();
        if per_instance < 64 || vertices == 0 {
            out.extend(corners(b.min, b.max));
            continue;
        }
        let step = vertices.div_ceil(per_instance).max(1);
        let all = mesh
            .primitives
            .iter()
            .flat_map(|&p| scene.primitives[p as usize].positions.iter());
        out.extend(all.step_by(step).map(|v| {
            inst.transform
                .transform_point3(DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64))
        }));
    }
    if let Some(c) = scene.points.as_ref().filter(|c| !c.is_empty()) {
        let (a, b) = robust_point_bounds(&c.positions);
        out.extend(corners(c.origin + a, c.origin + b));
    }
    out
}

/// The eight corners of the box `lo`..`hi`.
fn corners(lo: DVec3, hi: DVec3) -> impl Iterator<Item = DVec3> {
    (0..8).map(move |k| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// The 0.5th and 99.5th percentile of each axis over an even sample of
/// `points` (relative positions).
pub fn robust_point_bounds(points: &[[f32; 3]]) -> (DVec3, DVec3) {
    let step = points.len().div_ceil(SAMPLES).max(1);
    let mut axes: [Vec<f32>; 3] = Default::default();
    for p in points.iter().step_by(step) {
        for (a, v) in axes.iter_mut().zip(p) {
            a.push(*v);
        }
    }
    let mut lo = [0.0; 3];
    let mut hi = [0.0; 3];
    for (k, a) in axes.iter_mut().enumerate() {
        if a.is_empty() {
            continue;
        }
        a.sort_by(f32::total_cmp);
        let at = |q: f64| a[((a.len() - 1) as f64 * q).round() as usize] as f64;
        lo[k] = at(TAIL);
        hi[k] = at(1.0 - TAIL);
    }
    (DVec3::from(lo), DVec3::from(hi))
}

/// The tracking origin (the floor under a standing viewer) for `framing`
/// in `scene`, with `fov` the eye's field of view.
pub fn origin_pose(scene: &Scene, fov: &Fov, framing: Framing) -> Pose {
    let (lo, hi) = framing_bounds(scene);
    let standing = |head: Pose| Pose {
        position: head.position - DVec3::new(0.0, EYE_HEIGHT, 0.0),
        orientation: head.orientation,
    };
    match framing {
        Framing::Outside => {
            let samples = framing_samples(scene);
            let centre = (lo + hi) * 0.5;
            // The nearest of the candidate pitches: a flat site is seen
            // from higher up, a tall one more from the side.
            let head = OUTSIDE_PITCHES_DEG
                .iter()
                .map(|&pitch| frame_points(samples.iter().copied(), centre, fov, pitch))
                .min_by(|a, b| {
                    let d = |p: &Pose| (p.position - centre).length();
                    d(a).total_cmp(&d(b))
                })
                .expect("candidate pitches");
            standing(head)
        }
        Framing::Inside => {
            let c = (lo + hi) * 0.5;
            Pose::from_euler_deg(DVec3::new(c.x, lo.y, c.z), 0.0, 0.0, 0.0)
        }
        Framing::Spawn => match (scene.spawn, scene.cameras.first()) {
            (Some(spawn), _) => spawn,
            (None, Some(camera)) => camera_origin(&camera.pose),
            (None, None) => origin_pose(scene, fov, Framing::Outside),
        },
    }
}

/// The tracking origin that puts standing eyes at `camera` looking along
/// its heading.
pub fn camera_origin(camera: &Pose) -> Pose {
    let o = crate::interact::locomotion::Origin::from_pose(camera);
    Pose::from_euler_deg(
        o.position - DVec3::new(0.0, EYE_HEIGHT, 0.0),
        o.yaw.to_degrees(),
        0.0,
        0.0,
    )
}

/// The head pose for `framing` in `scene` with `profile`'s eyes: the
/// tracking origin with the eyes [`EYE_HEIGHT`] above it.
pub fn head_pose(scene: &Scene, profile: &HmdProfile, framing: Framing) -> Pose {
    origin_pose(scene, &profile.views[0].fov, framing).compose(&Pose {
        position: DVec3::new(0.0, EYE_HEIGHT, 0.0),
        orientation: glam::DQuat::IDENTITY,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// A few far outliers do not move the robust bounds off the bulk
        /// of the points.
        #[test]
        fn outliers_do_not_widen_the_robust_bounds(
            n in 1000usize..20_000,
            far in 1e3f32..1e6,
            outliers in 0usize..5,
        ) {
            let mut pts: Vec<[f32; 3]> = (0..n)
                .map(|i| {
                    let t = i as f32 / n as f32;
                    [10.0 * t, 2.0 * (t * 7.0).fract(), -5.0 * (t * 3.0).fract()]
                })
                .collect();
            for k in 0..outliers {
                pts.push([far * (k as f32 + 1.0), -far, far]);
            }
            let (lo, hi) = robust_point_bounds(&pts);
            prop_assert!(lo.x >= -0.1 && hi.x <= 10.1, "{lo} {hi}");
            prop_assert!(hi.x - lo.x >= 9.0, "{lo} {hi}");
            prop_assert!(lo.z >= -5.1 && hi.y <= 2.1);
        }
    }

    #[test]
    fn the_framed_scene_is_in_front_of_the_eyes_far_from_the_origin() {
        let mut scene = crate::scene::factory::generate(200, 1).unwrap();
        let shift = DVec3::new(512_000.0, 30.0, -4_100_000.0);
        for inst in &mut scene.instances {
            inst.transform.translation += shift;
        }
        let fov = Fov {
            left: -0.8,
            right: 0.8,
            up: 0.8,
            down: -0.8,
        };
        let (lo, hi) = framing_bounds(&scene);
        let centre = (lo + hi) * 0.5;
        let head = origin_pose(&scene, &fov, Framing::Outside);
        let eye = head.position + DVec3::new(0.0, EYE_HEIGHT, 0.0);
        let to_centre = (centre - eye).normalize();
        let forward = head.orientation * DVec3::NEG_Z;
        assert!(to_centre.dot(forward) > 0.99, "{to_centre} {forward}");
        assert!((eye - centre).length() > (hi - lo).length() * 0.5);
        let inside = origin_pose(&scene, &fov, Framing::Inside);
        assert!((inside.position.y - lo.y).abs() < 1e-9);
        assert!((inside.position.x - centre.x).abs() < 1e-6);
    }
}
