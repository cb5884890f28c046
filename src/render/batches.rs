//! Draw batching: the visible instance list becomes one instanced draw per
//! primitive (mesh part + material), so draw calls scale with the number of
//! distinct primitives, not with instances. Blended primitives are drawn per
//! instance, back to front.

use crate::scene::{AlphaMode, Scene};
use glam::DVec3;

/// Pipeline variant a primitive needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PipelineKey {
    /// 0 opaque, 1 mask, 2 blend (also the draw order).
    pub alpha: u8,
    /// Back faces drawn.
    pub double_sided: bool,
    /// No lighting.
    pub unlit: bool,
}

/// One draw: `count` instances of primitive `primitive`, whose instance ids
/// start at `first` in the visible buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Draw {
    /// Primitive index.
    pub primitive: u32,
    /// Offset into the visible buffer (the draw's firstInstance).
    pub first: u32,
    /// Instance count.
    pub count: u32,
}

/// Static tables derived from a scene once at load.
pub struct Batcher {
    /// Primitive indices of each instance's mesh, as (start, len) into `prims`.
    instance_prims: Vec<(u32, u32)>,
    prims: Vec<u32>,
    /// Pipeline key per primitive.
    pub keys: Vec<PipelineKey>,
    /// Non-blended primitives in draw order (grouped by pipeline key).
    order: Vec<u32>,
    /// World-space bounding-sphere centres (for back-to-front sorting of
    /// blended draws and the far-field split).
    centers: Vec<DVec3>,
    /// World-space bounding-sphere radii.
    radii: Vec<f64>,
    /// Triangles per primitive.
    tris: Vec<u32>,
    /// Every instance index, for frames drawn without culling.
    all: Vec<u32>,
    /// Per-frame scratch, kept so a frame allocates nothing once warm.
    counts: Vec<u32>,
    offsets: Vec<u32>,
    blended: Vec<(f64, u32, u32)>,
    near_list: Vec<u32>,
    far_list: Vec<u32>,
    far_tmp: Batches,
}

/// A frame's draws and the visible buffer contents that feed them.
#[derive(Default)]
pub struct Batches {
    /// Instance ids, grouped per draw.
    pub ids: Vec<u32>,
    /// Draws in submission order.
    pub draws: Vec<Draw>,
    /// Instance-primitive pairs drawn.
    pub instances_drawn: u64,
    /// Triangles submitted.
    pub triangles: u64,
    /// With a split monoscopic far field: `draws[..k]` feed the near field
    /// and `draws[k..]` the far field (None: every draw feeds both).
    pub far_start: Option<usize>,
    /// With `inset`'s own list: `draws[..k]` feed the wide views and
    /// `draws[k..]` the inset (None: every draw feeds both).
    pub inset_start: Option<usize>,
}

impl Batches {
    /// The draws of the (near-field) stereo passes (with inset: of the
    /// wide views).
    pub fn near_draws(&self) -> &[Draw] {
        let end = self.far_start.or(self.inset_start);
        &self.draws[..end.unwrap_or(self.draws.len())]
    }

    /// The draws of the inset views (the near draws when the inset has no
    /// list of its own).
    pub fn inset_draws(&self) -> &[Draw] {
        match self.inset_start {
            Some(k) => &self.draws[k..],
            None => self.near_draws(),
        }
    }

    /// The draws of the far-field pass.
    pub fn far_draws(&self) -> &[Draw] {
        &self.draws[self.far_start.unwrap_or(0)..]
    }
}

impl Batcher {
    /// Moves instance `index`'s bounding sphere (the blended sort and the
    /// far field's depth split read it).
    pub fn move_instance(&mut self, index: u32, center: DVec3, radius: f64) {
        if let (Some(c), Some(r)) = (
            self.centers.get_mut(index as usize),
            self.radii.get_mut(index as usize),
        ) {
            *c = center;
            *r = radius;
        }
    }

    /// Builds the tables for `scene`.
    pub fn new(scene: &Scene) -> Batcher {
        let mut mesh_slices = Vec::new();
        let mut prims = Vec::new();
        for m in &scene.meshes {
            mesh_slices.push((prims.len() as u32, m.primitives.len() as u32));
            prims.extend_from_slice(&m.primitives);
        }
        let instance_prims: Vec<(u32, u32)> = scene
            .instances
            .iter()
            .map(|i| mesh_slices[i.mesh as usize])
            .collect();
        let keys: Vec<PipelineKey> = scene
            .primitives
            .iter()
            .map(|p| {
                let m = &scene.materials[p.material as usize];
                let alpha = match m.alpha_mode {
                    AlphaMode::Opaque => 0,
                    AlphaMode::Mask => 1,
                    AlphaMode::Blend => 2,
                };
                PipelineKey {
                    alpha,
                    double_sided: m.double_sided,
                    unlit: m.unlit,
                }
            })
            .collect();
        let mut order: Vec<u32> = (0..keys.len() as u32)
            .filter(|&p| keys[p as usize].alpha < 2)
            .collect();
        order.sort_by_key(|&p| (keys[p as usize], scene.primitives[p as usize].material, p));
        let bounds = scene.world_bounds();
        let centers = bounds.iter().map(|b| b.center).collect();
        let radii = bounds.iter().map(|b| b.radius).collect();
        let tris = scene
            .primitives
            .iter()
            .map(|p| p.triangles() as u32)
            .collect();
        Batcher {
            all: (0..instance_prims.len() as u32).collect(),
            instance_prims,
            prims,
            counts: vec![0; keys.len()],
            offsets: vec![0; keys.len()],
            blended: Vec::new(),
            keys,
            order,
            centers,
            radii,
            tris,
            near_list: Vec::new(),
            far_list: Vec::new(),
            far_tmp: Batches::default(),
        }
    }

    /// The instances with at least one blended primitive, and how many
    /// blended primitives each has.
    pub fn blended_instances(&self) -> Vec<(u32, u32)> {
        (0..self.instance_prims.len() as u32)
            .filter_map(|i| {
                let n = self.blended_prims(i).count() as u32;
                (n > 0).then_some((i, n))
            })
            .collect()
    }

    fn blended_prims(&self, instance: u32) -> impl Iterator<Item = u32> + '_ {
        let (s, n) = self.instance_prims[instance as usize];
        self.prims[s as usize..(s + n) as usize]
            .iter()
            .copied()
            .filter(|&p| self.keys[p as usize].alpha == 2)
    }

    /// The blended draws alone of the `visible` instances (the GPU cull
    /// draws the rest): one per instance and blended primitive, sorted
    /// back to front from `eye`, their first instance counted from `base`.
    pub fn build_blended(&mut self, visible: &[u32], eye: DVec3, base: u32, out: &mut Batches) {
        *out = Batches {
            ids: std::mem::take(&mut out.ids),
            draws: std::mem::take(&mut out.draws),
            ..Batches::default()
        };
        out.ids.clear();
        out.draws.clear();
        let mut blended = std::mem::take(&mut self.blended);
        blended.clear();
        for &i in visible {
            let d = self.centers[i as usize].distance_squared(eye);
            blended.extend(self.blended_prims(i).map(|p| (d, p, i)));
        }
        blended.sort_by(|a, b| b.0.total_cmp(&a.0));
        for &(_, p, i) in &blended {
            out.draws.push(Draw {
                primitive: p,
                first: base + out.ids.len() as u32,
                count: 1,
            });
            out.ids.push(i);
            out.triangles += self.tris[p as usize] as u64;
        }
        out.instances_drawn = out.ids.len() as u64;
        self.blended = blended;
    }

    /// The non-blended primitives in draw order (grouped by pipeline key).
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// Like [`Batcher::build`] for a split monoscopic far field: the near
    /// draws get the visible instances whose bounding sphere `near(centre,
    /// radius)` keeps, the far draws (after `far_start`) those `far` keeps.
    /// An instance straddling the split is in both.
    pub fn build_split(
        &mut self,
        visible: Option<&[u32]>,
        eye: DVec3,
        near: impl Fn(DVec3, f64) -> bool,
        far: impl Fn(DVec3, f64) -> bool,
        out: &mut Batches,
    ) {
        out.far_start = Some(self.build_pair(visible, eye, Some(near), far, out));
    }

    /// Like [`Batcher::build`] for `inset`: the wide views' draws get the
    /// visible instances whose bounding sphere `wide(centre, radius)` keeps
    /// (None: every one; the wide views' hole leaves out what lies wholly
    /// under the inset's core), the inset's (after `inset_start`) those
    /// `keep` keeps (its narrower volume).
    pub fn build_inset(
        &mut self,
        visible: Option<&[u32]>,
        eye: DVec3,
        wide: Option<impl Fn(DVec3, f64) -> bool>,
        keep: impl Fn(DVec3, f64) -> bool,
        out: &mut Batches,
    ) {
        out.inset_start = Some(self.build_pair(visible, eye, wide, keep, out));
    }

    /// Two lists in one: the visible instances `first` keeps (None: all of
    /// them, grouped without a copy), then those `second` keeps, their
    /// draws after the returned index (ids offset).
    fn build_pair(
        &mut self,
        visible: Option<&[u32]>,
        eye: DVec3,
        first: Option<impl Fn(DVec3, f64) -> bool>,
        second: impl Fn(DVec3, f64) -> bool,
        out: &mut Batches,
    ) -> usize {
        let (mut near_list, mut far_list) = (
            std::mem::take(&mut self.near_list),
            std::mem::take(&mut self.far_list),
        );
        near_list.clear();
        far_list.clear();
        let all = std::mem::take(&mut self.all);
        let list = visible.unwrap_or(&all);
        for &i in list {
            let (c, r) = (self.centers[i as usize], self.radii[i as usize]);
            if first.as_ref().is_some_and(|f| f(c, r)) {
                near_list.push(i);
            }
            if second(c, r) {
                far_list.push(i);
            }
        }
        let mut tmp = std::mem::take(&mut self.far_tmp);
        self.group(if first.is_some() { &near_list } else { list }, eye, out);
        self.all = all;
        self.group(&far_list, eye, &mut tmp);
        let offset = out.ids.len() as u32;
        let start = out.draws.len();
        out.ids.extend_from_slice(&tmp.ids);
        out.draws.extend(tmp.draws.iter().map(|d| Draw {
            first: d.first + offset,
            ..*d
        }));
        out.instances_drawn += tmp.instances_drawn;
        out.triangles += tmp.triangles;
        self.far_tmp = tmp;
        self.near_list = near_list;
        self.far_list = far_list;
        start
    }

    /// Groups `visible` (instance indices; None = all) into draws. `eye` is
    /// the viewer position used to sort blended draws back to front.
    pub fn build(&mut self, visible: Option<&[u32]>, eye: DVec3, out: &mut Batches) {
        let all = std::mem::take(&mut self.all);
        self.group(visible.unwrap_or(&all), eye, out);
        self.all = all;
    }

    fn group(&mut self, visible: &[u32], eye: DVec3, out: &mut Batches) {
        out.far_start = None;
        out.inset_start = None;
        out.ids.clear();
        out.draws.clear();
        out.triangles = 0;
        self.counts.iter_mut().for_each(|c| *c = 0);
        let mut blended = std::mem::take(&mut self.blended);
        blended.clear();
        for &i in visible {
            let (s, n) = self.instance_prims[i as usize];
            for &p in &self.prims[s as usize..(s + n) as usize] {
                if self.keys[p as usize].alpha == 2 {
                    blended.push((self.centers[i as usize].distance_squared(eye), p, i));
                } else {
                    self.counts[p as usize] += 1;
                }
            }
        }
        let offsets = &mut self.offsets;
        let mut total = 0u32;
        for &p in &self.order {
            offsets[p as usize] = total;
            let c = self.counts[p as usize];
            if c > 0 {
                out.draws.push(Draw {
                    primitive: p,
                    first: total,
                    count: c,
                });
                out.triangles += c as u64 * self.tris[p as usize] as u64;
            }
            total += c;
        }
        out.ids.resize(total as usize, 0);
        for &i in visible {
            let (s, n) = self.instance_prims[i as usize];
            for &p in &self.prims[s as usize..(s + n) as usize] {
                if self.keys[p as usize].alpha < 2 {
                    let o = &mut offsets[p as usize];
                    out.ids[*o as usize] = i;
                    *o += 1;
                }
            }
        }
        blended.sort_by(|a, b| b.0.total_cmp(&a.0));
        for &(_, p, i) in &blended {
            out.draws.push(Draw {
                primitive: p,
                first: out.ids.len() as u32,
                count: 1,
            });
            out.ids.push(i);
            out.triangles += self.tris[p as usize] as u64;
        }
        out.instances_drawn = out.ids.len() as u64;
        self.blended = blended;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_split_keeps_each_side_and_offsets_the_far_draws() {
        let scene = crate::scene::factory::generate(3_000, 5).unwrap();
        let mut b = Batcher::new(&scene);
        let mut out = Batches::default();
        let split = 20.0;
        b.build_split(
            None,
            DVec3::ZERO,
            |c, r| c.length() - r < split,
            |c, r| c.length() + r > split,
            &mut out,
        );
        let ids_of = |draws: &[Draw]| {
            let mut v: Vec<u32> = draws
                .iter()
                .flat_map(|d| {
                    out.ids[d.first as usize..(d.first + d.count) as usize]
                        .iter()
                        .copied()
                })
                .collect();
            v.sort();
            v.dedup();
            v
        };
        let bounds = scene.world_bounds();
        let want = |keep: &dyn Fn(&WorldBoundsRef) -> bool| -> Vec<u32> {
            (0..bounds.len() as u32)
                .filter(|&i| keep(&(bounds[i as usize].center, bounds[i as usize].radius)))
                .collect()
        };
        let near = want(&|&(c, r)| c.length() - r < split);
        let far = want(&|&(c, r)| c.length() + r > split);
        assert!(!near.is_empty() && !far.is_empty());
        assert_eq!(ids_of(out.near_draws()), near);
        assert_eq!(ids_of(out.far_draws()), far);
        assert_eq!(out.far_start.map(|k| k > 0), Some(true));
        // Rebuilding without a split leaves no far marker behind.
        b.build(None, DVec3::ZERO, &mut out);
        assert_eq!(out.far_start, None);
        assert_eq!(out.near_draws().len(), out.far_draws().len());
    }

    type WorldBoundsRef = (DVec3, f64);

    #[test]
    fn every_visible_instance_is_drawn_once_per_primitive() {
        let scene = crate::scene::factory::generate(5_000, 3).unwrap();
        let mut b = Batcher::new(&scene);
        let mut out = Batches::default();
        let visible: Vec<u32> = (0..5_000).step_by(3).collect();
        b.build(Some(&visible), DVec3::ZERO, &mut out);
        assert_eq!(out.ids.len(), visible.len());
        let mut seen = out.ids.clone();
        seen.sort();
        assert_eq!(seen, visible);
        assert!(out.draws.len() <= scene.primitives.len());
        for d in &out.draws {
            for &i in &out.ids[d.first as usize..(d.first + d.count) as usize] {
                let mesh = &scene.meshes[scene.instances[i as usize].mesh as usize];
                assert!(mesh.primitives.contains(&d.primitive));
            }
        }
    }

    #[test]
    fn blended_draws_alone_are_sorted_back_to_front_after_the_base() {
        let scene = crate::scene::cad::generate(400, 2).unwrap();
        let mut b = Batcher::new(&scene);
        let blended = b.blended_instances();
        assert!(!blended.is_empty(), "cad scenes have glass parts");
        let visible: Vec<u32> = blended.iter().map(|&(i, _)| i).collect();
        let eye = DVec3::new(3.0, 1.0, -2.0);
        let mut out = Batches::default();
        b.build_blended(&visible, eye, 1000, &mut out);
        let want: u32 = blended.iter().map(|&(_, n)| n).sum();
        assert_eq!(out.draws.len() as u32, want);
        let bounds = scene.world_bounds();
        let mut last = f64::INFINITY;
        for (k, d) in out.draws.iter().enumerate() {
            assert_eq!((d.first, d.count), (1000 + k as u32, 1));
            assert_eq!(b.keys[d.primitive as usize].alpha, 2);
            let i = out.ids[k] as usize;
            let dist = bounds[i].center.distance_squared(eye);
            assert!(dist <= last, "draw {k} is nearer than the one before");
            last = dist;
        }
    }
}
