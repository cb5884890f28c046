//! Procedural primitives for built-in scenes: boxes and cylinders with
//! normals and UVs, each centred on the origin.

use super::Primitive;
use std::f32::consts::TAU;

/// An axis-aligned box with half-extents `h`, flat-shaded (24 vertices).
pub fn cuboid(h: [f32; 3], material: u32) -> Primitive {
    let mut p = Primitive {
        material,
        ..Primitive::default()
    };
    let faces: [([f32; 3], [f32; 3], [f32; 3]); 6] = [
        ([1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
        ([-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]),
        ([0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ];
    let mut uv = Vec::new();
    for (n, u, v) in faces {
        let base = p.positions.len() as u32;
        for (su, sv) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            let pos = [0, 1, 2].map(|i| (n[i] + su * u[i] + sv * v[i]) * h[i]);
            p.positions.push(pos);
            p.normals.push(n);
            uv.push([(su + 1.0) * 0.5, (1.0 - sv) * 0.5]);
        }
        p.indices
            .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    p.uv0 = Some(uv);
    p.compute_bounds();
    p
}

/// A capped cylinder along +Y with radius `r`, half-height `hh` and
/// `segments` sides (smooth side normals, flat caps).
pub fn cylinder(r: f32, hh: f32, segments: u32, material: u32) -> Primitive {
    let mut p = Primitive {
        material,
        ..Primitive::default()
    };
    let mut uv = Vec::new();
    let s = segments.max(3);
    for i in 0..=s {
        let a = TAU * i as f32 / s as f32;
        let (sin, cos) = a.sin_cos();
        for y in [-hh, hh] {
            p.positions.push([r * cos, y, -r * sin]);
            p.normals.push([cos, 0.0, -sin]);
            uv.push([i as f32 / s as f32, if y > 0.0 { 0.0 } else { 1.0 }]);
        }
    }
    for i in 0..s {
        let b = 2 * i;
        p.indices
            .extend_from_slice(&[b, b + 2, b + 3, b, b + 3, b + 1]);
    }
    for (y, ny) in [(hh, 1.0f32), (-hh, -1.0)] {
        let centre = p.positions.len() as u32;
        p.positions.push([0.0, y, 0.0]);
        p.normals.push([0.0, ny, 0.0]);
        uv.push([0.5, 0.5]);
        for i in 0..=s {
            let a = TAU * i as f32 / s as f32;
            let (sin, cos) = a.sin_cos();
            p.positions.push([r * cos, y, -r * sin]);
            p.normals.push([0.0, ny, 0.0]);
            uv.push([0.5 + 0.5 * cos, 0.5 - 0.5 * sin]);
        }
        for i in 0..s {
            let (a, b) = (centre + 1 + i, centre + 2 + i);
            if ny > 0.0 {
                p.indices.extend_from_slice(&[centre, a, b]);
            } else {
                p.indices.extend_from_slice(&[centre, b, a]);
            }
        }
    }
    p.uv0 = Some(uv);
    p.compute_bounds();
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Every triangle's winding must agree with its vertex normals
    /// (counter-clockwise front faces, as glTF specifies).
    fn assert_outward(p: &Primitive) {
        for t in p.indices.chunks(3) {
            let [a, b, c] = [0, 1, 2].map(|i| Vec3::from_array(p.positions[t[i] as usize]));
            let face = (b - a).cross(c - a);
            let n = Vec3::from_array(p.normals[t[0] as usize]);
            assert!(face.dot(n) > 0.0, "triangle {t:?} winds against its normal");
        }
    }

    #[test]
    fn cuboid_is_closed_and_outward() {
        let p = cuboid([1.0, 2.0, 3.0], 0);
        assert_eq!(p.triangles(), 12);
        assert_eq!(
            p.bounds,
            (Vec3::new(-1.0, -2.0, -3.0), Vec3::new(1.0, 2.0, 3.0))
        );
        assert_outward(&p);
    }

    #[test]
    fn cylinder_is_outward() {
        let p = cylinder(0.5, 2.0, 12, 0);
        assert_eq!(p.triangles(), 12 * 4);
        assert_outward(&p);
    }
}
