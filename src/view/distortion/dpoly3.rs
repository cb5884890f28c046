//! Valve's DPOLY3 radial model as Monado evaluates it
//! (`src/xrt/auxiliary/util/u_distortion_mesh.c`, `u_compute_distortion_vive`):
//! per colour channel, with r² measured in the eye's normalised panel
//! coordinates ([-1, 1] across the eye's width, y divided by the panel's
//! `physical_aspect_x_over_y`, the channel's centre subtracted),
//!
//!   D(r) = 1 / (1 + k1·r² + k2·r⁴ + k3·r⁶) + k4,
//!
//! and the panel point samples the eye image at q·D(r) (k4 is the "scaled"
//! part of DISTORT_DPOLY3_SCALED; Vive configurations leave it 0). Writing
//! B = 1 + k1 s + k2 s² + k3 s³ with s = r², the derivative is
//! D'(r) = −(k1 + 2 k2 s + 3 k3 s²)·2r / B².
//!
//! Where the lens coordinates of [`super`] sit on the panel follows from the
//! same function: q = ((2u − 1) − c_x, (2v − 1)/aspect − c_y), i.e. lens
//! centre ((1 + c_x)/2, (1 + aspect·c_y)/2) and unit (½, aspect/2) in panel
//! uv; Monado's `grow_for_undistort` and centre enter the eye-image side
//! (the profile's FOV and lens axis, see `manifests/hmd/vive.toml`).

/// DPOLY3 coefficients k1..k4 for red, green and blue.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dpoly3 {
    /// Per channel (red, green, blue): k1, k2, k3, k4.
    pub k: [[f64; 4]; 3],
}

impl Dpoly3 {
    /// D_k(r) and D_k'(r) for channel index `channel` (0 red, 1 green, 2 blue).
    pub fn factor(&self, channel: usize, r: f64) -> (f64, f64) {
        let [k1, k2, k3, k4] = self.k[channel];
        let s = r * r;
        let bottom = 1.0 + s * (k1 + s * (k2 + s * k3));
        let value = 1.0 / bottom + k4;
        let slope = -(k1 + s * (2.0 * k2 + 3.0 * k3 * s)) * 2.0 * r / (bottom * bottom);
        (value, slope)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factor_matches_monados_expression_and_a_finite_difference() {
        // Green channel of the Vive dump in libsurvive's redist/test.config.json.
        let p = Dpoly3 {
            k: [
                [
                    -0.1857388028229403,
                    -0.08608016110632045,
                    -0.009303358857686194,
                    0.0,
                ],
                [
                    -0.2218608508704322,
                    -0.0314973006170816,
                    -0.03811043372221242,
                    0.0,
                ],
                [
                    -0.2596104389948281,
                    0.0245967965162329,
                    -0.06998774577973522,
                    0.0,
                ],
            ],
        };
        for ch in 0..3 {
            let [k1, k2, k3, k4] = p.k[ch];
            for r in [0.0, 0.2, 0.7, 1.05] {
                let r2 = r * r;
                let expect = 1.0 / (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))) + k4;
                let (v, s) = p.factor(ch, r);
                assert!((v - expect).abs() < 1e-15);
                let h = 1e-6;
                let fd = (p.factor(ch, r + h).0 - p.factor(ch, (r - h).abs()).0) / (2.0 * h);
                if r > 0.0 {
                    assert!((s - fd).abs() < 1e-7, "{ch} {r}: {s} vs {fd}");
                }
            }
            assert_eq!(p.factor(ch, 0.0), (1.0, 0.0));
        }
    }
}
