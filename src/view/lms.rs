//! Lens-matched shading (`--opt lms`): the eye image rendered into a
//! smaller image whose pixel density falls off towards the edges as the
//! lens's demand does, then resampled to the rectilinear eye image the
//! runtime expects.
//!
//! The eye image is split at its centre into four quadrants. Each quadrant
//! is drawn with a modified clip-space w (NVIDIA's "clip-space w scaling",
//! `VK_NV_clip_space_w_scaling`; Vulkan spec, "Controlling Viewport W
//! Scaling"):
//!
//! ```text
//!   w' = w + cx·x + cy·y        cx = ±a, cy = ±b (signs of the quadrant)
//! ```
//!
//! so an eye NDC point (x, y) lands at LMS NDC
//! `(x, y) / D` with `D = 1 + a|x| + b|y|`. Within a quadrant this is one
//! linear map of homogeneous clip space (the last row of a 4×4 matrix), so
//! lines stay lines, perspective-correct interpolation stays correct, and
//! at a fixed LMS pixel depth is the eye's depth over the positive constant
//! D, which keeps the depth order. The inverse is `(u, v) · D'` with
//! `D' = 1 / (1 − a|u| − b|v|)`. The map's Jacobian determinant is
//! `1 / D³` (quotient rule on `x / D`, `y / D`), so the LMS image keeps a
//! linear density of `D^(−3/2)` LMS pixels per eye pixel: 1 at the centre,
//! less towards the edges.
//!
//! The LMS image keeps the eye image's pixel scale at the centre (one NDC
//! unit is half the eye image's width in pixels); its extent per side is
//! `1 / (1 + coefficient)` of the eye's half-extent. Each side has one
//! coefficient (left, right, up, down), so the quadrants tile a rectangle.
//!
//! The coefficients come from the HMD profile's lens when it has one
//! ([`fit`]): per quadrant the largest coefficient k (a = b = k) such that
//! every visible panel pixel there is still read at no less than
//! [`KEEP`] of the lens centre's density (lens density × D^(−3/2) ≥
//! KEEP × centre density) — the periphery never becomes much blurrier than
//! the centre already is — and each side takes the smaller of its two
//! quadrants' values. Some loss must be allowed: D grows linearly from the
//! image centre while lens densities stay flat over the central 10–20°
//! (the shipped Vive profile: 0.88 to 0.93 eye pixels per panel pixel out
//! to 20°), so demanding no loss at all leaves every coefficient at 0. Without a lens the
//! coefficient is [`DEFAULT_COEFFICIENT`] or the one `lms=K` gives.

use super::distortion::density::{self, for_each_visible};
use super::distortion::Lens;
use super::Fov;

/// The coefficient when the profile has no lens and `lms=K` gives none:
/// the image edges keep `1.4^(−3/2)` ≈ 60 % of the linear density (the
/// corners 43 %), and the image has (1/1.4)² ≈ 51 % of the eye's pixels.
pub const DEFAULT_COEFFICIENT: f64 = 0.4;

/// The share of the lens centre's sampling density the fit keeps
/// everywhere the panel reads (see the module's derivation).
pub const KEEP: f64 = 0.9;

/// The largest coefficient: with `a + b < 1`, `w' = w(1 + a·x + b·y)`
/// stays positive for every point of the eye's frustum (|x|, |y| ≤ 1 in
/// NDC), whichever quadrant draws it — `VK_NV_clip_space_w_scaling`
/// applies the scaling after clipping against the unscaled frustum, so a
/// non-positive w' would invert triangles inside the scissor.
pub const MAX_COEFFICIENT: f64 = 0.49;

/// The coefficients' quantum: they are rounded down to multiples of
/// 1/1024 so the values the renderer scales with, the resample pass reads
/// (packed as 16-bit integers) and the reports print are the same numbers.
pub const QUANTUM: f64 = 1.0 / 1024.0;

/// The four side coefficients, each in `0..=MAX_COEFFICIENT`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Coefficients {
    /// Left side (eye NDC x < 0).
    pub left: f64,
    /// Right side (x > 0).
    pub right: f64,
    /// Top side (Vulkan NDC y < 0).
    pub up: f64,
    /// Bottom side (y > 0).
    pub down: f64,
}

impl Coefficients {
    /// The same coefficient `k` on every side, quantized and clamped.
    pub fn uniform(k: f64) -> Coefficients {
        let k = quantize(k);
        Coefficients {
            left: k,
            right: k,
            up: k,
            down: k,
        }
    }

    /// The (a, b) pair that applies at eye NDC `(x, y)`.
    pub fn at(&self, x: f64, y: f64) -> (f64, f64) {
        (
            if x < 0.0 { self.left } else { self.right },
            if y < 0.0 { self.up } else { self.down },
        )
    }

    /// The coefficients as 16-bit integers of [`QUANTUM`]s, packed two per
    /// word: (left | right << 16, up | down << 16).
    pub fn packed(&self) -> [u32; 2] {
        let q = |v: f64| (v / QUANTUM).round() as u32 & 0xffff;
        [
            q(self.left) | q(self.right) << 16,
            q(self.up) | q(self.down) << 16,
        ]
    }
}

/// `k` rounded down to a multiple of [`QUANTUM`] within `0..=MAX_COEFFICIENT`
/// (NaN gives 0).
pub fn quantize(k: f64) -> f64 {
    let k = if k.is_nan() { 0.0 } else { k };
    ((k.clamp(0.0, MAX_COEFFICIENT) / QUANTUM).floor()) * QUANTUM
}

/// Eye NDC `(x, y)` → LMS NDC.
pub fn forward(c: &Coefficients, p: [f64; 2]) -> [f64; 2] {
    let (a, b) = c.at(p[0], p[1]);
    let d = 1.0 + a * p[0].abs() + b * p[1].abs();
    [p[0] / d, p[1] / d]
}

/// LMS NDC `(u, v)` → eye NDC (the inverse of [`forward`]; the quadrant is
/// the same on both sides since D > 0).
pub fn inverse(c: &Coefficients, q: [f64; 2]) -> [f64; 2] {
    let (a, b) = c.at(q[0], q[1]);
    let d = 1.0 / (1.0 - a * q[0].abs() - b * q[1].abs());
    [q[0] * d, q[1] * d]
}

/// LMS pixels per eye pixel along a side at eye NDC `(x, y)`: `D^(−3/2)`.
pub fn linear_density(c: &Coefficients, p: [f64; 2]) -> f64 {
    let (a, b) = c.at(p[0], p[1]);
    let d = 1.0 + a * p[0].abs() + b * p[1].abs();
    d.powf(-1.5)
}

/// Where the LMS image lies for an eye image of `eye` pixels: its size and
/// the pixel where eye NDC (0, 0) lands.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Layout {
    /// LMS image size in pixels (width, height).
    pub size: [u32; 2],
    /// The LMS pixel position of eye NDC (0, 0) (whole pixels, so the
    /// centre's pixels line up with the eye image's when its size is even).
    pub centre: [u32; 2],
    /// The eye image's size.
    pub eye: [u32; 2],
}

impl Layout {
    /// The layout for `eye` pixels and coefficients `c`.
    pub fn new(c: &Coefficients, eye: [u32; 2]) -> Layout {
        let half = [eye[0] as f64 * 0.5, eye[1] as f64 * 0.5];
        let lo = [
            (half[0] / (1.0 + c.left)).ceil() as u32,
            (half[1] / (1.0 + c.up)).ceil() as u32,
        ];
        let hi = [
            (half[0] / (1.0 + c.right)).ceil() as u32,
            (half[1] / (1.0 + c.down)).ceil() as u32,
        ];
        Layout {
            size: [(lo[0] + hi[0]).max(1), (lo[1] + hi[1]).max(1)],
            centre: lo,
            eye,
        }
    }

    /// The viewport every quadrant draws with: the eye image's size, placed
    /// so NDC (0, 0) lands on [`Layout::centre`] (x, y, width, height; x
    /// and y may be negative).
    pub fn viewport(&self) -> [f64; 4] {
        let (w, h) = (self.eye[0] as f64, self.eye[1] as f64);
        [
            self.centre[0] as f64 - w * 0.5,
            self.centre[1] as f64 - h * 0.5,
            w,
            h,
        ]
    }

    /// Quadrant `q`'s scissor (x, y, width, height): q's bit 0 set is the
    /// right half, bit 1 the bottom half. Together they tile the image.
    pub fn scissor(&self, q: u32) -> [u32; 4] {
        let (x, w) = if q & 1 == 0 {
            (0, self.centre[0])
        } else {
            (self.centre[0], self.size[0] - self.centre[0])
        };
        let (y, h) = if q & 2 == 0 {
            (0, self.centre[1])
        } else {
            (self.centre[1], self.size[1] - self.centre[1])
        };
        [x, y, w, h]
    }

    /// The fraction of the eye image's pixels the LMS image has.
    pub fn pixel_fraction(&self) -> f64 {
        (self.size[0] as f64 * self.size[1] as f64)
            / (self.eye[0] as f64 * self.eye[1] as f64).max(1.0)
    }

    /// The eye NDC point LMS pixel `p` (continuous) shows: the inverse of
    /// [`Layout::lms_pixel`].
    pub fn eye_ndc(&self, c: &Coefficients, p: [f64; 2]) -> [f64; 2] {
        let q = [
            (p[0] - self.centre[0] as f64) / (self.eye[0] as f64 * 0.5),
            (p[1] - self.centre[1] as f64) / (self.eye[1] as f64 * 0.5),
        ];
        inverse(c, q)
    }

    /// The LMS pixel position (continuous) where eye NDC `p` lands.
    pub fn lms_pixel(&self, c: &Coefficients, p: [f64; 2]) -> [f64; 2] {
        let q = forward(c, p);
        [
            self.centre[0] as f64 + q[0] * self.eye[0] as f64 * 0.5,
            self.centre[1] as f64 + q[1] * self.eye[1] as f64 * 0.5,
        ]
    }
}

/// The signed w-scaling pair (cx, cy) quadrant `q` draws with:
/// `w' = w + cx·x + cy·y` (see [`Layout::scissor`] for q's bits).
pub fn quadrant_scaling(c: &Coefficients, q: u32) -> [f32; 2] {
    let cx = if q & 1 == 0 { -c.left } else { c.right };
    let cy = if q & 2 == 0 { -c.up } else { c.down };
    [cx as f32, cy as f32]
}

/// The coefficients fitted to the lenses of `views` (lens, FOV, eye image
/// size), sampling every `stride`-th panel pixel: see the module's
/// derivation. One set for all views (both eyes share the quadrant layout
/// under multiview), each side the smallest over the views.
pub fn fit(views: &[(&Lens, &Fov, [u32; 2])], stride: u32) -> Coefficients {
    let mut quadrant = [MAX_COEFFICIENT; 4];
    for &(lens, fov, eye) in views {
        let centre = density::linear_density(lens, fov, eye, lens.centre).unwrap_or(1.0);
        let mut samples: [Vec<([f64; 2], f64)>; 4] = Default::default();
        for_each_visible(lens, fov, eye, stride, |s| {
            let [x, y] = s.eye_ndc;
            let q = (x >= 0.0) as usize | ((y >= 0.0) as usize) << 1;
            samples[q].push(([x.abs(), y.abs()], s.density));
        });
        for (q, list) in samples.iter().enumerate() {
            let ok = |k: f64| {
                list.iter().all(|&([x, y], d)| {
                    let dd = 1.0 + k * (x + y);
                    d * dd.powf(-1.5) >= KEEP * centre
                })
            };
            quadrant[q] = quadrant[q].min(largest(ok));
        }
    }
    let side = |a: usize, b: usize| quantize(quadrant[a].min(quadrant[b]));
    Coefficients {
        left: side(0, 2),
        right: side(1, 3),
        up: side(0, 1),
        down: side(2, 3),
    }
}

/// The largest k in `0..=MAX_COEFFICIENT` (to a quantum) for which the
/// monotone predicate `ok` holds (it holds at 0 or the answer is 0).
fn largest(ok: impl Fn(f64) -> bool) -> f64 {
    if ok(MAX_COEFFICIENT) {
        return MAX_COEFFICIENT;
    }
    let (mut lo, mut hi) = (0.0, MAX_COEFFICIENT);
    while hi - lo > QUANTUM * 0.5 {
        let mid = 0.5 * (lo + hi);
        if ok(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn coeffs() -> impl Strategy<Value = Coefficients> {
        (
            0.0..MAX_COEFFICIENT,
            0.0..MAX_COEFFICIENT,
            0.0..MAX_COEFFICIENT,
            0.0..MAX_COEFFICIENT,
        )
            .prop_map(|(l, r, u, d)| Coefficients {
                left: quantize(l),
                right: quantize(r),
                up: quantize(u),
                down: quantize(d),
            })
    }

    proptest! {
        #[test]
        fn eye_ndc_undoes_lms_pixel(c in coeffs(), x in -1.0f64..1.0, y in -1.0f64..1.0, w in 2u32..5000, h in 2u32..5000) {
            let l = Layout::new(&c, [w, h]);
            let p = l.eye_ndc(&c, l.lms_pixel(&c, [x, y]));
            prop_assert!((p[0] - x).abs() < 1e-9 && (p[1] - y).abs() < 1e-9);
        }

        /// The integer form of the layout, ceil(size * 512 / (1024 +
        /// count)) per side, is the layout's (the resample shader computes
        /// the centre so, `lms_resample.frag`).
        #[test]
        fn the_integer_layout_is_the_layouts(c in coeffs(), w in 1u32..65536, h in 1u32..65536) {
            let l = Layout::new(&c, [w, h]);
            let [lr, ud] = c.packed();
            let half = |size: u32, count: u32| (size * 512).div_ceil(1024 + count);
            let centre = [half(w, lr & 0xffff), half(h, ud & 0xffff)];
            prop_assert_eq!(l.centre, centre);
            let size = [centre[0] + half(w, lr >> 16), centre[1] + half(h, ud >> 16)];
            prop_assert_eq!(l.size, [size[0].max(1), size[1].max(1)]);
        }

        #[test]
        fn inverse_undoes_forward(c in coeffs(), x in -1.0f64..1.0, y in -1.0f64..1.0) {
            let q = forward(&c, [x, y]);
            let p = inverse(&c, q);
            prop_assert!((p[0] - x).abs() < 1e-12 && (p[1] - y).abs() < 1e-12);
        }

        /// The map is the projective map the GPU applies: (x, y, w) with
        /// w' = w + cx·x + cy·y, divided, for any positive w.
        #[test]
        fn forward_is_the_w_scaling(c in coeffs(), x in -1.0f64..1.0, y in -1.0f64..1.0, w in 0.01f64..100.0) {
            let q = (x >= 0.0) as u32 | ((y >= 0.0) as u32) << 1;
            let [cx, cy] = quadrant_scaling(&c, q);
            let (xc, yc) = (x * w, y * w);
            let wp = w + cx as f64 * xc + cy as f64 * yc;
            let f = forward(&c, [x, y]);
            prop_assert!((xc / wp - f[0]).abs() < 1e-6 && (yc / wp - f[1]).abs() < 1e-6);
        }

        /// D^(−3/2) against the determinant of the Jacobian by central
        /// differences.
        #[test]
        fn density_matches_finite_differences(c in coeffs(), x in 0.01f64..0.99, y in 0.01f64..0.99, sx in any::<bool>(), sy in any::<bool>()) {
            let p = [if sx { x } else { -x }, if sy { y } else { -y }];
            let h = 1e-6;
            let fx = |dx: f64, dy: f64| forward(&c, [p[0] + dx, p[1] + dy]);
            let (a, b) = (fx(h, 0.0), fx(-h, 0.0));
            let (cc, d) = (fx(0.0, h), fx(0.0, -h));
            let j = [
                [(a[0] - b[0]) / (2.0 * h), (cc[0] - d[0]) / (2.0 * h)],
                [(a[1] - b[1]) / (2.0 * h), (cc[1] - d[1]) / (2.0 * h)],
            ];
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            prop_assert!((det.sqrt() - linear_density(&c, p)).abs() < 1e-5);
        }

        /// Every eye pixel maps inside the LMS image, into its own
        /// quadrant's scissor, and the image is no larger than needed.
        #[test]
        fn layout_holds_the_eye_image(c in coeffs(), w in 2u32..1200, h in 2u32..1200, px in 0.0f64..1.0, py in 0.0f64..1.0) {
            let (w, h) = (w & !1, h & !1);
            let l = Layout::new(&c, [w, h]);
            let p = [px * 2.0 - 1.0, py * 2.0 - 1.0];
            let m = l.lms_pixel(&c, p);
            prop_assert!(m[0] >= -1e-9 && m[0] <= l.size[0] as f64 + 1e-9);
            prop_assert!(m[1] >= -1e-9 && m[1] <= l.size[1] as f64 + 1e-9);
            let q = (p[0] >= 0.0) as u32 | ((p[1] >= 0.0) as u32) << 1;
            let [sx, sy, sw, sh] = l.scissor(q);
            prop_assert!(m[0] >= sx as f64 - 1e-9 && m[0] <= (sx + sw) as f64 + 1e-9);
            prop_assert!(m[1] >= sy as f64 - 1e-9 && m[1] <= (sy + sh) as f64 + 1e-9);
            // The far corners reach within a pixel of the image's edges.
            let far = l.lms_pixel(&c, [1.0, 1.0 - 1e-12]);
            prop_assert!(l.size[0] as f64 - l.lms_pixel(&c, [1.0, 0.0])[0] < 1.0 + 1e-9);
            prop_assert!(far[1] <= l.size[1] as f64 + 1e-9);
            // The viewport puts NDC 0 on the centre.
            let v = l.viewport();
            prop_assert!((v[0] + v[2] * 0.5 - l.centre[0] as f64).abs() < 1e-9);
        }
    }

    #[test]
    fn quadrants_tile_the_image() {
        let c = Coefficients {
            left: 0.1,
            right: 0.3,
            up: 0.2,
            down: 0.45,
        };
        let l = Layout::new(&c, [1000, 800]);
        let area: u64 = (0..4)
            .map(|q| {
                let s = l.scissor(q);
                s[2] as u64 * s[3] as u64
            })
            .sum();
        assert_eq!(area, l.size[0] as u64 * l.size[1] as u64);
        // Zero coefficients: the eye image itself.
        let id = Layout::new(&Coefficients::uniform(0.0), [1000, 800]);
        assert_eq!(id.size, [1000, 800]);
        assert_eq!(id.centre, [500, 400]);
        assert!(
            Layout::new(&Coefficients::uniform(DEFAULT_COEFFICIENT), [1000, 800]).pixel_fraction()
                < 0.52
        );
    }

    #[test]
    fn coefficients_quantize_and_pack() {
        assert_eq!(quantize(f64::NAN), 0.0);
        assert_eq!(quantize(-1.0), 0.0);
        assert!(quantize(5.0) <= MAX_COEFFICIENT);
        let c = Coefficients::uniform(0.4);
        assert_eq!(c.left, 409.0 / 1024.0);
        assert_eq!(c.packed(), [409 | 409 << 16, 409 | 409 << 16]);
    }

    /// The fit against brute force: every visible panel pixel keeps at
    /// least KEEP of the centre's density, and one quantum more breaks that
    /// somewhere (or the coefficient is at its cap).
    #[test]
    fn fit_keeps_the_centre_density_share_and_no_more() {
        let vive = crate::view::profile::HmdProfile::load("vive").unwrap();
        let views: Vec<_> = vive
            .views
            .iter()
            .map(|v| (v.lens.as_ref().unwrap(), &v.fov, v.resolution))
            .collect();
        let c = fit(&views, 8);
        assert!(c.left > 0.0 && c.right > 0.0 && c.up > 0.0 && c.down > 0.0);
        let holds = |c: &Coefficients| {
            views.iter().all(|&(lens, fov, eye)| {
                let centre = linear_density_of(lens, fov, eye);
                let mut ok = true;
                for_each_visible(lens, fov, eye, 8, |s| {
                    ok &= s.density * super::linear_density(c, s.eye_ndc) >= KEEP * centre - 1e-12;
                });
                ok
            })
        };
        assert!(holds(&c));
        // One step more on every side must break it somewhere (unless
        // every side is at its cap).
        let all_more = Coefficients {
            left: (c.left + 2.0 * QUANTUM).min(MAX_COEFFICIENT),
            right: (c.right + 2.0 * QUANTUM).min(MAX_COEFFICIENT),
            up: (c.up + 2.0 * QUANTUM).min(MAX_COEFFICIENT),
            down: (c.down + 2.0 * QUANTUM).min(MAX_COEFFICIENT),
        };
        let capped = [c.left, c.right, c.up, c.down]
            .iter()
            .all(|&v| v + 2.0 * QUANTUM > MAX_COEFFICIENT);
        assert!(capped || !holds(&all_more), "{c:?} is not the largest fit");
    }

    fn linear_density_of(lens: &Lens, fov: &Fov, eye: [u32; 2]) -> f64 {
        density::linear_density(lens, fov, eye, lens.centre).unwrap()
    }
}
