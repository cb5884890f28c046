//! The PanoTools radial model, as OpenHMD uses it for the Oculus Rift and
//! HTC Vive: a panel point at lens radius r samples the undistorted image at
//! radius r' = r·(a·r³ + b·r² + c·r + d), and chromatic aberration scales r'
//! per colour channel (OpenHMD's "universal distortion" and "universal
//! aberration" values; its shader `examples/opengl/shaders/test1.frag`
//! computes `r * (d + c r + b r² + a r³)` and multiplies by the channel's
//! aberration factor).
//!
//! So the radial factor of channel k is D_k(r) = s_k·(a·r³ + b·r² + c·r + d)
//! and its derivative D_k'(r) = s_k·(3a·r² + 2b·r + c).

/// PanoTools coefficients and the per-channel aberration scales.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Panotools {
    /// a, b, c, d of r' = r·(a r³ + b r² + c r + d).
    pub k: [f64; 4],
    /// Scale of r' for red, green and blue.
    pub chroma: [f64; 3],
}

impl Panotools {
    /// D_k(r) and D_k'(r) for channel index `channel` (0 red, 1 green, 2 blue).
    pub fn factor(&self, channel: usize, r: f64) -> (f64, f64) {
        let [a, b, c, d] = self.k;
        let s = self.chroma[channel];
        let value = ((a * r + b) * r + c) * r + d;
        let slope = (3.0 * a * r + 2.0 * b) * r + c;
        (s * value, s * slope)
    }

    /// The factor as four coefficients of a polynomial in r, lowest power
    /// first, with the channel's scale folded in (for the GPU).
    pub fn cubic(&self, channel: usize) -> [f64; 4] {
        let [a, b, c, d] = self.k;
        let s = self.chroma[channel];
        [s * d, s * c, s * b, s * a]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factor_and_slope_match_the_polynomial_and_a_finite_difference() {
        let p = Panotools {
            k: [0.1, 0.2, 0.3, 1.0],
            chroma: [0.99, 1.0, 1.02],
        };
        for ch in 0..3 {
            for r in [0.0, 0.3, 0.9, 1.4] {
                let (v, s) = p.factor(ch, r);
                let expect = p.chroma[ch] * (0.1 * r * r * r + 0.2 * r * r + 0.3 * r + 1.0);
                assert!((v - expect).abs() < 1e-15);
                let h = 1e-6;
                let fd = (p.factor(ch, r + h).0 - p.factor(ch, r - h).0) / (2.0 * h);
                assert!((s - fd).abs() < 1e-8, "{ch} {r}: {s} vs {fd}");
                let c = p.cubic(ch);
                let poly = c[0] + c[1] * r + c[2] * r * r + c[3] * r * r * r;
                assert!((poly - v).abs() < 1e-15);
            }
        }
    }
}
