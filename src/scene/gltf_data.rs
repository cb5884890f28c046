//! glTF binary data: buffer views (plain, or compressed with
//! EXT_meshopt_compression / KHR_meshopt_compression) and accessors of every
//! component type KHR_mesh_quantization allows, dense or sparse, read into
//! `f32` or `u32` with every range checked first.
//!
//! References: glTF 2.0 §3.6 (buffers, views, accessors), §3.6.2.3 (sparse
//! accessors), §3.11 (normalized integer to float conversion);
//! EXT_meshopt_compression (Khronos extension registry,
//! `extensions/2.0/Vendor/EXT_meshopt_compression/README.md`).

use gltf::accessor::DataType;

/// Names under which a bufferView may carry meshopt-compressed data: the
/// vendor extension gltfpack writes, and its ratified Khronos successor
/// (same JSON, newer bitstream versions that the decoder also reads).
pub const MESHOPT_EXTENSIONS: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// Bytes of one bufferView: a range of a loaded buffer, or decoded data.
pub(super) enum ViewData {
    /// `buffers[buffer][start..end]`.
    Range {
        /// Buffer index.
        buffer: usize,
        /// First byte.
        start: usize,
        /// One past the last byte.
        end: usize,
    },
    /// Decoded meshopt data, held as `u32` words so that the decoder's
    /// filters (which write 16- and 32-bit values) see aligned memory;
    /// `len` bytes are valid.
    Decoded {
        /// The words.
        words: Vec<u32>,
        /// Valid bytes.
        len: usize,
    },
}

/// Decoded buffer views with the buffers they point into.
pub(super) struct Views<'a> {
    /// Loaded buffers (fallback buffers are empty).
    pub buffers: &'a [Vec<u8>],
    /// One entry per bufferView.
    pub views: &'a [ViewData],
}

impl Views<'_> {
    /// The bytes of bufferView `i`.
    pub fn bytes(&self, i: usize) -> &[u8] {
        match &self.views[i] {
            ViewData::Range { buffer, start, end } => &self.buffers[*buffer][*start..*end],
            ViewData::Decoded { words, len } => {
                // SAFETY: a u32 slice may be viewed as bytes (u8 has
                // alignment 1 and every bit pattern is valid); `len` is at
                // most 4 × words.len() (checked where it is built).
                let bytes = unsafe {
                    std::slice::from_raw_parts(words.as_ptr().cast::<u8>(), words.len() * 4)
                };
                &bytes[..*len]
            }
        }
    }
}

/// The meshopt compression parameters of one bufferView.
#[derive(Clone, Debug, PartialEq)]
pub struct Meshopt {
    /// Buffer holding the compressed stream.
    pub buffer: usize,
    /// Offset of the stream in that buffer.
    pub byte_offset: usize,
    /// Length of the compressed stream.
    pub byte_length: usize,
    /// Bytes per decoded element.
    pub byte_stride: usize,
    /// Decoded elements.
    pub count: usize,
    /// `ATTRIBUTES`, `TRIANGLES` or `INDICES`.
    pub mode: String,
    /// `NONE`, `OCTAHEDRAL`, `QUATERNION`, `EXPONENTIAL` or `COLOR`.
    pub filter: String,
}

impl Meshopt {
    /// Reads the extension object of a bufferView, or says what is wrong.
    pub fn parse(ext: &serde_json::Value) -> Result<Meshopt, String> {
        let num = |name: &str, default: Option<u64>| -> Result<usize, String> {
            match ext.get(name) {
                None => default.map(|d| d as usize).ok_or(format!("has no {name}")),
                Some(v) => v
                    .as_u64()
                    .and_then(|v| usize::try_from(v).ok())
                    .ok_or(format!("{name} {v} is not a non-negative integer")),
            }
        };
        let text = |name: &str, default: Option<&str>| -> Result<String, String> {
            match ext.get(name) {
                None => default.map(str::to_string).ok_or(format!("has no {name}")),
                Some(v) => v
                    .as_str()
                    .map(str::to_string)
                    .ok_or(format!("{name} {v} is not a string")),
            }
        };
        Ok(Meshopt {
            buffer: num("buffer", None)?,
            byte_offset: num("byteOffset", Some(0))?,
            byte_length: num("byteLength", None)?,
            byte_stride: num("byteStride", None)?,
            count: num("count", None)?,
            mode: text("mode", None)?,
            filter: text("filter", Some("NONE"))?,
        })
    }

    /// Checks the mode, filter and stride combinations the extension
    /// allows ("Mode and filter restrictions" in its README).
    pub fn validate(&self) -> Result<(), String> {
        let s = self.byte_stride;
        match self.mode.as_str() {
            "ATTRIBUTES" => {
                if s == 0 || !s.is_multiple_of(4) || s > 256 {
                    return Err(format!(
                        "ATTRIBUTES mode needs a byteStride that is a multiple of 4 up to 256, not {s}"
                    ));
                }
            }
            "TRIANGLES" | "INDICES" => {
                if s != 2 && s != 4 {
                    return Err(format!(
                        "{} mode needs byteStride 2 or 4, not {s}",
                        self.mode
                    ));
                }
                if self.mode == "TRIANGLES" && !self.count.is_multiple_of(3) {
                    return Err(format!(
                        "TRIANGLES mode needs a count divisible by 3, not {}",
                        self.count
                    ));
                }
                if self.filter != "NONE" {
                    return Err(format!(
                        "filter {} is only allowed with ATTRIBUTES mode, not {}",
                        self.filter, self.mode
                    ));
                }
            }
            other => return Err(format!("unknown mode '{other}'")),
        }
        let ok = match self.filter.as_str() {
            "NONE" => true,
            "OCTAHEDRAL" | "COLOR" => s == 4 || s == 8,
            "QUATERNION" => s == 8,
            "EXPONENTIAL" => s.is_multiple_of(4),
            other => return Err(format!("unknown filter '{other}'")),
        };
        if !ok {
            return Err(format!(
                "filter {} does not allow byteStride {s}",
                self.filter
            ));
        }
        Ok(())
    }

    /// Decodes `source` (the compressed stream) into `count × byteStride`
    /// bytes.
    pub fn decode(&self, source: &[u8]) -> Result<(Vec<u32>, usize), String> {
        self.validate()?;
        let len = self
            .count
            .checked_mul(self.byte_stride)
            .ok_or("count × byteStride overflows")?;
        let mut words = vec![0u32; len.div_ceil(4)];
        let dst = words.as_mut_ptr().cast::<std::ffi::c_void>();
        let (n, s) = (self.count, self.byte_stride);
        let (src, src_len) = (source.as_ptr(), source.len());
        // SAFETY: `dst` holds at least count × byteStride bytes, aligned to
        // 4; the decoders write exactly that many and read at most
        // `src_len` bytes of `src` (meshoptimizer documents them as safe
        // for untrusted input: malformed streams fail or give garbage, and
        // never read or write out of bounds).
        let rc = unsafe {
            use meshopt::ffi;
            match self.mode.as_str() {
                "ATTRIBUTES" => ffi::meshopt_decodeVertexBuffer(dst, n, s, src, src_len),
                "TRIANGLES" => ffi::meshopt_decodeIndexBuffer(dst, n, s, src, src_len),
                _ => ffi::meshopt_decodeIndexSequence(dst, n, s, src, src_len),
            }
        };
        if rc != 0 {
            return Err(format!(
                "{} stream of {src_len} bytes does not decode to {n} elements of {s} bytes (meshoptimizer error {rc})",
                self.mode
            ));
        }
        // SAFETY: as above; each filter rewrites the count × stride bytes
        // in place, with the stride checked in `validate`.
        unsafe {
            use meshopt::ffi;
            match self.filter.as_str() {
                "OCTAHEDRAL" => ffi::meshopt_decodeFilterOct(dst, n, s),
                "QUATERNION" => ffi::meshopt_decodeFilterQuat(dst, n, s),
                "EXPONENTIAL" => ffi::meshopt_decodeFilterExp(dst, n, s),
                "COLOR" => ffi::meshopt_decodeFilterColor(dst, n, s),
                _ => {}
            }
        }
        Ok((words, len))
    }
}

/// The meshopt extension object of a bufferView, if it has one.
pub fn meshopt_of<'a>(view: &'a gltf::buffer::View<'a>) -> Option<&'a serde_json::Value> {
    MESHOPT_EXTENSIONS
        .iter()
        .find_map(|name| view.extension_value(name))
}

/// Whether a buffer is a meshopt fallback buffer (its data need not exist).
pub fn is_fallback(buffer: &gltf::Buffer) -> bool {
    MESHOPT_EXTENSIONS.iter().any(|name| {
        buffer
            .extension_value(name)
            .and_then(|e| e.get("fallback"))
            .and_then(serde_json::Value::as_bool)
            .unwrap_or(false)
    })
}

/// Bytes per component of `dt`.
pub fn component_size(dt: DataType) -> usize {
    match dt {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

/// Reads component `k` at `b` as `f32`; normalized integers map to [0, 1]
/// or [-1, 1] by glTF 2.0 §3.11: `f = max(c / (2^(n-1) - 1), -1)` for
/// signed and `f = c / (2^n - 1)` for unsigned n-bit components.
fn component_f32(b: &[u8], dt: DataType, normalized: bool) -> f32 {
    match (dt, normalized) {
        (DataType::F32, _) => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        (DataType::I8, false) => b[0] as i8 as f32,
        (DataType::I8, true) => (b[0] as i8 as f32 / 127.0).max(-1.0),
        (DataType::U8, false) => b[0] as f32,
        (DataType::U8, true) => b[0] as f32 / 255.0,
        (DataType::I16, false) => i16::from_le_bytes([b[0], b[1]]) as f32,
        (DataType::I16, true) => (i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0).max(-1.0),
        (DataType::U16, false) => u16::from_le_bytes([b[0], b[1]]) as f32,
        (DataType::U16, true) => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
        (DataType::U32, false) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
        (DataType::U32, true) => {
            u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32 / 4_294_967_295.0
        }
    }
}

/// Reads an unsigned integer component (indices, sparse indices).
fn component_u32(b: &[u8], dt: DataType) -> Option<u32> {
    match dt {
        DataType::U8 => Some(b[0] as u32),
        DataType::U16 => Some(u16::from_le_bytes([b[0], b[1]]) as u32),
        DataType::U32 => Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        _ => None,
    }
}

/// The byte range `offset + (count - 1) × stride + elem` must fit in
/// `len`; returns a description of the overflow otherwise.
fn fits(offset: usize, count: usize, stride: usize, elem: usize, len: usize) -> bool {
    count == 0
        || (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(elem))
            .and_then(|x| x.checked_add(offset))
            .is_some_and(|n| n <= len)
}

/// Reads accessor `a` as `count` elements of `N` floats (dense data, then
/// sparse substitutions); an accessor without a bufferView starts as zeros.
pub(super) fn read_f32<const N: usize>(
    views: &Views,
    a: &gltf::Accessor,
) -> Result<Vec<[f32; N]>, String> {
    let dims = a.dimensions().multiplicity();
    if dims != N {
        return Err(format!(
            "accessor {} has {dims} components, {N} expected",
            a.index()
        ));
    }
    let (dt, norm) = (a.data_type(), a.normalized());
    let cs = component_size(dt);
    let elem = cs * N;
    let read =
        |bytes: &[u8], offset: usize, stride: usize, count: usize, out: &mut Vec<[f32; N]>| {
            for i in 0..count {
                let e = &bytes[offset + i * stride..];
                out.push(std::array::from_fn(|k| {
                    component_f32(&e[k * cs..], dt, norm)
                }));
            }
        };
    let mut out = Vec::with_capacity(a.count());
    match a.view() {
        Some(view) => {
            let bytes = views.bytes(view.index());
            let stride = view.stride().unwrap_or(elem);
            if !fits(a.offset(), a.count(), stride, elem, bytes.len()) {
                return Err(format!(
                    "accessor {} ({} elements of {elem} bytes at offset {}) is out of range of bufferView {} ({} bytes)",
                    a.index(),
                    a.count(),
                    a.offset(),
                    view.index(),
                    bytes.len()
                ));
            }
            read(bytes, a.offset(), stride, a.count(), &mut out);
        }
        None => out.resize(a.count(), [0.0; N]),
    }
    if let Some(sparse) = a.sparse() {
        let idx = sparse_indices(views, a, &sparse)?;
        let values = sparse.values();
        let bytes = views.bytes(values.view().index());
        if !fits(values.offset(), idx.len(), elem, elem, bytes.len()) {
            return Err(format!(
                "accessor {}: {} sparse values at offset {} run past bufferView {} ({} bytes)",
                a.index(),
                idx.len(),
                values.offset(),
                values.view().index(),
                bytes.len()
            ));
        }
        let mut v = Vec::with_capacity(idx.len());
        read(bytes, values.offset(), elem, idx.len(), &mut v);
        for (i, value) in idx.into_iter().zip(v) {
            out[i] = value;
        }
    }
    Ok(out)
}

/// The checked target indices of a sparse accessor.
fn sparse_indices(
    views: &Views,
    a: &gltf::Accessor,
    sparse: &gltf::accessor::sparse::Sparse,
) -> Result<Vec<usize>, String> {
    let ind = sparse.indices();
    let dt = match ind.index_type() {
        gltf::accessor::sparse::IndexType::U8 => DataType::U8,
        gltf::accessor::sparse::IndexType::U16 => DataType::U16,
        gltf::accessor::sparse::IndexType::U32 => DataType::U32,
    };
    let cs = component_size(dt);
    let n = sparse.count();
    if n > a.count() {
        return Err(format!(
            "accessor {}: {n} sparse values for {} elements",
            a.index(),
            a.count()
        ));
    }
    let bytes = views.bytes(ind.view().index());
    if !fits(ind.offset(), n, cs, cs, bytes.len()) {
        return Err(format!(
            "accessor {}: {n} sparse indices at offset {} run past bufferView {} ({} bytes)",
            a.index(),
            ind.offset(),
            ind.view().index(),
            bytes.len()
        ));
    }
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let i = component_u32(&bytes[ind.offset() + k * cs..], dt).unwrap_or(u32::MAX) as usize;
        if i >= a.count() {
            return Err(format!(
                "accessor {}: sparse index {i} is out of range of its {} elements",
                a.index(),
                a.count()
            ));
        }
        out.push(i);
    }
    Ok(out)
}

/// Reads an unsigned-integer scalar accessor (indices) as `u32`, sparse
/// substitutions included.
pub(super) fn read_u32(views: &Views, a: &gltf::Accessor) -> Result<Vec<u32>, String> {
    let dt = a.data_type();
    if a.dimensions().multiplicity() != 1
        || !matches!(dt, DataType::U8 | DataType::U16 | DataType::U32)
    {
        return Err(format!(
            "accessor {} must hold unsigned byte, short or int scalars",
            a.index()
        ));
    }
    let cs = component_size(dt);
    let read = |bytes: &[u8], offset: usize, stride: usize, count: usize, out: &mut Vec<u32>| {
        for i in 0..count {
            out.push(component_u32(&bytes[offset + i * stride..], dt).unwrap_or(0));
        }
    };
    let mut out = Vec::with_capacity(a.count());
    match a.view() {
        Some(view) => {
            let bytes = views.bytes(view.index());
            let stride = view.stride().unwrap_or(cs);
            if !fits(a.offset(), a.count(), stride, cs, bytes.len()) {
                return Err(format!(
                    "accessor {} ({} elements of {cs} bytes at offset {}) is out of range of bufferView {} ({} bytes)",
                    a.index(),
                    a.count(),
                    a.offset(),
                    view.index(),
                    bytes.len()
                ));
            }
            read(bytes, a.offset(), stride, a.count(), &mut out);
        }
        None => out.resize(a.count(), 0),
    }
    if let Some(sparse) = a.sparse() {
        let idx = sparse_indices(views, a, &sparse)?;
        let values = sparse.values();
        let bytes = views.bytes(values.view().index());
        if !fits(values.offset(), idx.len(), cs, cs, bytes.len()) {
            return Err(format!(
                "accessor {}: {} sparse values at offset {} run past bufferView {} ({} bytes)",
                a.index(),
                idx.len(),
                values.offset(),
                values.view().index(),
                bytes.len()
            ));
        }
        let mut v = Vec::with_capacity(idx.len());
        read(bytes, values.offset(), cs, idx.len(), &mut v);
        for (i, value) in idx.into_iter().zip(v) {
            out[i] = value;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ext(mode: &str, filter: &str, stride: usize, count: usize) -> Meshopt {
        Meshopt {
            buffer: 0,
            byte_offset: 0,
            byte_length: 0,
            byte_stride: stride,
            count,
            mode: mode.into(),
            filter: filter.into(),
        }
    }

    #[test]
    fn normalized_conversion_follows_the_spec() {
        assert_eq!(component_f32(&[0x81], DataType::I8, true), -1.0);
        assert_eq!(component_f32(&[0x80], DataType::I8, true), -1.0);
        assert_eq!(component_f32(&[127], DataType::I8, true), 1.0);
        assert_eq!(component_f32(&[255], DataType::U8, true), 1.0);
        assert_eq!(component_f32(&[0xff, 0x7f], DataType::I16, true), 1.0);
        assert_eq!(component_f32(&[0x00, 0x80], DataType::I16, true), -1.0);
        assert_eq!(component_f32(&[0xff, 0xff], DataType::U16, true), 1.0);
        assert_eq!(component_f32(&[0x34, 0x12], DataType::U16, false), 4660.0);
        assert_eq!(component_f32(&[0xfe], DataType::I8, false), -2.0);
    }

    #[test]
    fn mode_and_filter_rules() {
        assert!(ext("ATTRIBUTES", "NONE", 12, 3).validate().is_ok());
        assert!(ext("ATTRIBUTES", "OCTAHEDRAL", 4, 3).validate().is_ok());
        assert!(ext("ATTRIBUTES", "QUATERNION", 8, 3).validate().is_ok());
        assert!(ext("ATTRIBUTES", "EXPONENTIAL", 12, 3).validate().is_ok());
        assert!(ext("TRIANGLES", "NONE", 2, 6).validate().is_ok());
        assert!(ext("INDICES", "NONE", 4, 7).validate().is_ok());
        for (m, want) in [
            (ext("ATTRIBUTES", "NONE", 6, 3), "multiple of 4"),
            (ext("ATTRIBUTES", "NONE", 260, 3), "multiple of 4"),
            (ext("ATTRIBUTES", "QUATERNION", 4, 3), "does not allow"),
            (ext("ATTRIBUTES", "OCTAHEDRAL", 12, 3), "does not allow"),
            (ext("TRIANGLES", "NONE", 2, 4), "divisible by 3"),
            (
                ext("TRIANGLES", "OCTAHEDRAL", 2, 3),
                "only allowed with ATTRIBUTES",
            ),
            (ext("INDICES", "NONE", 1, 3), "byteStride 2 or 4"),
            (ext("LINES", "NONE", 4, 3), "unknown mode"),
            (ext("ATTRIBUTES", "ZIP", 4, 3), "unknown filter"),
        ] {
            let e = m.validate().unwrap_err();
            assert!(e.contains(want), "{m:?}: {e}");
        }
    }

    #[test]
    fn streams_round_trip_through_the_decoders() {
        let verts: Vec<[u16; 4]> = (0..100u16).map(|i| [i, i * 3, 7, 1000 - i]).collect();
        let enc = meshopt::encode_vertex_buffer(&verts).unwrap();
        let (words, len) = ext("ATTRIBUTES", "NONE", 8, 100).decode(&enc).unwrap();
        assert_eq!(len, 800);
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        let want: Vec<u8> = verts
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        assert_eq!(&bytes[..len], &want[..]);

        let tris: Vec<u32> = vec![0, 1, 2, 2, 1, 3, 3, 1, 4];
        let enc = meshopt::encode_index_buffer(&tris, 5).unwrap();
        let (words, _) = ext("TRIANGLES", "NONE", 4, 9).decode(&enc).unwrap();
        assert_eq!(words, tris);
        let enc = meshopt::encode_index_sequence(&tris, 5).unwrap();
        let (words, _) = ext("INDICES", "NONE", 4, 9).decode(&enc).unwrap();
        assert_eq!(words, tris);

        let e = ext("ATTRIBUTES", "NONE", 8, 100)
            .decode(&enc[..enc.len() / 2])
            .unwrap_err();
        assert!(e.contains("does not decode"), "{e}");
    }

    #[test]
    fn octahedral_and_exponential_filters_decode() {
        let normals = [[0.0f32, 0.0, 1.0, 0.0], [0.6, 0.8, 0.0, 0.0]];
        let enc: Vec<[i8; 4]> = meshopt::encode_filter_oct(&normals, 8);
        let stream = meshopt::encode_vertex_buffer(&enc).unwrap();
        let (words, _) = ext("ATTRIBUTES", "OCTAHEDRAL", 4, 2)
            .decode(&stream)
            .unwrap();
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        for (n, b) in normals.iter().zip(bytes.chunks(4)) {
            let d: Vec<f32> = b[..3].iter().map(|&c| c as i8 as f32 / 127.0).collect();
            for k in 0..3 {
                assert!((d[k] - n[k]).abs() < 0.02, "{d:?} vs {n:?}");
            }
        }
        let values = [1.5f32, -0.25, 1000.0];
        let enc = meshopt::encode_filter_exp(&[values], 24, meshopt::EncodeExpMode::Separate);
        let stream = meshopt::encode_vertex_buffer(&enc).unwrap();
        let (words, _) = ext("ATTRIBUTES", "EXPONENTIAL", 12, 1)
            .decode(&stream)
            .unwrap();
        for (w, v) in words.iter().zip(values) {
            assert!(
                (f32::from_bits(*w) - v).abs() < 1e-3 * v.abs(),
                "{w} vs {v}"
            );
        }
        let q = glam::Quat::from_rotation_y(0.7);
        let enc = meshopt::encode_filter_quat(&[q.to_array()], 12);
        let stream = meshopt::encode_vertex_buffer(&enc).unwrap();
        let (words, _) = ext("ATTRIBUTES", "QUATERNION", 8, 1)
            .decode(&stream)
            .unwrap();
        let c: Vec<f32> = words
            .iter()
            .flat_map(|w| w.to_le_bytes())
            .collect::<Vec<u8>>()
            .chunks(2)
            .map(|b| i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0)
            .collect();
        let got = glam::Quat::from_xyzw(c[0], c[1], c[2], c[3]).normalize();
        assert!(got.dot(q).abs() > 0.9999, "{got:?} vs {q:?}");
    }
}
