//! Moving instances: a scene manifest's placement may move (`motion = {
//! spin_deg_s = …, bob_m = …, bob_period_s = … }`), every instance it
//! placed with it. Each placement spins about its own vertical axis and
//! bobs along it; per grid cell the motion starts at its own phase, so a
//! moving grid does not move in lock step.
//!
//! An instance `j` of the placed source, at local transform `N_j` in its
//! placement `P`, stands at `P · M(t) · N_j` at time `t`, where
//! `M(t) = T(0, b·sin(2π(t/T_b + φ)), 0) · R_y(ω·t + 2π·φ)` (a rigid
//! motion in the placement's own frame: the placement's scale and yaw
//! stay). Pure math: the frame driver asks for the moved transforms of a
//! frame and hands only those on to culling and the GPU.

use glam::{DAffine3, DQuat, DVec3};
use rayon::prelude::*;
use serde::Deserialize;

/// Largest spin rate accepted, degrees per second (100 turns a second).
pub const MAX_SPIN_DEG_S: f64 = 36_000.0;
/// Largest bob amplitude accepted, metres in the placement's frame.
pub const MAX_BOB_M: f64 = 1e6;
/// Shortest and longest bob period accepted, seconds.
pub const BOB_PERIOD_S: (f64, f64) = (1e-3, 1e6);

/// How one manifest placement moves.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Motion {
    /// Turn rate about the placement's vertical axis, degrees per second
    /// (positive: counter-clockwise seen from above).
    #[serde(default)]
    pub spin_deg_s: f64,
    /// Amplitude of the vertical bob, metres in the placement's frame.
    #[serde(default)]
    pub bob_m: f64,
    /// Period of the bob, seconds.
    #[serde(default = "default_period")]
    pub bob_period_s: f64,
}

fn default_period() -> f64 {
    2.0
}

impl Motion {
    /// Checks the values: finite, within the documented ranges. Returns
    /// what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.spin_deg_s.is_finite() && self.spin_deg_s.abs() <= MAX_SPIN_DEG_S) {
            return Err(format!(
                "motion spin_deg_s = {:?} must be a number within ±{MAX_SPIN_DEG_S}",
                self.spin_deg_s
            ));
        }
        if !(self.bob_m.is_finite() && self.bob_m.abs() <= MAX_BOB_M) {
            return Err(format!(
                "motion bob_m = {:?} must be a number within ±{MAX_BOB_M}",
                self.bob_m
            ));
        }
        let (lo, hi) = BOB_PERIOD_S;
        if !(self.bob_period_s.is_finite() && (lo..=hi).contains(&self.bob_period_s)) {
            return Err(format!(
                "motion bob_period_s = {:?} must be a number in [{lo}, {hi}] seconds",
                self.bob_period_s
            ));
        }
        Ok(())
    }

    /// Whether it moves at all (a zero spin and bob place statically).
    pub fn moves(&self) -> bool {
        self.spin_deg_s != 0.0 || self.bob_m != 0.0
    }

    /// `M(t)` of a placement at phase `phase` (a fraction of a cycle).
    pub fn at(&self, t: f64, phase: f64) -> DAffine3 {
        let tau = std::f64::consts::TAU;
        // Reduced to one cycle before the trigonometry, so hours of run
        // time keep full precision.
        let turn = (self.spin_deg_s * t / 360.0 + phase).rem_euclid(1.0);
        let bob = if self.bob_m == 0.0 {
            0.0
        } else {
            let cycle = (t / self.bob_period_s + phase).rem_euclid(1.0);
            self.bob_m * (tau * cycle).sin()
        };
        DAffine3::from_rotation_translation(
            DQuat::from_rotation_y(tau * turn),
            DVec3::new(0.0, bob, 0.0),
        )
    }
}

/// The phase of grid cell `k`: the fractional part of `k` times the
/// golden ratio's conjugate, spreading any number of cells evenly over a
/// cycle (Weyl's equidistribution of `k·α mod 1` for irrational `α`).
pub fn cell_phase(k: usize) -> f64 {
    (k as f64 * 0.618_033_988_749_894_9).fract()
}

/// The placements of one moving manifest entry.
#[derive(Clone, Debug, PartialEq)]
pub struct MovingGroup {
    /// How they move.
    pub motion: Motion,
    /// The placed source's instances: scene mesh index and transform
    /// relative to the placement.
    pub locals: Vec<(u32, DAffine3)>,
    /// Per placement: its transform, its phase, and the scene index of
    /// its first instance (its instances follow in `locals` order).
    pub placements: Vec<(DAffine3, f64, u32)>,
}

impl MovingGroup {
    /// Instances that move with this group.
    pub fn len(&self) -> usize {
        self.locals.len() * self.placements.len()
    }

    /// True when nothing moves with it.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One instance's transform at a frame's time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moved {
    /// Scene instance index.
    pub index: u32,
    /// Its mesh.
    pub mesh: u32,
    /// Object-to-world transform at that time.
    pub transform: DAffine3,
}

/// Every moving instance of `groups` at time `t` seconds, into `out`
/// (cleared first), in scene instance order within each group.
pub fn transforms_at(groups: &[MovingGroup], t: f64, out: &mut Vec<Moved>) {
    out.clear();
    for g in groups {
        let start = out.len();
        out.resize(
            start + g.len(),
            Moved {
                index: 0,
                mesh: 0,
                transform: DAffine3::IDENTITY,
            },
        );
        let n = g.locals.len().max(1);
        out[start..]
            .par_chunks_mut(n)
            .zip(g.placements.par_iter())
            .with_min_len(64)
            .for_each(|(chunk, &(place, phase, first))| {
                let m = place * g.motion.at(t, phase);
                for (j, (slot, &(mesh, local))) in chunk.iter_mut().zip(&g.locals).enumerate() {
                    *slot = Moved {
                        index: first + j as u32,
                        mesh,
                        transform: m * local,
                    };
                }
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn close(a: DAffine3, b: DAffine3, tol: f64) -> bool {
        a.matrix3.abs_diff_eq(b.matrix3, tol) && a.translation.abs_diff_eq(b.translation, tol)
    }

    #[test]
    fn a_spin_turns_by_its_rate_and_a_bob_returns_after_its_period() {
        let m = Motion {
            spin_deg_s: 90.0,
            bob_m: 0.5,
            bob_period_s: 4.0,
        };
        // One second: a quarter turn, +X goes to -Z; a quarter period up.
        let a = m.at(1.0, 0.0);
        assert!(a
            .transform_vector3(DVec3::X)
            .abs_diff_eq(DVec3::NEG_Z, 1e-12));
        assert!((a.translation.y - 0.5).abs() < 1e-12);
        // A whole bob period later the height is back; the spin is 360°.
        assert!(close(m.at(0.0, 0.0), DAffine3::IDENTITY, 1e-12));
        assert!(close(m.at(4.0, 0.0), DAffine3::IDENTITY, 1e-12));
        assert!(!Motion {
            spin_deg_s: 0.0,
            bob_m: 0.0,
            bob_period_s: 2.0
        }
        .moves());
    }

    #[test]
    fn hours_of_run_time_keep_the_motion_exact() {
        let m = Motion {
            spin_deg_s: 33.0,
            bob_m: 0.25,
            bob_period_s: 1.5,
        };
        // t and t + one common period (the spin's 360/33 s and the bob's
        // 1.5 s meet every 120 s) give the same transform after 10 hours.
        let t = 36_000.0 + 0.37;
        assert!(close(m.at(t, 0.3), m.at(t + 120.0, 0.3), 1e-9));
    }

    #[test]
    fn bad_values_name_the_key() {
        let ok = Motion {
            spin_deg_s: 10.0,
            bob_m: 0.1,
            bob_period_s: 2.0,
        };
        assert!(ok.validate().is_ok());
        for (m, key) in [
            (
                Motion {
                    spin_deg_s: f64::NAN,
                    ..ok
                },
                "spin_deg_s",
            ),
            (
                Motion {
                    bob_m: f64::INFINITY,
                    ..ok
                },
                "bob_m",
            ),
            (
                Motion {
                    bob_period_s: 0.0,
                    ..ok
                },
                "bob_period_s",
            ),
            (
                Motion {
                    spin_deg_s: 1e9,
                    ..ok
                },
                "spin_deg_s",
            ),
        ] {
            let e = m.validate().unwrap_err();
            assert!(e.contains(key), "{e}");
        }
    }

    #[test]
    fn cell_phases_spread_over_the_cycle() {
        // 1000 cells: every tenth of the cycle holds 100 ± 5 of them.
        let mut bins = [0u32; 10];
        for k in 0..1000 {
            let p = cell_phase(k);
            assert!((0.0..1.0).contains(&p));
            bins[(p * 10.0) as usize] += 1;
        }
        assert!(bins.iter().all(|&b| (95..=105).contains(&b)), "{bins:?}");
    }

    proptest! {
        /// Every moved instance equals the brute-force product
        /// `P · M(t) · N_j`, carries its own index and mesh, and keeps the
        /// placement's scale (the motion is rigid).
        #[test]
        fn moved_transforms_equal_the_brute_force_product(
            spin in -720.0f64..720.0,
            bob in -3.0f64..3.0,
            period in 0.1f64..10.0,
            t in 0.0f64..1000.0,
            scale in 0.01f64..100.0,
            cells in 1usize..40,
            locals in 1usize..5,
        ) {
            let motion = Motion { spin_deg_s: spin, bob_m: bob, bob_period_s: period };
            let group = MovingGroup {
                motion,
                locals: (0..locals)
                    .map(|j| (j as u32 * 3, DAffine3::from_translation(DVec3::new(j as f64, 1.0, -2.0))))
                    .collect(),
                placements: (0..cells)
                    .map(|k| {
                        let p = DAffine3::from_scale_rotation_translation(
                            DVec3::splat(scale),
                            DQuat::from_rotation_y(k as f64),
                            DVec3::new(10.0 * k as f64, 0.0, 5.0),
                        );
                        (p, cell_phase(k), 7 + (k * locals) as u32)
                    })
                    .collect(),
            };
            let mut out = Vec::new();
            transforms_at(std::slice::from_ref(&group), t, &mut out);
            prop_assert_eq!(out.len(), cells * locals);
            for (i, m) in out.iter().enumerate() {
                let (k, j) = (i / locals, i % locals);
                let (p, phase, first) = group.placements[k];
                let want = p * motion.at(t, phase) * group.locals[j].1;
                prop_assert_eq!(m.index, first + j as u32);
                prop_assert_eq!(m.mesh, group.locals[j].0);
                prop_assert!(close(m.transform, want, 1e-9 * (1.0 + scale * 400.0)));
                let s = m.transform.matrix3.x_axis.length();
                prop_assert!((s - scale).abs() <= 1e-9 * scale);
            }
        }
    }
}
