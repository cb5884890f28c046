//! Exact ray casts against a scene: a bounding volume hierarchy over the
//! instances' world boxes narrows a ray to the instances whose boxes it
//! crosses, then every triangle of those instances is tested in the
//! instance's object space. What the hand points at, where a teleport arc
//! lands and where a measuring point sits all come from here.

use crate::cull::bvh::Bvh;
use crate::scene::{Scene, WorldBounds};
use glam::{DAffine3, DMat3, DVec3};

/// Leaf size of the query's hierarchy: small leaves, because every instance
/// a leaf holds costs a box test and possibly a triangle loop.
const LEAF_SIZE: usize = 4;

/// A ray `origin + t · direction`, `t` in `[0, max_t]`; `direction` need
/// not be unit length (an arc segment uses its chord, `t` in `[0, 1]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point, world space.
    pub origin: DVec3,
    /// Direction, world space.
    pub direction: DVec3,
    /// Largest parameter tested.
    pub max_t: f64,
}

impl Ray {
    /// The point at parameter `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.direction * t
    }
}

/// The closest surface a ray meets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Instance index into [`Scene::instances`].
    pub instance: u32,
    /// Primitive index into [`Scene::primitives`].
    pub primitive: u32,
    /// Ray parameter of the hit.
    pub t: f64,
    /// World-space point.
    pub point: DVec3,
    /// Unit world-space geometric normal of the triangle, turned to face
    /// the ray's origin.
    pub normal: DVec3,
}

/// Per-instance data a cast needs: the inverse transform (rays go into
/// object space) and the normal matrix (normals come back out).
#[derive(Clone, Copy, Debug)]
struct Placed {
    inverse: DAffine3,
    normal_matrix: DMat3,
    mesh: u32,
}

/// A scene prepared for ray casts: instance boxes in a hierarchy plus each
/// instance's inverse transform. Built once per scene; instances whose
/// transform cannot be inverted are never hit.
pub struct SceneQuery<'a> {
    scene: &'a Scene,
    bvh: Option<Bvh>,
    placed: Vec<Option<Placed>>,
}

/// A moved instance for the query: its index, what casts need (None when
/// its transform cannot be inverted), its world box (None for an unknown
/// mesh).
type MovedPlace = (u32, Option<Placed>, Option<(DVec3, DVec3)>);

/// Slab test (Kay and Kajiya, "Ray Tracing Complex Scenes", SIGGRAPH 1986):
/// the parameter interval where the ray is inside all three slabs of the box,
/// clipped to `[0, max_t]`; None when it is empty. `inv` is the
/// component-wise reciprocal of the direction (±inf for a zero component,
/// which the min/max below handle; a 0 × inf NaN is discarded by
/// `f64::min`/`max` returning the other operand).
fn slab(origin: DVec3, inv: DVec3, max_t: f64, lo: DVec3, hi: DVec3) -> Option<f64> {
    let mut t0 = 0.0f64;
    let mut t1 = max_t;
    for a in 0..3 {
        let (o, i) = (origin[a], inv[a]);
        let (ta, tb) = ((lo[a] - o) * i, (hi[a] - o) * i);
        let (near, far) = if ta <= tb { (ta, tb) } else { (tb, ta) };
        if near.is_nan() || far.is_nan() {
            // Direction 0 on this axis with the origin on a slab face:
            // inside exactly when the origin lies within the slab.
            if o < lo[a] || o > hi[a] {
                return None;
            }
            continue;
        }
        t0 = t0.max(near);
        t1 = t1.min(far);
        if t0 > t1 {
            return None;
        }
    }
    Some(t0)
}

/// Möller–Trumbore ray/triangle intersection (Möller and Trumbore, "Fast,
/// Minimum Storage Ray/Triangle Intersection", JGT 1997): solves
/// `o + t d = (1 − u − v) a + u b + v c` by Cramer's rule with
/// `p = d × e2`, `det = e1 · p`, `u = (o − a) · p / det`,
/// `q = (o − a) × e1`, `v = d · q / det`, `t = e2 · q / det`. Both faces
/// count. Returns `t` within `(0, max_t]`.
pub fn ray_triangle(o: DVec3, d: DVec3, max_t: f64, a: DVec3, b: DVec3, c: DVec3) -> Option<f64> {
    let e1 = b - a;
    let e2 = c - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    // Relative threshold: a triangle seen exactly edge-on, or degenerate.
    if det.abs() <= 1e-12 * e1.length() * e2.length() * d.length() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > 0.0 && t <= max_t).then_some(t)
}

impl<'a> SceneQuery<'a> {
    /// Prepares `scene` for casts.
    pub fn new(scene: &'a Scene) -> SceneQuery<'a> {
        let boxes = scene.world_aabbs();
        let bvh = Bvh::build(&boxes, LEAF_SIZE)
            .map_err(|e| {
                tracing::warn!("ray casts disabled: the scene's bounds are invalid ({e:?})")
            })
            .ok();
        let placed = scene
            .instances
            .iter()
            .map(|inst| {
                let det = inst.transform.matrix3.determinant();
                (det.is_finite() && det.abs() > 1e-300).then(|| Placed {
                    inverse: inst.transform.inverse(),
                    // Normals transform by the inverse transpose of the
                    // linear part (keeps them perpendicular to tangents).
                    normal_matrix: inst.transform.matrix3.inverse().transpose(),
                    mesh: inst.mesh,
                })
            })
            .collect();
        SceneQuery { scene, bvh, placed }
    }

    /// Moves instances to where the scene's motion put them (the frame
    /// driver's last `moved`): their inverse transforms are replaced and
    /// their boxes updated in the hierarchy, so rays hit them where they are
    /// drawn. A moved instance whose transform cannot be inverted is no
    /// longer hit; an update the hierarchy refuses (non-finite bounds) is
    /// skipped with a warning and casts keep the last good boxes.
    pub fn move_instances(&mut self, moved: &[crate::scene::motion::Moved]) {
        if moved.is_empty() {
            return;
        }
        use rayon::prelude::*;
        let scene = self.scene;
        let len = self.placed.len();
        // Per instance in parallel: its inverse and its world box.
        let placed: Vec<MovedPlace> = moved
            .par_iter()
            .with_min_len(256)
            .filter(|m| (m.index as usize) < len)
            .map(|m| {
                let det = m.transform.matrix3.determinant();
                let p = (det.is_finite() && det.abs() > 1e-300).then(|| Placed {
                    inverse: m.transform.inverse(),
                    normal_matrix: m.transform.matrix3.inverse().transpose(),
                    mesh: m.mesh,
                });
                let b = ((m.mesh as usize) < scene.meshes.len()).then(|| {
                    let b = WorldBounds::of(scene.mesh_bounds(m.mesh), &m.transform);
                    (b.min, b.max)
                });
                (m.index, p, b)
            })
            .collect();
        let mut boxes = Vec::with_capacity(placed.len());
        for (i, p, b) in placed {
            self.placed[i as usize] = p;
            if let Some(b) = b {
                boxes.push((i, b));
            }
        }
        if let Some(bvh) = self.bvh.as_mut() {
            if let Err(e) = bvh.update(&boxes) {
                tracing::warn!("ray casts keep the last instance boxes: {e:?}");
            }
        }
    }

    /// The scene queried.
    pub fn scene(&self) -> &Scene {
        self.scene
    }

    /// The world bounds of instance `i` (None when out of range or when
    /// ray casts are disabled).
    pub fn instance_bounds(&self, i: u32) -> Option<(DVec3, DVec3)> {
        let b = self.bvh.as_ref()?;
        ((i as usize) < b.len()).then(|| b.instances.get(i as usize))
    }

    /// The closest triangle of instance `i` along `ray`, at most `max_t`.
    fn instance_hit(&self, i: u32, ray: &Ray, max_t: f64) -> Option<Hit> {
        let placed = self.placed.get(i as usize).copied().flatten()?;
        // An affine map keeps the ray parameter: o' + t d' = M⁻¹(o + t d).
        let o = placed.inverse.transform_point3(ray.origin);
        let d = placed.inverse.transform_vector3(ray.direction);
        let mut best: Option<(f64, u32, DVec3)> = None;
        let mut limit = max_t;
        let mesh = self.scene.meshes.get(placed.mesh as usize)?;
        for &pi in &mesh.primitives {
            let Some(prim) = self.scene.primitives.get(pi as usize) else {
                continue;
            };
            let vertex = |k: u32| {
                prim.positions
                    .get(k as usize)
                    .map(|p| DVec3::from(p.map(f64::from)))
            };
            for tri in prim.indices.chunks_exact(3) {
                let (Some(a), Some(b), Some(c)) = (vertex(tri[0]), vertex(tri[1]), vertex(tri[2]))
                else {
                    continue;
                };
                if let Some(t) = ray_triangle(o, d, limit, a, b, c) {
                    limit = t;
                    best = Some((t, pi, (b - a).cross(c - a)));
                }
            }
        }
        let (t, primitive, n_obj) = best?;
        let mut normal = (placed.normal_matrix * n_obj).normalize_or_zero();
        if normal.dot(ray.direction) > 0.0 {
            normal = -normal;
        }
        Some(Hit {
            instance: i,
            primitive,
            t,
            point: ray.at(t),
            normal,
        })
    }

    /// The closest hit along `ray`: hierarchy nodes whose boxes the ray
    /// crosses nearer than the best hit so far, then the triangles of their
    /// instances.
    pub fn cast(&self, ray: &Ray) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        if bvh.is_empty() || !(ray.origin.is_finite() && ray.direction.is_finite()) {
            return None;
        }
        let inv = ray.direction.recip();
        let mut best: Option<Hit> = None;
        let mut stack = vec![0usize];
        while let Some(n) = stack.pop() {
            let limit = best.map_or(ray.max_t, |h| h.t);
            let node = &bvh.nodes[n];
            if slab(ray.origin, inv, limit, node.lo, node.hi).is_none() {
                continue;
            }
            if bvh.is_leaf(n) {
                for k in node.first..node.first + node.count {
                    let (lo, hi) = bvh.ordered.get(k as usize);
                    let limit = best.map_or(ray.max_t, |h| h.t);
                    if slab(ray.origin, inv, limit, lo, hi).is_none() {
                        continue;
                    }
                    if let Some(h) = self.instance_hit(bvh.order[k as usize], ray, limit) {
                        best = Some(h);
                    }
                }
            } else {
                stack.push(node.right as usize);
                stack.push(n + 1);
            }
        }
        best
    }

    /// The closest hit by testing every triangle of every instance, no
    /// hierarchy: the reference the hierarchy's cast is checked against.
    pub fn cast_brute_force(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        for i in 0..self.scene.instances.len() as u32 {
            let limit = best.map_or(ray.max_t, |h| h.t);
            if let Some(h) = self.instance_hit(i, ray, limit) {
                best = Some(h);
            }
        }
        best
    }

    /// The first hit along a polyline (an arc sampled into chords): each
    /// chord is cast as a ray with `t` in `[0, 1]`. Returns the hit and the
    /// index of the chord it lies on.
    pub fn cast_polyline(&self, points: &[DVec3]) -> Option<(Hit, usize)> {
        points.windows(2).enumerate().find_map(|(i, w)| {
            self.cast(&Ray {
                origin: w[0],
                direction: w[1] - w[0],
                max_t: 1.0,
            })
            .map(|h| (h, i))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{shapes, Instance, Mesh};
    use glam::DQuat;
    use proptest::prelude::*;

    /// A scene of `n` unit-ish cuboids placed pseudo-randomly.
    fn boxes(n: usize, seed: u64) -> Scene {
        let mut s = Scene::default();
        s.materials.push(crate::scene::Material::default());
        s.primitives.push(shapes::cuboid([0.5, 0.3, 0.7], 0));
        s.meshes.push(Mesh {
            name: "box".into(),
            primitives: vec![0],
        });
        let mut rng = crate::scene::factory::SplitMix64::new(seed);
        for _ in 0..n {
            let p = DVec3::new(
                rng.unit() * 20.0 - 10.0,
                rng.unit() * 6.0,
                rng.unit() * 20.0 - 10.0,
            );
            let q = DQuat::from_euler(glam::EulerRot::YXZ, rng.unit() * 6.3, rng.unit() * 0.8, 0.0);
            let scale = DVec3::splat(0.5 + rng.unit() * 1.5);
            s.instances.push(Instance {
                mesh: 0,
                transform: DAffine3::from_scale_rotation_translation(scale, q, p),
            });
        }
        s
    }

    #[test]
    fn moved_instances_are_hit_where_they_moved_to() {
        let s = boxes(1, 3);
        let mut q = SceneQuery::new(&s);
        let down = |x: f64| Ray {
            origin: DVec3::new(x, 50.0, 0.0),
            direction: DVec3::NEG_Y,
            max_t: 100.0,
        };
        // The box stands at x = 100 now (it was within ±10).
        let moved = [crate::scene::motion::Moved {
            index: 0,
            mesh: 0,
            transform: DAffine3::from_translation(DVec3::new(100.0, 0.0, 0.0)),
        }];
        q.move_instances(&moved);
        let h = q.cast(&down(100.0)).expect("hit where it moved to");
        assert_eq!(h.instance, 0);
        // The cuboid's half height is 0.3 above its centre at y = 0.
        assert!((h.point.y - 0.3).abs() < 1e-6, "{h:?}");
        assert_eq!(
            q.cast_brute_force(&down(100.0)).map(|h| h.instance),
            Some(0)
        );
        let was = s.instances[0].transform.translation;
        assert!(q
            .cast(&down(was.x))
            .is_none_or(|h| (h.point.x - 100.0).abs() < 1.0));
        let (lo, hi) = q.instance_bounds(0).unwrap();
        assert!(lo.x > 99.0 && hi.x < 101.0, "{lo} {hi}");
        // A singular transform is never hit; NaN bounds are refused and the
        // last good boxes stay.
        q.move_instances(&[crate::scene::motion::Moved {
            transform: DAffine3::from_scale(DVec3::ZERO),
            ..moved[0]
        }]);
        assert!(q.cast(&down(100.0)).is_none());
        q.move_instances(&[crate::scene::motion::Moved {
            transform: DAffine3::from_translation(DVec3::splat(f64::NAN)),
            ..moved[0]
        }]);
        assert!(q.instance_bounds(0).unwrap().0.is_finite());
    }

    #[test]
    fn hits_the_top_of_a_floor_from_above_with_an_upward_normal() {
        let mut s = boxes(0, 1);
        s.instances.push(Instance {
            mesh: 0,
            transform: DAffine3::from_translation(DVec3::new(0.0, -0.3, 0.0)),
        });
        let q = SceneQuery::new(&s);
        let h = q
            .cast(&Ray {
                origin: DVec3::new(0.1, 2.0, 0.2),
                direction: DVec3::NEG_Y,
                max_t: 10.0,
            })
            .expect("hit");
        // Vertices are f32: 0.3 is stored to ~1e-8.
        assert!((h.t - 2.0).abs() < 1e-6, "{h:?}");
        assert!((h.normal - DVec3::Y).length() < 1e-12);
        assert!(q
            .cast(&Ray {
                origin: DVec3::new(0.1, 2.0, 0.2),
                direction: DVec3::NEG_Y,
                max_t: 1.9,
            })
            .is_none());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

    /// After random instances moved, the hierarchy's cast agrees with
    /// testing every triangle.
    #[test]
    fn casts_after_moves_match_brute_force(
        seed in 0u64..1000, dx in -8.0..8.0f64, dz in -8.0..8.0f64,
        ox in -12.0..12.0f64, oz in -12.0..12.0f64, yaw in 0.0..6.3f64, pitch in -1.2..-0.05f64,
    ) {
        let s = boxes(40, seed);
        let mut q = SceneQuery::new(&s);
        let moved: Vec<crate::scene::motion::Moved> = s
            .instances
            .iter()
            .enumerate()
            .filter(|(i, _)| i % 3 == 0)
            .map(|(i, inst)| crate::scene::motion::Moved {
                index: i as u32,
                mesh: inst.mesh,
                transform: DAffine3::from_translation(DVec3::new(dx, 0.0, dz)) * inst.transform,
            })
            .collect();
        q.move_instances(&moved);
        let d = DQuat::from_euler(glam::EulerRot::YXZ, yaw, pitch, 0.0) * DVec3::NEG_Z;
        let ray = Ray { origin: DVec3::new(ox, 8.0, oz), direction: d, max_t: 100.0 };
        let (a, b) = (q.cast(&ray), q.cast_brute_force(&ray));
        prop_assert_eq!(a.map(|h| h.instance), b.map(|h| h.instance));
        if let (Some(a), Some(b)) = (a, b) {
            prop_assert!((a.t - b.t).abs() < 1e-9);
        }
    }

        #[test]
        fn the_hierarchy_finds_the_brute_force_hit(
            seed in 0u64..1000,
            o in prop::array::uniform3(-12.0f64..12.0),
            d in prop::array::uniform3(-1.0f64..1.0),
        ) {
            let s = boxes(60, seed);
            let q = SceneQuery::new(&s);
            let ray = Ray { origin: DVec3::from(o), direction: DVec3::from(d), max_t: 40.0 };
            let fast = q.cast(&ray);
            let slow = q.cast_brute_force(&ray);
            match (fast, slow) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    prop_assert!((a.t - b.t).abs() <= 1e-9 * (1.0 + b.t), "{a:?} vs {b:?}");
                }
                other => prop_assert!(false, "hierarchy and brute force disagree: {other:?}"),
            }
        }
    }
}
