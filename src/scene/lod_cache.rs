//! LOD chain cache (`--opt lod,lod-cache`): the chains [`super::lod`]
//! builds for a scene loaded from a file are kept next to it, in
//! `FILE.lodcache`, keyed by a content hash of every primitive's positions
//! and indices and of the simplifier's settings and algorithm version
//! ([`ALGORITHM`]). A later load with the same content reads them instead
//! of simplifying again; anything else — another hash, a truncated file,
//! counts beyond the file, indices out of range, empty or non-shrinking
//! levels, non-finite or decreasing errors — is a warning, the chains are
//! built again and the file replaced. (A value altered within those
//! bounds is not detected: the file is a cache, not a signed artefact.) Writing is atomic (a
//! temporary file renamed over the old one); a folder that cannot be
//! written is a warning, never an error.
//!
//! Layout, little-endian: the magic `VLODC001`, the hash (u64), the
//! primitive count (u32); per primitive its level count (u32) and per level
//! its error (f32) and index count (u32) followed by the indices (u32).

use super::lod::{Chains, Level, MIN_TRIANGLES};
use super::Scene;
use crate::view::lod::MAX_LEVELS;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"VLODC001";

/// What the chains depend on besides the content: bump it whenever
/// `scene::lod::chain` changes how it simplifies (options, targets, stop
/// rule), so caches built by the old code are rebuilt.
pub const ALGORITHM: &[u8] =
    b"lod chain 1: meshopt 0.7 simplify_decoder, ErrorAbsolute|Permissive, halving, stop above 90 %";

/// What happened to the cache on one load (for `stats.json`).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CacheUse {
    /// The chains were read from this file.
    Read(PathBuf),
    /// The chains were built and written to this file.
    Written(PathBuf),
    /// The chains were built; the file could not be written (why).
    NotWritten(String),
}

/// The cache file of a scene loaded from `source`.
pub fn path_for(source: &Path) -> PathBuf {
    let mut name = source.file_name().unwrap_or_default().to_os_string();
    name.push(".lodcache");
    source.with_file_name(name)
}

/// FNV-1a, 64 bits (Fowler, Noll, Vo; the offset basis and prime of the
/// published 64-bit parameters), over `bytes` from state `h`.
fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The content hash of `scene`'s primitives and the simplifier's settings.
pub fn content_hash(scene: &Scene) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325;
    h = fnv1a(h, MAGIC);
    h = fnv1a(h, ALGORITHM);
    for v in [MAX_LEVELS as u64, MIN_TRIANGLES as u64] {
        h = fnv1a(h, &v.to_le_bytes());
    }
    h = fnv1a(h, &(scene.primitives.len() as u64).to_le_bytes());
    for p in &scene.primitives {
        h = fnv1a(h, &(p.positions.len() as u64).to_le_bytes());
        for v in p.positions.iter().flatten() {
            h = fnv1a(h, &v.to_bits().to_le_bytes());
        }
        h = fnv1a(h, &(p.indices.len() as u64).to_le_bytes());
        for i in &p.indices {
            h = fnv1a(h, &i.to_le_bytes());
        }
    }
    h
}

/// The file's bytes for `chains` of content `hash`.
pub fn encode(hash: u64, chains: &Chains) -> Vec<u8> {
    let mut out = Vec::with_capacity(20 + chains.index_bytes() as usize);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&hash.to_le_bytes());
    out.extend_from_slice(&(chains.levels.len() as u32).to_le_bytes());
    for levels in &chains.levels {
        out.extend_from_slice(&(levels.len() as u32).to_le_bytes());
        for l in levels {
            out.extend_from_slice(&l.error.to_le_bytes());
            out.extend_from_slice(&(l.indices.len() as u32).to_le_bytes());
            for i in &l.indices {
                out.extend_from_slice(&i.to_le_bytes());
            }
        }
    }
    out
}

/// Reads little-endian words off the front of a byte slice.
struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    fn u32(&mut self, what: &str) -> Result<u32, String> {
        let (head, rest) = self
            .0
            .split_first_chunk::<4>()
            .ok_or_else(|| format!("the file ends inside {what}"))?;
        self.0 = rest;
        Ok(u32::from_le_bytes(*head))
    }

    fn u64(&mut self, what: &str) -> Result<u64, String> {
        let (head, rest) = self
            .0
            .split_first_chunk::<8>()
            .ok_or_else(|| format!("the file ends inside {what}"))?;
        self.0 = rest;
        Ok(u64::from_le_bytes(*head))
    }
}

/// The chains in `bytes`, checked against `scene` (content `hash`): every
/// count within the file, every index within its primitive's vertices,
/// errors finite and non-decreasing. What is wrong otherwise.
pub fn decode(bytes: &[u8], hash: u64, scene: &Scene) -> Result<Chains, String> {
    let rest = bytes
        .strip_prefix(MAGIC)
        .ok_or("not a vergence LOD cache (version 1)")?;
    let mut r = Reader(rest);
    let got = r.u64("the hash")?;
    if got != hash {
        return Err(format!(
            "made for other content (hash {got:016x}, the scene's is {hash:016x})"
        ));
    }
    let n = r.u32("the primitive count")? as usize;
    if n != scene.primitives.len() {
        return Err(format!(
            "{n} primitives, the scene has {}",
            scene.primitives.len()
        ));
    }
    let mut levels = Vec::with_capacity(n);
    for (k, p) in scene.primitives.iter().enumerate() {
        let count = r.u32("a level count")? as usize;
        if count >= MAX_LEVELS {
            return Err(format!(
                "primitive {k}: {count} levels (at most {})",
                MAX_LEVELS - 1
            ));
        }
        let mut chain: Vec<Level> = Vec::with_capacity(count);
        for j in 0..count {
            let error = f32::from_bits(r.u32("a level's error")?);
            let last = chain.last().map_or(0.0, |l| l.error);
            if !(error.is_finite() && error >= last) {
                return Err(format!(
                    "primitive {k} level {j}: error {error} (finite, not below the level before)"
                ));
            }
            let len = r.u32("an index count")? as usize;
            let above = chain.last().map_or(p.indices.len(), |l| l.indices.len());
            if len == 0 || len >= above {
                return Err(format!(
                    "primitive {k} level {j}: {len} indices (a level has fewer than the one above, {above}, and at least one triangle)"
                ));
            }
            if !len.is_multiple_of(3) || len > r.0.len() / 4 {
                return Err(format!(
                    "primitive {k} level {j}: {len} indices (whole triangles, within the file)"
                ));
            }
            let (words, rest) = r.0.split_at(4 * len);
            r.0 = rest;
            let indices: Vec<u32> = words
                .chunks_exact(4)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            if let Some(bad) = indices.iter().find(|&&i| i as usize >= p.positions.len()) {
                return Err(format!(
                    "primitive {k} level {j}: index {bad} beyond its {} vertices",
                    p.positions.len()
                ));
            }
            chain.push(Level { indices, error });
        }
        levels.push(chain);
    }
    if !r.0.is_empty() {
        return Err(format!("{} bytes after the last primitive", r.0.len()));
    }
    Ok(Chains {
        levels,
        build_ms: 0.0,
    })
}

/// The most bytes a cache of `scene`'s chains can hold: the header, and
/// per primitive its level count and at most `MAX_LEVELS - 1` levels, each
/// an error, a count and fewer indices than the primitive has. A larger
/// file is not this scene's cache and is not read.
pub fn max_bytes(scene: &Scene) -> u64 {
    let levels = (MAX_LEVELS - 1) as u64;
    let header = (MAGIC.len() + 12) as u64;
    scene.primitives.iter().fold(header, |n, p| {
        n + 4 + levels * (8 + 4 * p.indices.len() as u64)
    })
}

/// The cache at `file` for `scene`, read only when it is a regular file
/// no larger than [`max_bytes`].
pub fn read_for(file: &Path, scene: &Scene) -> std::io::Result<Vec<u8>> {
    let limit = max_bytes(scene).min(crate::fsio::MAX_SCENE_FILE_BYTES);
    crate::fsio::read_cache(file, limit)
}

/// The chains of `scene` (loaded from `source`) through the cache next to
/// it: read when it holds this content, else built and written. Reading
/// and writing problems are warnings (logged) and reported in the
/// [`CacheUse`].
pub fn load_or_build(scene: &Scene, source: &Path) -> (Chains, CacheUse) {
    let t = std::time::Instant::now();
    let file = path_for(source);
    let hash = content_hash(scene);
    match read_for(&file, scene) {
        Ok(bytes) => match decode(&bytes, hash, scene) {
            Ok(mut chains) => {
                chains.build_ms = t.elapsed().as_secs_f64() * 1e3;
                return (chains, CacheUse::Read(file));
            }
            Err(why) => tracing::warn!(
                "LOD cache {}: {why}; building the chains again",
                file.display()
            ),
        },
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => tracing::warn!(
            "LOD cache {}: {e}; building the chains again",
            file.display()
        ),
    }
    let mut chains = super::lod::build(scene);
    // The cache was read as a cache, not an input: a file this command
    // did read as an input (a glTF buffer of the same name) stays refused.
    let written = crate::fsio::write_bytes(&file, &encode(hash, &chains));
    chains.build_ms = t.elapsed().as_secs_f64() * 1e3;
    match written {
        Ok(()) => (chains, CacheUse::Written(file)),
        Err(e) => {
            tracing::warn!("LOD cache not written: {e}");
            (chains, CacheUse::NotWritten(e.to_string()))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{shapes, Mesh, Scene};

    fn scene() -> Scene {
        Scene {
            name: "cache".into(),
            primitives: vec![
                shapes::cylinder(1.0, 2.0, 128, 0),
                shapes::cuboid([1.0, 2.0, 3.0], 0),
            ],
            meshes: vec![Mesh {
                name: "m".into(),
                primitives: vec![0, 1],
            }],
            ..Scene::default()
        }
    }

    #[test]
    fn chains_survive_the_round_trip_and_other_content_is_refused() {
        let s = scene();
        let chains = super::super::lod::build(&s);
        let hash = content_hash(&s);
        let bytes = encode(hash, &chains);
        let back = decode(&bytes, hash, &s).unwrap();
        assert_eq!(back.levels, chains.levels);
        // Moving one vertex changes the hash: the file no longer applies.
        let mut moved = s.clone();
        moved.primitives[0].positions[3][1] += 1e-3;
        let other = content_hash(&moved);
        assert_ne!(other, hash);
        assert!(decode(&bytes, other, &moved)
            .unwrap_err()
            .contains("other content"));
    }

    #[test]
    fn every_truncation_and_every_flipped_byte_is_refused_or_harmless() {
        let s = scene();
        let chains = super::super::lod::build(&s);
        let hash = content_hash(&s);
        let bytes = encode(hash, &chains);
        for cut in 0..bytes.len() {
            assert!(decode(&bytes[..cut], hash, &s).is_err(), "cut at {cut}");
        }
        // A flipped byte either is refused or still decodes into chains
        // whose indices lie within the primitives (an altered index or
        // error inside the checked ranges).
        for at in 0..bytes.len() {
            let mut b = bytes.clone();
            b[at] ^= 0x5a;
            if let Ok(c) = decode(&b, hash, &s) {
                for (p, levels) in s.primitives.iter().zip(&c.levels) {
                    for l in levels {
                        assert!(l.indices.iter().all(|&i| (i as usize) < p.positions.len()));
                        assert!(l.error.is_finite());
                    }
                }
            }
        }
    }
}
