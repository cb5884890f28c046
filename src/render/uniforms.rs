//! The frame's uniform block: `FrameData` in `shaders/common.glsl` (set 0,
//! binding 0, std140) as a `#[repr(C)]` struct with the same members in the
//! same order. Every member is a mat4 or vec4 (arrays of them have a 16-byte
//! stride), so std140 adds no padding and the Rust layout equals the GLSL
//! one; the tests check the size (11 024 bytes) and every offset against
//! the GLSL block.
//!
//! Positions are camera-relative: the view-projections take world points
//! relative to the render origin (the head), whose f64 position travels
//! split into a high and a low f32 (instance translations are split the same
//! way and recombined on the GPU).

use crate::gpu::memory::Pod;
use crate::interact::overlay::{OverlayBox, MAX_BOXES};
use crate::interact::section::SectionPlane;
use crate::view::{projection, StereoRig, View};
use glam::{DMat3, DVec3, Mat4, Vec3, Vec4};

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
    /// The section plane relative to the render origin as the clip
    /// distance's coefficients: `dot(section.xyz, p) + section.w` is
    /// negative (clipped) beyond the plane; (0, 0, 0, 1) keeps everything.
    pub section: Vec4,
    /// x: the number of overlay boxes in `overlay`.
    pub overlay_info: Vec4,
    /// Overlay boxes (controllers, rays, arcs, markers, labels), four
    /// vec4 each: centre relative to the render origin and red, then the
    /// three half-axis vectors with green, blue and 1.
    pub overlay: [Vec4; 4 * MAX_BOXES],
}

/// Size of [`FrameUniforms`] in bytes (the uniform buffer's size).
pub const SIZE: u64 = std::mem::size_of::<FrameUniforms>() as u64;

const _: () = assert!(
    SIZE == 8 * 64 + (17 + 4 * MAX_BOXES as u64) * 16,
    "FrameUniforms has no padding: 8 mat4s and only vec4s besides"
);
const _: () = assert!(
    SIZE <= 16384,
    "within the smallest maxUniformBufferRange Vulkan allows"
);

/// The clip-distance coefficients of `plane` for positions relative to
/// `origin` (what `FrameUniforms::section` holds): a world point `x = p +
/// origin` is beyond the plane when `n · p + (d + n · origin) > 0`; the
/// offset is formed in f64 so a plane far from the world origin keeps its
/// precision. None keeps everything.
pub fn section_coefficients(plane: Option<&SectionPlane>, origin: DVec3) -> Vec4 {
    match plane {
        Some(p) => {
            let d = p.d + p.normal.dot(origin);
            (-p.normal).as_vec3().extend(-d as f32)
        }
        None => Vec4::new(0.0, 0.0, 0.0, 1.0),
    }
}

/// What the user's tools add to a frame: the section plane and the overlay
/// boxes, set by the frame loop before each frame (the renderer's starting
/// plane is the configuration's `--section`).
#[derive(Clone, Debug, Default)]
pub struct FrameExtras {
    /// The section plane (None: nothing is cut).
    pub section: Option<SectionPlane>,
    /// Controllers, rays, the teleport arc and marker, measure points and
    /// the label, world space.
    pub overlay: Vec<OverlayBox>,
}

impl FrameExtras {
    /// Writes the plane and the boxes into `u` (positions relative to
    /// `origin`, the render origin).
    pub fn apply(&self, u: &mut FrameUniforms, origin: DVec3) {
        u.section = section_coefficients(self.section.as_ref(), origin);
        write_overlay(u, &self.overlay, origin);
    }
}

/// Writes `boxes` (at most [`MAX_BOXES`]; more are dropped) into `u`'s
/// overlay, positions relative to `origin`.
pub fn write_overlay(u: &mut FrameUniforms, boxes: &[OverlayBox], origin: DVec3) {
    let n = boxes.len().min(MAX_BOXES);
    for (i, b) in boxes[..n].iter().enumerate() {
        let [r, g, bl] = b.color;
        u.overlay[4 * i] = (b.center - origin).as_vec3().extend(r);
        u.overlay[4 * i + 1] = b.axes[0].as_vec3().extend(g);
        u.overlay[4 * i + 2] = b.axes[1].as_vec3().extend(bl);
        u.overlay[4 * i + 3] = b.axes[2].as_vec3().extend(1.0);
    }
    u.overlay_info = Vec4::new(n as f32, 0.0, 0.0, 0.0);
}

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
            section: section_coefficients(None, origin),
            overlay_info: Vec4::ZERO,
            overlay: [Vec4::ZERO; 4 * MAX_BOXES],
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
        f.extend([0.0, 0.0, 0.0, 1.0]);
        f.extend(std::iter::repeat_n(0.0, 4 + 16 * MAX_BOXES));
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
            assert_eq!(SIZE, 11024);
            assert_eq!(reference.len() * 4, 11024);
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
            ("section", offset_of!(FrameUniforms, section)),
            ("overlay_info", offset_of!(FrameUniforms, overlay_info)),
            ("overlay", offset_of!(FrameUniforms, overlay)),
            ("<end>", SIZE as usize),
        ];
        let rust: Vec<(String, usize)> = rust.iter().map(|(n, o)| (n.to_string(), *o)).collect();
        assert_eq!(glsl, rust);
    }

    #[test]
    fn section_coefficients_clip_beyond_the_plane_far_from_the_origin() {
        let origin = DVec3::new(1.0e5, 2.0, -3.0e5);
        let plane = SectionPlane::through(origin + DVec3::new(0.5, 0.0, 0.0), DVec3::X).unwrap();
        let c = section_coefficients(Some(&plane), origin);
        let clip = |rel: Vec3| c.truncate().dot(rel) + c.w;
        assert!(clip(Vec3::new(0.49, 0.0, 0.0)) > 0.0, "kept short of it");
        assert!(clip(Vec3::new(0.51, 7.0, -4.0)) < 0.0, "clipped beyond");
        assert!((clip(Vec3::ZERO) - 0.5).abs() < 1e-6);
        assert_eq!(
            section_coefficients(None, origin),
            Vec4::new(0.0, 0.0, 0.0, 1.0)
        );
    }

    #[test]
    fn overlay_boxes_are_written_relative_to_the_origin_and_bounded() {
        let rig = rig();
        let mut u = FrameUniforms::new(&rig, 0.05, [None, None], 8.0);
        let origin = rig.head.position;
        let b = OverlayBox {
            center: origin + DVec3::new(1.0, 2.0, 3.0),
            axes: [DVec3::X * 0.1, DVec3::Y * 0.2, DVec3::Z * 0.3],
            color: [0.25, 0.5, 0.75],
        };
        write_overlay(&mut u, &vec![b; MAX_BOXES + 5], origin);
        assert_eq!(u.overlay_info.x, MAX_BOXES as f32);
        assert_eq!(u.overlay[0], Vec4::new(1.0, 2.0, 3.0, 0.25));
        assert_eq!(u.overlay[2], Vec4::new(0.0, 0.2, 0.0, 0.75));
        assert_eq!(u.overlay[4 * MAX_BOXES - 1], Vec4::new(0.0, 0.0, 0.3, 1.0));
    }
}
