//! The culling volumes as seen by the traversal: a node is classified as
//! outside, inside or straddling; an instance is kept or rejected. Each
//! volume carries a small mask of still-unresolved tests, so a child skips
//! the planes (or cone parts) its parent was already fully inside of
//! (plane masking, Assarsson & Möller, "Optimized View Frustum Culling
//! Algorithms for Bounding Boxes", 2000).

use glam::DVec3;

use crate::view::cone::{sphere_slack, Cone};
use crate::view::frustum::PlaneSet;

/// Result of testing a hierarchy node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// Every instance below is rejected.
    Outside,
    /// Every instance below is kept.
    Inside,
    /// Undecided; the mask says which tests remain.
    Partial(u8),
}

/// A volume the hierarchy and the brute-force scan can test against.
pub trait Volume: Sync {
    /// Mask with every test still to do.
    fn full_mask(&self) -> u8;
    /// Classifies a node box. Must be consistent with `keeps`: `Outside`
    /// only if `keeps` rejects every box inside, `Inside` only if it keeps
    /// every box inside, and a cleared mask bit only if that part of `keeps`
    /// passes for every box inside.
    fn classify(&self, min: DVec3, max: DVec3, mask: u8) -> Class;
    /// Tests one instance box with the tests left in `mask`.
    fn keeps(&self, min: DVec3, max: DVec3, mask: u8) -> bool;
}

impl Volume for PlaneSet {
    fn full_mask(&self) -> u8 {
        ((1u16 << self.len) - 1) as u8
    }

    #[inline]
    fn classify(&self, min: DVec3, max: DVec3, mask: u8) -> Class {
        let (a, b) = (min - self.origin, max - self.origin);
        let mut m = mask;
        let mut bits = mask;
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let p = &self.planes[i];
            // Both evaluations round monotonically, so a contained box can
            // neither exceed the node's max nor fall below its min.
            if p.max_over_box(a, b) < 0.0 {
                return Class::Outside;
            }
            if p.min_over_box(a, b) >= 0.0 {
                m &= !(1 << i);
            }
        }
        if m == 0 {
            Class::Inside
        } else {
            Class::Partial(m)
        }
    }

    #[inline]
    fn keeps(&self, min: DVec3, max: DVec3, mask: u8) -> bool {
        let (a, b) = (min - self.origin, max - self.origin);
        let mut bits = mask;
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            if self.planes[i].max_over_box(a, b) < 0.0 {
                return false;
            }
        }
        true
    }
}

/// Mask bit of the cone's lateral test.
const CONE_SIDE: u8 = 1;
/// Mask bit of the cone's far plane.
const CONE_FAR: u8 = 2;

impl Volume for Cone {
    fn full_mask(&self) -> u8 {
        CONE_SIDE | if self.far.is_some() { CONE_FAR } else { 0 }
    }

    /// Node test: any box inside the node box has its circumscribed sphere
    /// inside the ball of radius `√2 · R` around the node centre (`R` the
    /// node's half-diagonal): with half-extents `e ≤ E` and centre offset
    /// `|c' - c| ≤ |E - e|`, `|E - e| + |e| ≤ √2 |E|` because
    /// `|E - e|² + |e|² ≤ |E|²` for `0 ≤ e ≤ E` (Cauchy–Schwarz). Both cone
    /// bounds are 1-Lipschitz, so deciding on that inflated ball, with a
    /// rounding slack larger than the instance test's, agrees with every
    /// instance below.
    #[inline]
    fn classify(&self, min: DVec3, max: DVec3, mask: u8) -> Class {
        let (a, b) = (min - self.apex, max - self.apex);
        let d = (a + b) * 0.5;
        let big = (b - a).length() * 0.5 * std::f64::consts::SQRT_2;
        let slack = 1e-9 * (1.0 + d.length() + big);
        let mut m = mask;
        if m & CONE_SIDE != 0 {
            let s = self.surface_bound(d);
            if s > big + slack {
                return Class::Outside;
            }
            if -s >= big + slack {
                m &= !CONE_SIDE;
            }
        }
        if m & CONE_FAR != 0 {
            if let Some(f) = self.far {
                let h = f.normal.dot(d);
                if h - big > f.depth + slack {
                    return Class::Outside;
                }
                if h + big <= f.depth - slack {
                    m &= !CONE_FAR;
                }
            }
        }
        if m == 0 {
            Class::Inside
        } else {
            Class::Partial(m)
        }
    }

    #[inline]
    fn keeps(&self, min: DVec3, max: DVec3, mask: u8) -> bool {
        let (a, b) = (min - self.apex, max - self.apex);
        let d = (a + b) * 0.5;
        let r = (b - a).length() * 0.5;
        let slack = sphere_slack(d, r);
        if mask & CONE_SIDE != 0 && self.surface_bound(d) > r + slack {
            return false;
        }
        if mask & CONE_FAR != 0 {
            if let Some(f) = self.far {
                if f.normal.dot(d) - r > f.depth + slack {
                    return false;
                }
            }
        }
        true
    }
}
