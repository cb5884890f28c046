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
    mask_image_until(area, fov, width, height, &|| false).unwrap_or_default()
}

/// [`mask_image`], asking `stop` once per image row and giving up (None)
/// when it says so (the bench passes the quit flag).
///
/// Cost: a scanline pass. Each triangle contributes, per row it crosses,
/// one span (its exact intersection with the row of pixel centres, edges
/// included) to a difference array of the row; a prefix sum then marks
/// the row. Time is O(Σ rows crossed per triangle + width × height)
/// instead of O(triangles × pixels) for bounding-box tests, so 4096
/// full-height triangles at 1024² cost about 4 M span updates.
pub fn mask_image_until(
    area: &HiddenArea,
    fov: &Fov,
    width: u32,
    height: u32,
    stop: &dyn Fn() -> bool,
) -> Option<Vec<bool>> {
    let [l, r, u, d] = fov.tangents();
    let (w, h) = (width as usize, height as usize);
    let mut out = vec![false; w * h];
    if w == 0 || h == 0 {
        return Some(out);
    }
    let px = |t: f64| (t - l) / (r - l) * width as f64 - 0.5;
    let py = |t: f64| (u - t) / (u - d) * height as f64 - 0.5;
    // Triangles in pixel space with the rows they cross, by first row.
    let mut starts: Vec<Vec<[(f64, f64); 3]>> = vec![Vec::new(); h];
    for tri in area.indices.chunks_exact(3) {
        let Some(p) = tri
            .iter()
            .map(|&i| area.vertices.get(i as usize))
            .collect::<Option<Vec<_>>>()
        else {
            continue;
        };
        let t = [0, 1, 2].map(|k| (px(p[k][0] as f64), py(p[k][1] as f64)));
        let (a, b, c) = (t[0], t[1], t[2]);
        let area2 = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
        if area2 == 0.0 || !area2.is_finite() {
            continue;
        }
        let y_lo = a.1.min(b.1).min(c.1).ceil().max(0.0);
        if y_lo >= h as f64 || a.1.max(b.1).max(c.1) < 0.0 {
            continue;
        }
        starts[y_lo as usize].push(t);
    }
    let mut active: Vec<[(f64, f64); 3]> = Vec::new();
    let mut diff = vec![0i32; w + 1];
    for (y, row_starts) in starts.into_iter().enumerate() {
        if stop() {
            return None;
        }
        let yf = y as f64;
        active.extend(row_starts);
        active.retain(|t| t[0].1.max(t[1].1).max(t[2].1) >= yf);
        if active.is_empty() {
            continue;
        }
        diff.iter_mut().for_each(|v| *v = 0);
        for t in &active {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for (p, q) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                if p.1 == q.1 {
                    if p.1 == yf {
                        lo = lo.min(p.0.min(q.0));
                        hi = hi.max(p.0.max(q.0));
                    }
                } else if yf >= p.1.min(q.1) && yf <= p.1.max(q.1) {
                    let x = p.0 + (yf - p.1) * (q.0 - p.0) / (q.1 - p.1);
                    lo = lo.min(x);
                    hi = hi.max(x);
                }
            }
            let x0 = lo.ceil().max(0.0);
            let x1 = hi.floor().min(w as f64 - 1.0);
            if x0 > x1 {
                continue;
            }
            diff[x0 as usize] += 1;
            diff[x1 as usize + 1] -= 1;
        }
        let mut run = 0;
        for (x, cell) in out[y * w..(y + 1) * w].iter_mut().enumerate() {
            run += diff[x];
            *cell = run > 0;
        }
    }
    Some(out)
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

    /// The bounding-box reference the scanline pass replaced.
    fn brute_force(area: &HiddenArea, fov: &Fov, w: u32, h: u32) -> Vec<bool> {
        let [l, r, u, d] = fov.tangents();
        let mut out = vec![false; (w * h) as usize];
        for tri in area.indices.chunks_exact(3) {
            let p = [tri[0], tri[1], tri[2]].map(|i| area.vertices[i as usize]);
            let q = p.map(|v| {
                (
                    (v[0] as f64 - l) / (r - l) * w as f64 - 0.5,
                    (u - v[1] as f64) / (u - d) * h as f64 - 0.5,
                )
            });
            let edge = |a: (f64, f64), b: (f64, f64), p: (f64, f64)| {
                (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0)
            };
            for y in 0..h {
                for x in 0..w {
                    let c = (x as f64, y as f64);
                    let e = [
                        edge(q[0], q[1], c),
                        edge(q[1], q[2], c),
                        edge(q[2], q[0], c),
                    ];
                    let inside = e.iter().all(|&v| v >= 0.0) || e.iter().all(|&v| v <= 0.0);
                    if inside && e.iter().any(|&v| v != 0.0) {
                        out[(y * w + x) as usize] = true;
                    }
                }
            }
        }
        out
    }

    #[test]
    fn scanline_mask_matches_the_brute_force_reference() {
        let fov = Fov {
            left: -0.9,
            right: 0.7,
            up: 0.8,
            down: -1.0,
        };
        let area = default_hidden_area(&fov);
        let (a, b) = (
            mask_image(&area, &fov, 97, 61),
            brute_force(&area, &fov, 97, 61),
        );
        let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        // Only pixel centres exactly on an edge may round differently.
        assert!(differ <= 4, "{differ} of {} pixels differ", a.len());
    }

    #[test]
    fn many_full_image_triangles_are_cheap_and_stoppable() {
        let fov = Fov::symmetric(0.8, 0.8);
        let mut vertices = Vec::new();
        for k in 0..4096 {
            let t = k as f32 / 4096.0 * 0.01;
            vertices.extend([[-2.0, -2.0 + t], [2.0, -2.0], [0.0, 2.0]]);
        }
        let area = HiddenArea {
            indices: (0..vertices.len() as u32).collect(),
            vertices,
        };
        let t = std::time::Instant::now();
        let m = mask_image(&area, &fov, 512, 512);
        assert!(t.elapsed().as_secs_f64() < 5.0, "{:?}", t.elapsed());
        assert!(m[256 * 512 + 256]);
        let calls = std::cell::Cell::new(0);
        let stopped = mask_image_until(&area, &fov, 512, 512, &|| {
            calls.set(calls.get() + 1);
            calls.get() > 3
        });
        assert!(stopped.is_none());
        assert_eq!(calls.get(), 4);
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
