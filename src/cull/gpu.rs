//! The culling volumes of one frame as data for the GPU cull pass
//! (`gpu-cull`): the same planes and cones the CPU strategies test
//! ([`super::Culler`]), re-expressed relative to the render origin in f32,
//! in the std140 layout `shaders/gpu_cull.comp` declares. Pure math: no
//! Vulkan types.
//!
//! The GPU test mirrors [`super::volume::Volume::keeps`]: a plane rejects a
//! box whose p-vertex lies behind it, a cone rejects a box whose
//! circumscribed sphere lies outside a tangent plane or beyond the far
//! plane. The shader evaluates in f32 what the CPU evaluates in f64, so it
//! widens every test by [`GPU_SLACK`] times the magnitudes involved: it may
//! keep a box lying within that distance outside a volume, never drop one
//! the CPU keeps.

use glam::DVec3;

use super::{volumes, CullError, CullParams, Strategy, Volumes};
use crate::view::frustum::Frustum;
use crate::view::StereoRig;

/// Relative slack of the GPU tests: a few f32 ulps (2⁻²⁴ ≈ 6e-8) of the
/// largest magnitude entering a test, times the dozen roundings of a dot
/// product and the box/plane offsets (Higham, "Accuracy and Stability of
/// Numerical Algorithms", 2002, §3.1: a dot product of length n has error at
/// most n·u·Σ|aᵢbᵢ|).
pub const GPU_SLACK: f32 = 1e-6;

/// Volume kind: up to two sets of planes (frusta, a superfrustum).
pub const KIND_PLANES: u32 = 0;
/// Volume kind: up to two cones.
pub const KIND_CONES: u32 = 1;

/// One frame's culling volumes (std140; `Volumes` in gpu_cull.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VolumeData {
    /// x: [`KIND_PLANES`] or [`KIND_CONES`]; y: how many volumes (1 or 2;
    /// an instance is kept when any keeps it); z, w: planes in set 0, 1.
    pub info: [u32; 4],
    /// Plane `i` of set `s` at `6 s + i`: unit inward normal (xyz) and
    /// offset (w), relative to the render origin: kept side `n · p + w ≥ 0`.
    pub planes: [[f32; 4]; 12],
    /// Per cone: apex relative to the render origin (xyz), 1.0 in w when
    /// the cone has a far plane.
    pub cone_apex: [[f32; 4]; 2],
    /// Per cone: unit axis (xyz), cos of the half-angle (w).
    pub cone_axis: [[f32; 4]; 2],
    /// Per cone: far-plane unit normal (xyz), its distance from the apex
    /// along that normal (w).
    pub cone_far: [[f32; 4]; 2],
    /// x, y: sin of the half-angle of cone 0, 1; z: [`GPU_SLACK`].
    pub cone_sin: [f32; 4],
    /// Render origin, high f32 part (xyz).
    pub origin_hi: [f32; 4],
    /// Render origin, low f32 part (xyz).
    pub origin_lo: [f32; 4],
    /// x: instance count; y: dispatch width in instances (threads per row
    /// of workgroups); z, w: unused.
    pub counts: [u32; 4],
    /// A monoscopic far field's split (`mffr`; see [`FarSplitAxes`]):
    /// each eye's and far camera's position relative to the render origin
    /// (xyz; w = 1 when the axis is used) and unit forward direction,
    /// in the order eye 0, eye 1, far 0, far 1.
    pub split_axes: [[f32; 4]; 8],
    /// x: the near test's threshold (split + margin); y: the far test's
    /// (split − margin); z, w: unused.
    pub split: [f32; 4],
    /// The inset's lists (see [`InsetLists`]): x 1 when this frame
    /// divides its instances between the wide views (first command set)
    /// and the inset (second); y 1 when the wide views have a hole; z, w
    /// unused.
    pub inset_info: [u32; 4],
    /// Side planes relative to the render origin (normal, offset): each
    /// eye's volume through the inset at 0..4 and 4..8, through the core
    /// at 8..12 and 12..16.
    pub inset_planes: [[f32; 4]; 16],
}

/// Bytes of [`VolumeData`]: 3 uvec4 and 46 vec4, no padding.
pub const VOLUME_DATA_SIZE: usize = 49 * 16;

/// The inset's two lists with `gpu-cull`, as the CPU batcher makes them
/// (`Batcher::build_inset`): the inset views draw what one eye's volume
/// through the inset rectangle keeps, the wide views all but what both
/// eyes' volumes through the inset's core contain (the wide views' hole,
/// [`crate::view::inset_hole`]). Only the four side planes of each volume
/// go to the GPU: the cull's own volumes hold the near and far planes, and
/// a box inside all four side planes of a pyramid from the eye projects
/// inside its rectangle wherever it lies in depth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InsetLists {
    /// Each eye's frustum through the inset rectangle.
    pub inset: [Frustum; 2],
    /// Each eye's frustum through the inset's core (None: no hole).
    pub core: Option<[Frustum; 2]>,
}

impl InsetLists {
    /// Writes the side planes relative to the render origin `origin` into
    /// `data`.
    pub fn write(&self, origin: DVec3, data: &mut VolumeData) {
        let mut put = |at: usize, f: &Frustum| {
            // n · (p - o_eye) + d = n · (p - O) + d + n · (O - o_eye).
            let shift = origin - f.planes.origin;
            for (i, p) in f.side_planes().iter().enumerate() {
                data.inset_planes[at + i] = v4(p.normal, p.d + p.normal.dot(shift));
            }
        };
        put(0, &self.inset[0]);
        put(4, &self.inset[1]);
        if let Some(core) = &self.core {
            put(8, &core[0]);
            put(12, &core[1]);
        }
        data.inset_info = [1, u32::from(self.core.is_some()), 0, 0];
    }
}

/// The signed distance of the box (centre `c` relative to the render
/// origin, half-extents `e`) to `plane`, at its nearest (`toward` false:
/// the n-vertex) or farthest point (true: the p-vertex), in f32 as
/// gpu_cull.comp evaluates it, and the magnitude its rounding scales with.
fn box_reach(plane: [f32; 4], c: [f32; 3], e: [f32; 3], toward: bool) -> (f32, f32) {
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let abs = |a: [f32; 3]| [a[0].abs(), a[1].abs(), a[2].abs()];
    let n = [plane[0], plane[1], plane[2]];
    let spread = dot(abs(n), e);
    let at = dot(n, c) + if toward { spread } else { -spread };
    let scale = dot(abs(n), abs(c)) + spread + plane[3].abs() + 1.0;
    (at + plane[3], scale)
}

/// Whether the inset views draw the box (centre `c` relative to the render
/// origin, half-extents `e`), in f32 as gpu_cull.comp tests it: some eye's
/// inset volume keeps it, widened by the slack (it never drops what the
/// CPU's f64 test keeps).
pub fn inset_keeps(v: &VolumeData, c: [f32; 3], e: [f32; 3]) -> bool {
    let slack = v.cone_sin[2];
    (0..2).any(|eye| {
        (0..4).all(|i| {
            let (at, scale) = box_reach(v.inset_planes[4 * eye + i], c, e, true);
            at >= -slack * scale
        })
    })
}

/// Whether the wide views skip the box: both eyes' core volumes contain
/// it, narrowed by the slack (it never skips what the CPU's f64 test
/// draws), and the frame has a hole.
pub fn core_contains(v: &VolumeData, c: [f32; 3], e: [f32; 3]) -> bool {
    let slack = v.cone_sin[2];
    v.inset_info[1] != 0
        && (0..2).all(|eye| {
            (0..4).all(|i| {
                let (at, scale) = box_reach(v.inset_planes[8 + 4 * eye + i], c, e, false);
                at >= slack * scale
            })
        })
}

/// The near/far split of a monoscopic far field (`mffr`), as both the CPU
/// batcher and the GPU cull test it: an instance (bounding sphere centre
/// `c`, radius `r`) is near when, along some eye's forward axis, it
/// reaches nearer than `split + margin`, and far when, along some far
/// camera's axis, it reaches beyond `split − margin` (both when it
/// straddles).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FarSplitAxes {
    /// The eyes' positions and unit forward directions.
    pub eyes: [(DVec3, DVec3); 2],
    /// The far cameras rendered this frame (position, unit forward).
    pub fars: [Option<(DVec3, DVec3)>; 2],
    /// The split distance (metres).
    pub split: f64,
    /// The tolerance added on either side (metres).
    pub margin: f64,
}

impl FarSplitAxes {
    /// Whether the near views draw the sphere.
    pub fn near(&self, c: DVec3, r: f64) -> bool {
        self.eyes
            .iter()
            .any(|(p, f)| (c - *p).dot(*f) - r < self.split + self.margin)
    }

    /// Whether the far pass draws the sphere.
    pub fn far(&self, c: DVec3, r: f64) -> bool {
        self.fars
            .iter()
            .flatten()
            .any(|(p, f)| (c - *p).dot(*f) + r > self.split - self.margin)
    }

    /// Writes the axes relative to the render origin `origin` into `data`.
    pub fn write(&self, origin: DVec3, data: &mut VolumeData) {
        let axes = [
            Some(self.eyes[0]),
            Some(self.eyes[1]),
            self.fars[0],
            self.fars[1],
        ];
        for (k, a) in axes.iter().enumerate() {
            data.split_axes[2 * k] = match a {
                Some((p, _)) => v4(*p - origin, 1.0),
                None => [0.0; 4],
            };
            data.split_axes[2 * k + 1] = a.map_or([0.0; 4], |(_, f)| v4(f, 0.0));
        }
        data.split = [
            (self.split + self.margin) as f32,
            (self.split - self.margin) as f32,
            0.0,
            0.0,
        ];
    }
}

const _: () = assert!(std::mem::size_of::<VolumeData>() == VOLUME_DATA_SIZE);

/// Splits `v` into a high f32 and the f32 remainder (the two-float
/// representation the vertex shader uses for translations).
fn split(v: DVec3) -> ([f32; 3], [f32; 3]) {
    let hi = v.as_vec3();
    let lo = (v - hi.as_dvec3()).as_vec3();
    (hi.to_array(), lo.to_array())
}

fn v4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// The volumes `strategy` tests for `rig` at frame `frame` (the same ones
/// [`super::Culler::cull`] builds, with the same per-eye fallback when a
/// combined volume is impossible), relative to the render origin `origin`.
/// `PerEyeBrute` tests the per-eye frusta. Returns the data and whether the
/// fallback was taken.
pub fn volume_data(
    strategy: Strategy,
    rig: &StereoRig,
    frame: u64,
    params: &CullParams,
    origin: DVec3,
) -> Result<(VolumeData, bool), CullError> {
    let (vols, fallback) = volumes(strategy, rig, frame, params)?;
    let (hi, lo) = split(origin);
    let mut out = VolumeData {
        origin_hi: [hi[0], hi[1], hi[2], 0.0],
        origin_lo: [lo[0], lo[1], lo[2], 0.0],
        ..VolumeData::default()
    };
    out.cone_sin[2] = GPU_SLACK;
    match vols {
        Volumes::Planes(sets) => {
            out.info[0] = KIND_PLANES;
            out.info[1] = sets.len().min(2) as u32;
            for (s, set) in sets.iter().take(2).enumerate() {
                out.info[2 + s] = set.len as u32;
                // n · (p - o_set) + d = n · (p - O) + d + n · (O - o_set).
                let shift = origin - set.origin;
                for (i, p) in set.planes().iter().enumerate() {
                    out.planes[6 * s + i] = v4(p.normal, p.d + p.normal.dot(shift));
                }
            }
        }
        Volumes::Cones(cones) => {
            out.info[0] = KIND_CONES;
            out.info[1] = cones.len().min(2) as u32;
            for (s, c) in cones.iter().take(2).enumerate() {
                let far = c.far.is_some();
                out.cone_apex[s] = v4(c.apex - origin, if far { 1.0 } else { 0.0 });
                out.cone_axis[s] = v4(c.axis, c.cos);
                out.cone_sin[s] = c.sin as f32;
                if let Some(f) = c.far {
                    out.cone_far[s] = v4(f.normal, f.depth);
                }
            }
        }
    }
    Ok((out, fallback))
}

/// The GPU test of a box (centre `c` relative to the render origin,
/// half-extents `e`) against `v`, in f32 as gpu_cull.comp evaluates it: the
/// reference the shader is written against, and what the tests check
/// against the CPU strategies.
pub fn keeps(v: &VolumeData, c: [f32; 3], e: [f32; 3]) -> bool {
    let slack = v.cone_sin[2];
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let abs = |a: [f32; 3]| [a[0].abs(), a[1].abs(), a[2].abs()];
    let len = |a: [f32; 3]| dot(a, a).sqrt();
    (0..v.info[1] as usize).any(|s| {
        if v.info[0] == KIND_PLANES {
            (0..v.info[2 + s] as usize).all(|i| {
                let p = v.planes[6 * s + i];
                let n = [p[0], p[1], p[2]];
                // max over the box of n · x + d = n · c + |n| · e + d.
                let reach = dot(n, c) + dot(abs(n), e);
                let scale = dot(abs(n), abs(c)) + dot(abs(n), e) + p[3].abs() + 1.0;
                reach + p[3] >= -slack * scale
            })
        } else {
            let a = v.cone_apex[s];
            let d = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let r = len(e);
            let scale = slack * (1.0 + len(d) + r);
            let ax = v.cone_axis[s];
            let axis = [ax[0], ax[1], ax[2]];
            let l = dot(d, axis);
            let cr = [
                d[1] * axis[2] - d[2] * axis[1],
                d[2] * axis[0] - d[0] * axis[2],
                d[0] * axis[1] - d[1] * axis[0],
            ];
            let side = len(cr) * ax[3] - l * v.cone_sin[s];
            if side > r + scale {
                return false;
            }
            let f = v.cone_far[s];
            a[3] == 0.0 || dot([f[0], f[1], f[2]], d) - r <= f[3] + scale
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cull::{cull_flat, Bvh, DEFAULT_LEAF_SIZE};
    use crate::view::{Fov, Pose};
    use glam::DQuat;

    fn rig(at: DVec3, yaw: f64) -> StereoRig {
        let eye = |x: f64| {
            (
                Pose {
                    position: DVec3::new(x, 0.0, 0.0),
                    ..Pose::default()
                },
                Fov::symmetric(0.9, 0.85),
            )
        };
        let head = Pose {
            position: at,
            orientation: DQuat::from_rotation_y(yaw),
        };
        StereoRig::from_head(head, &[eye(-0.032), eye(0.032)])
    }

    /// A seeded generator of uniform numbers in [0, 1) (a 64-bit LCG's
    /// top 53 bits).
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Every strategy: the f32 GPU test keeps every box the CPU keeps, and
    /// keeps nothing the CPU drops except boxes within the slack.
    #[test]
    fn gpu_test_keeps_what_the_cpu_keeps() {
        let mut rnd = uniform(7);
        let origin = DVec3::new(1.0e4, 3.0, -2.0e4);
        let boxes: Vec<(DVec3, DVec3)> = (0..4000)
            .map(|_| {
                let c = origin + DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 120.0;
                let e = DVec3::new(rnd(), rnd(), rnd()) * 2.0 + DVec3::splat(0.01);
                (c - e, c + e)
            })
            .collect();
        let bvh = Bvh::build(&boxes, DEFAULT_LEAF_SIZE).unwrap();
        for strategy in Strategy::ALL {
            for (k, draw_distance) in [None, Some(30.0)].into_iter().enumerate() {
                let params = CullParams {
                    draw_distance,
                    ..CullParams::default()
                };
                let r = rig(origin, 0.7 * k as f64 + 0.3);
                let cpu = cull_flat(strategy, &r, 3, &bvh, &params).unwrap().visible;
                let (v, _) = volume_data(strategy, &r, 3, &params, r.head.position).unwrap();
                let gpu: Vec<u32> = (0..boxes.len() as u32)
                    .filter(|&i| {
                        let (a, b) = boxes[i as usize];
                        let c = ((a + b) * 0.5 - r.head.position).as_vec3().to_array();
                        let e = ((b - a) * 0.5).as_vec3().to_array();
                        keeps(&v, c, e)
                    })
                    .collect();
                assert!(!cpu.is_empty(), "{strategy}: nothing visible");
                assert_eq!(gpu, cpu, "{strategy}, draw distance {draw_distance:?}");
            }
        }
    }

    /// The inset's lists: over random boxes around a far-off render origin,
    /// the f32 GPU tests keep every box an eye's inset volume keeps in f64
    /// (side planes, p-vertex) and skip only boxes both core volumes
    /// contain in f64 (n-vertex); they disagree only within the slack.
    #[test]
    fn the_inset_lists_f32_tests_hold_the_f64_ones() {
        let mut rnd = uniform(11);
        let origin = DVec3::new(-3.0e4, 2.0, 1.5e4);
        let r = rig(origin, 0.4);
        let frusta = |t: [f64; 4]| {
            [0, 1].map(|e| Frustum::from_tangents(&r.views[e].pose, t, 0.05, None).unwrap())
        };
        let lists = InsetLists {
            inset: frusta([-0.4, 0.35, 0.3, -0.45]),
            core: Some(frusta([-0.3, 0.25, 0.2, -0.35])),
        };
        let mut data = VolumeData {
            cone_sin: [0.0, 0.0, GPU_SLACK, 0.0],
            ..VolumeData::default()
        };
        lists.write(r.head.position, &mut data);
        assert_eq!(data.inset_info, [1, 1, 0, 0]);
        let (mut kept, mut contained, mut differ) = (0, 0, 0);
        for _ in 0..20_000 {
            let dir = DVec3::new(rnd() - 0.5, rnd() - 0.5, -1.0);
            let c = origin + r.head.orientation * dir * (0.2 + rnd() * 60.0);
            let half = DVec3::new(rnd(), rnd(), rnd()) * 1.5;
            let (lo, hi) = (c - half, c + half);
            let cpu_keeps = lists.inset.iter().any(|f| {
                let (a, b) = (lo - f.planes.origin, hi - f.planes.origin);
                f.side_planes().iter().all(|p| p.max_over_box(a, b) >= 0.0)
            });
            let cpu_contains = lists.core.unwrap().iter().all(|f| {
                let (a, b) = (lo - f.planes.origin, hi - f.planes.origin);
                f.side_planes().iter().all(|p| p.min_over_box(a, b) >= 0.0)
            });
            let cf = (c - r.head.position).as_vec3().to_array();
            let e = (half * (1.0 + 1e-6)).as_vec3().to_array();
            let (gk, gc) = (inset_keeps(&data, cf, e), core_contains(&data, cf, e));
            assert!(
                !cpu_keeps || gk,
                "a box the inset keeps was dropped: {c} ± {half}"
            );
            assert!(
                !gc || cpu_contains,
                "a box the core does not contain was skipped: {c} ± {half}"
            );
            kept += usize::from(cpu_keeps);
            contained += usize::from(cpu_contains);
            differ += usize::from(gk != cpu_keeps) + usize::from(gc != cpu_contains);
        }
        assert!(
            kept > 1000 && contained > 300,
            "{kept} kept, {contained} contained"
        );
        assert!(differ * 1000 < 20_000, "{differ} answers differ from f64");
        // Without a hole nothing is skipped.
        let mut plain = data;
        InsetLists {
            core: None,
            ..lists
        }
        .write(r.head.position, &mut plain);
        assert!(!core_contains(&plain, [0.0, 0.0, -10.0], [0.1; 3]));
        assert!(core_contains(
            &data,
            (r.head.orientation * DVec3::new(0.0, 0.0, -10.0))
                .as_vec3()
                .to_array(),
            [0.1; 3]
        ));
    }
}
