//! KHR_draco_mesh_compression: a primitive whose geometry is one Draco
//! mesh stream in a bufferView, decoded with the pure-Rust `draco-core`
//! decoder.
//!
//! The extension's `attributes` map glTF semantics to Draco attribute unique
//! ids; the primitive's accessors still describe the decoded data (count,
//! type, componentType, normalized), and every decoded count is checked
//! against them, so a stream that disagrees with its accessors is an error
//! rather than a silent misread. Draco's own quantization and octahedral
//! normal transforms are undone by the decoder; integer attributes the
//! accessor marks `normalized` are normalized here.

use draco_core::decoder_buffer::DecoderBuffer;
use draco_core::draco_types::DataType;
use draco_core::geometry_attribute::PointAttribute;
use draco_core::mesh::Mesh;
use draco_core::mesh_decoder::MeshDecoder;
use draco_core::DecodeLimits;

/// The extension's name.
pub const NAME: &str = "KHR_draco_mesh_compression";

/// A primitive's KHR_draco_mesh_compression object.
#[derive(Debug, Clone, PartialEq)]
pub struct DracoExt {
    /// The bufferView holding the Draco stream.
    pub view: usize,
    /// (glTF semantic, Draco unique id), in the file's order.
    pub attributes: Vec<(String, u32)>,
}

impl DracoExt {
    /// Reads the extension object; None when `prim` has none.
    pub fn of(prim: &gltf::Primitive) -> Option<Result<DracoExt, String>> {
        prim.extension_value(NAME).map(DracoExt::parse)
    }

    /// Reads `{"bufferView": N, "attributes": {"POSITION": ID, ...}}`.
    pub fn parse(v: &serde_json::Value) -> Result<DracoExt, String> {
        let view = v
            .get("bufferView")
            .and_then(serde_json::Value::as_u64)
            .ok_or_else(|| format!("{NAME}: bufferView is missing or not an index"))?;
        let map = v
            .get("attributes")
            .and_then(serde_json::Value::as_object)
            .ok_or_else(|| format!("{NAME}: attributes is missing or not an object"))?;
        let mut attributes = Vec::with_capacity(map.len());
        for (semantic, id) in map {
            let id = id
                .as_u64()
                .and_then(|i| u32::try_from(i).ok())
                .ok_or_else(|| {
                    format!("{NAME}: attribute {semantic} id {id} is not a Draco attribute id")
                })?;
            attributes.push((semantic.clone(), id));
        }
        Ok(DracoExt {
            view: usize::try_from(view).unwrap_or(usize::MAX),
            attributes,
        })
    }

    /// The Draco id of `semantic`, if the stream carries it.
    pub fn id_of(&self, semantic: &str) -> Option<u32> {
        self.attributes
            .iter()
            .find(|(s, _)| s == semantic)
            .map(|&(_, id)| id)
    }
}

/// What the primitive's accessors declare, which the stream must match.
#[derive(Debug, Clone, Copy)]
pub struct Expected {
    /// The vertex count (every attribute accessor's count).
    pub vertices: usize,
    /// The index count (the indices accessor's), if the primitive has one.
    pub indices: Option<usize>,
    /// Most bytes the decode may produce (what is left of the load budget).
    pub max_bytes: u64,
}

/// A decoded Draco mesh.
pub struct Decoded {
    mesh: Mesh,
    ext: DracoExt,
    /// Triangle corners as point indices.
    pub indices: Vec<u32>,
}

/// Decodes `stream` (the bytes of the extension's bufferView) and checks
/// it against `expected` and the extension's attribute ids.
pub fn decode(stream: &[u8], ext: &DracoExt, expected: Expected) -> Result<Decoded, String> {
    let mut limits = DecodeLimits::default()
        .with_max_points(expected.vertices as u64)
        .with_max_decoded_bytes(expected.max_bytes);
    if let Some(n) = expected.indices {
        limits = limits.with_max_faces((n / 3) as u64);
    }
    let mut buffer = DecoderBuffer::new(stream).with_limits(limits);
    let mut mesh = Mesh::new();
    MeshDecoder::new()
        .decode(&mut buffer, &mut mesh)
        .map_err(|e| format!("{NAME}: the Draco stream cannot be decoded: {e}"))?;
    if mesh.num_points() != expected.vertices {
        return Err(format!(
            "{NAME}: the Draco stream decodes {} vertices, but the primitive's accessors declare {}",
            mesh.num_points(),
            expected.vertices
        ));
    }
    let corners = mesh.num_faces().saturating_mul(3);
    if let Some(n) = expected.indices.filter(|&n| n != corners) {
        return Err(format!(
            "{NAME}: the Draco stream decodes {} triangles ({corners} indices), but the indices accessor declares {n}",
            mesh.num_faces()
        ));
    }
    if mesh.num_faces() == 0 {
        return Err(format!("{NAME}: the Draco stream holds no triangles"));
    }
    for (semantic, id) in &ext.attributes {
        if mesh.attribute_by_unique_id(*id).is_none() {
            return Err(format!(
                "{NAME}: attribute {semantic} names Draco attribute id {id}, which the stream does not have ({} attributes)",
                mesh.num_attributes()
            ));
        }
    }
    let indices = mesh
        .faces()
        .as_flattened()
        .iter()
        .map(|p| p.0)
        .collect::<Vec<u32>>();
    if let Some(bad) = indices.iter().find(|&&i| i as usize >= expected.vertices) {
        return Err(format!(
            "{NAME}: the Draco stream has index {bad}, out of range of its {} vertices",
            expected.vertices
        ));
    }
    Ok(Decoded {
        mesh,
        ext: ext.clone(),
        indices,
    })
}

impl Decoded {
    /// Whether the stream carries `semantic` (else it is read from its
    /// accessor as usual).
    pub fn has(&self, semantic: &str) -> bool {
        self.ext.id_of(semantic).is_some()
    }

    /// The values of `semantic` as `N`-component floats, one per vertex;
    /// `normalized` (the accessor's flag) maps integer values to [0, 1] or
    /// [-1, 1]. None when the stream does not carry it.
    pub fn floats<const N: usize>(
        &self,
        semantic: &str,
        normalized: bool,
    ) -> Option<Result<Vec<[f32; N]>, String>> {
        let id = self.ext.id_of(semantic)?;
        let att = self.mesh.attribute_by_unique_id(id)?;
        Some(
            read(att, self.mesh.num_points(), normalized)
                .map_err(|e| format!("{NAME}: {semantic}: {e}")),
        )
    }
}

/// Reads every point's value of `att` as `N` floats.
fn read<const N: usize>(
    att: &PointAttribute,
    points: usize,
    normalized: bool,
) -> Result<Vec<[f32; N]>, String> {
    let have = att.num_components() as usize;
    if have != N {
        return Err(format!(
            "Draco attribute {} has {have} components, but its accessor has {N}",
            att.unique_id()
        ));
    }
    let scale = match att.data_type() {
        DataType::Float32 => None,
        DataType::Int8 => Some(i8::MAX as f32),
        DataType::Uint8 => Some(u8::MAX as f32),
        DataType::Int16 => Some(i16::MAX as f32),
        DataType::Uint16 => Some(u16::MAX as f32),
        DataType::Int32 | DataType::Uint32 => None,
        other => return Err(format!("Draco component type {other:?} is not read")),
    };
    let flat = att.read_f32s(points, N);
    let norm = |v: f32| match scale {
        Some(s) if normalized || att.normalized() => (v / s).max(-1.0),
        _ => v,
    };
    Ok(flat
        .chunks_exact(N)
        .map(|c| std::array::from_fn(|k| norm(c[k])))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_extension_object_is_read_and_checked() {
        let e = DracoExt::parse(&serde_json::json!({
            "bufferView": 3, "attributes": {"POSITION": 1, "NORMAL": 0}
        }))
        .unwrap();
        assert_eq!(e.view, 3);
        assert_eq!(e.id_of("NORMAL"), Some(0));
        assert_eq!(e.id_of("TEXCOORD_0"), None);
        for bad in [
            serde_json::json!({"attributes": {}}),
            serde_json::json!({"bufferView": 0}),
            serde_json::json!({"bufferView": 0, "attributes": {"POSITION": -1}}),
            serde_json::json!({"bufferView": 0, "attributes": {"POSITION": 5000000000u64}}),
        ] {
            assert!(DracoExt::parse(&bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn garbage_is_an_error_not_a_panic() {
        let ext = DracoExt {
            view: 0,
            attributes: vec![("POSITION".into(), 0)],
        };
        let expected = Expected {
            vertices: 3,
            indices: Some(3),
            max_bytes: 1 << 20,
        };
        for stream in [
            &b""[..],
            b"DRACO",
            b"DRACO\x02\x02\x01\x01\x00\x00",
            b"not draco at all",
        ] {
            let e = decode(stream, &ext, expected).err().unwrap();
            assert!(e.contains("cannot be decoded"), "{e}");
        }
    }
}
