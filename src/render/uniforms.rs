//! The frame's uniform block: `FrameData` in `shaders/common.glsl` (set 0,
//! binding 0, std140) as a `#[repr(C)]` struct with the same members in the
//! same order. Every member is a mat4 or vec4 (arrays of them have a 16-byte
//! stride), so std140 adds no padding and the Rust layout equals the GLSL
//! one; the tests check the size (752 bytes) and every offset against the
//! GLSL block.
//!
//! Positions are camera-relative: the view-projections take world points
//! relative to the render origin (the head), whose f64 position travels
//! split into a high and a low f32 (instance translations are split the same
//! way and recombined on the GPU).

use crate::gpu::memory::Pod;
use crate::view::{projection, StereoRig, View};
use glam::{DMat3, Mat4, Vec3, Vec4};

use super::scene_gpu::split_dvec3;

/// The uniform block one frame's shaders read (`FrameData`).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct FrameUniforms {
    /// View-projection per view (reverse-Z, infinite far plane, relative to
    /// the render origin); 0 and 1 are the eyes, 2 and 3 the monoscopic far
    /// field's cameras.
    pub view_proj: [Mat4; 4],
    /// Each view's orientation (world from eye), rotation only.
    pub eye_rot: [Mat4; 4],
    /// Each view's FOV tangents: tan(left), tan(right), tan(up), tan(down).
    pub tangents: [Vec4; 4],
    /// Each view's position relative to the render origin (w = 1).
    pub eye_rel: [Vec4; 4],
    /// Render origin, high f32 part (w = 0).
    pub origin_hi: Vec4,
    /// Render origin, low f32 part (w = 0).
    pub origin_lo: Vec4,
    /// Direction towards the sun, world space (w = 0).
    pub sun_dir: Vec4,
    /// Sun radiance (rgb).
    pub sun_color: Vec4,
    /// Sky colour at the zenith.
    pub sky_zenith: Vec4,
    /// Sky colour at the horizon.
    pub sky_horizon: Vec4,
    /// Ground colour below the horizon.
    pub ground: Vec4,
}

/// Size of [`FrameUniforms`] in bytes (the uniform buffer's size).
pub const SIZE: u64 = std::mem::size_of::<FrameUniforms>() as u64;

const _: () = assert!(
    SIZE == 8 * 64 + 15 * 16,
    "FrameUniforms has no padding: 8 mat4s and 15 vec4s"
);

// SAFETY: repr(C) of f32 matrices and vectors whose sizes add up to the
// struct's (asserted above), so there is no padding.
unsafe impl Pod for FrameUniforms {}

impl FrameUniforms {
    /// The uniforms for `rig`: views 0 and 1 are its eyes (near plane
    /// `near`; a one-view rig repeats the left eye), views 2 and 3 the far
    /// cameras `far` (near plane `far_near`; an absent camera repeats the
    /// other, or the left eye when there is none).
    pub fn new(rig: &StereoRig, near: f64, far: [Option<View>; 2], far_near: f64) -> Self {
        let origin = rig.head.position;
        let views = [
            rig.views[0],
            *rig.views.get(1).unwrap_or(&rig.views[0]),
            far[0].unwrap_or(rig.views[0]),
            far[1].or(far[0]).unwrap_or(rig.views[0]),
        ];
        let near_of = |i: usize| if i >= 2 { far_near } else { near };
        let (hi, lo) = split_dvec3(origin);
        FrameUniforms {
            view_proj: std::array::from_fn(|i| {
                projection::view_projection_f32(&views[i].pose, &views[i].fov, near_of(i), origin)
            }),
            eye_rot: views.map(|v| Mat4::from_mat3(DMat3::from_quat(v.pose.orientation).as_mat3())),
            tangents: views.map(|v| Vec4::from_array(v.fov.tangents().map(|t| t as f32))),
            eye_rel: views.map(|v| (v.pose.position - origin).as_vec3().extend(1.0)),
            origin_hi: Vec3::from_array(hi).extend(0.0),
            origin_lo: Vec3::from_array(lo).extend(0.0),
            sun_dir: Vec3::new(0.35, 0.8, 0.45).normalize().extend(0.0),
            sun_color: Vec4::new(2.6, 2.45, 2.2, 0.0),
            sky_zenith: Vec4::new(0.30, 0.45, 0.75, 1.0),
            sky_horizon: Vec4::new(0.75, 0.80, 0.85, 1.0),
            ground: Vec4::new(0.25, 0.22, 0.20, 1.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::memory::as_bytes;
    use crate::view::{Fov, Pose};
    use glam::DVec3;
    use std::mem::offset_of;

    /// A rig far from the world origin (so the origin's low parts are not
    /// zero) with canted eyes of unequal FOVs.
    fn rig() -> StereoRig {
        let head = Pose::from_euler_deg(DVec3::new(12345.678, 1.7, -9876.54321), 30.0, -10.0, 5.0);
        let eye = |x: f64, yaw: f64, fov: Fov| {
            (
                Pose::from_euler_deg(DVec3::new(x, 0.01, -0.02), yaw, 1.0, 0.0),
                fov,
            )
        };
        let l = Fov {
            left: -0.9,
            right: 0.74,
            up: 0.8,
            down: -0.85,
        };
        let r = Fov {
            left: -0.74,
            right: 0.9,
            up: 0.82,
            down: -0.83,
        };
        StereoRig::from_head(head, &[eye(-0.0315, 5.0, l), eye(0.0315, -5.0, r)])
    }

    /// The float vector the renderer built before the struct, member by
    /// member in the block's order: the reference layout.
    fn float_layout(rig: &StereoRig, near: f64, far: [Option<View>; 2], far_near: f64) -> Vec<f32> {
        let origin = rig.head.position;
        let mut f = Vec::new();
        let views = [
            rig.views[0],
            *rig.views.get(1).unwrap_or(&rig.views[0]),
            far[0].unwrap_or(rig.views[0]),
            far[1].or(far[0]).unwrap_or(rig.views[0]),
        ];
        for (i, v) in views.iter().enumerate() {
            let n = if i >= 2 { far_near } else { near };
            f.extend(projection::view_projection_f32(&v.pose, &v.fov, n, origin).to_cols_array());
        }
        for v in &views {
            f.extend(
                Mat4::from_mat3(DMat3::from_quat(v.pose.orientation).as_mat3()).to_cols_array(),
            );
        }
        for v in &views {
            f.extend(v.fov.tangents().map(|t| t as f32));
        }
        for v in &views {
            f.extend((v.pose.position - origin).as_vec3().extend(1.0).to_array());
        }
        let (hi, lo) = split_dvec3(origin);
        f.extend([hi[0], hi[1], hi[2], 0.0, lo[0], lo[1], lo[2], 0.0]);
        f.extend(
            Vec3::new(0.35, 0.8, 0.45)
                .normalize()
                .extend(0.0)
                .to_array(),
        );
        f.extend([2.6, 2.45, 2.2, 0.0]);
        f.extend([0.30, 0.45, 0.75, 1.0]);
        f.extend([0.75, 0.80, 0.85, 1.0]);
        f.extend([0.25, 0.22, 0.20, 1.0]);
        f
    }

    #[test]
    fn bytes_equal_the_float_layout() {
        let rig = rig();
        let centre = crate::view::mffr::centre_view(&rig).unwrap();
        let second = View {
            pose: rig.views[1].pose,
            fov: centre.fov,
        };
        for far in [
            [None, None],
            [Some(centre), None],
            [Some(centre), Some(second)],
        ] {
            let u = FrameUniforms::new(&rig, 0.05, far, 8.0);
            let reference = float_layout(&rig, 0.05, far, 8.0);
            assert_eq!(SIZE, 752);
            assert_eq!(reference.len() * 4, 752);
            assert_eq!(as_bytes(std::slice::from_ref(&u)), as_bytes(&reference));
        }
    }

    /// std140 offsets of the members of `block` in `source` (mat4 and vec4
    /// members and arrays of them only, which is all `FrameData` holds).
    fn std140_offsets(source: &str, block: &str) -> Vec<(String, usize)> {
        let start = source
            .find(&format!("uniform {block} {{"))
            .expect("block found");
        let body = &source[start..];
        let body = &body[body.find('{').unwrap() + 1..body.find('}').unwrap()];
        let mut offset = 0;
        let mut out = Vec::new();
        for line in body.lines() {
            let decl = line.split("//").next().unwrap().trim();
            let Some(decl) = decl.strip_suffix(';') else {
                continue;
            };
            let (ty, name) = decl.split_once(' ').expect("type and name");
            let size = match ty {
                "mat4" => 64,
                "vec4" => 16,
                other => panic!("{other}: not a type this check knows"),
            };
            let (name, count) = match name.trim().split_once('[') {
                Some((n, c)) => (n, c.trim_end_matches(']').parse::<usize>().unwrap()),
                None => (name.trim(), 1),
            };
            out.push((name.to_string(), offset));
            offset += size * count;
        }
        out.push(("<end>".into(), offset));
        out
    }

    #[test]
    fn offsets_match_the_glsl_block() {
        let glsl = std140_offsets(include_str!("../../shaders/common.glsl"), "FrameData");
        let rust = [
            ("view_proj", offset_of!(FrameUniforms, view_proj)),
            ("eye_rot", offset_of!(FrameUniforms, eye_rot)),
            ("tangents", offset_of!(FrameUniforms, tangents)),
            ("eye_rel", offset_of!(FrameUniforms, eye_rel)),
            ("origin_hi", offset_of!(FrameUniforms, origin_hi)),
            ("origin_lo", offset_of!(FrameUniforms, origin_lo)),
            ("sun_dir", offset_of!(FrameUniforms, sun_dir)),
            ("sun_color", offset_of!(FrameUniforms, sun_color)),
            ("sky_zenith", offset_of!(FrameUniforms, sky_zenith)),
            ("sky_horizon", offset_of!(FrameUniforms, sky_horizon)),
            ("ground", offset_of!(FrameUniforms, ground)),
            ("<end>", SIZE as usize),
        ];
        let rust: Vec<(String, usize)> = rust.iter().map(|(n, o)| (n.to_string(), *o)).collect();
        assert_eq!(glsl, rust);
    }
}
