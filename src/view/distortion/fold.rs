//! Exact checks that a lens does not fold over or blow up inside its
//! visible radius, where sampling could step over a narrow fault.
//!
//! Both models reduce to the sign of a cubic on an interval. A cubic's
//! minimum on a closed interval lies at an endpoint or at a critical
//! point, a root of its derivative (a quadratic, solved in closed form),
//! so evaluating it there decides the sign exactly up to rounding.
//! - PanoTools (Dersch's `radial` with coefficients a, b, c, d, per
//!   channel scaled by s): g(r) = s·r·(a r³ + b r² + c r + d), so
//!   g'(r) = s·(4a r³ + 3b r² + 2c r + d) must stay positive on [0, r_max].
//! - DPOLY3 (Monado's Vive model): D(r) = 1 / (1 + k1 r² + k2 r⁴ + k3 r⁶)
//!   plus k4 has a pole where the cubic 1 + k1 q + k2 q² + k3 q³ in
//!   q = r² reaches zero; it must stay positive on [0, r_max²].

/// The least value of the cubic `c[0] + c[1] x + c[2] x² + c[3] x³` on
/// [`lo`, `hi`] (its endpoints and the real critical points inside).
pub fn cubic_min(c: [f64; 4], lo: f64, hi: f64) -> f64 {
    let at = |x: f64| ((c[3] * x + c[2]) * x + c[1]) * x + c[0];
    let mut least = at(lo).min(at(hi));
    // c'(x) = 3 c3 x² + 2 c2 x + c1.
    let (a, b, k) = (3.0 * c[3], 2.0 * c[2], c[1]);
    let mut roots = Vec::with_capacity(2);
    if a == 0.0 {
        if b != 0.0 {
            roots.push(-k / b);
        }
    } else {
        let disc = b * b - 4.0 * a * k;
        if disc >= 0.0 {
            // The numerically stable pair: q = −(b + sign(b)·√disc) / 2,
            // roots q / a and k / q.
            let sign = if b >= 0.0 { 1.0 } else { -1.0 };
            let q = -0.5 * (b + sign * disc.sqrt());
            if q != 0.0 {
                roots.push(q / a);
                roots.push(k / q);
            } else {
                roots.push(0.0);
            }
        }
    }
    for x in roots {
        if x > lo && x < hi {
            least = least.min(at(x));
        }
    }
    least
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn the_minimum_is_at_most_every_sample_and_attained(
            c in prop::array::uniform4(-10.0f64..10.0),
            lo in -2.0f64..1.0,
            span in 0.01f64..3.0,
        ) {
            let hi = lo + span;
            let at = |x: f64| ((c[3] * x + c[2]) * x + c[1]) * x + c[0];
            let m = cubic_min(c, lo, hi);
            let scale = 1.0 + c.iter().map(|v| v.abs()).sum::<f64>() * 30.0;
            let mut sampled = f64::INFINITY;
            for i in 0..=4000 {
                let x = lo + span * i as f64 / 4000.0;
                let v = at(x);
                sampled = sampled.min(v);
                prop_assert!(m <= v + 1e-9 * scale, "min {m} above f({x}) = {v}");
            }
            // Dense sampling comes within its step of the true minimum.
            prop_assert!(sampled - m <= 1e-4 * scale, "min {m}, sampled {sampled}");
        }
    }

    #[test]
    fn a_narrow_dip_between_samples_is_found() {
        // (x − m)² (x + 1) − δ: below zero only within about 1e-5 of m,
        // which a thousand samples step over.
        let (m, delta) = (0.50037, 1e-10);
        let c = [m * m - delta, m * m - 2.0 * m, 1.0 - 2.0 * m, 1.0];
        assert!(cubic_min(c, 0.0, 1.0) < 0.0);
        let sampled = (0..=1000)
            .map(|i| i as f64 / 1000.0)
            .map(|x| ((c[3] * x + c[2]) * x + c[1]) * x + c[0])
            .fold(f64::INFINITY, f64::min);
        assert!(sampled > 0.0, "{sampled}");
    }
}
