//! Where the in-headset panel floats and where a hand points on it: a flat
//! rectangle in tracking space, placed in front of the head when the menu
//! button opens it (turned by the head's yaw only, so it stands upright),
//! and the intersection of a hand's aim ray with it as panel coordinates.
//! Pure geometry; the panel's contents and its OpenXR quad layer live in
//! `targets`.
//!
//! The hit is the standard ray–plane intersection: with the plane through
//! the centre `c` with unit normal `n`, a ray `o + t·d` meets it at
//! `t = ((c − o)·n) / (d·n)`; the point's coordinates along the panel's
//! own x (right) and y (up) axes give `u = x/w + ½` and `v = ½ − y/h`
//! (top-left origin, as images and egui count).

use crate::view::Pose;
use glam::{DQuat, DVec3};

/// Panel width and height, metres (a 16:10 sheet readable at arm's length).
pub const SIZE_M: [f64; 2] = [0.64, 0.40];
/// How far in front of the head the panel opens, metres.
pub const DISTANCE_M: f64 = 0.6;
/// How far below the eyes its centre sits, metres.
pub const DROP_M: f64 = 0.15;

/// An open panel: its centre pose in tracking space (its +Z faces the
/// user, +X is its right edge, +Y its top) and its size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Panel {
    /// Centre and orientation, tracking space.
    pub pose: Pose,
    /// Width and height, metres.
    pub size_m: [f64; 2],
}

/// Where a ray meets the panel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PanelHit {
    /// Panel coordinates: u from the left edge, v from the top, 0..1.
    pub uv: [f64; 2],
    /// Distance along the ray, metres (tracking space).
    pub distance: f64,
}

impl Panel {
    /// A panel of [`SIZE_M`] [`DISTANCE_M`] in front of `head` along its
    /// horizontal facing, [`DROP_M`] below it, facing it upright. A head
    /// looking straight up or down opens it along its own up vector's
    /// horizontal part instead (the yaw is still defined there).
    pub fn facing(head: &Pose) -> Panel {
        let flat = |v: DVec3| DVec3::new(v.x, 0.0, v.z).try_normalize();
        let fwd = flat(head.forward())
            .or_else(|| flat(head.orientation * DVec3::Y))
            .unwrap_or(DVec3::NEG_Z);
        // Yaw that turns −Z onto `fwd`; the panel's +Z faces back at the head.
        let yaw = (-fwd.x).atan2(-fwd.z);
        Panel {
            pose: Pose {
                position: head.position + fwd * DISTANCE_M - DVec3::Y * DROP_M,
                orientation: DQuat::from_rotation_y(yaw),
            },
            size_m: SIZE_M,
        }
    }

    /// The tracking-space point at panel coordinates `uv`.
    pub fn point(&self, uv: [f64; 2]) -> DVec3 {
        let local = DVec3::new(
            (uv[0] - 0.5) * self.size_m[0],
            (0.5 - uv[1]) * self.size_m[1],
            0.0,
        );
        self.pose.position + self.pose.orientation * local
    }

    /// Where the ray along `aim`'s −Z meets the panel's front, if it does
    /// (a ray from behind, parallel to it, or pointing away misses).
    pub fn hit(&self, aim: &Pose) -> Option<PanelHit> {
        let n = self.pose.orientation * DVec3::Z;
        let d = aim.forward();
        let o = aim.position;
        let denom = d.dot(n);
        // Only rays travelling against the normal reach the front face
        // (a NaN fails this too).
        if denom.is_nan() || denom >= -1e-9 {
            return None;
        }
        let t = (self.pose.position - o).dot(n) / denom;
        if !(t.is_finite() && t >= 0.0) {
            return None;
        }
        let p = o + d * t;
        let local = self.pose.orientation.inverse() * (p - self.pose.position);
        let uv = [
            local.x / self.size_m[0] + 0.5,
            0.5 - local.y / self.size_m[1],
        ];
        let inside = uv.iter().all(|c| (0.0..=1.0).contains(c));
        inside.then_some(PanelHit { uv, distance: t })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn looking(from: DVec3, at: DVec3) -> Pose {
        let d = (at - from).normalize();
        Pose {
            position: from,
            orientation: DQuat::from_rotation_arc(DVec3::NEG_Z, d),
        }
    }

    fn panel(x: f64, y: f64, z: f64, yaw: f64) -> Panel {
        Panel {
            pose: Pose {
                position: DVec3::new(x, y, z),
                orientation: DQuat::from_rotation_y(yaw),
            },
            size_m: SIZE_M,
        }
    }

    #[test]
    fn opens_in_front_of_the_head_facing_it() {
        let head = Pose {
            position: DVec3::new(1.0, 1.6, 2.0),
            orientation: DQuat::from_rotation_y(0.5) * DQuat::from_rotation_x(-0.4),
        };
        let p = Panel::facing(&head);
        let fwd = DVec3::new(-(0.5f64).sin(), 0.0, -(0.5f64).cos());
        let expect = head.position + fwd * DISTANCE_M - DVec3::Y * DROP_M;
        assert!(p.pose.position.distance(expect) < 1e-12);
        // Upright, and its front (+Z) points back along the facing.
        let n = p.pose.orientation * DVec3::Z;
        assert!(n.distance(-fwd) < 1e-12, "{n}");
        assert!((p.pose.orientation * DVec3::Y).distance(DVec3::Y) < 1e-12);
        // The centre ray from straight ahead hits the middle.
        let from = p.pose.position + n * 0.5;
        let h = p.hit(&looking(from, p.pose.position)).expect("hit");
        assert!((h.uv[0] - 0.5).abs() < 1e-12 && (h.uv[1] - 0.5).abs() < 1e-12);
        assert!((h.distance - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_head_looking_straight_down_still_opens_it() {
        let head = Pose {
            position: DVec3::new(0.0, 1.6, 0.0),
            orientation: DQuat::from_rotation_x(-std::f64::consts::FRAC_PI_2),
        };
        let p = Panel::facing(&head);
        assert!(p.pose.position.is_finite());
        // Looking down, the head's up points forward (−Z).
        assert!(p.pose.position.z < -0.5, "{}", p.pose.position);
    }

    #[test]
    fn corners_are_where_uv_says() {
        let p = panel(0.0, 1.45, -0.6, 0.0);
        let tl = p.point([0.0, 0.0]);
        assert!(tl.distance(DVec3::new(-0.32, 1.65, -0.6)) < 1e-12, "{tl}");
        let br = p.point([1.0, 1.0]);
        assert!(br.distance(DVec3::new(0.32, 1.25, -0.6)) < 1e-12, "{br}");
    }

    proptest! {
        /// A ray from anywhere in front aimed at a point of the panel hits
        /// it there, at the distance to that point.
        #[test]
        fn a_ray_at_a_panel_point_hits_that_point(
            x in -5.0..5.0f64, y in 0.0..3.0f64, z in -5.0..5.0f64, yaw in -3.2..3.2f64,
            u in 0.001..0.999f64, v in 0.001..0.999f64,
            ox in -2.0..2.0f64, oy in -2.0..2.0f64, oz in 0.05..3.0f64,
        ) {
            let p = panel(x, y, z, yaw);
            let target = p.point([u, v]);
            let from = p.pose.position + p.pose.orientation * DVec3::new(ox, oy, oz);
            let h = p.hit(&looking(from, target)).expect("hits");
            prop_assert!((h.uv[0] - u).abs() < 1e-9 && (h.uv[1] - v).abs() < 1e-9, "{h:?}");
            prop_assert!((h.distance - from.distance(target)).abs() < 1e-9);
        }

        /// Brute force: march along the ray in 1 mm steps and look for a
        /// crossing of the panel's plane inside its rectangle; the hit
        /// agrees (within the step), and misses when the march finds none.
        #[test]
        fn agrees_with_a_march_along_the_ray(
            yaw in -3.2..3.2f64,
            ox in -1.0..1.0f64, oy in -1.0..1.0f64, oz in -1.0..1.0f64,
            dx in -1.0..1.0f64, dy in -1.0..1.0f64, dz in -1.0..1.0f64,
        ) {
            let p = panel(0.0, 1.0, 0.0, yaw);
            let d = DVec3::new(dx, dy, dz);
            prop_assume!(d.length() > 0.1);
            let from = p.pose.position + p.pose.orientation * DVec3::new(ox, oy, oz);
            let aim = looking(from, from + d);
            let n = p.pose.orientation * DVec3::Z;
            let dir = aim.forward();
            let side = |q: DVec3| (q - p.pose.position).dot(n);
            let mut found: Option<(f64, [f64; 2])> = None;
            let step = 1e-3;
            for i in 0..3000 {
                let (a, b) = (from + dir * (i as f64 * step), from + dir * ((i + 1) as f64 * step));
                // Front to back only.
                if side(a) >= 0.0 && side(b) < 0.0 {
                    let local = p.pose.orientation.inverse() * (b - p.pose.position);
                    let uv = [local.x / p.size_m[0] + 0.5, 0.5 - local.y / p.size_m[1]];
                    found = Some((i as f64 * step, uv));
                    break;
                }
            }
            let inside = |uv: [f64; 2], m: f64| uv.iter().all(|c| (m..=1.0 - m).contains(c));
            match (p.hit(&aim), found) {
                (Some(h), Some((t, _))) => prop_assert!((h.distance - t).abs() < 2.0 * step),
                (Some(h), None) => prop_assert!(false, "hit {h:?} the march did not find"),
                // A march crossing well inside the rectangle must be a hit.
                (None, Some((_, uv))) => prop_assert!(!inside(uv, 0.01), "missed at {uv:?}"),
                (None, None) => {}
            }
        }

        /// Rays from behind the panel never hit it.
        #[test]
        fn rays_from_behind_miss(
            yaw in -3.2..3.2f64, u in 0.0..1.0f64, v in 0.0..1.0f64,
            ox in -2.0..2.0f64, oy in -2.0..2.0f64, oz in 0.01..3.0f64,
        ) {
            let p = panel(0.0, 1.0, 0.0, yaw);
            let from = p.pose.position + p.pose.orientation * DVec3::new(ox, oy, -oz);
            prop_assert!(p.hit(&looking(from, p.point([u, v]))).is_none());
        }
    }
}
