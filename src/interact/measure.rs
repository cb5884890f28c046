//! Measuring: two presses place two points on surfaces, the distance
//! between them is shown in metres to the millimetre, and a third press
//! starts over.

use glam::DVec3;

/// Resolution of a shown distance, metres.
pub const RESOLUTION_M: f64 = 0.001;

/// A distance rounded to [`RESOLUTION_M`] as its label, e.g. `"2.357 m"`.
pub fn label(distance_m: f64) -> String {
    format!("{:.3} m", round_mm(distance_m))
}

/// `d` rounded to the nearest millimetre (half away from zero).
pub fn round_mm(d: f64) -> f64 {
    (d / RESOLUTION_M).round() * RESOLUTION_M
}

/// The measuring tool's state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Measure {
    /// The first point, once placed.
    pub first: Option<DVec3>,
    /// The second point, once placed.
    pub second: Option<DVec3>,
}

impl Measure {
    /// A press on a surface at `p`: places the first point, then the
    /// second (returning the distance, rounded to the millimetre), and a
    /// third press starts a new measurement at `p`.
    pub fn press(&mut self, p: DVec3) -> Option<f64> {
        match (self.first, self.second) {
            (Some(a), None) => {
                self.second = Some(p);
                Some(round_mm(a.distance(p)))
            }
            _ => {
                *self = Measure {
                    first: Some(p),
                    second: None,
                };
                None
            }
        }
    }

    /// The measured distance, rounded, when both points are placed.
    pub fn distance(&self) -> Option<f64> {
        Some(round_mm(self.first?.distance(self.second?)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interact::raycast::{Ray, SceneQuery};
    use crate::scene::{shapes, Instance, Material, Mesh, Scene};
    use glam::DAffine3;
    use proptest::prelude::*;

    #[test]
    fn three_presses_measure_then_start_over() {
        let mut m = Measure::default();
        assert_eq!(m.press(DVec3::ZERO), None);
        let d = m.press(DVec3::new(1.2344, 0.0, 0.0)).expect("distance");
        assert_eq!(label(d), "1.234 m");
        assert_eq!(m.press(DVec3::ONE), None);
        assert_eq!(m.first, Some(DVec3::ONE));
        assert_eq!(m.distance(), None);
    }

    proptest! {
        /// Two points placed by ray casts on two walls a known distance
        /// apart, far from the origin: the shown distance is within 1 mm.
        #[test]
        fn distances_between_surfaces_are_within_a_millimetre(
            gap in 0.01f64..400.0,
            far in prop::array::uniform3(-5000.0f64..5000.0),
            y in -1.0f64..1.0,
        ) {
            let mut s = Scene::default();
            s.materials.push(Material::default());
            s.primitives.push(shapes::cuboid([0.01, 2.0, 2.0], 0));
            s.meshes.push(Mesh { name: "wall".into(), primitives: vec![0] });
            let base = DVec3::from(far);
            // Inner faces at base.x and base.x + gap.
            for x in [base.x - 0.01, base.x + gap + 0.01] {
                s.instances.push(Instance {
                    mesh: 0,
                    transform: DAffine3::from_translation(DVec3::new(x, base.y, base.z)),
                });
            }
            let q = SceneQuery::new(&s);
            let mid = base + DVec3::new(gap * 0.5, y, 0.3);
            let mut m = Measure::default();
            for dir in [DVec3::NEG_X, DVec3::X] {
                let h = q.cast(&Ray { origin: mid, direction: dir, max_t: 1e4 }).expect("wall");
                m.press(h.point);
            }
            let d = m.distance().expect("measured");
            prop_assert!((d - gap).abs() <= RESOLUTION_M, "{} vs {}", d, gap);
        }
    }
}
