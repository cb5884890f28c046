//! The pre-baked distortion mesh: a regular grid over the eye image, each
//! vertex placed where the panel shows it (the green channel's inverse map,
//! [`super::Lens::panel_of_tangent`]) and carrying the eye-image uv of each
//! colour channel at that panel point (the forward map), so a pass draws it
//! with no lens math on the GPU. This is the third of the distortion
//! methods (`--distortion mesh`); the grid method computes the same inverse
//! in its vertex shader.

use super::{eye_uv, tangent_of_eye, Lens};
use crate::view::Fov;

/// One vertex: panel position in NDC and the eye uv of red, green, blue.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct MeshVertex {
    /// Panel position in NDC (x right, y down as Vulkan's).
    pub ndc: [f32; 2],
    /// Eye uv of the red channel.
    pub red: [f32; 2],
    /// Eye uv of the green channel.
    pub green: [f32; 2],
    /// Eye uv of the blue channel.
    pub blue: [f32; 2],
}

/// A triangle mesh for one eye.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertices.
    pub vertices: Vec<MeshVertex>,
    /// Triangle list.
    pub indices: Vec<u32>,
}

/// Grid cells per side of the eye image.
pub const GRID_CELLS: u32 = 128;

/// How far the grid reaches beyond the eye image on each side, in eye uv:
/// where a lens's aberration makes red or blue sample inside the image
/// while green samples outside it, the mesh still covers the panel pixel
/// (the sampler's black border gives the channel that is outside), as the
/// per-fragment method does. 5 % covers chromatic scales up to 1.1.
pub const GRID_MARGIN: f64 = 0.05;

/// The panel uv of an eye-image uv through `lens` (green channel), with
/// points the visible lens does not reach pulled onto its rim (their
/// triangles then lie on the rim, where fragments beyond r_max are
/// discarded).
pub fn panel_of_eye(lens: &Lens, fov: &Fov, uv: [f64; 2]) -> [f64; 2] {
    let t = tangent_of_eye(fov, uv);
    if let Some(p) = lens.panel_of_tangent(t, 1) {
        return p;
    }
    let qd = lens.undistorted_of_tangent(t);
    let rho = qd[0].hypot(qd[1]).max(f64::MIN_POSITIVE);
    let s = lens.r_max / rho;
    lens.panel_of_lens([qd[0] * s, qd[1] * s])
}

/// The pre-baked mesh of `cells`×`cells` cells over the eye image of
/// `fov` (with [`GRID_MARGIN`] around it) for `lens`.
pub fn build(lens: &Lens, fov: &Fov, cells: u32) -> Mesh {
    let n = cells.max(1);
    let mut vertices = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
    for j in 0..=n {
        for i in 0..=n {
            let span = 1.0 + 2.0 * GRID_MARGIN;
            let uv = [
                i as f64 / n as f64 * span - GRID_MARGIN,
                j as f64 / n as f64 * span - GRID_MARGIN,
            ];
            let p = panel_of_eye(lens, fov, uv);
            let channel = |k: usize| {
                let t = lens
                    .tangent_of_panel(p, k)
                    .or_else(|| {
                        // On the rim (within rounding of r_max): evaluate there.
                        let q = lens.lens_of_panel(p);
                        let r = q[0].hypot(q[1]);
                        let (d, _) = lens.radial.factor(k, r);
                        Some(lens.tangent_of_undistorted([q[0] * d, q[1] * d]))
                    })
                    .expect("evaluated");
                let e = eye_uv(fov, t);
                [e[0] as f32, e[1] as f32]
            };
            vertices.push(MeshVertex {
                ndc: [(p[0] * 2.0 - 1.0) as f32, (p[1] * 2.0 - 1.0) as f32],
                red: channel(0),
                green: channel(1),
                blue: channel(2),
            });
        }
    }
    let mut indices = Vec::with_capacity((n * n * 6) as usize);
    let at = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
            indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    Mesh { vertices, indices }
}
