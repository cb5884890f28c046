//! Scenes: geometry, materials, textures and instances in a GPU-agnostic form.
//! Loaders (glTF, the procedural `factory`, TOML manifests) all produce a
//! [`Scene`]; the renderer uploads only what the scene uses.

pub mod basis;
pub mod budget;
pub mod cad;
pub mod draco;
pub mod e57;
pub mod factory;
pub mod gltf_data;
pub mod gltf_load;
pub mod image_decode;
pub mod lod;
pub mod lod_cache;
pub mod manifest;
pub mod motion;
pub mod octree;
pub mod octree_cache;
pub mod ply;
pub mod point_files;
pub mod points;
pub mod shapes;
pub mod uri;

use crate::error::{Error, Result};
use glam::{DAffine3, DVec3, Vec3};
use std::path::Path;

/// The count N of a built-in scene spec `name:N` (or plain `name`, which
/// is `default` when it has one), within 1..=`max`; None when `spec` is not
/// this built-in (then it is a file path: `factory_hall.glb` or
/// `cad/engine.glb` load as files).
fn builtin_count(
    spec: &str,
    name: &str,
    default: Option<usize>,
    max: usize,
) -> Option<Result<usize>> {
    let rest = spec.strip_prefix(name)?;
    let bad = || {
        Error::config(
            "--scene",
            format!("'{spec}': expected {name}:N with N a count within 1..={max}"),
        )
    };
    let n = match rest.strip_prefix(':') {
        Some(n) => n.replace('_', "").parse::<usize>().map_err(|_| bad()),
        None if rest.is_empty() => default.ok_or_else(bad),
        None => return None,
    };
    Some(n.and_then(|n| {
        if (1..=max).contains(&n) {
            Ok(n)
        } else {
            Err(bad())
        }
    }))
}

/// Checks a built-in scene's count `n` (`what` it counts) against
/// 1..=`max`, one error naming `name:n` otherwise.
fn count_within(name: &str, n: usize, max: usize, what: &str) -> Result<()> {
    if n == 0 || n > max {
        return Err(Error::config(
            "--scene",
            format!("{name}:{n}: {what} must be within 1..={max}"),
        ));
    }
    Ok(())
}

/// The instance count of a `factory` / `factory:N` spec (None: not one).
fn factory_count(spec: &str) -> Option<Result<usize>> {
    builtin_count(
        spec,
        "factory",
        Some(factory::DEFAULT_INSTANCES),
        factory::MAX_INSTANCES,
    )
}

/// How a material's alpha is interpreted (glTF `alphaMode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub enum AlphaMode {
    /// Alpha ignored.
    Opaque,
    /// Fragments with alpha below the cutoff are discarded.
    Mask,
    /// Alpha-blended, drawn after opaque geometry without depth writes.
    Blend,
}

/// A reference from a material slot to a texture and a UV set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexRef {
    /// Index into [`Scene::textures`].
    pub texture: u32,
    /// UV set (0 or 1).
    pub tex_coord: u32,
}

/// A PBR metallic-roughness material (glTF 2.0 core) or an unlit one.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name for diagnostics.
    pub name: String,
    /// Linear base colour factor (RGBA).
    pub base_color: [f32; 4],
    /// Metallic factor.
    pub metallic: f32,
    /// Roughness factor.
    pub roughness: f32,
    /// Linear emissive factor.
    pub emissive: [f32; 3],
    /// Base colour texture (sRGB).
    pub base_color_tex: Option<TexRef>,
    /// Metallic (B) / roughness (G) texture (linear).
    pub metallic_roughness_tex: Option<TexRef>,
    /// Tangent-space normal map (linear) and its scale.
    pub normal_tex: Option<(TexRef, f32)>,
    /// Occlusion texture (R, linear) and its strength.
    pub occlusion_tex: Option<(TexRef, f32)>,
    /// Emissive texture (sRGB).
    pub emissive_tex: Option<TexRef>,
    /// Alpha mode.
    pub alpha_mode: AlphaMode,
    /// Alpha cutoff for [`AlphaMode::Mask`].
    pub alpha_cutoff: f32,
    /// Whether back faces are drawn (and lit with a flipped normal).
    pub double_sided: bool,
    /// Unlit (no lighting; base colour only).
    pub unlit: bool,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: "default".into(),
            base_color: [1.0; 4],
            metallic: 1.0,
            roughness: 1.0,
            emissive: [0.0; 3],
            base_color_tex: None,
            metallic_roughness_tex: None,
            normal_tex: None,
            occlusion_tex: None,
            emissive_tex: None,
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
            double_sided: false,
            unlit: false,
        }
    }
}

/// A decoded texture image, RGBA8.
#[derive(Clone, Debug)]
pub struct Texture {
    /// Name (source URI or index) for diagnostics.
    pub name: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Whether texels are sRGB-encoded colour (base colour, emissive).
    pub srgb: bool,
    /// Whether the sampler repeats (else clamps).
    pub repeat: bool,
    /// Whether the sampler filters linearly (else nearest).
    pub linear: bool,
    /// RGBA8 texels, row-major; shared (not copied) by every texture and
    /// scene that uses the same decoded image.
    pub rgba8: std::sync::Arc<Vec<u8>>,
}

/// One drawable: a vertex/index range with one material.
#[derive(Clone, Debug, Default)]
pub struct Primitive {
    /// Positions (object space).
    pub positions: Vec<[f32; 3]>,
    /// Normals (always present; generated flat when the source has none).
    pub normals: Vec<[f32; 3]>,
    /// Tangents (xyz, w = handedness), present when the material has a normal map.
    pub tangents: Option<Vec<[f32; 4]>>,
    /// First UV set.
    pub uv0: Option<Vec<[f32; 2]>>,
    /// Second UV set.
    pub uv1: Option<Vec<[f32; 2]>>,
    /// Linear vertex colours.
    pub colors: Option<Vec<[f32; 4]>>,
    /// Triangle list indices (u16 sources are widened on load).
    pub indices: Vec<u32>,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Object-space bounds (min, max).
    pub bounds: (Vec3, Vec3),
}

impl Primitive {
    /// Recomputes [`Primitive::bounds`] from the positions.
    pub fn compute_bounds(&mut self) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in &self.positions {
            lo = lo.min(Vec3::from_array(*p));
            hi = hi.max(Vec3::from_array(*p));
        }
        if self.positions.is_empty() {
            lo = Vec3::ZERO;
            hi = Vec3::ZERO;
        }
        self.bounds = (lo, hi);
    }

    /// Number of triangles.
    pub fn triangles(&self) -> usize {
        self.indices.len() / 3
    }
}

/// A mesh: primitives drawn together under one transform.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Name for diagnostics.
    pub name: String,
    /// Indices into [`Scene::primitives`].
    pub primitives: Vec<u32>,
}

/// One placed copy of a mesh.
#[derive(Clone, Copy, Debug)]
pub struct Instance {
    /// Index into [`Scene::meshes`].
    pub mesh: u32,
    /// Object-to-world transform in double precision.
    pub transform: DAffine3,
}

/// Per-instance world bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldBounds {
    /// Axis-aligned box minimum.
    pub min: DVec3,
    /// Axis-aligned box maximum.
    pub max: DVec3,
    /// Bounding sphere centre (box centre).
    pub center: DVec3,
    /// Bounding sphere radius (half the box diagonal).
    pub radius: f64,
}

impl WorldBounds {
    /// The world box of a mesh with object-space bounds `(lo, hi)` under
    /// `transform`: the box's centre transformed, its half-extents through
    /// the absolute linear part (Arvo, "Transforming Axis-Aligned Bounding
    /// Boxes", Graphics Gems, 1990).
    pub fn of((lo, hi): (Vec3, Vec3), transform: &DAffine3) -> WorldBounds {
        let c = (lo + hi).as_dvec3() * 0.5;
        let h = (hi - lo).as_dvec3() * 0.5;
        let m = transform.matrix3;
        let wc = transform.transform_point3(c);
        let abs = glam::DMat3::from_cols(m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs());
        let wh = abs * h;
        WorldBounds {
            min: wc - wh,
            max: wc + wh,
            center: wc,
            radius: wh.length(),
        }
    }
}

/// A loaded scene.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Scene name (file name, `factory:N`, manifest name).
    pub name: String,
    /// Node count of the source (glTF nodes, or generated placements).
    pub nodes: usize,
    /// Drawables.
    pub primitives: Vec<Primitive>,
    /// Meshes.
    pub meshes: Vec<Mesh>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Textures (decoded).
    pub textures: Vec<Texture>,
    /// Placed mesh instances.
    pub instances: Vec<Instance>,
    /// glTF `extensionsUsed` of the source file.
    pub extensions_used: Vec<String>,
    /// glTF `extensionsRequired` of the source file.
    pub extensions_required: Vec<String>,
    /// Viewpoints from the file's cameras (glTF camera nodes), in node
    /// traversal order.
    pub cameras: Vec<SceneCamera>,
    /// The sun the file defines (a KHR_lights_punctual directional light).
    pub sun: Option<Sun>,
    /// Where a viewer of the scene starts (the tracking origin: the floor
    /// under a standing viewer), when the scene defines it (a generated
    /// factory's hall entrance); `--frame spawn` uses it.
    pub spawn: Option<crate::view::Pose>,
    /// Names of the file's scenes (glTF `scenes`; one was placed).
    pub scene_names: Vec<String>,
    /// The source file's nodes, for naming what the user points at (glTF
    /// scenes; empty for generated ones, so a 10M-instance factory keeps
    /// no names).
    pub node_info: Vec<NodeInfo>,
    /// Per instance, its node in [`Scene::node_info`] ([`NO_NODE`]: none);
    /// empty when the scene keeps no nodes.
    pub instance_node: Vec<u32>,
    /// Instances that move (manifest `motion`), by placement group.
    pub moving: Vec<motion::MovingGroup>,
    /// The file the scene was loaded from (None: generated).
    pub source: Option<std::path::PathBuf>,
    /// A point cloud drawn with the meshes (`--scene scan.laz`, manifest
    /// `[[points]]`); None: meshes only.
    pub points: Option<std::sync::Arc<points::PointCloud>>,
}

/// A source node (glTF) as selection names it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeInfo {
    /// The node's name.
    pub name: Option<String>,
    /// The parent node (index into [`Scene::node_info`]).
    pub parent: Option<u32>,
    /// The node's `extras`, as JSON text.
    pub extras: Option<String>,
}

/// [`Scene::instance_node`] of an instance that came from no node.
pub const NO_NODE: u32 = u32::MAX;

/// Deepest node path [`Scene::node_path`] walks (deeper ancestors are
/// left out).
pub const MAX_PATH_DEPTH: usize = 64;

/// A viewpoint a scene file defines.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneCamera {
    /// Index of the camera in the file (glTF `cameras`).
    pub index: usize,
    /// The camera's name, else its node's, else `camera N`.
    pub name: String,
    /// World pose (looking down its local -Z, +Y up, as [`crate::view::Pose`]).
    pub pose: crate::view::Pose,
    /// Vertical field of view in radians (None: orthographic).
    pub yfov: Option<f64>,
}

/// A directional light standing in for the renderer's default sun.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sun {
    /// Unit vector from the scene towards the light, world space.
    pub direction: DVec3,
    /// Linear RGB colour times intensity (lux for glTF lights).
    pub color: [f32; 3],
}

/// Which optional vertex streams and pipeline features a scene uses; the
/// renderer creates only these.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SceneFeatures {
    /// Some primitive has tangents.
    pub tangents: bool,
    /// Some primitive has UV set 0.
    pub uv0: bool,
    /// Some primitive has UV set 1.
    pub uv1: bool,
    /// Some primitive has vertex colours.
    pub colors: bool,
    /// Some material is alpha-masked.
    pub alpha_mask: bool,
    /// Some material is alpha-blended.
    pub alpha_blend: bool,
    /// Some material is double-sided.
    pub double_sided: bool,
    /// Some material is unlit.
    pub unlit: bool,
}

impl Scene {
    /// Loads a scene from a `--scene` argument: `factory`, `factory:N`,
    /// `cad:N`, a `.gltf`/`.glb` file, a point file or a `.toml` scene
    /// manifest. A point cloud's octree comes from its cache file when
    /// that is usable (`octree_cache`).
    pub fn load(spec: &str) -> Result<Scene> {
        Scene::load_with(spec, false)
    }

    /// [`Scene::load`]; with `write_octree_cache`, a point cloud's octree
    /// is built and written to its cache file (`inspect --write-octree`).
    pub fn load_with(spec: &str, write_octree_cache: bool) -> Result<Scene> {
        if let Some(n) = factory_count(spec) {
            return factory::generate(n?, factory::DEFAULT_SEED);
        }
        if let Some(n) = cad::spec_count(spec) {
            return cad::generate(n?, cad::DEFAULT_SEED);
        }
        let path = Path::new(spec);
        let mut scene = match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
        {
            Some(e) if e == "toml" => manifest::load_with(path, write_octree_cache),
            Some(e) if e == "las" || e == "laz" || e == "ply" || e == "e57" => {
                Ok(Scene::of_points(
                    point_files::read_file(path)?.with_octree_cached(path, write_octree_cache),
                ))
            }
            _ => gltf_load::load(path),
        }?;
        scene.source = Some(path.to_path_buf());
        Ok(scene)
    }

    /// Checks, without loading it, that a `--scene` value can be loaded:
    /// `factory[:N]` with N within the factory's limit, `cad:N`, or a regular file
    /// under the size limit (what a bench plan checks for every scene
    /// before measuring the first).
    pub fn check_spec(spec: &str) -> Result<()> {
        if let Some(n) = factory_count(spec) {
            return n.map(|_| ());
        }
        if let Some(n) = cad::spec_count(spec) {
            return n.map(|_| ());
        }
        let path = Path::new(spec);
        let io = |source: std::io::Error| Error::Io {
            path: path.to_path_buf(),
            source,
        };
        let meta = std::fs::metadata(path).map_err(io)?;
        if !meta.is_file() {
            return Err(io(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "not a regular file",
            )));
        }
        if meta.len() > crate::fsio::MAX_SCENE_FILE_BYTES {
            return Err(io(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "{} bytes, over the {}-byte limit",
                    meta.len(),
                    crate::fsio::MAX_SCENE_FILE_BYTES
                ),
            )));
        }
        Ok(())
    }

    /// A scene holding only `cloud` (no meshes), named after its file.
    pub fn of_points(cloud: points::PointCloud) -> Scene {
        Scene {
            name: cloud
                .source
                .as_ref()
                .and_then(|p| p.file_name())
                .map_or("points".into(), |n| n.to_string_lossy().into_owned()),
            points: Some(std::sync::Arc::new(cloud)),
            ..Scene::default()
        }
    }

    /// Total triangles over all instances.
    pub fn instanced_triangles(&self) -> usize {
        let per_mesh: Vec<usize> = self
            .meshes
            .iter()
            .map(|m| {
                m.primitives
                    .iter()
                    .map(|&p| self.primitives[p as usize].triangles())
                    .sum()
            })
            .collect();
        self.instances
            .iter()
            .map(|i| per_mesh[i.mesh as usize])
            .sum()
    }

    /// Object-space bounds of a mesh (union of its primitives).
    pub fn mesh_bounds(&self, mesh: u32) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for &p in &self.meshes[mesh as usize].primitives {
            let (a, b) = self.primitives[p as usize].bounds;
            lo = lo.min(a);
            hi = hi.max(b);
        }
        if lo.x > hi.x {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        (lo, hi)
    }

    /// World AABB and bounding sphere of every instance (Arvo's method for
    /// transforming an AABB: "Transforming Axis-Aligned Bounding Boxes",
    /// Graphics Gems, 1990 — the extent along each world axis is the sum of
    /// the absolute matrix entries times the half-extents).
    pub fn world_bounds(&self) -> Vec<WorldBounds> {
        let mesh_bounds: Vec<(Vec3, Vec3)> = (0..self.meshes.len() as u32)
            .map(|m| self.mesh_bounds(m))
            .collect();
        self.instances
            .iter()
            .map(|inst| WorldBounds::of(mesh_bounds[inst.mesh as usize], &inst.transform))
            .collect()
    }

    /// Instances that move (manifest `motion`).
    pub fn moving_instances(&self) -> usize {
        self.moving.iter().map(motion::MovingGroup::len).sum()
    }

    /// World AABBs as (min, max) pairs, the culling module's input.
    pub fn world_aabbs(&self) -> Vec<(DVec3, DVec3)> {
        self.world_bounds()
            .into_iter()
            .map(|b| (b.min, b.max))
            .collect()
    }

    /// The node instance `instance` came from, when the scene keeps nodes.
    pub fn node_of(&self, instance: usize) -> Option<u32> {
        self.instance_node
            .get(instance)
            .copied()
            .filter(|&n| (n as usize) < self.node_info.len())
    }

    /// The names from the root down to `node`, joined by `/` (an unnamed
    /// node shows as `node N`; at most [`MAX_PATH_DEPTH`] levels, the
    /// deepest kept).
    pub fn node_path(&self, node: u32) -> String {
        let mut parts = Vec::new();
        let mut at = Some(node);
        while let Some(n) = at.filter(|_| parts.len() < MAX_PATH_DEPTH) {
            let Some(info) = self.node_info.get(n as usize) else {
                break;
            };
            parts.push(info.name.clone().unwrap_or_else(|| format!("node {n}")));
            at = info.parent;
        }
        parts.reverse();
        parts.join("/")
    }

    /// Bounds of the whole scene.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for b in self.world_bounds() {
            lo = lo.min(b.min);
            hi = hi.max(b.max);
        }
        if let Some(c) = self.points.as_ref().filter(|c| !c.is_empty()) {
            let (a, b) = c.bounds();
            lo = lo.min(a);
            hi = hi.max(b);
        }
        if lo.x > hi.x {
            return (DVec3::ZERO, DVec3::ZERO);
        }
        (lo, hi)
    }

    /// The features the renderer must support for this scene.
    pub fn features(&self) -> SceneFeatures {
        let mut f = SceneFeatures::default();
        for p in &self.primitives {
            f.tangents |= p.tangents.is_some();
            f.uv0 |= p.uv0.is_some();
            f.uv1 |= p.uv1.is_some();
            f.colors |= p.colors.is_some();
        }
        for m in &self.materials {
            f.alpha_mask |= m.alpha_mode == AlphaMode::Mask;
            f.alpha_blend |= m.alpha_mode == AlphaMode::Blend;
            f.double_sided |= m.double_sided;
            f.unlit |= m.unlit;
        }
        f
    }

    /// Appends `other` (re-indexing its meshes, primitives, materials and
    /// textures), placing its instances with `place` applied after their own
    /// transforms, once per entry of `placements`.
    pub fn append(&mut self, other: &Scene, placements: &[DAffine3]) {
        let nodes = !(other.instance_node.is_empty() && self.instance_node.is_empty());
        if nodes {
            let n0 = self.node_info.len() as u32;
            self.instance_node.resize(self.instances.len(), NO_NODE);
            self.node_info
                .extend(other.node_info.iter().map(|n| NodeInfo {
                    parent: n.parent.map(|p| p + n0),
                    ..n.clone()
                }));
            for _ in placements {
                self.instance_node
                    .extend(
                        (0..other.instances.len()).map(|i| match other.instance_node.get(i) {
                            Some(&k) if k != NO_NODE => k + n0,
                            _ => NO_NODE,
                        }),
                    );
            }
        }
        let p0 = self.primitives.len() as u32;
        let m0 = self.meshes.len() as u32;
        let mat0 = self.materials.len() as u32;
        let t0 = self.textures.len() as u32;
        self.textures.extend(other.textures.iter().cloned());
        self.materials.extend(other.materials.iter().map(|m| {
            let mut m = m.clone();
            let slots = [
                m.base_color_tex.as_mut(),
                m.metallic_roughness_tex.as_mut(),
                m.normal_tex.as_mut().map(|(t, _)| t),
                m.occlusion_tex.as_mut().map(|(t, _)| t),
                m.emissive_tex.as_mut(),
            ];
            for t in slots.into_iter().flatten() {
                t.texture += t0;
            }
            m
        }));
        self.primitives.extend(other.primitives.iter().map(|p| {
            let mut p = p.clone();
            p.material += mat0;
            p
        }));
        self.meshes.extend(other.meshes.iter().map(|m| Mesh {
            name: m.name.clone(),
            primitives: m.primitives.iter().map(|p| p + p0).collect(),
        }));
        for place in placements {
            for inst in &other.instances {
                self.instances.push(Instance {
                    mesh: inst.mesh + m0,
                    transform: *place * inst.transform,
                });
            }
        }
        self.nodes = self
            .nodes
            .saturating_add(other.nodes.saturating_mul(placements.len()));
    }
}
