//! Inverting a lens's radial map: given an undistorted radius ρ, find the
//! panel radius r with g(r) = r·D(r) = ρ.
//!
//! Method: Newton's iteration safeguarded by bisection ("rtsafe", Press et
//! al., *Numerical Recipes*, 3rd ed., §9.4). The profile loader checks that g
//! is strictly increasing on [0, r_max] ([`super::Lens::validate`]), so the
//! root is unique there and [0, r_max] brackets it. Each step keeps the
//! bracket [lo, hi] with g(lo) ≤ ρ ≤ g(hi); a Newton step is taken only when
//! it lands strictly inside the bracket and shrinks the step at least by half
//! compared with the step before, otherwise the bracket is bisected. The
//! iterate therefore never leaves [lo, hi] and cannot jump to another root
//! of g − ρ outside the visible lens (real lens polynomials fold over beyond
//! it), and the bracket at least halves every two steps, so the iteration
//! ends after at most about 2·log2(r_max/ε) steps whatever the polynomial.

/// Most iterations: bisection alone reaches 2^-100 of the bracket.
const MAX_STEPS: usize = 200;

/// The r in [0, `hi`] with `g(r).0 = target`, where `g` returns the value
/// and the derivative of an increasing function with g(0) = 0. None when
/// `target` is not finite, negative, or beyond g(hi) (outside the visible
/// lens).
pub fn solve_increasing(g: impl Fn(f64) -> (f64, f64), target: f64, hi: f64) -> Option<f64> {
    if !target.is_finite() || target < 0.0 || !hi.is_finite() || hi <= 0.0 {
        return None;
    }
    let (g_hi, _) = g(hi);
    let tol = 1e-15 * target.max(1.0);
    if target > g_hi + tol {
        return None;
    }
    if target >= g_hi {
        return Some(hi);
    }
    if target == 0.0 {
        return Some(0.0);
    }
    let (mut lo, mut hi) = (0.0f64, hi);
    let (_, slope0) = g(0.0);
    let mut r = if slope0 > 0.0 {
        (target / slope0).clamp(lo, hi)
    } else {
        0.5 * hi
    };
    let mut last_step = hi - lo;
    for _ in 0..MAX_STEPS {
        let (value, slope) = g(r);
        let f = value - target;
        if f.abs() <= tol {
            return Some(r);
        }
        if f < 0.0 {
            lo = r;
        } else {
            hi = r;
        }
        let newton = r - f / slope;
        let step = (newton - r).abs();
        let next = if slope > 0.0 && newton > lo && newton < hi && step <= 0.5 * last_step {
            last_step = step;
            newton
        } else {
            last_step = hi - lo;
            0.5 * (lo + hi)
        };
        if (next - r).abs() <= 1e-16 * r.max(1.0) || hi - lo <= 1e-16 * hi.max(1.0) {
            return Some(next);
        }
        r = next;
    }
    Some(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn cubic(a: f64, b: f64, c: f64, d: f64) -> impl Fn(f64) -> (f64, f64) {
        move |r: f64| {
            let dv = ((a * r + b) * r + c) * r + d;
            let dd = (3.0 * a * r + 2.0 * b) * r + c;
            (r * dv, dv + r * dd)
        }
    }

    #[test]
    fn identity_map_returns_the_target() {
        let g = |r: f64| (r, 1.0);
        assert_eq!(solve_increasing(g, 0.25, 1.0), Some(0.25));
        assert_eq!(solve_increasing(g, 1.0, 1.0), Some(1.0));
        assert_eq!(solve_increasing(g, 0.0, 1.0), Some(0.0));
    }

    #[test]
    fn out_of_range_and_non_finite_targets_are_none() {
        let g = |r: f64| (r, 1.0);
        assert_eq!(solve_increasing(g, 1.5, 1.0), None);
        assert_eq!(solve_increasing(g, -0.1, 1.0), None);
        assert_eq!(solve_increasing(g, f64::NAN, 1.0), None);
        assert_eq!(solve_increasing(g, f64::INFINITY, 1.0), None);
    }

    #[test]
    fn the_root_inside_the_bracket_is_found_when_the_polynomial_folds_outside() {
        // g(r) = r(1 + 0.5r - 0.3r^3): increasing on [0, 1], folding later;
        // g - target has a second root beyond r = 1 that Newton from a bad
        // start would reach.
        let g = cubic(-0.3, 0.0, 0.5, 1.0);
        for target in [0.01, 0.4, 0.9, 1.19] {
            let r = solve_increasing(&g, target, 1.0).expect("inside");
            assert!((0.0..=1.0).contains(&r));
            assert!((g(r).0 - target).abs() < 1e-12, "{target}: {r}");
        }
    }

    proptest! {
        /// Against brute force: the root agrees with a 1e5-step scan.
        #[test]
        fn agrees_with_a_dense_scan(a in -0.2f64..0.5, b in -0.2f64..0.5, c in 0.0f64..0.5,
                                    frac in 0.0f64..1.0) {
            let g = cubic(a, b, c, 1.0);
            let hi = 1.0;
            // Only increasing maps are valid input.
            let n = 100_000;
            let increasing = (0..n).all(|i| {
                let r0 = hi * i as f64 / n as f64;
                let r1 = hi * (i + 1) as f64 / n as f64;
                g(r1).0 > g(r0).0
            });
            prop_assume!(increasing);
            let target = frac * g(hi).0;
            let r = solve_increasing(&g, target, hi).expect("inside");
            let scan = (0..=n)
                .map(|i| hi * i as f64 / n as f64)
                .min_by(|x, y| (g(*x).0 - target).abs().total_cmp(&(g(*y).0 - target).abs()))
                .unwrap();
            prop_assert!((r - scan).abs() <= 2.0 * hi / n as f64, "r {r} scan {scan}");
            prop_assert!((g(r).0 - target).abs() < 1e-12);
        }
    }
}
