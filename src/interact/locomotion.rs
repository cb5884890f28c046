//! Moving the user through the world by moving the tracking origin: the
//! runtime keeps reporting head and hands in its tracking space, and the
//! world sees them through [`Origin`] (tracking → world: a yaw-only
//! rotation, a uniform scale and a translation). Teleport arcs, smooth
//! move, fly, snap turn about the head, world grab with two-hand
//! scale/rotate and recentring are all changes of that origin.

use super::raycast::{Hit, SceneQuery};
use crate::view::Pose;
use glam::{DQuat, DVec3};

/// Gravity of the teleport arc, m/s² (a parabola "thrown" from the hand).
pub const ARC_GRAVITY: f64 = 9.81;
/// Launch speed of the teleport arc, m/s: with g = 9.81 a 45° throw from
/// 1.2 m reaches about v²/g ≈ 10 m.
pub const ARC_SPEED: f64 = 10.0;
/// Time step between arc samples, seconds.
pub const ARC_STEP: f64 = 0.02;
/// Longest arc, seconds of flight.
pub const ARC_MAX_TIME: f64 = 4.0;
/// Steepest ground a teleport lands on: the surface normal within 30° of up.
pub const MAX_SLOPE_DEG: f64 = 30.0;
/// Smallest world-to-user scale of a two-hand grab (the user 100× smaller).
pub const MIN_SCALE: f64 = 0.01;
/// Largest scale of a two-hand grab (the user 100× larger).
pub const MAX_SCALE: f64 = 100.0;

/// The tracking origin in the world: a tracking-space point `p` sits at
/// `position + yaw · (scale · p)` in the world. `scale` > 1 makes the user
/// larger (the world looks smaller).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Origin {
    /// World position of the tracking-space origin.
    pub position: DVec3,
    /// Rotation of tracking space about world +Y, radians.
    pub yaw: f64,
    /// Tracking-to-world scale.
    pub scale: f64,
}

impl Default for Origin {
    fn default() -> Self {
        Origin {
            position: DVec3::ZERO,
            yaw: 0.0,
            scale: 1.0,
        }
    }
}

/// `a` wrapped into (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let w = a.rem_euclid(t);
    if w > std::f64::consts::PI {
        w - t
    } else {
        w
    }
}

/// The yaw (about +Y, radians, 0 looking down −Z, positive turning left)
/// of a direction's horizontal part; 0 for a vertical direction.
pub fn yaw_of(direction: DVec3) -> f64 {
    if direction.x.abs() + direction.z.abs() < 1e-12 {
        return 0.0;
    }
    // R_y(θ)·(0,0,−1) = (−sin θ, 0, −cos θ), so θ = atan2(−x, −z).
    (-direction.x).atan2(-direction.z)
}

impl Origin {
    /// An origin at a spawn pose: its position and the yaw of its facing
    /// (pitch and roll are dropped: the floor stays level).
    pub fn from_pose(p: &Pose) -> Origin {
        Origin {
            position: p.position,
            yaw: yaw_of(p.forward()),
            scale: 1.0,
        }
    }

    /// The rotation part.
    pub fn rotation(&self) -> DQuat {
        DQuat::from_rotation_y(self.yaw)
    }

    /// A tracking-space point in the world.
    pub fn point(&self, p: DVec3) -> DVec3 {
        self.position + self.rotation() * (p * self.scale)
    }

    /// A tracking-space direction in the world (not rescaled).
    pub fn direction(&self, d: DVec3) -> DVec3 {
        self.rotation() * d
    }

    /// A tracking-space pose in the world.
    pub fn pose(&self, p: &Pose) -> Pose {
        Pose {
            position: self.point(p.position),
            orientation: (self.rotation() * p.orientation).normalize(),
        }
    }

    /// The origin turned by `angle` radians about the vertical through the
    /// world point `pivot`: a point `x` moves to `pivot + R(x − pivot)`, so
    /// `pivot` (the head) stays put while the world turns around it.
    pub fn turned_about(&self, pivot: DVec3, angle: f64) -> Origin {
        let r = DQuat::from_rotation_y(angle);
        Origin {
            position: pivot + r * (self.position - pivot),
            yaw: wrap_angle(self.yaw + angle),
            scale: self.scale,
        }
    }

    /// The origin rescaled by `factor` about the world point `pivot`
    /// (clamped to [`MIN_SCALE`, `MAX_SCALE`]): `pivot` stays put.
    pub fn scaled_about(&self, pivot: DVec3, factor: f64) -> Origin {
        let scale = (self.scale * factor).clamp(MIN_SCALE, MAX_SCALE);
        let k = scale / self.scale;
        Origin {
            position: pivot + (self.position - pivot) * k,
            yaw: self.yaw,
            scale,
        }
    }

    /// The origin moved so that the head (tracking-space position
    /// `head_tracking`) stands over `target`: the head's horizontal
    /// position goes to the target's and the tracking floor (y = 0) to the
    /// target's height; the head keeps its height above the floor.
    pub fn teleported(&self, head_tracking: DVec3, target: DVec3) -> Origin {
        let floor = self.point(DVec3::new(head_tracking.x, 0.0, head_tracking.z));
        Origin {
            position: self.position + (target - floor),
            ..*self
        }
    }
}

/// The teleport arc from `start` thrown along `direction` at `speed`:
/// `p(t) = start + v t − ½ g t² ŷ` (projectile motion), sampled every
/// [`ARC_STEP`] seconds for at most [`ARC_MAX_TIME`] s, stopping once
/// below `floor_y`.
pub fn arc_points(start: DVec3, direction: DVec3, speed: f64, floor_y: f64) -> Vec<DVec3> {
    let v = direction.normalize_or_zero() * speed;
    let steps = (ARC_MAX_TIME / ARC_STEP).ceil() as usize;
    let mut out = Vec::with_capacity(steps + 1);
    for i in 0..=steps {
        let t = i as f64 * ARC_STEP;
        let p = start + v * t - DVec3::Y * (0.5 * ARC_GRAVITY * t * t);
        out.push(p);
        if p.y < floor_y {
            break;
        }
    }
    out
}

/// Whether a surface with unit normal `n` is level enough to stand on:
/// `n · ŷ ≥ cos 30°`.
pub fn walkable(n: DVec3) -> bool {
    n.dot(DVec3::Y) >= MAX_SLOPE_DEG.to_radians().cos() - 1e-12
}

/// Where a teleport arc ends up.
#[derive(Clone, Debug, PartialEq)]
pub struct ArcResult {
    /// The arc, up to the hit (or the whole arc on a miss).
    pub points: Vec<DVec3>,
    /// The first surface the arc meets.
    pub hit: Option<Hit>,
    /// The landing point: the hit when its surface is walkable.
    pub target: Option<DVec3>,
}

/// Casts the teleport arc against the scene: the first surface it meets
/// ends it; it is a target only if walkable (a wall or a slope over 30°
/// stops the arc with no target).
pub fn cast_teleport(q: &SceneQuery, start: DVec3, direction: DVec3, speed: f64) -> ArcResult {
    let (lo, _) = q.scene().bounds();
    let floor = lo.y.min(start.y) - 1.0;
    let mut points = arc_points(start, direction, speed, floor);
    match q.cast_polyline(&points) {
        Some((hit, seg)) => {
            points.truncate(seg + 1);
            points.push(hit.point);
            ArcResult {
                points,
                target: walkable(hit.normal).then_some(hit.point),
                hit: Some(hit),
            }
        }
        None => ArcResult {
            points,
            hit: None,
            target: None,
        },
    }
}

/// The displacement of one frame of smooth move: the stick (x right, y
/// forward, each in [−1, 1]) steers along `facing` (the head's or the
/// hand's forward) at `speed` m/s for `dt` s. Walking keeps to the
/// horizontal plane; flying follows `facing` up and down too.
pub fn smooth_move(facing: DVec3, stick: [f64; 2], speed: f64, dt: f64, fly: bool) -> DVec3 {
    let mut fwd = facing;
    if !fly {
        fwd.y = 0.0;
    }
    let fwd = fwd.normalize_or_zero();
    if fwd == DVec3::ZERO {
        return DVec3::ZERO;
    }
    // Right is forward × up (looking down −Z, right is +X).
    let right = fwd.cross(DVec3::Y).normalize_or_zero();
    let mut s = DVec3::new(stick[0], 0.0, stick[1]);
    let m = s.length();
    if m > 1.0 {
        s /= m;
    }
    (fwd * s.z + right * s.x) * speed * dt
}

/// A two-hand grab, as started: both hands' world positions and the
/// origin at that moment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoHandGrab {
    /// World positions of the left and right hands at the start.
    pub world: [DVec3; 2],
    /// The origin at the start.
    pub origin: Origin,
}

impl TwoHandGrab {
    /// Starts a grab with the hands at tracking positions `hands`.
    pub fn start(origin: Origin, hands: [DVec3; 2]) -> TwoHandGrab {
        TwoHandGrab {
            world: hands.map(|h| origin.point(h)),
            origin,
        }
    }

    /// The origin that keeps the grabbed world points in the hands, now at
    /// tracking positions `hands`: the horizontal hand-to-hand vector
    /// fixes the yaw (the turn of the world about the vertical), its
    /// length the scale (the world stretches as the hands part), and the
    /// midpoint the translation. With `d = b − a` (tracking, horizontal)
    /// and `D = B − A` (world, horizontal), `scale = |D|/|d|`,
    /// `yaw = yaw(D) − yaw(d)`, `position = (A+B)/2 − R(yaw)·scale·(a+b)/2`
    /// — solving `position + R·scale·a = A`, `… b = B` in the plane. The
    /// scale is clamped to [`MIN_SCALE`, `MAX_SCALE`].
    pub fn update(&self, hands: [DVec3; 2]) -> Origin {
        let flat = |v: DVec3| DVec3::new(v.x, 0.0, v.z);
        let d = flat(hands[1] - hands[0]);
        let dw = flat(self.world[1] - self.world[0]);
        if d.length() < 1e-4 || dw.length() < 1e-9 {
            return self.origin;
        }
        let scale = (dw.length() / d.length()).clamp(MIN_SCALE, MAX_SCALE);
        let yaw = wrap_angle(yaw_of(dw) - yaw_of(d));
        let mid_t = (hands[0] + hands[1]) * 0.5;
        let mid_w = (self.world[0] + self.world[1]) * 0.5;
        let r = DQuat::from_rotation_y(yaw);
        Origin {
            position: mid_w - r * (mid_t * scale),
            yaw,
            scale,
        }
    }
}

/// A one-hand grab: the world point in the hand stays in the hand.
pub fn one_hand_drag(origin: &Origin, grabbed_world: DVec3, hand_tracking: DVec3) -> Origin {
    Origin {
        position: origin.position + (grabbed_world - origin.point(hand_tracking)),
        ..*origin
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interact::raycast::SceneQuery;
    use crate::scene::{shapes, Instance, Material, Mesh, Scene};
    use glam::DAffine3;
    use proptest::prelude::*;

    /// A scene with one large square slab (half size 50 m, 0.05 m thick)
    /// tilted by `slope_deg` about X, its top surface through the origin.
    fn slope(slope_deg: f64) -> Scene {
        let mut s = Scene::default();
        s.materials.push(Material::default());
        s.primitives.push(shapes::cuboid([50.0, 0.05, 50.0], 0));
        s.meshes.push(Mesh {
            name: "slab".into(),
            primitives: vec![0],
        });
        let q = DQuat::from_rotation_x(slope_deg.to_radians());
        s.instances.push(Instance {
            mesh: 0,
            transform: DAffine3::from_rotation_translation(q, q * DVec3::new(0.0, -0.05, 0.0)),
        });
        s
    }

    #[test]
    fn the_arc_lands_on_a_floor_and_not_on_a_wall_or_the_void() {
        let floor = slope(0.0);
        let q = SceneQuery::new(&floor);
        let start = DVec3::new(0.0, 1.2, 0.0);
        let dir = DVec3::new(0.0, 1.0, -1.0);
        let r = cast_teleport(&q, start, dir, ARC_SPEED);
        let t = r.target.expect("lands on the floor");
        // Range of a projectile launched at 45° from height h:
        // x = v cos θ · (v sin θ + √(v² sin² θ + 2 g h)) / g.
        let (v, th, h) = (ARC_SPEED, std::f64::consts::FRAC_PI_4, 1.2);
        let range =
            v * th.cos() * (v * th.sin() + ((v * th.sin()).powi(2) + 2.0 * ARC_GRAVITY * h).sqrt())
                / ARC_GRAVITY;
        assert!(t.y.abs() < 1e-9, "{t}");
        assert!((-t.z - range).abs() < 1e-2, "range {} vs {range}", -t.z);
        // A wall: the same slab turned upright in front.
        let mut wall = slope(90.0);
        wall.instances[0].transform = DAffine3::from_rotation_translation(
            DQuat::from_rotation_x(std::f64::consts::FRAC_PI_2),
            DVec3::new(0.0, 0.0, -3.0),
        );
        let q = SceneQuery::new(&wall);
        let r = cast_teleport(&q, start, dir, ARC_SPEED);
        assert!(
            r.hit.is_some() && r.target.is_none(),
            "a wall stops the arc without a target"
        );
        let empty = Scene::default();
        let q = SceneQuery::new(&empty);
        let r = cast_teleport(&q, start, dir, ARC_SPEED);
        assert!(r.hit.is_none() && r.target.is_none());
        assert!(r.points.len() > 10);
    }

    proptest! {
        #[test]
        fn slopes_up_to_30_degrees_are_walkable_and_steeper_ones_not(deg in 0.0f64..80.0) {
            prop_assume!((deg - MAX_SLOPE_DEG).abs() > 0.01);
            let s = slope(deg);
            let q = SceneQuery::new(&s);
            // Aim straight down from above the slope: the arc falls on it.
            let r = cast_teleport(&q, DVec3::new(0.0, 5.0, 0.0), DVec3::NEG_Y, 1.0);
            let hit = r.hit.expect("the slope is below");
            let want = deg <= MAX_SLOPE_DEG;
            prop_assert_eq!(r.target.is_some(), want, "{} deg, normal {}", deg, hit.normal);
            prop_assert!((hit.normal.y - deg.to_radians().cos()).abs() < 1e-6);
        }

        #[test]
        fn snap_turn_keeps_the_head_and_turns_the_view(
            pos in prop::array::uniform3(-100.0f64..100.0),
            yaw in -3.0f64..3.0,
            scale in 0.1f64..10.0,
            head in prop::array::uniform3(-2.0f64..2.0),
            angle in -3.0f64..3.0,
        ) {
            let o = Origin { position: DVec3::from(pos), yaw, scale };
            let head_t = DVec3::from(head);
            let head_w = o.point(head_t);
            let t = o.turned_about(head_w, angle);
            prop_assert!((t.point(head_t) - head_w).length() < 1e-9);
            let look = Pose { position: head_t, orientation: DQuat::from_rotation_y(0.3) };
            let before = yaw_of(o.pose(&look).forward());
            let after = yaw_of(t.pose(&look).forward());
            prop_assert!(wrap_angle(after - before - angle).abs() < 1e-9);
        }

        #[test]
        fn two_hand_grab_keeps_both_grabbed_points_in_the_hands(
            yaw in -3.0f64..3.0,
            a0 in prop::array::uniform3(-1.0f64..1.0),
            b0 in prop::array::uniform3(-1.0f64..1.0),
            turn in -3.0f64..3.0,
            stretch in 0.2f64..5.0,
            shift in prop::array::uniform3(-1.0f64..1.0),
        ) {
            let o = Origin { position: DVec3::new(3.0, 0.0, -2.0), yaw, scale: 1.0 };
            let (a0, b0) = (DVec3::from(a0), DVec3::from(b0));
            prop_assume!(DVec3::new(b0.x - a0.x, 0.0, b0.z - a0.z).length() > 0.1);
            let g = TwoHandGrab::start(o, [a0, b0]);
            // Move the hands: turn about their midpoint and part them by
            // `stretch` horizontally (same heights), then shift both.
            let mid = (a0 + b0) * 0.5;
            let r = DQuat::from_rotation_y(turn);
            let mv = |p: DVec3| {
                let d = p - mid;
                mid + r * DVec3::new(d.x * stretch, d.y, d.z * stretch) + DVec3::from(shift)
            };
            let (a, b) = (mv(a0), mv(b0));
            let n = g.update([a, b]);
            // The world scales by 1/stretch (the user shrinks as the hands part).
            prop_assert!((n.scale - 1.0 / stretch).abs() < 1e-9);
            prop_assert!(wrap_angle(n.yaw - (yaw - turn)).abs() < 1e-9);
            // Horizontally both grabbed points stay in the hands; the
            // midpoint stays exactly.
            let flat = |v: DVec3| DVec3::new(v.x, 0.0, v.z);
            prop_assert!((flat(n.point(a)) - flat(g.world[0])).length() < 1e-9);
            prop_assert!((flat(n.point(b)) - flat(g.world[1])).length() < 1e-9);
            prop_assert!((n.point((a + b) * 0.5) - (g.world[0] + g.world[1]) * 0.5).length() < 1e-9);
        }

        #[test]
        fn smooth_move_goes_speed_times_time_along_the_facing(
            yaw in -3.0f64..3.0,
            pitch in -1.4f64..1.4,
            sx in -1.0f64..1.0,
            sy in -1.0f64..1.0,
            speed in 0.1f64..10.0,
            dt in 0.001f64..0.1,
        ) {
            let facing = DQuat::from_rotation_y(yaw) * DQuat::from_rotation_x(pitch) * DVec3::NEG_Z;
            let d = smooth_move(facing, [sx, sy], speed, dt, false);
            let m = (sx * sx + sy * sy).sqrt().min(1.0);
            prop_assert!(d.y.abs() < 1e-12, "walking stays level");
            prop_assert!((d.length() - speed * dt * m).abs() < 1e-9);
            // Forward-only stick goes along the facing's horizontal yaw.
            let f = smooth_move(facing, [0.0, 1.0], speed, dt, false);
            prop_assert!(wrap_angle(yaw_of(f) - yaw).abs() < 1e-9);
            let fly = smooth_move(facing, [0.0, 1.0], speed, dt, true);
            prop_assert!((fly - facing * speed * dt).length() < 1e-9);
        }

        #[test]
        fn teleport_puts_the_head_over_the_target(
            pos in prop::array::uniform3(-100.0f64..100.0),
            yaw in -3.0f64..3.0,
            scale in 0.1f64..10.0,
            head in prop::array::uniform3(-2.0f64..2.0),
            target in prop::array::uniform3(-100.0f64..100.0),
        ) {
            let o = Origin { position: DVec3::from(pos), yaw, scale };
            let head_t = DVec3::new(head[0], head[1].abs() + 0.5, head[2]);
            let t = o.teleported(head_t, DVec3::from(target));
            let h = t.point(head_t);
            prop_assert!((h.x - target[0]).abs() < 1e-9 && (h.z - target[2]).abs() < 1e-9);
            prop_assert!((h.y - (target[1] + head_t.y * scale)).abs() < 1e-9);
        }

        #[test]
        fn one_hand_drag_keeps_the_grabbed_point(
            pos in prop::array::uniform3(-10.0f64..10.0),
            hand in prop::array::uniform3(-1.0f64..1.0),
            moved in prop::array::uniform3(-1.0f64..1.0),
        ) {
            let o = Origin { position: DVec3::from(pos), yaw: 0.7, scale: 2.0 };
            let grabbed = o.point(DVec3::from(hand));
            let n = one_hand_drag(&o, grabbed, DVec3::from(moved));
            prop_assert!((n.point(DVec3::from(moved)) - grabbed).length() < 1e-9);
        }
    }

    #[test]
    fn scale_is_clamped_to_a_hundredth_and_a_hundred() {
        let o = Origin::default();
        let g = TwoHandGrab::start(o, [DVec3::new(-0.5, 1.0, 0.0), DVec3::new(0.5, 1.0, 0.0)]);
        let tiny = g.update([DVec3::new(-0.001, 1.0, 0.0), DVec3::new(0.001, 1.0, 0.0)]);
        assert_eq!(tiny.scale, MAX_SCALE);
        let s = o.scaled_about(DVec3::ONE, 1e-6);
        assert_eq!(s.scale, MIN_SCALE);
        assert!(
            (s.point(DVec3::ONE) - DVec3::ONE).length() < 1e-12,
            "pivot fixed"
        );
    }
}
