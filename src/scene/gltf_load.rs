//! glTF 2.0 import (`.gltf` with external or data: buffers, `.glb`).
//!
//! The `gltf` crate parses and validates the JSON; this module resolves
//! buffers and images itself so that every failure names the file and the
//! problem, and checks every accessor and index range against the real buffer
//! sizes before reading, so a malformed file is an error, never a panic.

use super::gltf_data::{self, Meshopt, ViewData, Views};
use super::{
    AlphaMode, Instance, Material, Mesh, Primitive, Scene, SceneCamera, Sun, TexRef, Texture,
};
use crate::error::{Error, Result};
use glam::{DAffine3, DMat4, DQuat, DVec3, Vec2, Vec3};
use gltf::accessor::Dimensions;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// How vergence treats a glTF extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Support {
    /// Read and rendered.
    Supported,
    /// Read, with the parts vergence cannot draw ignored (the note says which).
    Partial,
    /// A file that requires it is refused (the note says why).
    Refused,
}

/// Every glTF extension vergence knows, how it is treated, and a note.
/// Extensions not listed are ignored when only used, refused when required.
pub const EXTENSIONS: &[(&str, Support, &str)] = &[
    (
        "KHR_mesh_quantization",
        Support::Supported,
        "8/16-bit integer attributes, dequantized to f32 on load",
    ),
    (
        "EXT_meshopt_compression",
        Support::Supported,
        "meshoptimizer decoders (attributes, triangles, indices; octahedral, quaternion, exponential filters); fallback buffers are not read",
    ),
    (
        "KHR_meshopt_compression",
        Support::Supported,
        "as EXT_meshopt_compression, plus the color filter",
    ),
    (
        "KHR_texture_transform",
        Support::Supported,
        "offset, rotation, scale and texCoord, applied to the UVs on load",
    ),
    (
        "EXT_texture_webp",
        Support::Supported,
        "WebP images decoded with the image crate",
    ),
    (
        "KHR_materials_emissive_strength",
        Support::Supported,
        "multiplies the emissive factor",
    ),
    (
        "KHR_materials_unlit",
        Support::Supported,
        "base colour only",
    ),
    (
        "EXT_mesh_gpu_instancing",
        Support::Supported,
        "TRANSLATION, ROTATION, SCALE per instance",
    ),
    (
        "KHR_lights_punctual",
        Support::Partial,
        "the first directional light becomes the sun; point and spot lights are ignored",
    ),
    (
        "KHR_texture_basisu",
        Support::Supported,
        "KTX2 images: Basis Universal ETC1S and UASTC transcoded to RGBA8 (pure-Rust basisu transcoder), uncompressed RGBA8 read as is",
    ),
    (
        "KHR_draco_mesh_compression",
        Support::Supported,
        "decoded with the pure-Rust draco-core decoder (edgebreaker, valence and sequential meshes; positions, normals, tangents, UVs, colours, indices)",
    ),
];

/// How `name` is treated, with the note, if vergence knows it.
pub fn support(name: &str) -> Option<(Support, &'static str)> {
    EXTENSIONS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|&(_, s, note)| (s, note))
}

/// Extensions a file may list in `extensionsRequired` (the supported and
/// partly supported entries of [`EXTENSIONS`]).
pub const SUPPORTED_REQUIRED: &[&str] = &[
    "KHR_mesh_quantization",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "KHR_texture_transform",
    "EXT_texture_webp",
    "KHR_materials_emissive_strength",
    "KHR_materials_unlit",
    "EXT_mesh_gpu_instancing",
    "KHR_lights_punctual",
    "KHR_texture_basisu",
    "KHR_draco_mesh_compression",
];
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
    /// Which buffers are meshopt fallback buffers (never read).
    fallback: Vec<bool>,
    views: Vec<ViewData>,
    /// Whether the file declares KHR_mesh_quantization.
    quantization: bool,
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

    fn data(&self) -> Views<'_> {
        Views {
            buffers: &self.buffers,
            views: &self.views,
        }
    }

    /// Reads accessor `a` as `N`-component floats.
    fn floats<const N: usize>(&self, a: &gltf::Accessor) -> Result<Vec<[f32; N]>> {
        gltf_data::read_f32(&self.data(), a).map_err(|e| self.err(e))
    }
}

/// Loads a `.gltf` or `.glb` file. A path that does not exist but ends in
/// `#N` or `#NAME` loads that scene of the file instead of the default one.
pub fn load(path: &Path) -> Result<Scene> {
    load_in(path, &super::budget::LoadBudget::default())
}

/// Loads a `.gltf` or `.glb` file within `budget` (a manifest's, shared by
/// all it names). A path that does not exist but ends in `#N` or `#NAME`
/// loads that scene of the file instead of the default one.
pub fn load_in(path: &Path, budget: &super::budget::LoadBudget) -> Result<Scene> {
    let (path, selector) = split_scene_selector(path);
    if let Some(meta) = std::fs::metadata(&path).ok().filter(|m| m.is_file()) {
        budget
            .spend(Some(meta.len()), "the scene file")
            .map_err(|m| Error::scene(&path, m))?;
    }
    let bytes =
        crate::fsio::read_bounded(&path, crate::fsio::MAX_SCENE_FILE_BYTES).map_err(|source| {
            Error::Io {
                path: path.to_path_buf(),
                source,
            }
        })?;
    load_bytes_scene_in(&path, &bytes, selector.as_deref(), budget)
}

/// Splits `file.glb#2` or `file.glb#Name` into the file and the scene
/// selector, when the path as given is not itself a file.
fn split_scene_selector(path: &Path) -> (PathBuf, Option<String>) {
    let text = path.to_string_lossy();
    if !path.exists() {
        if let Some((file, sel)) = text.rsplit_once('#') {
            if !sel.is_empty() && !sel.contains(['/', '\\']) {
                return (PathBuf::from(file), Some(sel.to_string()));
            }
        }
    }
    (path.to_path_buf(), None)
}

/// Loads glTF or GLB content already read from `path` (external resources
/// resolve relative to `path`'s folder).
pub fn load_bytes(path: &Path, bytes: &[u8]) -> Result<Scene> {
    load_bytes_scene(path, bytes, None)
}

/// [`load_bytes`] within `budget`.
pub fn load_bytes_in(
    path: &Path,
    bytes: &[u8],
    budget: &super::budget::LoadBudget,
) -> Result<Scene> {
    load_bytes_scene_in(path, bytes, None, budget)
}

/// As [`load_bytes`], placing the nodes of the scene `selector` names (an
/// index or a name; None: the default scene, else the first).
pub fn load_bytes_scene(path: &Path, bytes: &[u8], selector: Option<&str>) -> Result<Scene> {
    load_bytes_scene_in(path, bytes, selector, &super::budget::LoadBudget::default())
}

/// [`load_bytes_scene`] within `budget`.
pub fn load_bytes_scene_in(
    path: &Path,
    bytes: &[u8],
    selector: Option<&str>,
    budget: &super::budget::LoadBudget,
) -> Result<Scene> {
    let (gltf, required) = parse(path, bytes)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let used: Vec<String> = gltf
        .document
        .extensions_used()
        .map(str::to_string)
        .collect();
    let mut ctx = Ctx {
        path,
        dir,
        buffers: Vec::new(),
        budget,
        fallback: Vec::new(),
        views: Vec::new(),
        quantization: used.iter().any(|e| e == "KHR_mesh_quantization")
            || required.iter().any(|e| e == "KHR_mesh_quantization"),
    };
    (ctx.buffers, ctx.fallback) = load_buffers(&ctx, &gltf)?;
    ctx.views = build_views(&ctx, &gltf.document)?;
    check_accessors(&ctx, &gltf.document)?;
    check_attribute_types(&ctx, &gltf.document)?;

    let mut scene = Scene {
        name: path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        nodes: gltf.document.nodes().len(),
        extensions_used: used,
        extensions_required: required,
        ..Scene::default()
    };
    let images = decode_images(&ctx, &gltf.document)?;
    let mut textures = TextureCache {
        images,
        ..TextureCache::default()
    };
    let mut uv_transforms = Vec::new();
    for m in gltf.document.materials() {
        let (mat, uvt) =
            convert_material(&ctx, &gltf.document, &m, &mut textures, &mut scene.textures)?;
        scene.materials.push(mat);
        uv_transforms.push(uvt);
    }
    let default_material = scene.materials.len() as u32;
    scene.materials.push(Material {
        metallic: 0.0,
        roughness: 0.8,
        ..Material::default()
    });
    uv_transforms.push([None; 2]);

    for mesh in gltf.document.meshes() {
        let mut out = Mesh {
            name: mesh.name().unwrap_or("mesh").to_string(),
            primitives: Vec::new(),
        };
        for prim in mesh.primitives() {
            if let Some(p) = convert_primitive(
                &ctx,
                &mesh,
                &prim,
                &scene.materials,
                &uv_transforms,
                default_material,
            )? {
                out.primitives.push(scene.primitives.len() as u32);
                scene.primitives.push(p);
            }
        }
        scene.meshes.push(out);
    }
    let lights = punctual_lights(&ctx, &gltf.document)?;
    place_nodes(&ctx, &gltf.document, selector, &lights, &mut scene)?;
    Ok(scene)
}

/// Parses and validates glTF or GLB bytes; returns the document and its
/// `extensionsRequired`. What the `gltf` crates assume without checking is
/// checked first (a primitive's attribute accessor indexes, which
/// gltf-json 1.4.1's validator indexes without a bounds check; an image's
/// uri or bufferView + mimeType, which gltf 1.4.1 unwraps; texture
/// sources), so a bad file is an error instead of a panic. Required
/// extensions are checked against [`SUPPORTED_REQUIRED`] here, and removed
/// before the crate's validator (which only knows its compiled-in ones).
fn parse(path: &Path, bytes: &[u8]) -> Result<(gltf::Gltf, Vec<String>)> {
    let describe = |e: gltf::Error| Error::scene(path, describe_gltf_error(bytes, &e));
    // gltf 1.4.1 binary.rs subtracts the 12-byte header from the declared
    // length without a check (an overflow panic in debug builds; found by
    // fuzzing). GLB §4.4.3: the header's length is the whole file; the
    // gltf crate ignores bytes past it, which hides a damaged or
    // concatenated file.
    if let Some(h) = bytes.get(..12).filter(|h| h.starts_with(b"glTF")) {
        let declared = u32::from_le_bytes([h[8], h[9], h[10], h[11]]);
        if declared < 12 {
            return Err(Error::scene(
                path,
                format!("malformed or truncated .glb container: declared length {declared} is shorter than its 12-byte header"),
            ));
        }
        if (declared as usize) < bytes.len() {
            return Err(Error::scene(
                path,
                format!(
                    "malformed .glb container: its header declares {declared} bytes but the file has {}",
                    bytes.len()
                ),
            ));
        }
    }
    let raw = gltf::Gltf::from_slice_without_validation(bytes).map_err(describe)?;
    let blob = raw.blob;
    let mut json = raw.document.into_json();
    let required = std::mem::take(&mut json.extensions_required);
    for ext in &required {
        if !SUPPORTED_REQUIRED.contains(&ext.as_str()) {
            return Err(Error::scene(path, unsupported_required(ext)));
        }
    }
    // Accessors a Draco stream fills have no bufferView, which the crate's
    // validator reports as missing; those reports are dropped below.
    let mut draco_filled = std::collections::HashSet::new();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let draco = prim
                .extensions
                .as_ref()
                .and_then(|e| e.others.get(super::draco::NAME));
            if let Some(ext) = draco {
                let ext = super::draco::DracoExt::parse(ext)
                    .map_err(|e| Error::scene(path, format!("mesh {m} primitive {p}: {e}")))?;
                for (semantic, index) in &prim.attributes {
                    let name = semantic.to_string();
                    if ext.id_of(&name).is_some() {
                        draco_filled.insert(index.value());
                    }
                }
                if let Some(i) = &prim.indices {
                    draco_filled.insert(i.value());
                }
            }
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
    let mut errors = Vec::new();
    {
        use gltf::json::validation::Validate;
        json.validate(&json, gltf::json::Path::new, &mut |path, error| {
            errors.push((path(), error))
        });
    }
    errors.retain(|(at, e)| {
        !(matches!(e, gltf::json::validation::Error::Missing)
            && draco_filled
                .iter()
                .any(|i| at.as_str() == format!("accessors[{i}].bufferView")))
    });
    if !errors.is_empty() {
        return Err(describe(gltf::Error::Validation(errors)));
    }
    let document = gltf::Document::from_json_without_validation(json);
    Ok((gltf::Gltf { document, blob }, required))
}

/// The message for a required extension vergence cannot honour.
fn unsupported_required(name: &str) -> String {
    match support(name) {
        Some((Support::Refused, why)) => {
            format!("requires glTF extension {name}, which vergence does not support: {why}")
        }
        _ => format!(
            "requires glTF extension {name}, which vergence does not support (supported: {})",
            SUPPORTED_REQUIRED.join(", ")
        ),
    }
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

/// Reads every buffer except meshopt fallback buffers (which the
/// extension says a loader that decodes it must not fetch; they are left
/// empty). Only buffer 0 may be the GLB binary chunk (glTF 2.0 §4.4.3.3).
fn load_buffers(ctx: &Ctx, gltf: &gltf::Gltf) -> Result<(Vec<Vec<u8>>, Vec<bool>)> {
    let mut out = Vec::new();
    let mut fallback = Vec::new();
    for b in gltf.document.buffers() {
        let what = format!("buffer {}", b.index());
        if gltf_data::is_fallback(&b) {
            out.push(Vec::new());
            fallback.push(true);
            continue;
        }
        let mut data = match b.source() {
            gltf::buffer::Source::Bin if b.index() == 0 => {
                let blob = gltf.blob.as_ref().ok_or_else(|| {
                    ctx.err(format!(
                        "{what} refers to the GLB binary chunk, which is missing"
                    ))
                })?;
                ctx.spend(blob.len() as u64, &what)?;
                blob.clone()
            }
            gltf::buffer::Source::Bin => {
                return Err(ctx.err(format!(
                    "{what} has no uri (only buffer 0 may be the GLB binary chunk, and it is not a meshopt fallback buffer)"
                )))
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
        fallback.push(false);
    }
    Ok((out, fallback))
}

/// Resolves every bufferView: a checked range of a loaded buffer, or the
/// decoded output of its meshopt stream. A view into a fallback buffer
/// must be compressed (its bytes do not exist otherwise).
fn build_views(ctx: &Ctx, doc: &gltf::Document) -> Result<Vec<ViewData>> {
    let mut out = Vec::with_capacity(doc.views().len());
    for v in doc.views() {
        let label = format!("bufferView {}", v.index());
        if let Some(ext) = gltf_data::meshopt_of(&v) {
            let m = Meshopt::parse(ext)
                .map_err(|e| ctx.err(format!("{label}: meshopt compression {e}")))?;
            out.push(decode_meshopt_view(ctx, &v, &m, &label)?);
            continue;
        }
        let b = v.buffer().index();
        if ctx.fallback[b] {
            return Err(ctx.err(format!(
                "{label} points into buffer {b}, a meshopt fallback buffer, but is not compressed; its data is not in the file"
            )));
        }
        let len = ctx.buffers[b].len();
        let end = v.offset().checked_add(v.length());
        match end {
            Some(end) if end <= len => out.push(ViewData::Range {
                buffer: b,
                start: v.offset(),
                end,
            }),
            _ => {
                return Err(ctx.err(format!(
                    "{label} (offset {}, length {}) runs past the end of buffer {b} ({len} bytes)",
                    v.offset(),
                    v.length(),
                )))
            }
        }
    }
    Ok(out)
}

fn decode_meshopt_view(
    ctx: &Ctx,
    v: &gltf::buffer::View,
    m: &Meshopt,
    label: &str,
) -> Result<ViewData> {
    let fail = |e: String| ctx.err(format!("{label}: meshopt {e}"));
    let source = ctx
        .buffers
        .get(m.buffer)
        .ok_or_else(|| fail(format!("stream refers to missing buffer {}", m.buffer)))?;
    if ctx.fallback[m.buffer] {
        return Err(fail(format!(
            "stream is in buffer {}, which is itself a fallback buffer",
            m.buffer
        )));
    }
    let end = m.byte_offset.checked_add(m.byte_length);
    let Some(stream) = end.and_then(|e| source.get(m.byte_offset..e)) else {
        return Err(fail(format!(
            "stream (offset {}, length {}) is longer than buffer {} ({} bytes)",
            m.byte_offset,
            m.byte_length,
            m.buffer,
            source.len()
        )));
    };
    if let Some(s) = v.stride() {
        if s != m.byte_stride {
            return Err(fail(format!(
                "byteStride {} differs from the bufferView's {s}",
                m.byte_stride
            )));
        }
    }
    let decoded = m.count.checked_mul(m.byte_stride);
    if decoded.is_none_or(|d| d < v.length()) {
        return Err(fail(format!(
            "stream decodes to {} × {} bytes, less than the bufferView's byteLength {}",
            m.count,
            m.byte_stride,
            v.length()
        )));
    }
    m.validate().map_err(&fail)?;
    // Before anything is reserved: meshopt's densest code (a vertex
    // group's 2-bit header for 16 zero deltas of a byte) packs 64 decoded
    // bytes into one, and the index codecs pack less; a stream that claims
    // more is refused rather than trusted with memory.
    let most = (stream.len() as u64)
        .saturating_mul(64)
        .saturating_add(64 << 10);
    let want = decoded.unwrap_or(0) as u64;
    if want > most {
        return Err(fail(format!(
            "stream of {} bytes claims {} × {} = {want} decoded bytes, more than 64 per stream byte",
            stream.len(),
            m.count,
            m.byte_stride
        )));
    }
    ctx.spend(want, label)?;
    let (words, _) = m.decode(stream).map_err(fail)?;
    Ok(ViewData::Decoded {
        words,
        len: v.length(),
    })
}

/// Component types and shapes glTF 2.0 allows for the attributes vergence
/// reads (spec §3.7.2.1 "Overview" table of mesh attributes, and §3.7.2.1
/// for indices), widened by KHR_mesh_quantization's table ("Extending Mesh
/// Attributes") when the file declares it.
fn check_attribute_types(ctx: &Ctx, doc: &gltf::Document) -> Result<()> {
    use gltf::accessor::DataType::{F32, I16, I8, U16, U32, U8};
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
                let int8_16 = matches!(dt, I8 | U8 | I16 | U16);
                let signed_norm = matches!(dt, I8 | I16) && norm;
                // (core glTF, KHR_mesh_quantization's additions).
                let (core, quantized) = match &semantic {
                    Semantic::Positions => (dt == F32, int8_16),
                    Semantic::Normals => (dt == F32, signed_norm),
                    Semantic::Tangents => (dt == F32, signed_norm),
                    Semantic::TexCoords(_) => {
                        (dt == F32 || (matches!(dt, U8 | U16) && norm), int8_16)
                    }
                    Semantic::Colors(_) => (dt == F32 || (matches!(dt, U8 | U16) && norm), false),
                    Semantic::Joints(_) => (matches!(dt, U8 | U16) && !norm, false),
                    Semantic::Weights(_) => (dt == F32 || (matches!(dt, U8 | U16) && norm), false),
                    // Application-specific attributes (`_NAME`) are not
                    // read; any type is theirs to choose.
                    Semantic::Extras(_) => (true, false),
                };
                let shape = match &semantic {
                    Semantic::Positions | Semantic::Normals => dims == Dimensions::Vec3,
                    Semantic::Tangents | Semantic::Joints(_) | Semantic::Weights(_) => {
                        dims == Dimensions::Vec4
                    }
                    Semantic::TexCoords(_) => dims == Dimensions::Vec2,
                    Semantic::Colors(_) => matches!(dims, Dimensions::Vec3 | Dimensions::Vec4),
                    Semantic::Extras(_) => true,
                };
                if shape && !core && quantized && !ctx.quantization {
                    return Err(bad(
                        &semantic.to_string(),
                        &a,
                        "this only with KHR_mesh_quantization, which the file does not declare",
                    ));
                }
                if !shape || !(core || quantized) {
                    return Err(bad(
                        &semantic.to_string(),
                        &a,
                        match &semantic {
                            Semantic::Normals | Semantic::Tangents if int8_16 => {
                                "integer normals and tangents only as normalized signed byte or short (KHR_mesh_quantization)"
                            }
                            _ => "the types in the glTF 2.0 and KHR_mesh_quantization attribute tables",
                        },
                    ));
                }
            }
        }
    }
    Ok(())
}

fn check_accessors(ctx: &Ctx, doc: &gltf::Document) -> Result<()> {
    let data = ctx.data();
    for a in doc.accessors() {
        if a.count() == 0 {
            return Err(ctx.err(format!("accessor {} has count 0", a.index())));
        }
        let Some(view) = a.view() else { continue };
        let elem = a.size();
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            // glTF 2.0 §3.6.2.4: byteStride must hold a whole element.
            return Err(ctx.err(format!(
                "accessor {}: bufferView {} byteStride {stride} is smaller than its {elem}-byte elements",
                a.index(),
                view.index()
            )));
        }
        let len = data.bytes(view.index()).len();
        let need = (a.count() - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(elem))
            .and_then(|x| x.checked_add(a.offset()));
        if need.is_none_or(|n| n > len) {
            return Err(ctx.err(format!(
                "accessor {} ({} elements of {elem} bytes at offset {}) is out of range of bufferView {} ({len} bytes)",
                a.index(),
                a.count(),
                a.offset(),
                view.index(),
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
    images: HashMap<usize, DecodedImage>,
}

/// A decoded image: width, height and its shared RGBA8 texels.
type DecodedImage = (u32, u32, std::sync::Arc<Vec<u8>>);

/// The image a texture samples: the EXT_texture_webp source, else the core
/// source, else the KHR_texture_basisu source (a KTX2 image).
fn texture_image(ctx: &Ctx, doc: &gltf::Document, tex: &gltf::Texture) -> Result<usize> {
    let ext = |name: &str| {
        tex.extension_value(name)
            .and_then(|e| e.get("source"))
            .map(|v| v.as_u64().map_or(usize::MAX, |i| i as usize))
    };
    let core = doc.as_json().textures[tex.index()].source.value();
    let core = (core != u32::MAX as usize).then_some(core);
    let index = ext("EXT_texture_webp")
        .or(core)
        .or_else(|| ext("KHR_texture_basisu"))
        .ok_or_else(|| ctx.err(format!("texture {} has no image source", tex.index())))?;
    if index >= doc.images().len() {
        return Err(ctx.err(format!(
            "texture {} refers to image {index}, but there are {}",
            tex.index(),
            doc.images().len()
        )));
    }
    Ok(index)
}

/// Every texture a material slot uses, as (texture, image) indices.
fn material_textures(ctx: &Ctx, doc: &gltf::Document) -> Result<Vec<(usize, usize)>> {
    let mut out = Vec::new();
    for m in doc.materials() {
        let pbr = m.pbr_metallic_roughness();
        let slots = [
            pbr.base_color_texture().map(|t| t.texture()),
            pbr.metallic_roughness_texture().map(|t| t.texture()),
            m.normal_texture().map(|t| t.texture()),
            m.occlusion_texture().map(|t| t.texture()),
            m.emissive_texture().map(|t| t.texture()),
        ];
        for t in slots.into_iter().flatten() {
            out.push((t.index(), texture_image(ctx, doc, &t)?));
        }
    }
    Ok(out)
}

/// Reads the bytes of every image a material uses (in file order, against
/// the resource budget), then decodes them in parallel with rayon.
fn decode_images(ctx: &Ctx, doc: &gltf::Document) -> Result<HashMap<usize, DecodedImage>> {
    let mut wanted: Vec<usize> = material_textures(ctx, doc)?
        .into_iter()
        .map(|(_, i)| i)
        .collect();
    wanted.sort_unstable();
    wanted.dedup();
    let images: Vec<gltf::Image> = doc.images().collect();
    let mut sources = Vec::with_capacity(wanted.len());
    let mut free = super::image_decode::FREE_DECODE_BYTES;
    for &i in &wanted {
        let img = &images[i];
        let (name, bytes, mime) = match img.source() {
            gltf::image::Source::Uri { uri, mime_type } => (
                uri.to_string(),
                read_uri(ctx, uri, &format!("image {i}"))?,
                mime_type.map(str::to_string),
            ),
            gltf::image::Source::View { view, mime_type } => (
                format!("image {i} (bufferView {})", view.index()),
                ctx.data().bytes(view.index()).to_vec(),
                Some(mime_type.to_string()),
            ),
        };
        let ktx2 = mime.as_deref() == Some("image/ktx2")
            || bytes.starts_with(&super::image_decode::KTX2_MAGIC);
        // Charged before any image is decoded (they decode in parallel).
        let size = super::image_decode::decoded_bytes(&bytes, ktx2).map_err(|e| {
            ctx_err_path(ctx.path, format!("image '{name}' cannot be decoded: {e}"))
        })?;
        free = decode_ratio_check(ctx, &name, size, &bytes, free)?;
        ctx.spend(size, &format!("image '{name}'"))?;
        sources.push((i, name, bytes, ktx2));
    }
    use rayon::prelude::*;
    let decoded: Vec<Result<(usize, String, image::RgbaImage)>> = sources
        .into_par_iter()
        .map(|(i, name, bytes, ktx2)| {
            let img = if ktx2 {
                super::image_decode::decode_ktx2_rgba8(&bytes)
            } else {
                super::image_decode::decode_rgba8(&bytes)
            };
            img.map(|img| (i, name.clone(), img)).map_err(|e| {
                ctx_err_path(ctx.path, format!("image '{name}' cannot be decoded: {e}"))
            })
        })
        .collect();
    let mut out = HashMap::new();
    for d in decoded {
        let (i, _, img) = d?;
        let (w, h) = img.dimensions();
        out.insert(i, (w, h, std::sync::Arc::new(img.into_raw())));
    }
    Ok(out)
}

/// An image that would decode to more than [`MAX_DECODE_RATIO`] times
/// its encoded size (in its own pixel format for PNG,
/// [`super::image_decode::ratio_limit`]) is refused unless the scene's shared allowance
/// (`free`, what is left of [`FREE_DECODE_BYTES`]) covers it; returns
/// what is left of the allowance.
///
/// [`MAX_DECODE_RATIO`]: super::image_decode::MAX_DECODE_RATIO
/// [`FREE_DECODE_BYTES`]: super::image_decode::FREE_DECODE_BYTES
fn decode_ratio_check(ctx: &Ctx, name: &str, size: u64, bytes: &[u8], free: u64) -> Result<u64> {
    let ratio = super::image_decode::MAX_DECODE_RATIO;
    let encoded = bytes.len() as u64;
    if size <= super::image_decode::ratio_limit(bytes) {
        return Ok(free);
    }
    if size <= free {
        return Ok(free - size);
    }
    Err(ctx_err_path(
        ctx.path,
        format!(
            "image '{name}': {encoded} encoded bytes claim {size} decoded bytes, over {ratio}:1 (a decompression bomb?)"
        ),
    ))
}

/// A scene error for `path` (usable from threads without the context).
fn ctx_err_path(path: &Path, message: String) -> Error {
    Error::scene(path, message)
}

/// A KHR_texture_transform as the 2×3 matrix `T · R · S` of the extension's
/// README (its GLSL: `rotation = mat3(cos, sin, 0, -sin, cos, 0, 0, 0, 1)`
/// in column order, so `R·(u, v) = (cos·u − sin·v, sin·u + cos·v)`), stored
/// as columns `[a, b, c]` with `uv' = a·u + b·v + c`.
type UvTransform = [[f32; 2]; 3];

/// Reads a texture info's KHR_texture_transform (None when absent or the
/// identity) and its texCoord override.
fn texture_transform(
    ctx: &Ctx,
    ext: Option<&serde_json::Value>,
    what: &str,
) -> Result<(Option<UvTransform>, Option<u32>)> {
    let Some(ext) = ext else {
        return Ok((None, None));
    };
    let pair = |name: &str, default: [f32; 2]| -> Result<[f32; 2]> {
        match ext.get(name) {
            None => Ok(default),
            Some(v) => {
                let a = v.as_array().filter(|a| a.len() == 2);
                let p = a.and_then(|a| Some([a[0].as_f64()? as f32, a[1].as_f64()? as f32]));
                p.filter(|p| p.iter().all(|c| c.is_finite()))
                    .ok_or_else(|| {
                        ctx.err(format!(
                            "{what}: KHR_texture_transform {name} {v} is not two finite numbers"
                        ))
                    })
            }
        }
    };
    let offset = pair("offset", [0.0, 0.0])?;
    let scale = pair("scale", [1.0, 1.0])?;
    let rotation = match ext.get("rotation") {
        None => 0.0,
        Some(v) => v.as_f64().filter(|r| r.is_finite()).ok_or_else(|| {
            ctx.err(format!(
                "{what}: KHR_texture_transform rotation {v} is not a finite number"
            ))
        })? as f32,
    };
    let tex_coord = match ext.get("texCoord") {
        None => None,
        Some(v) => Some(v.as_u64().filter(|&c| c <= 1).ok_or_else(|| {
            ctx.err(format!(
                "{what}: KHR_texture_transform texCoord {v}: only 0 and 1 are supported"
            ))
        })? as u32),
    };
    let (sin, cos) = rotation.sin_cos();
    let m = [
        [cos * scale[0], sin * scale[0]],
        [-sin * scale[1], cos * scale[1]],
        offset,
    ];
    let identity = [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]];
    Ok(((m != identity).then_some(m), tex_coord))
}

/// Applies `m` to every UV.
fn apply_uv_transform(uv: &mut [[f32; 2]], m: &UvTransform) {
    for p in uv {
        let [u, v] = *p;
        *p = [
            m[0][0] * u + m[1][0] * v + m[2][0],
            m[0][1] * u + m[1][1] * v + m[2][1],
        ];
    }
}

fn texture(
    ctx: &Ctx,
    doc: &gltf::Document,
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
    let image = texture_image(ctx, doc, &tex)?;
    let img = doc
        .images()
        .nth(image)
        .ok_or_else(|| ctx.err(format!("texture {}: no image {image}", tex.index())))?;
    let name = match img.source() {
        gltf::image::Source::Uri { uri, .. } => uri.to_string(),
        gltf::image::Source::View { view, .. } => {
            format!("image {} (bufferView {})", img.index(), view.index())
        }
    };
    let (width, height, rgba) = cache
        .images
        .get(&image)
        .ok_or_else(|| ctx.err(format!("image '{name}' was not decoded")))?;
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

/// Converts a material; also returns the UV transform each UV set needs
/// (KHR_texture_transform, baked into the primitives' UVs on load).
fn convert_material(
    ctx: &Ctx,
    doc: &gltf::Document,
    m: &gltf::Material,
    cache: &mut TextureCache,
    out: &mut Vec<Texture>,
) -> Result<(Material, [Option<UvTransform>; 2])> {
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
    let label = format!(
        "material {} ('{}')",
        m.index().map_or("default".into(), |i| i.to_string()),
        m.name().unwrap_or("")
    );
    if let Some(ext) = m.extensions() {
        mat.unlit = ext.contains_key("KHR_materials_unlit");
        if let Some(v) = ext
            .get("KHR_materials_emissive_strength")
            .and_then(|v| v.get("emissiveStrength"))
        {
            let s = v.as_f64().filter(|s| s.is_finite() && *s >= 0.0).ok_or_else(|| {
                ctx.err(format!(
                    "{label}: KHR_materials_emissive_strength emissiveStrength {v} is not a number ≥ 0"
                ))
            })?;
            mat.emissive = mat.emissive.map(|c| c * s as f32);
        }
    }
    let mut transforms: [Option<(UvTransform, &'static str)>; 2] = [None; 2];
    let mut slot = |t: gltf::Texture,
                    coord: u32,
                    ext: Option<&serde_json::Value>,
                    srgb: bool,
                    name: &'static str|
     -> Result<TexRef> {
        let (m, over) = texture_transform(ctx, ext, &format!("{label} {name} texture"))?;
        let coord = over.unwrap_or(coord);
        let r = texture(ctx, doc, t, coord, srgb, cache, out)?;
        let m = m.unwrap_or([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]);
        match &transforms[coord as usize] {
            None => transforms[coord as usize] = Some((m, name)),
            Some((prev, first)) if *prev != m => tracing::warn!(
                "{}: {label}: the {name} texture's KHR_texture_transform differs from the {first} texture's on TEXCOORD_{coord}; the {first} texture's is used",
                ctx.path.display()
            ),
            Some(_) => {}
        }
        Ok(r)
    };
    const TT: &str = "KHR_texture_transform";
    mat.base_color_tex = pbr
        .base_color_texture()
        .map(|t| {
            slot(
                t.texture(),
                t.tex_coord(),
                t.extension_value(TT),
                true,
                "base colour",
            )
        })
        .transpose()?;
    mat.metallic_roughness_tex = pbr
        .metallic_roughness_texture()
        .map(|t| {
            slot(
                t.texture(),
                t.tex_coord(),
                t.extension_value(TT),
                false,
                "metallic-roughness",
            )
        })
        .transpose()?;
    if let Some(t) = m.normal_texture() {
        let r = slot(
            t.texture(),
            t.tex_coord(),
            t.extension_value(TT),
            false,
            "normal",
        )?;
        mat.normal_tex = Some((r, t.scale()));
    }
    if let Some(t) = m.occlusion_texture() {
        let r = slot(
            t.texture(),
            t.tex_coord(),
            t.extension_value(TT),
            false,
            "occlusion",
        )?;
        mat.occlusion_tex = Some((r, t.strength()));
    }
    mat.emissive_tex = m
        .emissive_texture()
        .map(|t| {
            slot(
                t.texture(),
                t.tex_coord(),
                t.extension_value(TT),
                true,
                "emissive",
            )
        })
        .transpose()?;
    let identity = [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]];
    let uvt = transforms.map(|t| t.map(|(m, _)| m).filter(|m| *m != identity));
    Ok((mat, uvt))
}

fn convert_primitive(
    ctx: &Ctx,
    mesh: &gltf::Mesh,
    prim: &gltf::Primitive,
    materials: &[Material],
    uv_transforms: &[[Option<UvTransform>; 2]],
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
    let draco = match super::draco::DracoExt::of(prim) {
        None => None,
        Some(ext) => {
            let ext = ext.map_err(|e| ctx.err(format!("{label}: {e}")))?;
            if prim.mode() != gltf::mesh::Mode::Triangles {
                return Err(ctx.err(format!(
                    "{label}: {} needs mode TRIANGLES (or POINTS), not {:?}",
                    super::draco::NAME,
                    prim.mode()
                )));
            }
            Some(decode_draco(ctx, prim, &label, &ext)?)
        }
    };
    let read = Reader {
        ctx,
        draco: draco.as_ref(),
        label: &label,
    };
    let attr = |s: gltf::Semantic| prim.get(&s).map(|a| (s, a));
    let positions: Vec<[f32; 3]> = match attr(gltf::Semantic::Positions) {
        Some((s, a)) => read.floats(&s, &a)?,
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
    let raw_indices: Vec<u32> = match (&draco, prim.indices()) {
        (Some(d), _) => d.indices.clone(),
        (None, Some(a)) => gltf_data::read_u32(&ctx.data(), &a).map_err(|e| ctx.err(e))?,
        (None, None) => (0..n as u32).collect(),
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
    p.normals = match attr(gltf::Semantic::Normals) {
        Some((s, a)) => read.floats(&s, &a)?,
        None => generate_normals(&p.positions, &p.indices),
    };
    check_len("NORMAL", p.normals.len())?;
    for (set, slot) in [(0u32, &mut p.uv0), (1, &mut p.uv1)] {
        if let Some((s, a)) = attr(gltf::Semantic::TexCoords(set)) {
            let mut v: Vec<[f32; 2]> = read.floats(&s, &a)?;
            check_len(&format!("TEXCOORD_{set}"), v.len())?;
            if let Some(m) = &uv_transforms[material as usize][set as usize] {
                apply_uv_transform(&mut v, m);
            }
            *slot = Some(v);
        }
    }
    if let Some((s, a)) = attr(gltf::Semantic::Colors(0)) {
        let v: Vec<[f32; 4]> = if a.dimensions() == Dimensions::Vec3 {
            read.floats::<3>(&s, &a)?
                .into_iter()
                .map(|[r, g, b]| [r, g, b, 1.0])
                .collect()
        } else {
            read.floats(&s, &a)?
        };
        check_len("COLOR_0", v.len())?;
        p.colors = Some(v);
    }
    if let Some((nt, _)) = &mat.normal_tex {
        if let Some((s, a)) = attr(gltf::Semantic::Tangents) {
            let v: Vec<[f32; 4]> = read.floats(&s, &a)?;
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

/// Reads a primitive's attributes: from its Draco stream where the
/// KHR_draco_mesh_compression extension maps the semantic, else from the
/// accessor.
struct Reader<'a> {
    ctx: &'a Ctx<'a>,
    draco: Option<&'a super::draco::Decoded>,
    label: &'a str,
}

impl Reader<'_> {
    fn floats<const N: usize>(
        &self,
        semantic: &gltf::Semantic,
        a: &gltf::Accessor,
    ) -> Result<Vec<[f32; N]>> {
        let decoded = self
            .draco
            .and_then(|d| d.floats::<N>(&semantic.to_string(), a.normalized()));
        match decoded {
            Some(v) => v.map_err(|e| self.ctx.err(format!("{}: {e}", self.label))),
            None => self.ctx.floats(a),
        }
    }
}

/// Decodes a primitive's Draco stream, checked against its accessors and
/// paid for from the load budget.
fn decode_draco(
    ctx: &Ctx,
    prim: &gltf::Primitive,
    label: &str,
    ext: &super::draco::DracoExt,
) -> Result<super::draco::Decoded> {
    let fail = |e: String| ctx.err(format!("{label}: {e}"));
    if ext.view >= ctx.views.len() {
        return Err(fail(format!(
            "{}: bufferView {} does not exist ({} bufferViews)",
            super::draco::NAME,
            ext.view,
            ctx.views.len()
        )));
    }
    let position = prim
        .get(&gltf::Semantic::Positions)
        .ok_or_else(|| fail("has no POSITION attribute".into()))?;
    let vertices = position.count();
    let mut floats_per_vertex = 0usize;
    for (semantic, a) in prim.attributes() {
        let name = semantic.to_string();
        if ext.id_of(&name).is_some() {
            if a.count() != vertices {
                return Err(fail(format!(
                    "{name} accessor {} has {} elements but POSITION has {vertices}",
                    a.index(),
                    a.count()
                )));
            }
            floats_per_vertex += a.dimensions().multiplicity();
        }
    }
    let indices = prim.indices().map(|a| a.count());
    let bytes = (vertices as u64)
        .checked_mul(floats_per_vertex as u64 * 4)
        .and_then(|b| b.checked_add(indices.unwrap_or(0) as u64 * 4));
    ctx.budget
        .spend(bytes, &format!("{label}: the decoded Draco stream"))
        .map_err(|m| ctx.err(m))?;
    let expected = super::draco::Expected {
        vertices,
        indices,
        max_bytes: bytes.unwrap_or(0).saturating_mul(4).max(1 << 20),
    };
    super::draco::decode(ctx.data().bytes(ext.view), ext, expected).map_err(fail)
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

/// EXT_mesh_gpu_instancing: per-instance TRANSLATION / ROTATION / SCALE
/// (float, or the integer types KHR_mesh_quantization allows).
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
        let float = a.data_type() == gltf::accessor::DataType::F32;
        if a.dimensions() != dims
            || !(float || (ctx.quantization && a.data_type() != gltf::accessor::DataType::U32))
        {
            return Err(ctx.err(format!(
                "node {}: EXT_mesh_gpu_instancing {name} must be float {dims:?} (or 8/16-bit with KHR_mesh_quantization)",
                node.index()
            )));
        }
        Ok(Some(a))
    };
    let t: Option<Vec<[f32; 3]>> = accessor("TRANSLATION", Dimensions::Vec3)?
        .map(|a| ctx.floats(&a))
        .transpose()?;
    let r: Option<Vec<[f32; 4]>> = accessor("ROTATION", Dimensions::Vec4)?
        .map(|a| ctx.floats(&a))
        .transpose()?;
    let s: Option<Vec<[f32; 3]>> = accessor("SCALE", Dimensions::Vec3)?
        .map(|a| ctx.floats(&a))
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

/// A node's local transform: its `matrix`, or `T · R · S` from its
/// translation, rotation and scale (glTF 2.0 §3.5.3; the crate composes
/// TRS into a matrix).
fn node_transform(node: &gltf::Node) -> DAffine3 {
    let m = node.transform().matrix();
    let d = DMat4::from_cols_array_2d(&m.map(|c| c.map(|v| v as f64)));
    DAffine3::from_mat4(d)
}

/// A KHR_lights_punctual light as vergence uses it.
#[derive(Clone, Copy, Debug)]
enum Light {
    /// A directional light: linear colour × intensity (lux).
    Directional([f32; 3]),
    /// Point or spot (ignored).
    Other,
}

/// The document's KHR_lights_punctual lights.
fn punctual_lights(ctx: &Ctx, doc: &gltf::Document) -> Result<Vec<Light>> {
    let Some(list) = doc
        .extension_value("KHR_lights_punctual")
        .and_then(|e| e.get("lights"))
    else {
        return Ok(Vec::new());
    };
    let list = list
        .as_array()
        .ok_or_else(|| ctx.err("KHR_lights_punctual lights is not an array"))?;
    let mut out = Vec::with_capacity(list.len());
    for (i, l) in list.iter().enumerate() {
        let bad = |what: &str| ctx.err(format!("KHR_lights_punctual light {i}: {what}"));
        let kind = l
            .get("type")
            .and_then(|t| t.as_str())
            .ok_or_else(|| bad("has no type"))?;
        let color = match l.get("color") {
            None => [1.0; 3],
            Some(c) => {
                let a = c.as_array().filter(|a| a.len() == 3);
                let v = a.and_then(|a| {
                    Some([
                        a[0].as_f64()? as f32,
                        a[1].as_f64()? as f32,
                        a[2].as_f64()? as f32,
                    ])
                });
                v.filter(|v| v.iter().all(|x| x.is_finite() && *x >= 0.0))
                    .ok_or_else(|| bad(&format!("color {c} is not three numbers ≥ 0")))?
            }
        };
        let intensity = match l.get("intensity") {
            None => 1.0,
            Some(v) => v
                .as_f64()
                .filter(|x| x.is_finite() && *x >= 0.0)
                .ok_or_else(|| bad(&format!("intensity {v} is not a number ≥ 0")))?
                as f32,
        };
        out.push(match kind {
            "directional" => Light::Directional(color.map(|c| c * intensity)),
            "point" | "spot" => Light::Other,
            other => return Err(bad(&format!("unknown type '{other}'"))),
        });
    }
    Ok(out)
}

/// The nodes of the selected scene (`selector`: an index or a name), the
/// default scene, the first scene, or (with no scenes) every root node.
fn root_nodes<'a>(
    ctx: &Ctx,
    doc: &'a gltf::Document,
    selector: Option<&str>,
) -> Result<Vec<gltf::Node<'a>>> {
    if let Some(sel) = selector {
        let found = match sel.parse::<usize>() {
            Ok(i) => doc.scenes().nth(i),
            Err(_) => doc.scenes().find(|s| s.name() == Some(sel)),
        };
        let names: Vec<String> = doc
            .scenes()
            .map(|s| format!("{} '{}'", s.index(), s.name().unwrap_or("")))
            .collect();
        return found.map(|s| s.nodes().collect()).ok_or_else(|| {
            ctx.err(format!(
                "has no scene '{sel}' (scenes: {})",
                if names.is_empty() {
                    "none".into()
                } else {
                    names.join(", ")
                }
            ))
        });
    }
    Ok(match doc.default_scene().or_else(|| doc.scenes().next()) {
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
    })
}

/// A world transform as a camera pose: its translation and its rotation
/// with scale removed (the columns normalized, then made orthonormal by
/// the quaternion conversion).
fn camera_pose(world: &DAffine3) -> Option<crate::view::Pose> {
    let m = world.matrix3;
    let cols = [m.x_axis, m.y_axis, m.z_axis].map(|c| c.try_normalize());
    let [Some(x), Some(y), Some(z)] = cols else {
        return None;
    };
    let mut r = glam::DMat3::from_cols(x, y, z);
    if r.determinant() < 0.0 {
        r.z_axis = -r.z_axis;
    }
    let q = DQuat::from_mat3(&r).normalize();
    q.is_finite().then_some(crate::view::Pose {
        position: world.translation,
        orientation: q,
    })
}

fn place_nodes(
    ctx: &Ctx,
    doc: &gltf::Document,
    selector: Option<&str>,
    lights: &[Light],
    scene: &mut Scene,
) -> Result<()> {
    let roots = root_nodes(ctx, doc, selector)?;
    name_nodes(doc, scene);
    let mut visited = vec![false; doc.nodes().len()];
    let mut dropped: std::collections::BTreeMap<&'static str, usize> = Default::default();
    let mut ignored_lights = 0usize;
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
        if let Some(cam) = node.camera() {
            place_camera(ctx, &node, &cam, &world, scene);
        }
        if let Some(i) = node
            .extension_value("KHR_lights_punctual")
            .and_then(|e| e.get("light"))
        {
            ignored_lights += place_light(ctx, &node, i, lights, &world, scene)? as usize;
        }
        if let Some(mesh) = node.mesh() {
            place_mesh(ctx, doc, (&node, &mesh), &world, scene, &mut dropped)?;
        }
        for child in node.children() {
            stack.push((child, world, depth + 1));
        }
    }
    for (why, n) in dropped {
        tracing::warn!("{}: dropped {n} instance(s) with {why}", ctx.path.display());
    }
    if ignored_lights > 0 {
        tracing::warn!(
            "{}: ignored {ignored_lights} KHR_lights_punctual light(s) (point and spot lights, and directional lights after the first)",
            ctx.path.display()
        );
    }
    Ok(())
}

/// The scenes' names, and every node's name, parent and extras (for
/// naming selections).
fn name_nodes(doc: &gltf::Document, scene: &mut Scene) {
    scene.scene_names = doc
        .scenes()
        .map(|s| {
            s.name()
                .map_or_else(|| format!("scene {}", s.index()), str::to_string)
        })
        .collect();
    scene.node_info = doc
        .nodes()
        .map(|n| super::NodeInfo {
            name: n.name().map(str::to_string),
            parent: None,
            extras: n.extras().as_ref().map(|r| r.get().to_string()),
        })
        .collect();
    for n in doc.nodes() {
        for c in n.children() {
            if let Some(info) = scene.node_info.get_mut(c.index()) {
                info.parent = Some(n.index() as u32);
            }
        }
    }
}

/// A camera node as a viewpoint. A camera whose node scales an axis to
/// zero has no orientation: said, not dropped unseen.
fn place_camera(
    ctx: &Ctx,
    node: &gltf::Node,
    cam: &gltf::Camera,
    world: &DAffine3,
    scene: &mut Scene,
) {
    let Some(pose) = camera_pose(world) else {
        tracing::warn!(
            "{}: node {} places camera {} with a degenerate transform (an axis scaled to zero); it is not offered as a viewpoint",
            ctx.path.display(),
            node.index(),
            cam.index()
        );
        return;
    };
    let yfov = match cam.projection() {
        gltf::camera::Projection::Perspective(p) => Some(p.yfov() as f64),
        gltf::camera::Projection::Orthographic(_) => None,
    };
    scene.cameras.push(SceneCamera {
        index: cam.index(),
        name: cam
            .name()
            .or(node.name())
            .map_or_else(|| format!("camera {}", cam.index()), str::to_string),
        pose,
        yfov,
    });
}

/// A node's KHR_lights_punctual light `i`: the first directional light
/// is the sun; returns whether the light was ignored (point and spot
/// lights, later directional lights). A light that does not exist is an
/// error.
fn place_light(
    ctx: &Ctx,
    node: &gltf::Node,
    i: &serde_json::Value,
    lights: &[Light],
    world: &DAffine3,
    scene: &mut Scene,
) -> Result<bool> {
    let light = i
        .as_u64()
        .and_then(|i| lights.get(i as usize))
        .ok_or_else(|| {
            ctx.err(format!(
                "node {}: KHR_lights_punctual light {i} does not exist ({} lights)",
                node.index(),
                lights.len()
            ))
        })?;
    match light {
        Light::Directional(color) if scene.sun.is_none() => {
            // The light shines along its node's local -Z
            // (KHR_lights_punctual, "Directional"): the sun lies along +Z.
            let towards = world.matrix3 * DVec3::Z;
            if let Some(direction) = towards.try_normalize() {
                scene.sun = Some(Sun {
                    direction,
                    color: *color,
                });
            }
            Ok(false)
        }
        _ => Ok(true),
    }
}

/// A mesh node's instances (one, or its EXT_mesh_gpu_instancing copies),
/// within the scene's instance limit; instances with a degenerate or
/// non-finite transform are counted in `dropped` by reason.
fn place_mesh(
    ctx: &Ctx,
    doc: &gltf::Document,
    (node, mesh): (&gltf::Node, &gltf::Mesh),
    world: &DAffine3,
    scene: &mut Scene,
    dropped: &mut std::collections::BTreeMap<&'static str, usize>,
) -> Result<()> {
    let locals = gpu_instances(ctx, doc, node, MAX_SCENE_INSTANCES - scene.instances.len())?
        .unwrap_or_else(|| vec![DAffine3::IDENTITY]);
    if scene.instances.len() + locals.len() > MAX_SCENE_INSTANCES {
        return Err(ctx.err(format!(
            "node {} would take the scene over {MAX_SCENE_INSTANCES} instances",
            node.index()
        )));
    }
    for local in locals {
        let transform = *world * local;
        match instance_problem(&transform) {
            None => {
                scene.instances.push(Instance {
                    mesh: mesh.index() as u32,
                    transform,
                });
                scene.instance_node.push(node.index() as u32);
            }
            Some(why) => *dropped.entry(why).or_default() += 1,
        }
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
    fn required_list_matches_the_extension_table() {
        let mut from_table: Vec<&str> = EXTENSIONS
            .iter()
            .filter(|(_, s, _)| *s != Support::Refused)
            .map(|(n, _, _)| *n)
            .collect();
        let mut listed = SUPPORTED_REQUIRED.to_vec();
        from_table.sort_unstable();
        listed.sort_unstable();
        assert_eq!(from_table, listed);
        assert_eq!(
            support("KHR_draco_mesh_compression").map(|s| s.0),
            Some(Support::Supported)
        );
    }

    #[test]
    fn texture_transform_follows_the_extension_matrix() {
        // T · R · S with R(θ) = [cos −sin; sin cos]: (1, 0) → (s·cos, s·sin) + offset.
        let (s, c) = 0.3f32.sin_cos();
        let m = [[c * 2.0, s * 2.0], [-s * 3.0, c * 3.0], [0.5, 0.25]];
        let mut uv = [[1.0, 0.0], [0.0, 1.0]];
        apply_uv_transform(&mut uv, &m);
        assert!((uv[0][0] - (2.0 * c + 0.5)).abs() < 1e-6);
        assert!((uv[0][1] - (2.0 * s + 0.25)).abs() < 1e-6);
        assert!((uv[1][0] - (-3.0 * s + 0.5)).abs() < 1e-6);
        assert!((uv[1][1] - (3.0 * c + 0.25)).abs() < 1e-6);
    }

    #[test]
    fn strips_and_fans_become_lists() {
        assert_eq!(strip_to_list(&[0, 1, 2, 3]), vec![0, 1, 2, 2, 1, 3]);
        assert_eq!(fan_to_list(&[0, 1, 2, 3]), vec![0, 1, 2, 0, 2, 3]);
    }
}
