//! Point clouds (laser scans of existing plants): the points in memory, and
//! reading and writing them as ASPRS LAS 1.2–1.4 and LAZ (the `las` crate,
//! with `laz` for the compressed form).
//!
//! Coordinates arrive as f64 (survey coordinates reach 10^5–10^7 m); the
//! cloud keeps an f64 origin (for a file, its coordinate offset when that
//! lies near the points, else its bounds' centre) and every point as an
//! f32 offset from it, so rendering stays camera-relative:
//! within a cloud's extent (at most [`MAX_EXTENT_M`]) an f32 offset keeps
//! about a millimetre per kilometre.

use crate::error::{Error, Result};
use glam::DVec3;
use std::path::{Path, PathBuf};

/// The most points one cloud may hold (16 bytes each in memory, on the CPU
/// and again on the GPU).
pub const MAX_POINTS: u64 = 1_200_000_000;
/// The largest extent of a cloud along any axis, metres.
pub const MAX_EXTENT_M: f64 = 1e9;
/// The largest LAS/LAZ file read.
pub const MAX_FILE_BYTES: u64 = 64 << 30;
/// Points read per chunk (the reader streams; memory holds one chunk of
/// decoded records besides the cloud).
const CHUNK: u64 = 1 << 20;
/// The most bytes of raw records decoded at once.
const FILL_BYTES: u64 = 64 << 20;

/// A point cloud: an f64 origin and per point an f32 offset, a colour and
/// a classification.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointCloud {
    /// World position of the offsets' zero.
    pub origin: DVec3,
    /// Per point, its position relative to `origin`.
    pub positions: Vec<[f32; 3]>,
    /// Per point, sRGB red, green, blue and the intensity's high byte.
    pub colors: Vec<[u8; 4]>,
    /// Per point, the ASPRS classification code.
    pub classification: Vec<u8>,
    /// The file it came from (None: generated).
    pub source: Option<PathBuf>,
    /// The level-of-detail octree over the points (None: drawn whole every
    /// frame); its nodes index the points as they are ordered now.
    pub octree: Option<super::octree::Octree>,
}

impl PointCloud {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether it has no points.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// World bounds of the points (zero when empty).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        if self.positions.is_empty() {
            return (DVec3::ZERO, DVec3::ZERO);
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in &self.positions {
            let v = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            lo = lo.min(v);
            hi = hi.max(v);
        }
        (self.origin + lo, self.origin + hi)
    }

    /// World position of point `i`.
    pub fn world(&self, i: usize) -> DVec3 {
        let p = self.positions[i];
        self.origin + DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    }
}

impl PointCloud {
    /// The cloud moved by `place` (a similarity: translation, rotation,
    /// uniform scale): the origin in f64, the offsets through the linear
    /// part.
    pub fn placed(mut self, place: &glam::DAffine3) -> PointCloud {
        self.origin = place.transform_point3(self.origin);
        let m = place.matrix3;
        for p in &mut self.positions {
            let v = m * DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            *p = [v.x as f32, v.y as f32, v.z as f32];
        }
        self
    }

    /// Appends `other`'s points, re-offset from this cloud's origin.
    pub fn append(&mut self, other: &PointCloud) {
        let shift = other.origin - self.origin;
        self.positions.extend(other.positions.iter().map(|p| {
            let v = shift + DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            [v.x as f32, v.y as f32, v.z as f32]
        }));
        self.colors.extend_from_slice(&other.colors);
        self.classification.extend_from_slice(&other.classification);
        self.octree = None;
    }

    /// The cloud with its octree built (its points reordered into the
    /// nodes' order).
    pub fn with_octree(self) -> PointCloud {
        let (tree, order) = super::octree::build(&self.positions);
        self.ordered(tree, order)
    }

    /// [`PointCloud::with_octree`] for a cloud loaded from `source`: the
    /// octree read from `source`'s cache file when it is usable, else
    /// built (and with `write_cache`, written there); the tree's `cache`
    /// says which (`scene::octree_cache`).
    pub fn with_octree_cached(self, source: &Path, write_cache: bool) -> PointCloud {
        let (mut tree, order, used) =
            super::octree_cache::load_or_build(self.origin, &self.positions, source, write_cache);
        tree.cache = Some(used);
        self.ordered(tree, order)
    }

    /// The cloud reordered by `order` (point i becomes old point
    /// `order[i]`) with `tree` over it.
    fn ordered(mut self, tree: super::octree::Octree, order: Vec<u32>) -> PointCloud {
        permute(&mut self.positions, &order);
        permute(&mut self.colors, &order);
        permute(&mut self.classification, &order);
        self.octree = Some(tree);
        self
    }
}

/// `v` reordered so element i is the old element `order[i]`.
fn permute<T: Copy + Send + Sync>(v: &mut Vec<T>, order: &[u32]) {
    use rayon::prelude::*;
    let old = std::mem::take(v);
    *v = order.par_iter().map(|&i| old[i as usize]).collect();
}

/// Whether `path` names a LAS or LAZ file (by extension).
pub fn is_las(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("las") || e.eq_ignore_ascii_case("laz"))
}

fn bad(path: &Path, message: impl Into<String>) -> Error {
    Error::Scene {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// A `las` error as a message: an early end of the file says so.
fn las_message(e: &las::Error) -> String {
    let eof = |io: &std::io::Error| io.kind() == std::io::ErrorKind::UnexpectedEof;
    match e {
        las::Error::Io(io) | las::Error::LasZipError(laz::LasZipError::IoError(io)) if eof(io) => {
            "the file ends early (truncated, or a header or chunk table points past its end)"
                .to_string()
        }
        other => other.to_string(),
    }
}

/// Checks what the `las` and `laz` crates would trust: the header's point
/// count (within [`MAX_POINTS`]; `las` multiplies it by the record length
/// unchecked), and a LAZ file's chunk table before the `laz` crate reads it (that
/// reader reserves memory for as many chunks as the table's 32-bit count
/// says): the table's offset (the first 8 bytes of the point data, or the
/// file's last 8 when a streaming writer left −1) must lie inside the file,
/// and its chunk count may not exceed the header's point count (every
/// chunk holds a point) or what the rest of the file could list. Files
/// whose point format is not compressed pass untouched. Leaves `r` at the
/// start.
fn header_guard<R: std::io::Read + std::io::Seek>(
    r: &mut R,
    size: u64,
) -> std::result::Result<(), String> {
    use std::io::SeekFrom;
    let eof = |e: std::io::Error| format!("the file ends early ({e})");
    let mut head = [0u8; 255];
    r.seek(SeekFrom::Start(0)).map_err(eof)?;
    let got = read_up_to(r, &mut head).map_err(eof)?;
    if got < 227 || &head[..4] != b"LASF" {
        r.seek(SeekFrom::Start(0)).map_err(eof)?;
        return Ok(());
    }
    let u32_at = |o: usize| u32::from_le_bytes([head[o], head[o + 1], head[o + 2], head[o + 3]]);
    let legacy = u32_at(107) as u64;
    // The count as the `las` crate takes it: the legacy field, or LAS
    // 1.4's 64-bit one when that is 0.
    let count = if legacy == 0 && head[25] >= 4 && got >= 255 {
        u64::from_le_bytes(head[247..255].try_into().expect("8 bytes"))
    } else {
        legacy
    };
    let record = u16::from_le_bytes([head[105], head[106]]) as u64;
    let data = u32_at(96) as u64;
    // The `las` crate multiplies these without a check.
    if count > MAX_POINTS
        || count
            .checked_mul(record)
            .and_then(|b| b.checked_add(data))
            .is_none()
    {
        return Err(format!(
            "the header says {count} points, over the {MAX_POINTS}-point limit"
        ));
    }
    vlr_guard(r, &head[..got], size, record)?;
    if head[104] & 0x80 == 0 {
        r.seek(SeekFrom::Start(0)).map_err(eof)?;
        return Ok(());
    }
    let mut word = [0u8; 8];
    r.seek(SeekFrom::Start(data)).map_err(eof)?;
    r.read_exact(&mut word).map_err(eof)?;
    let mut table = i64::from_le_bytes(word);
    if table == -1 {
        r.seek(SeekFrom::End(-8)).map_err(eof)?;
        r.read_exact(&mut word).map_err(eof)?;
        table = i64::from_le_bytes(word);
    }
    if table < 0 || (table as u64).saturating_add(8) > size {
        return Err(format!(
            "the LAZ chunk table offset {table} points outside the file's {size} bytes"
        ));
    }
    r.seek(SeekFrom::Start(table as u64)).map_err(eof)?;
    r.read_exact(&mut word).map_err(eof)?;
    let chunks = u32::from_le_bytes(word[4..8].try_into().expect("4 bytes")) as u64;
    let room = (size - table as u64 - 8).saturating_mul(8);
    if chunks > count.max(1) || chunks > room.max(1) {
        return Err(format!(
            "the LAZ chunk table lists {chunks} chunks for {count} points in {size} bytes"
        ));
    }
    r.seek(SeekFrom::Start(0)).map_err(eof)?;
    Ok(())
}

/// The most bytes of LAZ "extra bytes" items per point vergence decodes:
/// the `laz` decoder builds arithmetic models for each such byte before it
/// reads a point (several kilobytes each), so a few hundred bytes of VLR
/// could otherwise ask for gigabytes.
const MAX_LAZ_EXTRA_BYTES: u64 = 1024;
/// The most items a laszip VLR may list (a point format has at most five).
const MAX_LAZ_ITEMS: u64 = 32;

/// Checks the variable-length records the `las` crate sizes memory by
/// before reading them (LAS 1.4 R15 §2.5 and §2.6): each VLR header and its
/// 16-bit length lie inside the file; the extended VLR at the header's
/// `start_of_first_evlr` (the one the crate reads) and any after it, with
/// their 64-bit lengths, lie inside the file; a laszip VLR's items sum to
/// the header's record length, are few, and carry at most
/// [`MAX_LAZ_EXTRA_BYTES`] extra bytes.
fn vlr_guard<R: std::io::Read + std::io::Seek>(
    r: &mut R,
    head: &[u8],
    size: u64,
    record: u64,
) -> std::result::Result<(), String> {
    use std::io::SeekFrom;
    let eof = |e: std::io::Error| format!("the file ends early ({e})");
    let u16_at = |b: &[u8], o: usize| u16::from_le_bytes([b[o], b[o + 1]]) as u64;
    let u32_at = |b: &[u8], o: usize| u32::from_le_bytes(b[o..o + 4].try_into().expect("4")) as u64;
    let u64_at = |b: &[u8], o: usize| u64::from_le_bytes(b[o..o + 8].try_into().expect("8"));
    let count = u32_at(head, 100);
    if count > size / 54 {
        return Err(format!(
            "the header lists {count} VLRs, more than the file's {size} bytes hold"
        ));
    }
    // The `las` crate reads the whole header of the file's version (227,
    // 235 or 375 bytes) whatever its header-size field says, then skips
    // to that field when it is larger: the VLRs start at the larger one.
    let version_header = match head[25] {
        0..=2 => 227,
        3 => 235,
        _ => 375,
    };
    let mut pos = u16_at(head, 94).max(version_header);
    let compressed = head[104] & 0x80 != 0;
    let mut vlr = [0u8; 54];
    for k in 0..count {
        if pos + 54 > size {
            return Err(format!(
                "VLR {k} starts at byte {pos}, past the file's end ({size} bytes)"
            ));
        }
        r.seek(SeekFrom::Start(pos)).map_err(eof)?;
        r.read_exact(&mut vlr).map_err(eof)?;
        let len = u16_at(&vlr, 20);
        if pos + 54 + len > size {
            return Err(format!(
                "VLR {k} claims {len} bytes past the file's end ({size} bytes)"
            ));
        }
        if compressed && vlr[2..16] == *b"laszip encoded" && u16_at(&vlr, 18) == 22204 {
            let mut data = vec![0u8; len as usize];
            r.read_exact(&mut data).map_err(eof)?;
            laszip_items_guard(&data, record)?;
        }
        pos += 54 + len;
    }
    // The crate reads the first extended VLR (LAS 1.4, a count and a
    // start both set), whose 64-bit length it allocates.
    if head.len() >= 247 && head[25] >= 4 && u32_at(head, 243) > 0 && u64_at(head, 235) > 0 {
        let pos = u64_at(head, 235);
        if pos.saturating_add(60) > size {
            return Err(format!(
                "the extended VLR starts at byte {pos}, past the file's end ({size} bytes)"
            ));
        }
        r.seek(SeekFrom::Start(pos + 20)).map_err(eof)?;
        let mut word = [0u8; 8];
        r.read_exact(&mut word).map_err(eof)?;
        let len = u64::from_le_bytes(word);
        if len > size - pos - 60 {
            return Err(format!(
                "extended VLR 0 claims {len} bytes, more than the file's {size} bytes hold"
            ));
        }
    }
    Ok(())
}

/// A laszip VLR's item list (LASzip's specification: 34 bytes of settings,
/// the item count at byte 32, then per item its type, size and version as
/// 16-bit words): at most [`MAX_LAZ_ITEMS`] items whose sizes sum to the
/// point record length, extra-byte items (types 0 and 14) within
/// [`MAX_LAZ_EXTRA_BYTES`].
fn laszip_items_guard(data: &[u8], record: u64) -> std::result::Result<(), String> {
    let u16_at = |o: usize| u16::from_le_bytes([data[o], data[o + 1]]) as u64;
    if data.len() < 34 {
        return Err(format!(
            "the laszip VLR is {} bytes, under the 34 its settings take",
            data.len()
        ));
    }
    let items = u16_at(32);
    if items > MAX_LAZ_ITEMS || 34 + 6 * items as usize > data.len() {
        return Err(format!(
            "the laszip VLR lists {items} items in {} bytes",
            data.len()
        ));
    }
    let (mut total, mut extra) = (0u64, 0u64);
    for i in 0..items as usize {
        let (kind, bytes) = (u16_at(34 + 6 * i), u16_at(36 + 6 * i));
        total += bytes;
        if kind == 0 || kind == 14 {
            extra += bytes;
        }
    }
    if total != record {
        return Err(format!(
            "the laszip VLR's items take {total} bytes a point, the header's records {record}"
        ));
    }
    if extra > MAX_LAZ_EXTRA_BYTES {
        return Err(format!(
            "the laszip VLR lists {extra} extra bytes a point, over the {MAX_LAZ_EXTRA_BYTES} vergence decodes"
        ));
    }
    Ok(())
}

/// Reads into `buf` until it is full or the source ends; the bytes read.
fn read_up_to<R: std::io::Read>(r: &mut R, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..])? {
            0 => break,
            k => n += k,
        }
    }
    Ok(n)
}

/// Reads a LAS or LAZ file: header checked first (point count against the
/// file's size and [`MAX_POINTS`], finite scales and offsets, extents within
/// [`MAX_EXTENT_M`]), then the points in chunks. LAS's y is up in vergence:
/// a file's (x, y, z) with z up becomes (x, z, −y). Colours are 16-bit in
/// LAS; their high bytes are kept (files whose colours are all 8-bit are
/// detected on the first chunk and kept as they are).
pub fn read_las(path: &Path) -> Result<PointCloud> {
    let (file, size) = open_point_file(path)?;
    read_las_from(path, file, size)
}

/// Opens a point file for buffered reading through the file layer
/// ([`crate::fsio::open_read`]: a regular file only, never blocking on a
/// FIFO, at most [`MAX_FILE_BYTES`], remembered as an input so no output
/// or cache of this command replaces it) and returns its size.
pub(crate) fn open_point_file(path: &Path) -> Result<(std::io::BufReader<std::fs::File>, u64)> {
    let (file, size) =
        crate::fsio::open_read(path, MAX_FILE_BYTES).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
    Ok((std::io::BufReader::new(file), size))
}

/// The bounds of a file's points as a first pass over it finds them (f64
/// world coordinates, already y up), checked as every streaming reader
/// (PLY, E57) checks them: each point finite, the extent within
/// [`MAX_EXTENT_M`]; [`Survey::empty_cloud`] puts the origin at the bounds'
/// centre to the metre (PLY; E57 reads in one pass and uses its first point).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Survey {
    /// Points added so far.
    pub count: u64,
    lo: DVec3,
    hi: DVec3,
}

impl Survey {
    /// No points yet.
    pub(crate) fn new() -> Self {
        Survey {
            count: 0,
            lo: DVec3::splat(f64::INFINITY),
            hi: DVec3::splat(f64::NEG_INFINITY),
        }
    }

    /// Adds the point at `w`; a coordinate that is not finite is an error
    /// naming the point's index (`path` names the file).
    pub(crate) fn add(&mut self, path: &Path, w: DVec3) -> Result<()> {
        if !w.is_finite() {
            return Err(bad(
                path,
                format!("point {} at {w:?} is not finite", self.count),
            ));
        }
        self.lo = self.lo.min(w);
        self.hi = self.hi.max(w);
        self.count += 1;
        Ok(())
    }

    /// An error when the points span more than [`MAX_EXTENT_M`].
    pub(crate) fn check_extent(&self, path: &Path) -> Result<()> {
        let extent = (self.hi - self.lo).max_element();
        if self.count > 0 && extent > MAX_EXTENT_M {
            return Err(bad(
                path,
                format!("the points span {extent:.3e} m, more than {MAX_EXTENT_M} m"),
            ));
        }
        Ok(())
    }

    /// An empty cloud with room for every point surveyed, its origin the
    /// bounds' centre to the metre (zero without points); an extent over
    /// [`MAX_EXTENT_M`] is an error.
    pub(crate) fn empty_cloud(&self, path: &Path) -> Result<PointCloud> {
        self.check_extent(path)?;
        let origin = if self.count == 0 {
            DVec3::ZERO
        } else {
            ((self.lo + self.hi) * 0.5).round()
        };
        let n = self.count as usize;
        Ok(PointCloud {
            origin,
            positions: Vec::with_capacity(n),
            colors: Vec::with_capacity(n),
            classification: Vec::with_capacity(n),
            ..PointCloud::default()
        })
    }
}

impl PointCloud {
    /// Appends a point given in f64 world coordinates (y up) as its f32
    /// offset from the origin, with its colour and class (what the
    /// streaming readers call a point at a time).
    pub(crate) fn push_world(&mut self, w: DVec3, color: [u8; 4], class: u8) {
        let d = w - self.origin;
        self.positions.push([d.x as f32, d.y as f32, d.z as f32]);
        self.colors.push(color);
        self.classification.push(class);
    }
}

/// [`read_las`] of a file's bytes already in memory (`name` names it in
/// errors; what the fuzz target reads).
pub fn read_las_bytes(name: &Path, bytes: Vec<u8>) -> Result<PointCloud> {
    let size = bytes.len() as u64;
    read_las_from(name, std::io::Cursor::new(bytes), size)
}

fn read_las_from<R: std::io::Read + std::io::Seek + Send + Sync + 'static>(
    path: &Path,
    read: R,
    size: u64,
) -> Result<PointCloud> {
    let mut read = read;
    header_guard(&mut read, size).map_err(|m| bad(path, m))?;
    // The LAZ decoder asserts on some corrupt streams instead of returning
    // an error (found by tests/fuzz_mutate.rs): its panics become this
    // file's error, with the default panic report silenced meanwhile.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let decoded =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| decode(path, read, size)));
    std::panic::set_hook(hook);
    decoded.unwrap_or_else(|_| {
        Err(bad(
            path,
            "corrupt point data: the LAS/LAZ decoder failed on it",
        ))
    })
}

/// A LAS/LAZ header's checks before any point is read: the count within
/// the point limit and what the file's size can hold, finite positive
/// scales with finite offsets, and finite bounds within the extent limit
/// (returned, in LAS's axes).
fn check_header(path: &Path, header: &las::Header, size: u64) -> Result<(DVec3, DVec3)> {
    let count = header.number_of_points();
    let format = *header.point_format();
    let record = u64::from(format.len()).max(1);
    if count > MAX_POINTS {
        return Err(bad(
            path,
            format!("the header says {count} points, over the {MAX_POINTS}-point limit"),
        ));
    }
    // An uncompressed file must hold every record; LAZ packs a point into
    // a few bytes, never into less than 1/64 of one.
    if format.is_compressed && count > size.saturating_mul(64) {
        return Err(bad(
            path,
            format!(
                "the header says {count} points, more than a LAZ file of {size} bytes can hold"
            ),
        ));
    }
    if !format.is_compressed && count.saturating_mul(record) > size {
        return Err(bad(
            path,
            format!("the header says {count} points of {record} bytes, more than the file's {size} bytes hold"),
        ));
    }
    let t = header.transforms();
    for (axis, tr) in [("x", t.x), ("y", t.y), ("z", t.z)] {
        if !(tr.scale.is_finite() && tr.scale > 0.0 && tr.offset.is_finite()) {
            return Err(bad(
                path,
                format!(
                    "the {axis} scale {} / offset {} is not a positive finite scale and a finite offset",
                    tr.scale, tr.offset
                ),
            ));
        }
    }
    let b = header.bounds();
    let (lo, hi) = (
        DVec3::new(b.min.x, b.min.y, b.min.z),
        DVec3::new(b.max.x, b.max.y, b.max.z),
    );
    if !(lo.is_finite() && hi.is_finite()) || (hi - lo).max_element() > MAX_EXTENT_M {
        return Err(bad(
            path,
            format!("the header's bounds {lo:?} – {hi:?} are not finite or span more than {MAX_EXTENT_M} m"),
        ));
    }
    Ok((lo, hi))
}

/// Appends point `p` to `cloud` (y up, relative to its origin; its raw
/// colour, or intensity as grey, to `chunk` for the chunk's bit-depth
/// decision). A point outside `(lo, hi)` (the header's bounds with slack)
/// is an error.
fn push_point(
    path: &Path,
    cloud: &mut PointCloud,
    chunk: &mut Vec<[u16; 3]>,
    p: &las::Point,
    (lo, hi): (DVec3, DVec3),
) -> Result<()> {
    let w = DVec3::new(p.x, p.y, p.z);
    if !w.is_finite() || w.cmplt(lo).any() || w.cmpgt(hi).any() {
        return Err(bad(
            path,
            format!(
                "point {} at {w:?} lies outside the header's bounds",
                cloud.len()
            ),
        ));
    }
    let d = DVec3::new(p.x, p.z, -p.y) - cloud.origin;
    cloud.positions.push([d.x as f32, d.y as f32, d.z as f32]);
    chunk.push(
        p.color
            .map_or([p.intensity; 3], |c| [c.red, c.green, c.blue]),
    );
    cloud.colors.push([0, 0, 0, (p.intensity >> 8) as u8]);
    cloud.classification.push(u8::from(p.classification));
    Ok(())
}

/// [`read_las_from`] after the guard: header checks, then the points in
/// chunks.
fn decode<R: std::io::Read + std::io::Seek + Send + Sync + 'static>(
    path: &Path,
    read: R,
    size: u64,
) -> Result<PointCloud> {
    let mut reader = las::Reader::new(read).map_err(|e| bad(path, las_message(&e)))?;
    let header = reader.header().clone();
    let count = header.number_of_points();
    let record = u64::from(header.point_format().len()).max(1);
    let (lo, hi) = check_header(path, &header, size)?;
    let t = header.transforms();
    // The file's own coordinate offset when it lies near the points (then
    // every offset from it is the file's integer times its scale, exactly,
    // and writing the cloud back with the same offset gives the same
    // integers); else the bounds' centre to the metre.
    let centre = (lo + hi) * 0.5;
    let file_offset = DVec3::new(t.x.offset, t.y.offset, t.z.offset);
    let o = if (file_offset - centre).abs().max_element() <= (hi - lo).max_element() + 1000.0 {
        file_offset
    } else {
        centre.round()
    };
    let origin = DVec3::new(o.x, o.z, -o.y);
    // Reserved up front only as far as a chunk's worth (a header's count
    // is not trusted with memory); the rest grows as points arrive.
    let n = count.min(CHUNK * 16) as usize;
    let mut cloud = PointCloud {
        origin,
        positions: Vec::with_capacity(n),
        colors: Vec::with_capacity(n),
        classification: Vec::with_capacity(n),
        source: Some(path.to_path_buf()),
        octree: None,
    };
    let mut data = las::PointDataBuilder::new().for_header(&header).build();
    // The decoder's buffer holds a fill's records: at most FILL_BYTES,
    // however long a record the header claims.
    let per_fill = (FILL_BYTES / record).clamp(1, CHUNK);
    let slack = (hi - lo).max_element() * 1e-6 + 1e-3;
    // Whether the file's colours are 8-bit values in LAS's 16-bit fields
    // (older writers), decided on the first chunk.
    let mut eight_bit = None;
    let mut chunk: Vec<[u16; 3]> = Vec::new();
    loop {
        let got = reader
            .fill_points(per_fill, &mut data)
            .map_err(|e| bad(path, format!("point {}: {}", cloud.len(), las_message(&e))))?;
        if got == 0 {
            break;
        }
        chunk.clear();
        for p in data.points() {
            let p =
                p.map_err(|e| bad(path, format!("point {}: {}", cloud.len(), las_message(&e))))?;
            push_point(path, &mut cloud, &mut chunk, &p, (lo - slack, hi + slack))?;
            if cloud.len() as u64 > count {
                return Err(bad(
                    path,
                    format!("the header says {count} points, the file holds more"),
                ));
            }
        }
        let small = *eight_bit.get_or_insert_with(|| chunk.iter().flatten().all(|&v| v <= 255));
        let first = cloud.len() - chunk.len();
        for (dst, src) in cloud.colors[first..].iter_mut().zip(&chunk) {
            for k in 0..3 {
                dst[k] = if small {
                    src[k] as u8
                } else {
                    (src[k] >> 8) as u8
                };
            }
        }
    }
    if cloud.len() as u64 != count {
        return Err(bad(
            path,
            format!(
                "the header says {count} points, the file holds {}",
                cloud.len()
            ),
        ));
    }
    Ok(cloud)
}

/// Writes `cloud` as LAS 1.4 point format 7 (x, y, z, intensity, RGB,
/// classification), compressed as LAZ when `path` ends in `.laz`; `scale`
/// is the coordinate quantum in metres (e.g. 0.001). vergence's (x, y, z)
/// with y up goes out as LAS's (x, −z, y) with z up.
pub fn write_las(path: &Path, cloud: &PointCloud, scale: f64) -> Result<()> {
    let err = |e: las::Error| bad(path, e.to_string());
    check_writable(cloud, scale).map_err(|m| Error::Output {
        path: path.to_path_buf(),
        message: m,
    })?;
    let mut builder = las::Builder::from((1, 4));
    builder.point_format = las::point::Format::new(7).map_err(err)?;
    builder.generating_software = "vergence scan".into();
    let o = cloud.origin;
    let t = |offset: f64| las::Transform { scale, offset };
    builder.transforms = las::Vector {
        x: t(o.x),
        y: t(-o.z),
        z: t(o.y),
    };
    builder.point_format.is_compressed = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("laz"));
    let header = builder.into_header().map_err(err)?;
    // Written to a fresh temporary file beside the target, renamed over
    // it when complete.
    crate::fsio::prepare_output(path)?;
    let out = |e: std::io::Error| Error::Output {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let tmp = crate::fsio::TempFile::beside(path).map_err(out)?;
    let file = tmp.file().try_clone().map_err(out)?;
    write_points(
        las::Writer::new(std::io::BufWriter::new(file), header),
        cloud,
    )
    .map_err(err)?;
    tmp.persist(path).map_err(out)
}

/// Why `cloud` cannot be written as LAS at coordinate quantum `scale`
/// (checked before the `las` writer starts, whose drop panics when its
/// header cannot be finished): no points (a LAS without points is a file vergence refuses to
/// read), or a point whose offset from the origin (the file's coordinate
/// offset) is not finite or more quanta than LAS's 32-bit integers hold.
pub fn check_writable(cloud: &PointCloud, scale: f64) -> std::result::Result<(), String> {
    if cloud.is_empty() {
        return Err("no points to write".into());
    }
    if !(scale.is_finite() && scale > 0.0) {
        return Err(format!(
            "the coordinate quantum {scale} is not a positive number"
        ));
    }
    if let Some(i) = cloud
        .positions
        .iter()
        .position(|p| !p.iter().all(|v| v.is_finite()))
    {
        return Err(format!("point {i} is not finite"));
    }
    let reach = cloud
        .positions
        .iter()
        .flatten()
        .fold(0.0f64, |m, &v| m.max(f64::from(v).abs()));
    let most = f64::from(i32::MAX) * scale;
    if reach > most {
        return Err(format!(
            "the points reach {reach:.3e} m from their origin; LAS at {scale} m a step holds {most:.3e} m"
        ));
    }
    Ok(())
}

fn write_points(
    w: las::Result<las::Writer<std::io::BufWriter<std::fs::File>>>,
    cloud: &PointCloud,
) -> las::Result<()> {
    let mut w = w?;
    for i in 0..cloud.len() {
        let p = cloud.world(i);
        let c = cloud.colors[i];
        let point = las::Point {
            x: p.x,
            y: -p.z,
            z: p.y,
            intensity: u16::from(c[3]) << 8,
            color: Some(las::Color {
                red: u16::from(c[0]) << 8,
                green: u16::from(c[1]) << 8,
                blue: u16::from(c[2]) << 8,
            }),
            classification: las::point::Classification::new(cloud.classification[i])
                .unwrap_or(las::point::Classification::Unclassified),
            gps_time: Some(0.0),
            return_number: 1,
            number_of_returns: 1,
            ..Default::default()
        };
        w.write_point(point)?;
    }
    w.close()
}
