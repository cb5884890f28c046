//! The lens-circle default for the HMD stencil mask: when neither the
//! runtime (XR_KHR_visibility_mask) nor the HMD profile gives a hidden-area
//! mesh, the visible area is taken as the ellipse inscribed in the view's
//! tangent-space FOV rectangle, and everything between that ellipse and the
//! rectangle is hidden. For a rectangle of half-extents a, b the inscribed
//! ellipse covers πab of its 4ab, so the default hides 1 − π/4 ≈ 21.5 % of
//! the image (Valve measured 17 % for the Vive's real mask: Vlachos, "Advanced
//! VR Rendering", GDC 2015).
//!
//! Triangulation: rays from the rectangle centre at angles θ, with the
//! ellipse point `c + (a cos θ, b sin θ)` and the rectangle point where the
//! same ray leaves the rectangle, `c + (a cos θ, b sin θ) / max(|cos θ|,
//! |sin θ|)`. Consecutive rays bound a quad of the hidden ring; the four
//! corner rays (θ = 45° + k·90°, where |cos θ| = |sin θ|) are always among the
//! rays, so every quad's outer edge lies on one side of the rectangle and the
//! ring is covered without gaps.

use super::{Fov, HiddenArea};

/// Rays around the ellipse (a multiple of 8, so the corner rays are included).
pub const LENS_SEGMENTS: usize = 64;

/// The hidden-area mesh of the default lens for `fov`, in tangent space
/// (the z = -1 plane), as a triangle list.
pub fn default_hidden_area(fov: &Fov) -> HiddenArea {
    let [l, r, u, d] = fov.tangents();
    let (cx, cy) = ((l + r) * 0.5, (u + d) * 0.5);
    let (a, b) = ((r - l) * 0.5, (u - d) * 0.5);
    let mut vertices = Vec::with_capacity(LENS_SEGMENTS * 6);
    let ray = |k: usize| {
        let t = std::f64::consts::TAU * k as f64 / LENS_SEGMENTS as f64;
        let (s, c) = t.sin_cos();
        let inner = [cx + a * c, cy + b * s];
        let out = 1.0 / c.abs().max(s.abs());
        let outer = [cx + a * c * out, cy + b * s * out];
        (inner, outer)
    };
    for k in 0..LENS_SEGMENTS {
        let (i0, o0) = ray(k);
        let (i1, o1) = ray(k + 1);
        for p in [i0, o0, o1, i0, o1, i1] {
            vertices.push([p[0] as f32, p[1] as f32]);
        }
    }
    let indices = (0..vertices.len() as u32).collect();
    HiddenArea { vertices, indices }
}

/// The fraction of a `width`×`height` image of `fov` whose pixel centres
/// lie inside `area`'s triangles (CPU reference for tests and stats).
pub fn masked_fraction(area: &HiddenArea, fov: &Fov, width: u32, height: u32) -> f64 {
    let mask = mask_image(area, fov, width, height);
    mask.iter().filter(|&&m| m).count() as f64 / mask.len().max(1) as f64
}

/// Per pixel (row-major, top row first): whether its centre lies inside a
/// triangle of `area`. Pixel (x, y) has the tangent-space centre
/// `l + (x + ½)/w·(r − l)`, `u − (y + ½)/h·(u − d)` (image y points down).
pub fn mask_image(area: &HiddenArea, fov: &Fov, width: u32, height: u32) -> Vec<bool> {
    let [l, r, u, d] = fov.tangents();
    let mut out = vec![false; (width * height) as usize];
    let v = |i: u32| {
        let p = area.vertices[i as usize];
        [p[0] as f64, p[1] as f64]
    };
    for tri in area.indices.chunks_exact(3) {
        if tri.iter().any(|&i| i as usize >= area.vertices.len()) {
            continue;
        }
        let (p0, p1, p2) = (v(tri[0]), v(tri[1]), v(tri[2]));
        let px = |t: f64| (t - l) / (r - l) * width as f64 - 0.5;
        let py = |t: f64| (u - t) / (u - d) * height as f64 - 0.5;
        let xs = [px(p0[0]), px(p1[0]), px(p2[0])];
        let ys = [py(p0[1]), py(p1[1]), py(p2[1])];
        let x0 = xs
            .iter()
            .cloned()
            .fold(f64::INFINITY, f64::min)
            .floor()
            .max(0.0) as u32;
        let x1 = xs
            .iter()
            .cloned()
            .fold(f64::NEG_INFINITY, f64::max)
            .ceil()
            .min(width as f64 - 1.0);
        let y0 = ys
            .iter()
            .cloned()
            .fold(f64::INFINITY, f64::min)
            .floor()
            .max(0.0) as u32;
        let y1 = ys
            .iter()
            .cloned()
            .fold(f64::NEG_INFINITY, f64::max)
            .ceil()
            .min(height as f64 - 1.0);
        if x1 < 0.0 || y1 < 0.0 {
            continue;
        }
        let edge = |a: (f64, f64), b: (f64, f64), p: (f64, f64)| {
            (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0)
        };
        let (a, b, c) = ((xs[0], ys[0]), (xs[1], ys[1]), (xs[2], ys[2]));
        for y in y0..=y1 as u32 {
            for x in x0..=x1 as u32 {
                let p = (x as f64, y as f64);
                let (e0, e1, e2) = (edge(a, b, p), edge(b, c, p), edge(c, a, p));
                let inside =
                    (e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0) || (e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0);
                if inside && (e0 != 0.0 || e1 != 0.0 || e2 != 0.0) {
                    out[(y * width + x) as usize] = true;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_lens_hides_one_minus_pi_over_four() {
        for fov in [
            Fov::symmetric(0.74, 0.78),
            Fov {
                left: -0.95,
                right: 0.6,
                up: 0.9,
                down: -1.1,
            },
        ] {
            let area = default_hidden_area(&fov);
            let f = masked_fraction(&area, &fov, 800, 800);
            let want = 1.0 - std::f64::consts::PI / 4.0;
            // The 64-gon inside the ellipse hides a little more than the ellipse.
            assert!((f - want).abs() < 0.01, "{f} vs {want} for {fov:?}");
        }
    }

    #[test]
    fn corners_are_hidden_and_the_centre_is_not() {
        let fov = Fov::symmetric(0.8, 0.8);
        let m = mask_image(&default_hidden_area(&fov), &fov, 100, 100);
        for (x, y) in [(0, 0), (99, 0), (0, 99), (99, 99), (2, 1), (97, 98)] {
            assert!(m[y * 100 + x], "corner pixel ({x}, {y}) visible");
        }
        for (x, y) in [(50, 50), (50, 2), (2, 50), (97, 50), (50, 97)] {
            assert!(!m[y * 100 + x], "pixel ({x}, {y}) inside the lens hidden");
        }
    }

    #[test]
    fn every_vertex_lies_within_the_fov_rectangle() {
        let fov = Fov {
            left: -1.2,
            right: 0.3,
            up: 1.0,
            down: -0.2,
        };
        let [l, r, u, d] = fov.tangents();
        for p in default_hidden_area(&fov).vertices {
            let (x, y) = (p[0] as f64, p[1] as f64);
            assert!(x >= l - 1e-5 && x <= r + 1e-5 && y >= d - 1e-5 && y <= u + 1e-5);
        }
    }
}
