//! glTF 2.0 import (`.gltf` with external or data: buffers, `.glb`).
//!
//! The `gltf` crate parses and validates the JSON; this module resolves
//! buffers and images itself so that every failure names the file and the
//! problem, and checks every accessor and index range against the real buffer
//! sizes before reading, so a malformed file is an error, never a panic.

use super::{AlphaMode, Instance, Material, Mesh, Primitive, Scene, TexRef, Texture};
use crate::error::{Error, Result};
use glam::{DAffine3, DMat4, DQuat, DVec3, Vec2, Vec3};
use gltf::accessor::Dimensions;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Extensions a file may list in `extensionsRequired`.
pub const SUPPORTED_REQUIRED: &[&str] = &["KHR_materials_unlit", "EXT_mesh_gpu_instancing"];
/// Deepest node hierarchy accepted.
pub const MAX_NODE_DEPTH: usize = 256;

struct Ctx<'a> {
    path: &'a Path,
    dir: PathBuf,
    buffers: Vec<Vec<u8>>,
    /// The load's memory budget (shared with the manifest naming this
    /// file, if any), so repeated references to one large file cannot
    /// multiply memory without bound.
    budget: &'a super::budget::LoadBudget,
}

/// Most bytes of buffers, image files and decoded textures one glTF file may
/// make vergence hold.
pub const MAX_SCENE_RESOURCE_BYTES: u64 = super::budget::MAX_SCENE_LOAD_BYTES;
/// Most instances one glTF file may place.
pub const MAX_SCENE_INSTANCES: usize = 50_000_000;

impl Ctx<'_> {
    fn err(&self, message: impl Into<String>) -> Error {
        Error::scene(self.path, message)
    }

    /// Takes `bytes` from the resource budget for `what`, or fails.
    fn spend(&self, bytes: u64, what: &str) -> Result<()> {
        self.budget
            .spend(Some(bytes), what)
            .map_err(|m| self.err(m))
    }
}

/// Loads a `.gltf` or `.glb` file.
pub fn load(path: &Path) -> Result<Scene> {
    load_in(path, &super::budget::LoadBudget::default())
}

/// Loads a `.gltf` or `.glb` file within `budget` (a manifest's, shared by
/// all it names).
pub fn load_in(path: &Path, budget: &super::budget::LoadBudget) -> Result<Scene> {
    if let Some(meta) = std::fs::metadata(path).ok().filter(|m| m.is_file()) {
        budget
            .spend(Some(meta.len()), "the scene file")
            .map_err(|m| Error::scene(path, m))?;
    }
    let bytes =
        crate::fsio::read_bounded(path, crate::fsio::MAX_SCENE_FILE_BYTES).map_err(|source| {
            Error::Io {
                path: path.to_path_buf(),
                source,
            }
        })?;
    load_bytes_in(path, &bytes, budget)
}

/// Loads glTF or GLB content already read from `path` (external resources
/// resolve relative to `path`'s folder).
pub fn load_bytes(path: &Path, bytes: &[u8]) -> Result<Scene> {
    load_bytes_in(path, bytes, &super::budget::LoadBudget::default())
}

/// [`load_bytes`] within `budget`.
pub fn load_bytes_in(
    path: &Path,
    bytes: &[u8],
    budget: &super::budget::LoadBudget,
) -> Result<Scene> {
    let gltf = parse(path, bytes)?;
    for ext in gltf.document.extensions_required() {
        if !SUPPORTED_REQUIRED.contains(&ext) {
            return Err(Error::scene(
                path,
                format!("requires glTF extension {ext}, which vergence does not support (supported: {})", SUPPORTED_REQUIRED.join(", ")),
            ));
        }
    }
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut ctx = Ctx {
        path,
        dir,
        buffers: Vec::new(),
        budget,
    };
    ctx.buffers = load_buffers(&ctx, &gltf)?;
    check_views_and_accessors(&ctx, &gltf.document)?;
    check_attribute_types(&ctx, &gltf.document)?;

    let mut scene = Scene {
        name: path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        nodes: gltf.document.nodes().len(),
        ..Scene::default()
    };
    let mut textures = TextureCache::default();
    for m in gltf.document.materials() {
        let mat = convert_material(&ctx, &m, &mut textures, &mut scene.textures)?;
        scene.materials.push(mat);
    }
    let default_material = scene.materials.len() as u32;
    scene.materials.push(Material {
        metallic: 0.0,
        roughness: 0.8,
        ..Material::default()
    });

    for mesh in gltf.document.meshes() {
        let mut out = Mesh {
            name: mesh.name().unwrap_or("mesh").to_string(),
            primitives: Vec::new(),
        };
        for prim in mesh.primitives() {
            if let Some(p) =
                convert_primitive(&ctx, &mesh, &prim, &scene.materials, default_material)?
            {
                out.primitives.push(scene.primitives.len() as u32);
                scene.primitives.push(p);
            }
        }
        scene.meshes.push(out);
    }
    place_nodes(&ctx, &gltf.document, &mut scene)?;
    Ok(scene)
}

/// Parses and validates glTF or GLB bytes. What the `gltf` crates assume
/// without checking is checked first (a primitive's attribute accessor
/// indexes, which gltf-json 1.4.1's validator indexes without a bounds
/// check; an image's uri or bufferView + mimeType, which gltf 1.4.1
/// unwraps), so a bad file is an error instead of a panic.
fn parse(path: &Path, bytes: &[u8]) -> Result<gltf::Gltf> {
    let describe = |e: gltf::Error| Error::scene(path, describe_gltf_error(bytes, &e));
    // GLB §4.4.3: the header's length is the whole file; the gltf crate
    // ignores bytes past it, which hides a damaged or concatenated file.
    if let Some(len) = bytes
        .get(8..12)
        .filter(|_| bytes.starts_with(b"glTF"))
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    {
        if len < bytes.len() {
            return Err(Error::scene(
                path,
                format!(
                    "malformed .glb container: its header declares {len} bytes but the file has {}",
                    bytes.len()
                ),
            ));
        }
    }
    let raw = gltf::Gltf::from_slice_without_validation(bytes).map_err(describe)?;
    let json = raw.document.as_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, index) in &prim.attributes {
                if index.value() >= json.accessors.len() {
                    return Err(Error::scene(
                        path,
                        format!(
                            "invalid glTF: mesh {m} primitive {p}: attribute {} refers to accessor {}, but there are {}",
                            match semantic {
                                gltf::json::validation::Checked::Valid(s) => s.to_string(),
                                gltf::json::validation::Checked::Invalid => "?".into(),
                            },
                            index.value(),
                            json.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    // gltf 1.4.1 image.rs unwraps these: an image has a uri, or a
    // bufferView with a mimeType (glTF 2.0 §5.18).
    for (i, img) in json.images.iter().enumerate() {
        let ok = match &img.buffer_view {
            Some(_) => img.mime_type.is_some(),
            None => img.uri.is_some(),
        };
        if !ok {
            return Err(Error::scene(
                path,
                format!("invalid glTF: image {i} needs a uri, or a bufferView with a mimeType"),
            ));
        }
    }
    let blob = raw.blob;
    let document = gltf::Document::from_json(raw.document.into_json()).map_err(describe)?;
    Ok(gltf::Gltf { document, blob })
}

fn describe_gltf_error(bytes: &[u8], e: &gltf::Error) -> String {
    let glb = bytes.starts_with(b"glTF");
    match e {
        gltf::Error::Binary(g) => format!("malformed or truncated .glb container: {g}"),
        gltf::Error::Deserialize(d) if !glb && !bytes.trim_ascii_start().starts_with(b"{") => {
            format!("not a glTF file (neither GLB nor JSON): {d}")
        }
        gltf::Error::Deserialize(d) => format!("invalid glTF JSON: {d}"),
        gltf::Error::Validation(v) => {
            if let Some((p, _)) = v
                .iter()
                .find(|(p, _)| p.as_str().starts_with("extensionsRequired"))
            {
                let name = p.as_str().split('"').nth(1).unwrap_or("?").to_string();
                return format!(
                    "requires glTF extension {name}, which vergence does not support (supported: {})",
                    SUPPORTED_REQUIRED.join(", ")
                );
            }
            let list: Vec<String> = v
                .iter()
                .take(5)
                .map(|(p, e)| format!("{}: {e}", p.as_str()))
                .collect();
            format!("invalid glTF: {}", list.join("; "))
        }
        other => format!("cannot parse glTF: {other}"),
    }
}

/// Resolves a URI inside the scene folder or decodes a data: URI
/// ([`super::uri`]).
fn read_uri(ctx: &Ctx, uri: &str, what: &str) -> Result<Vec<u8>> {
    let bytes = super::uri::read_within(&ctx.dir, uri, ctx.budget.left())
        .map_err(|e| ctx.err(format!("{what}: {e}")))?;
    ctx.spend(bytes.len() as u64, what)?;
    Ok(bytes)
}

fn load_buffers(ctx: &Ctx, gltf: &gltf::Gltf) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::new();
    for b in gltf.document.buffers() {
        let what = format!("buffer {}", b.index());
        let mut data = match b.source() {
            gltf::buffer::Source::Bin => {
                let blob = gltf.blob.as_ref().ok_or_else(|| {
                    ctx.err(format!(
                        "{what} refers to the GLB binary chunk, which is missing"
                    ))
                })?;
                ctx.spend(blob.len() as u64, &what)?;
                blob.clone()
            }
            gltf::buffer::Source::Uri(uri) => read_uri(ctx, uri, &what)?,
        };
        if data.len() < b.length() {
            return Err(ctx.err(format!(
                "{what} declares {} bytes but only {} are present",
                b.length(),
                data.len()
            )));
        }
        data.truncate(b.length());
        out.push(data);
    }
    Ok(out)
}

/// Component types and shapes glTF 2.0 allows for the attributes vergence
/// reads (spec §3.7.2.1 "Overview" table of mesh attributes, and §3.7.2.1
/// for indices). The `gltf` crate's readers assume them (`unreachable!`
/// otherwise), so each primitive is checked before it is read.
fn check_attribute_types(ctx: &Ctx, doc: &gltf::Document) -> Result<()> {
    use gltf::accessor::DataType::{F32, U16, U32, U8};
    use gltf::mesh::Semantic;
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let label = format!("mesh {} primitive {}", mesh.index(), prim.index());
            let bad = |what: &str, a: &gltf::Accessor, allowed: &str| {
                ctx.err(format!(
                    "{label}: {what} accessor {} is {:?} {:?}{}; glTF allows {allowed}",
                    a.index(),
                    a.data_type(),
                    a.dimensions(),
                    if a.normalized() { " normalized" } else { "" }
                ))
            };
            if let Some(a) = prim.indices() {
                if !matches!(a.data_type(), U8 | U16 | U32) || a.dimensions() != Dimensions::Scalar
                {
                    return Err(bad("indices", &a, "unsigned byte, short or int scalars"));
                }
            }
            for (semantic, a) in prim.attributes() {
                let (dt, dims, norm) = (a.data_type(), a.dimensions(), a.normalized());
                let ok = match &semantic {
                    Semantic::Positions | Semantic::Normals => {
                        dt == F32 && dims == Dimensions::Vec3
                    }
                    Semantic::Tangents => dt == F32 && dims == Dimensions::Vec4,
                    Semantic::TexCoords(_) => {
                        dims == Dimensions::Vec2 && (dt == F32 || (matches!(dt, U8 | U16) && norm))
                    }
                    Semantic::Colors(_) => {
                        matches!(dims, Dimensions::Vec3 | Dimensions::Vec4)
                            && (dt == F32 || (matches!(dt, U8 | U16) && norm))
                    }
                    Semantic::Joints(_) => matches!(dt, U8 | U16) && dims == Dimensions::Vec4,
                    Semantic::Weights(_) => {
                        dims == Dimensions::Vec4 && (dt == F32 || (matches!(dt, U8 | U16) && norm))
                    }
                };
                if !ok {
                    return Err(bad(
                        &semantic.to_string(),
                        &a,
                        "the types in the glTF 2.0 attribute table",
                    ));
                }
            }
        }
    }
    Ok(())
}

fn check_views_and_accessors(ctx: &Ctx, doc: &gltf::Document) -> Result<()> {
    for v in doc.views() {
        let len = ctx.buffers[v.buffer().index()].len();
        let end = v.offset().checked_add(v.length());
        if end.is_none_or(|e| e > len) {
            return Err(ctx.err(format!(
                "bufferView {} (offset {}, length {}) runs past the end of buffer {} ({len} bytes)",
                v.index(),
                v.offset(),
                v.length(),
                v.buffer().index()
            )));
        }
    }
    for a in doc.accessors() {
        if a.sparse().is_some() {
            return Err(ctx.err(format!(
                "accessor {}: sparse accessors are not supported",
                a.index()
            )));
        }
        if a.count() == 0 {
            // The gltf readers compute `count - 1`.
            return Err(ctx.err(format!("accessor {} has count 0", a.index())));
        }
        let Some(view) = a.view() else { continue };
        let elem = a.size();
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            // glTF 2.0 §3.6.2.4: byteStride must hold a whole element (the
            // gltf readers assert it).
            return Err(ctx.err(format!(
                "accessor {}: bufferView {} byteStride {stride} is smaller than its {elem}-byte elements",
                a.index(),
                view.index()
            )));
        }
        let need = match a.count() {
            0 => Some(0),
            c => (c - 1)
                .checked_mul(stride)
                .and_then(|x| x.checked_add(elem))
                .and_then(|x| x.checked_add(a.offset())),
        };
        if need.is_none_or(|n| n > view.length()) {
            return Err(ctx.err(format!(
                "accessor {} ({} elements of {elem} bytes at offset {}) is out of range of bufferView {} ({} bytes)",
                a.index(),
                a.count(),
                a.offset(),
                view.index(),
                view.length()
            )));
        }
    }
    Ok(())
}

#[derive(Default)]
struct TextureCache {
    map: HashMap<(usize, bool), u32>,
    /// Decoded images by glTF image index: decoded and paid for once,
    /// shared by every texture that samples them.
    images: HashMap<usize, (u32, u32, std::sync::Arc<Vec<u8>>)>,
}

fn texture(
    ctx: &Ctx,
    tex: gltf::Texture,
    tex_coord: u32,
    srgb: bool,
    cache: &mut TextureCache,
    out: &mut Vec<Texture>,
) -> Result<TexRef> {
    if tex_coord > 1 {
        return Err(ctx.err(format!(
            "texture {} uses TEXCOORD_{tex_coord}; only 0 and 1 are supported",
            tex.index()
        )));
    }
    if let Some(&i) = cache.map.get(&(tex.index(), srgb)) {
        return Ok(TexRef {
            texture: i,
            tex_coord,
        });
    }
    let img = tex.source();
    let name = match img.source() {
        gltf::image::Source::Uri { uri, .. } => uri.to_string(),
        gltf::image::Source::View { view, .. } => {
            format!("image {} (bufferView {})", img.index(), view.index())
        }
    };
    if let std::collections::hash_map::Entry::Vacant(slot) = cache.images.entry(img.index()) {
        let bytes = match img.source() {
            gltf::image::Source::Uri { uri, .. } => {
                read_uri(ctx, uri, &format!("image {}", img.index()))?
            }
            gltf::image::Source::View { view, .. } => {
                let b = &ctx.buffers[view.buffer().index()];
                b[view.offset()..view.offset() + view.length()].to_vec()
            }
        };
        let decoded = super::image_decode::decode_rgba8(&bytes)
            .map_err(|e| ctx.err(format!("image '{name}' cannot be decoded: {e}")))?;
        ctx.spend(decoded.as_raw().len() as u64, &format!("image '{name}'"))?;
        let (w, h) = decoded.dimensions();
        slot.insert((w, h, std::sync::Arc::new(decoded.into_raw())));
    }
    let (width, height, rgba) = &cache.images[&img.index()];
    let sampler = tex.sampler();
    let repeat = !matches!(sampler.wrap_s(), gltf::texture::WrappingMode::ClampToEdge);
    let linear = !matches!(
        sampler.mag_filter(),
        Some(gltf::texture::MagFilter::Nearest)
    );
    let index = out.len() as u32;
    out.push(Texture {
        name,
        width: *width,
        height: *height,
        srgb,
        repeat,
        linear,
        rgba8: rgba.clone(),
    });
    cache.map.insert((tex.index(), srgb), index);
    Ok(TexRef {
        texture: index,
        tex_coord,
    })
}

fn convert_material(
    ctx: &Ctx,
    m: &gltf::Material,
    cache: &mut TextureCache,
    out: &mut Vec<Texture>,
) -> Result<Material> {
    let pbr = m.pbr_metallic_roughness();
    let mut mat = Material {
        name: m.name().unwrap_or("material").to_string(),
        base_color: pbr.base_color_factor(),
        metallic: pbr.metallic_factor(),
        roughness: pbr.roughness_factor(),
        emissive: m.emissive_factor(),
        alpha_mode: match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask,
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        },
        alpha_cutoff: m.alpha_cutoff().unwrap_or(0.5),
        double_sided: m.double_sided(),
        ..Material::default()
    };
    if let Some(ext) = m.extensions() {
        mat.unlit = ext.contains_key("KHR_materials_unlit");
        if let Some(s) = ext
            .get("KHR_materials_emissive_strength")
            .and_then(|v| v.get("emissiveStrength"))
            .and_then(|v| v.as_f64())
        {
            mat.emissive = mat.emissive.map(|c| c * s as f32);
        }
    }
    let mut load =
        |t: gltf::Texture, coord: u32, srgb: bool| texture(ctx, t, coord, srgb, cache, out);
    mat.base_color_tex = pbr
        .base_color_texture()
        .map(|t| load(t.texture(), t.tex_coord(), true))
        .transpose()?;
    mat.metallic_roughness_tex = pbr
        .metallic_roughness_texture()
        .map(|t| load(t.texture(), t.tex_coord(), false))
        .transpose()?;
    if let Some(t) = m.normal_texture() {
        mat.normal_tex = Some((load(t.texture(), t.tex_coord(), false)?, t.scale()));
    }
    if let Some(t) = m.occlusion_texture() {
        mat.occlusion_tex = Some((load(t.texture(), t.tex_coord(), false)?, t.strength()));
    }
    mat.emissive_tex = m
        .emissive_texture()
        .map(|t| load(t.texture(), t.tex_coord(), true))
        .transpose()?;
    Ok(mat)
}

fn convert_primitive(
    ctx: &Ctx,
    mesh: &gltf::Mesh,
    prim: &gltf::Primitive,
    materials: &[Material],
    default_material: u32,
) -> Result<Option<Primitive>> {
    let label = format!(
        "mesh {} ('{}') primitive {}",
        mesh.index(),
        mesh.name().unwrap_or(""),
        prim.index()
    );
    let tri_indices: fn(&[u32]) -> Vec<u32> = match prim.mode() {
        gltf::mesh::Mode::Triangles => |i| i.to_vec(),
        gltf::mesh::Mode::TriangleStrip => strip_to_list,
        gltf::mesh::Mode::TriangleFan => fan_to_list,
        other => {
            tracing::warn!(
                "{}: {label}: mode {other:?} is not drawn (only triangles are)",
                ctx.path.display()
            );
            return Ok(None);
        }
    };
    let reader = prim.reader(|b| Some(ctx.buffers[b.index()].as_slice()));
    let positions: Vec<[f32; 3]> = match reader.read_positions() {
        Some(p) => p.collect(),
        None => return Err(ctx.err(format!("{label} has no POSITION attribute"))),
    };
    let n = positions.len();
    let check_len = |what: &str, len: usize| -> Result<()> {
        if len != n {
            return Err(ctx.err(format!(
                "{label}: {what} has {len} elements but POSITION has {n}"
            )));
        }
        Ok(())
    };
    let raw_indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..n as u32).collect(),
    };
    if let Some(bad) = raw_indices.iter().find(|&&i| i as usize >= n) {
        return Err(ctx.err(format!(
            "{label}: index {bad} is out of range of its {n} vertices"
        )));
    }
    let mut indices = tri_indices(&raw_indices);
    indices.truncate(indices.len() / 3 * 3);
    let material = prim
        .material()
        .index()
        .map(|i| i as u32)
        .unwrap_or(default_material);
    let mat = &materials[material as usize];
    let mut p = Primitive {
        positions,
        indices,
        material,
        ..Primitive::default()
    };
    p.normals = match reader.read_normals() {
        Some(it) => it.collect(),
        None => generate_normals(&p.positions, &p.indices),
    };
    check_len("NORMAL", p.normals.len())?;
    if let Some(t) = reader.read_tex_coords(0) {
        let v: Vec<[f32; 2]> = t.into_f32().collect();
        check_len("TEXCOORD_0", v.len())?;
        p.uv0 = Some(v);
    }
    if let Some(t) = reader.read_tex_coords(1) {
        let v: Vec<[f32; 2]> = t.into_f32().collect();
        check_len("TEXCOORD_1", v.len())?;
        p.uv1 = Some(v);
    }
    if let Some(c) = reader.read_colors(0) {
        let v: Vec<[f32; 4]> = c.into_rgba_f32().collect();
        check_len("COLOR_0", v.len())?;
        p.colors = Some(v);
    }
    if let Some((nt, _)) = &mat.normal_tex {
        if let Some(t) = reader.read_tangents() {
            let v: Vec<[f32; 4]> = t.collect();
            check_len("TANGENT", v.len())?;
            p.tangents = Some(v);
        } else {
            let uv = if nt.tex_coord == 0 { &p.uv0 } else { &p.uv1 };
            let uv = uv.as_ref().ok_or_else(|| {
                ctx.err(format!(
                    "{label}: normal map without TEXCOORD_{}",
                    nt.tex_coord
                ))
            })?;
            p.tangents = Some(generate_tangents(&p.positions, &p.normals, uv, &p.indices));
        }
    }
    if p.positions
        .iter()
        .flatten()
        .any(|c| !c.is_finite() || c.abs() > 1e9)
    {
        return Err(ctx.err(format!(
            "{label}: POSITION contains NaN, infinite or absurd (over 1e9) values"
        )));
    }
    let fixed = sanitize_attributes(&mut p);
    if fixed > 0 {
        tracing::warn!(
            "{}: {label}: replaced {fixed} NaN or infinite normal, tangent, UV or colour values",
            ctx.path.display()
        );
    }
    p.compute_bounds();
    Ok(Some(p))
}

/// Replaces non-finite normals by +Y, tangents by +X, UVs and colours by
/// zero and one; returns how many vertices were changed.
fn sanitize_attributes(p: &mut Primitive) -> usize {
    fn fix<const N: usize>(v: &mut [[f32; N]], with: [f32; N]) -> usize {
        let mut n = 0;
        for a in v.iter_mut().filter(|a| a.iter().any(|c| !c.is_finite())) {
            *a = with;
            n += 1;
        }
        n
    }
    let mut n = fix(&mut p.normals, [0.0, 1.0, 0.0]);
    if let Some(t) = &mut p.tangents {
        n += fix(t, [1.0, 0.0, 0.0, 1.0]);
    }
    for uv in [&mut p.uv0, &mut p.uv1].into_iter().flatten() {
        n += fix(uv, [0.0, 0.0]);
    }
    if let Some(c) = &mut p.colors {
        n += fix(c, [1.0; 4]);
    }
    n
}

fn strip_to_list(i: &[u32]) -> Vec<u32> {
    let mut out = Vec::new();
    for k in 2..i.len() {
        if k % 2 == 0 {
            out.extend_from_slice(&[i[k - 2], i[k - 1], i[k]]);
        } else {
            out.extend_from_slice(&[i[k - 1], i[k - 2], i[k]]);
        }
    }
    out
}

fn fan_to_list(i: &[u32]) -> Vec<u32> {
    (2..i.len()).flat_map(|k| [i[0], i[k - 1], i[k]]).collect()
}

/// Area-weighted vertex normals from face normals.
fn generate_normals(pos: &[[f32; 3]], idx: &[u32]) -> Vec<[f32; 3]> {
    let mut acc = vec![Vec3::ZERO; pos.len()];
    for t in idx.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| Vec3::from_array(pos[t[k] as usize]));
        let n = (b - a).cross(c - a);
        for &k in t {
            acc[k as usize] += n;
        }
    }
    acc.iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3::Y).to_array())
        .collect()
}

/// Per-vertex tangents from UV gradients (Lengyel, "Computing Tangent Space
/// Basis Vectors for an Arbitrary Mesh", 2001): accumulate each triangle's
/// dP/du and dP/dv, Gram-Schmidt against the normal, handedness from the
/// sign of (N × T) · B.
fn generate_tangents(
    pos: &[[f32; 3]],
    nrm: &[[f32; 3]],
    uv: &[[f32; 2]],
    idx: &[u32],
) -> Vec<[f32; 4]> {
    let mut tan = vec![Vec3::ZERO; pos.len()];
    let mut bit = vec![Vec3::ZERO; pos.len()];
    for t in idx.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| t[k] as usize);
        let (e1, e2) = (
            Vec3::from(pos[b]) - Vec3::from(pos[a]),
            Vec3::from(pos[c]) - Vec3::from(pos[a]),
        );
        let (d1, d2) = (
            Vec2::from(uv[b]) - Vec2::from(uv[a]),
            Vec2::from(uv[c]) - Vec2::from(uv[a]),
        );
        let det = d1.x * d2.y - d2.x * d1.y;
        if det.abs() < 1e-20 {
            continue;
        }
        let r = 1.0 / det;
        let sdir = (e1 * d2.y - e2 * d1.y) * r;
        let tdir = (e2 * d1.x - e1 * d2.x) * r;
        for k in [a, b, c] {
            tan[k] += sdir;
            bit[k] += tdir;
        }
    }
    (0..pos.len())
        .map(|i| {
            let n = Vec3::from(nrm[i]);
            let t = (tan[i] - n * n.dot(tan[i]))
                .try_normalize()
                .unwrap_or_else(|| n.any_orthonormal_vector());
            let w = if n.cross(t).dot(bit[i]) < 0.0 {
                -1.0
            } else {
                1.0
            };
            [t.x, t.y, t.z, w]
        })
        .collect()
}

fn read_vec<T: gltf::accessor::Item + Copy>(ctx: &Ctx, a: &gltf::Accessor) -> Result<Vec<T>> {
    let it = gltf::accessor::Iter::<T>::new(a.clone(), |b| Some(ctx.buffers[b.index()].as_slice()))
        .ok_or_else(|| ctx.err(format!("accessor {} cannot be read", a.index())))?;
    Ok(it.collect())
}

/// EXT_mesh_gpu_instancing: per-instance TRANSLATION / ROTATION / SCALE.
fn gpu_instances(
    ctx: &Ctx,
    doc: &gltf::Document,
    node: &gltf::Node,
    max: usize,
) -> Result<Option<Vec<DAffine3>>> {
    let Some(ext) = node
        .extensions()
        .and_then(|e| e.get("EXT_mesh_gpu_instancing"))
    else {
        return Ok(None);
    };
    let attrs = ext.get("attributes").and_then(|a| a.as_object());
    let accessor = |name: &str, dims: Dimensions| -> Result<Option<gltf::Accessor>> {
        let Some(i) = attrs.and_then(|a| a.get(name)).and_then(|v| v.as_u64()) else {
            return Ok(None);
        };
        let a = doc.accessors().nth(i as usize).ok_or_else(|| {
            ctx.err(format!(
                "node {}: EXT_mesh_gpu_instancing {name} refers to missing accessor {i}",
                node.index()
            ))
        })?;
        if a.dimensions() != dims || a.data_type() != gltf::accessor::DataType::F32 {
            return Err(ctx.err(format!(
                "node {}: EXT_mesh_gpu_instancing {name} must be float {dims:?}",
                node.index()
            )));
        }
        Ok(Some(a))
    };
    let t: Option<Vec<[f32; 3]>> = accessor("TRANSLATION", Dimensions::Vec3)?
        .map(|a| read_vec(ctx, &a))
        .transpose()?;
    let r: Option<Vec<[f32; 4]>> = accessor("ROTATION", Dimensions::Vec4)?
        .map(|a| read_vec(ctx, &a))
        .transpose()?;
    let s: Option<Vec<[f32; 3]>> = accessor("SCALE", Dimensions::Vec3)?
        .map(|a| read_vec(ctx, &a))
        .transpose()?;
    let count = [
        t.as_ref().map(Vec::len),
        r.as_ref().map(Vec::len),
        s.as_ref().map(Vec::len),
    ]
    .into_iter()
    .flatten()
    .max()
    .unwrap_or(0);
    if count > max {
        return Err(ctx.err(format!(
            "node {}: EXT_mesh_gpu_instancing adds {count} instances, over the {MAX_SCENE_INSTANCES} instance limit",
            node.index()
        )));
    }
    let mut out = Vec::with_capacity(count);
    for i in 0..count {
        let tr = t
            .as_ref()
            .and_then(|v| v.get(i))
            .map_or(DVec3::ZERO, |v| Vec3::from(*v).as_dvec3());
        let ro = r
            .as_ref()
            .and_then(|v| v.get(i))
            .map_or(DQuat::IDENTITY, |q| {
                DQuat::from_xyzw(q[0] as f64, q[1] as f64, q[2] as f64, q[3] as f64).normalize()
            });
        let sc = s
            .as_ref()
            .and_then(|v| v.get(i))
            .map_or(DVec3::ONE, |v| Vec3::from(*v).as_dvec3());
        out.push(DAffine3::from_scale_rotation_translation(sc, ro, tr));
    }
    Ok(Some(out))
}

fn node_transform(node: &gltf::Node) -> DAffine3 {
    let m = node.transform().matrix();
    let d = DMat4::from_cols_array_2d(&m.map(|c| c.map(|v| v as f64)));
    DAffine3::from_mat4(d)
}

fn place_nodes(ctx: &Ctx, doc: &gltf::Document, scene: &mut Scene) -> Result<()> {
    let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s.nodes().collect(),
        None => {
            let mut is_child = vec![false; doc.nodes().len()];
            for n in doc.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            doc.nodes().filter(|n| !is_child[n.index()]).collect()
        }
    };
    let mut visited = vec![false; doc.nodes().len()];
    let mut dropped: std::collections::BTreeMap<&'static str, usize> = Default::default();
    let mut stack: Vec<(gltf::Node, DAffine3, usize)> = roots
        .into_iter()
        .map(|n| (n, DAffine3::IDENTITY, 0))
        .collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > MAX_NODE_DEPTH {
            return Err(ctx.err(format!(
                "node hierarchy deeper than {MAX_NODE_DEPTH} levels at node {}",
                node.index()
            )));
        }
        if std::mem::replace(&mut visited[node.index()], true) {
            return Err(ctx.err(format!(
                "node {} is reached twice (a cycle or shared child in the node graph)",
                node.index()
            )));
        }
        let world = parent * node_transform(&node);
        if !world.is_finite() {
            return Err(ctx.err(format!("node {} has a non-finite transform", node.index())));
        }
        if let Some(mesh) = node.mesh() {
            let locals =
                gpu_instances(ctx, doc, &node, MAX_SCENE_INSTANCES - scene.instances.len())?
                    .unwrap_or_else(|| vec![DAffine3::IDENTITY]);
            if scene.instances.len() + locals.len() > MAX_SCENE_INSTANCES {
                return Err(ctx.err(format!(
                    "node {} would take the scene over {MAX_SCENE_INSTANCES} instances",
                    node.index()
                )));
            }
            for local in locals {
                let transform = world * local;
                match instance_problem(&transform) {
                    None => scene.instances.push(Instance {
                        mesh: mesh.index() as u32,
                        transform,
                    }),
                    Some(why) => *dropped.entry(why).or_default() += 1,
                }
            }
        }
        for child in node.children() {
            stack.push((child, world, depth + 1));
        }
    }
    for (why, n) in dropped {
        tracing::warn!("{}: dropped {n} instance(s) with {why}", ctx.path.display());
    }
    Ok(())
}

/// Largest coordinate or scale factor an instance transform may hold, in
/// metres: beyond it f32 GPU positions lose all precision and frustum
/// tests overflow.
pub const MAX_TRANSFORM_MAGNITUDE: f64 = 1e9;

/// Why an instance transform cannot be drawn (None: it can): non-finite
/// values, a zero (singular) scale, or magnitudes over
/// [`MAX_TRANSFORM_MAGNITUDE`].
pub fn instance_problem(t: &DAffine3) -> Option<&'static str> {
    if !t.is_finite() {
        return Some("a NaN or infinite transform");
    }
    let m = t.matrix3;
    if m.to_cols_array()
        .iter()
        .chain(t.translation.as_ref())
        .any(|v| v.abs() > MAX_TRANSFORM_MAGNITUDE)
    {
        return Some("a scale or translation over 1e9 m");
    }
    // A scale so small the mesh collapses to a point (or a plane) shows
    // nothing and makes normals singular.
    if m.determinant().abs() < 1e-18 {
        return Some("a zero scale");
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_become_lists() {
        assert_eq!(strip_to_list(&[0, 1, 2, 3]), vec![0, 1, 2, 2, 1, 3]);
        assert_eq!(fan_to_list(&[0, 1, 2, 3]), vec![0, 1, 2, 0, 2, 3]);
    }
}
