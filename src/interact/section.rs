//! Section planes: a plane held in the hand; geometry on its far side is
//! clipped. The shaders clip per fragment by the signed distance; culling
//! skips instances whose bounds lie wholly beyond, tested here.

use crate::view::Pose;
use glam::DVec3;

/// A plane `n · x + d = 0` with unit normal `n`; points with positive
/// signed distance lie beyond it (are cut away).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SectionPlane {
    /// Unit normal, pointing into the cut-away side.
    pub normal: DVec3,
    /// Offset: `−n · p` for any point `p` on the plane.
    pub d: f64,
}

impl SectionPlane {
    /// The plane through `point` with normal `normal` (normalized; None
    /// for a zero or non-finite normal).
    pub fn through(point: DVec3, normal: DVec3) -> Option<SectionPlane> {
        let n = normal.try_normalize()?;
        point.is_finite().then(|| SectionPlane {
            normal: n,
            d: -n.dot(point),
        })
    }

    /// The plane held by a hand: through the hand's position, cutting away
    /// what lies in front of it (the hand's −Z).
    pub fn from_hand(hand: &Pose) -> Option<SectionPlane> {
        SectionPlane::through(hand.position, hand.forward())
    }

    /// Signed distance of `p` (positive: beyond, cut away).
    pub fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) + self.d
    }

    /// The plane as the four numbers a shader's clip distance takes:
    /// `gl_ClipDistance = −(n · x + d)` keeps the near side.
    pub fn shader_plane(&self) -> [f32; 4] {
        [
            -self.normal.x as f32,
            -self.normal.y as f32,
            -self.normal.z as f32,
            -self.d as f32,
        ]
    }

    /// Whether the box `[lo, hi]` lies wholly beyond the plane, so culling
    /// can skip it: its nearest point along `n` is beyond. For an AABB with
    /// centre `c` and half-extent `h`, the smallest signed distance over
    /// the box is `n · c + d − |n| · h` with `|n|` taken per component
    /// (the box's support in direction −n; Akenine-Möller et al., Real-Time
    /// Rendering 4th ed., §22.10.1 "Plane/Box Intersection").
    pub fn culls_box(&self, lo: DVec3, hi: DVec3) -> bool {
        let c = (lo + hi) * 0.5;
        let h = (hi - lo) * 0.5;
        self.distance(c) - self.normal.abs().dot(h) > 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn box_culling_matches_testing_all_eight_corners(
            n in prop::array::uniform3(-1.0f64..1.0),
            p in prop::array::uniform3(-5.0f64..5.0),
            lo in prop::array::uniform3(-5.0f64..5.0),
            size in prop::array::uniform3(0.0f64..4.0),
        ) {
            let Some(plane) = SectionPlane::through(DVec3::from(p), DVec3::from(n)) else {
                return Ok(());
            };
            let lo = DVec3::from(lo);
            let hi = lo + DVec3::from(size);
            let corners = (0..8).map(|i| DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            ));
            let min = corners.map(|c| plane.distance(c)).fold(f64::INFINITY, f64::min);
            // Away from the boundary both agree exactly.
            prop_assume!(min.abs() > 1e-9);
            prop_assert_eq!(plane.culls_box(lo, hi), min > 0.0);
        }
    }

    #[test]
    fn the_hand_cuts_away_what_is_in_front() {
        let hand = Pose::from_euler_deg(DVec3::new(0.0, 1.0, 0.0), 0.0, 0.0, 0.0);
        let plane = SectionPlane::from_hand(&hand).expect("plane");
        assert!(plane.distance(DVec3::new(0.0, 1.0, -2.0)) > 0.0);
        assert!(plane.culls_box(DVec3::new(-1.0, 0.0, -3.0), DVec3::new(1.0, 2.0, -1.0)));
        assert!(!plane.culls_box(DVec3::new(-1.0, 0.0, -3.0), DVec3::new(1.0, 2.0, 0.5)));
        let [a, b, c, d] = plane.shader_plane();
        // Clip distance positive (kept) behind the hand.
        assert!(a * 0.0 + b * 1.0 + c * 1.0 + d > 0.0);
        assert!(SectionPlane::through(DVec3::ZERO, DVec3::ZERO).is_none());
    }
}
