//! Where `run` starts and which places the right stick click cycles
//! through: the start (`--spawn`, the scene camera `--camera` names, or
//! the pose framing the scene), then the `--viewpoint` poses, then the
//! scene file's cameras (glTF camera nodes, by camera index) not already
//! used as the start.
//! Each is a tracking-origin pose: the floor 1.6 m under the eyes, turned
//! to the heading (a camera's pitch and roll are not kept: the user's head
//! supplies those).

pub use super::framing::camera_origin;
use super::headless::scene_camera;
use super::session::RunArgs;
use crate::error::Result;
use crate::interact::locomotion::Origin;
use crate::interact::{Interaction, Settings};
use crate::scene::Scene;
use crate::view::{Fov, Pose};

/// Standing eye height above the tracking origin, metres (as
/// [`super::framing::head_pose`] places the head).
pub const EYE_HEIGHT: f64 = 1.6;

/// One place of the cycle.
#[derive(Clone, Debug, PartialEq)]
pub struct Viewpoint {
    /// Where it came from: `spawn`, `--viewpoint N` or `camera N 'NAME'`.
    pub name: String,
    /// The tracking origin there.
    pub origin: Pose,
}

/// The cycle for `args` in `scene`, the start first; `fov` frames the
/// scene when nothing else places the start.
pub fn plan(args: &RunArgs, scene: &Scene, fov: &Fov) -> Result<Vec<Viewpoint>> {
    let label = |c: &crate::scene::SceneCamera| format!("camera {} '{}'", c.index, c.name);
    let start_camera = match &args.camera {
        Some(name) => {
            scene_camera(scene, name)?;
            let parsed = name.parse::<usize>().ok();
            scene
                .cameras
                .iter()
                .position(|c| Some(c.index) == parsed || (parsed.is_none() && c.name == *name))
        }
        None => None,
    };
    let start = match (args.spawn, start_camera) {
        (Some(p), _) => Viewpoint {
            name: "spawn".into(),
            origin: p,
        },
        (None, Some(i)) => Viewpoint {
            name: label(&scene.cameras[i]),
            origin: camera_origin(&scene.cameras[i].pose),
        },
        (None, None) => Viewpoint {
            name: "spawn".into(),
            origin: super::framing::origin_pose(scene, fov, args.framing),
        },
    };
    let mut out = vec![start];
    out.extend(args.viewpoints.iter().enumerate().map(|(i, p)| Viewpoint {
        name: format!("--viewpoint {}", i + 1),
        origin: *p,
    }));
    let mut cameras: Vec<usize> = (0..scene.cameras.len()).collect();
    cameras.sort_by_key(|&i| scene.cameras[i].index);
    for i in cameras {
        let c = &scene.cameras[i];
        if Some(i) != start_camera {
            out.push(Viewpoint {
                name: label(c),
                origin: camera_origin(&c.pose),
            });
        }
    }
    Ok(out)
}

/// The interaction state starting at `places[0]` with the rest in its
/// viewpoint cycle.
pub fn interaction(places: &[Viewpoint], settings: Settings) -> Interaction {
    let origin = |v: &Viewpoint| Origin::from_pose(&v.origin);
    let mut it = Interaction::new(origin(&places[0]), settings);
    it.viewpoints.extend(places[1..].iter().map(origin));
    it
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn a_camera_origin_puts_the_eyes_at_the_camera() {
        let cam = Pose::from_euler_deg(DVec3::new(1.0, 2.0, 3.0), 40.0, -20.0, 5.0);
        let o = camera_origin(&cam);
        let eyes = o.compose(&Pose::from_euler_deg(
            DVec3::new(0.0, EYE_HEIGHT, 0.0),
            0.0,
            0.0,
            0.0,
        ));
        assert!((eyes.position - cam.position).length() < 1e-9);
        let (f, g) = (eyes.forward(), cam.forward());
        let flat = DVec3::new(g.x, 0.0, g.z).normalize();
        assert!((f - flat).length() < 1e-9, "{f:?} vs {flat:?}");
    }
}
