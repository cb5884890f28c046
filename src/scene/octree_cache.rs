//! Point-cloud octree cache: `vergence inspect SCAN --write-octree` keeps the
//! octree [`super::octree::build`] makes for a point file (or a manifest of
//! point files) next to it, in `FILE.octree`, keyed by a content hash of
//! the cloud's origin and points in file order and of the build's settings
//! ([`ALGORITHM`]). Every later load of that file reads the octree and the
//! points' order from it instead of building; anything else — another
//! hash or point count, a truncated file, nodes that do not tile the
//! points, children before their parents or beyond the list, an order that
//! is not a permutation, non-finite cubes — is a warning, and the octree
//! is built as without a cache. (A value altered within those bounds is
//! not detected: the file is a cache, not a signed artefact.) Writing is
//! atomic (a temporary file renamed over the old one).
//!
//! Layout, little-endian: the magic `VOCTC001`, the hash (u64), the point
//! count (u64), the node count (u32); per node its cube's low corner (3 ×
//! f32), edge (f32), first point and count (u32 each) and eight children
//! (u32, `u32::MAX` for none); then the order (u32 per point: point i of
//! the reordered cloud is point `order[i]` of the file).

pub use super::octree::CacheUse;
use super::octree::{Node, Octree, GRID, LEAF_POINTS, NONE};
use glam::DVec3;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"VOCTC001";
/// Bytes of one node record.
const NODE_BYTES: usize = 56;

/// What the octree depends on besides the points: bump it whenever
/// `scene::octree::build` changes how it builds, so caches made by the
/// old code are rebuilt.
pub const ALGORITHM: &[u8] =
    b"octree 1: morton 21 bits, first point per grid cell, octant runs in order";

/// The cache file of a cloud loaded from `source`.
pub fn path_for(source: &Path) -> PathBuf {
    let mut name = source.file_name().unwrap_or_default().to_os_string();
    name.push(".octree");
    source.with_file_name(name)
}

/// FNV-1a (Fowler, Noll, Vo; the published 64-bit offset basis and
/// prime) applied to 32-bit words instead of bytes, from state `h`.
fn fnv1a_words(mut h: u64, words: impl IntoIterator<Item = u32>) -> u64 {
    for w in words {
        h ^= w as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The content hash of a cloud (its `origin` and `positions` in file
/// order) and the build's settings: each run of 2^20 points hashed on its
/// own (in parallel), the runs' hashes then hashed in order.
pub fn content_hash(origin: DVec3, positions: &[[f32; 3]]) -> u64 {
    const BASIS: u64 = 0xcbf2_9ce4_8422_2325;
    let runs: Vec<u64> = positions
        .par_chunks(1 << 20)
        .map(|run| fnv1a_words(BASIS, run.iter().flatten().map(|v| v.to_bits())))
        .collect();
    let mut h = fnv1a_words(BASIS, MAGIC.chunks(4).map(word));
    h = fnv1a_words(h, ALGORITHM.chunks(4).map(word));
    h = fnv1a_words(h, [GRID, LEAF_POINTS as u32]);
    h = fnv1a_words(h, origin.to_array().iter().flat_map(|v| split(v.to_bits())));
    h = fnv1a_words(h, split(positions.len() as u64));
    fnv1a_words(h, runs.into_iter().flat_map(split))
}

/// Up to four bytes as a little-endian word (zero-padded).
fn word(b: &[u8]) -> u32 {
    let mut w = [0u8; 4];
    w[..b.len()].copy_from_slice(b);
    u32::from_le_bytes(w)
}

/// A u64 as its low and high words.
fn split(v: u64) -> [u32; 2] {
    [v as u32, (v >> 32) as u32]
}

/// The cache file's bytes for `tree` and `order` over a cloud of hash
/// `hash`.
pub fn encode(hash: u64, tree: &Octree, order: &[u32]) -> Vec<u8> {
    let mut out = Vec::with_capacity(28 + tree.nodes.len() * NODE_BYTES + 4 * order.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&hash.to_le_bytes());
    out.extend_from_slice(&(order.len() as u64).to_le_bytes());
    out.extend_from_slice(&(tree.nodes.len() as u32).to_le_bytes());
    for n in &tree.nodes {
        for v in n.lo.iter().chain([&n.size]) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in [n.first, n.count].iter().chain(&n.children) {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    for i in order {
        out.extend_from_slice(&i.to_le_bytes());
    }
    out
}

/// Little-endian u32 at byte `at` (the caller checked the length).
fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// Decodes a cache file for a cloud of `points` points with hash `hash`:
/// the octree and the order, or why the file cannot be used.
pub fn decode(bytes: &[u8], hash: u64, points: usize) -> Result<(Octree, Vec<u32>), String> {
    if bytes.len() < 28 || &bytes[..8] != MAGIC {
        return Err("not an octree cache (magic)".into());
    }
    let u64_at = |at: usize| u32_at(bytes, at) as u64 | (u32_at(bytes, at + 4) as u64) << 32;
    if u64_at(8) != hash {
        return Err("made for other points or another build (hash)".into());
    }
    if u64_at(16) != points as u64 {
        return Err(format!(
            "made for {} points, the cloud has {points}",
            u64_at(16)
        ));
    }
    let count = u32_at(bytes, 24) as usize;
    let want = (count as u128) * NODE_BYTES as u128 + 4 * points as u128 + 28;
    if bytes.len() as u128 != want || count == 0 || count > points.max(1) {
        return Err(format!(
            "{} bytes for {count} nodes and {points} points (want {want})",
            bytes.len()
        ));
    }
    let mut nodes = Vec::with_capacity(count);
    for k in 0..count {
        let at = 28 + k * NODE_BYTES;
        let f = |j: usize| f32::from_bits(u32_at(bytes, at + 4 * j));
        let w = |j: usize| u32_at(bytes, at + 4 * j);
        let node = Node {
            lo: [f(0), f(1), f(2)],
            size: f(3),
            first: w(4),
            count: w(5),
            children: std::array::from_fn(|c| w(6 + c)),
        };
        if !(node.lo.iter().all(|v| v.is_finite()) && node.size.is_finite() && node.size > 0.0) {
            return Err(format!("node {k}: its cube is not finite"));
        }
        if node.first as u64 + node.count as u64 > points as u64 {
            return Err(format!("node {k}: points beyond the cloud"));
        }
        for &c in &node.children {
            if c != NONE && (c as usize >= count || c as usize <= k) {
                return Err(format!("node {k}: child {c} is not a later node"));
            }
        }
        nodes.push(node);
    }
    // The nodes' ranges tile 0..points, and each node has one parent.
    let mut ranges: Vec<(u32, u32)> = nodes.iter().map(|n| (n.first, n.count)).collect();
    ranges.sort_unstable();
    let mut next = 0u64;
    for (first, n) in ranges {
        if first as u64 != next {
            return Err("the nodes' points do not tile the cloud".into());
        }
        next += n as u64;
    }
    if next != points as u64 {
        return Err("the nodes' points do not tile the cloud".into());
    }
    let mut parent = vec![false; count];
    for n in &nodes {
        for &c in n.children.iter().filter(|&&c| c != NONE) {
            if std::mem::replace(&mut parent[c as usize], true) {
                return Err(format!("node {c} has two parents"));
            }
        }
    }
    if let Some(k) = (1..count).find(|&k| !parent[k]) {
        return Err(format!("node {k} has no parent"));
    }
    let base = 28 + count * NODE_BYTES;
    let order: Vec<u32> = (0..points).map(|i| u32_at(bytes, base + 4 * i)).collect();
    let mut seen = vec![false; points];
    for &i in &order {
        match seen.get_mut(i as usize) {
            Some(s) if !*s => *s = true,
            _ => return Err("the order is not a permutation of the points".into()),
        }
    }
    Ok((
        Octree {
            nodes,
            build_ms: 0.0,
            cache: None,
        },
        order,
    ))
}

/// The octree and order of a cloud at `origin` with `positions` (file
/// order) loaded from `source`: read from its cache when that is usable
/// (the time to read and check it as `build_ms`), else built — and with
/// `write`, the cache written (atomically) after building.
pub fn load_or_build(
    origin: DVec3,
    positions: &[[f32; 3]],
    source: &Path,
    write: bool,
) -> (Octree, Vec<u32>, CacheUse) {
    let started = std::time::Instant::now();
    let path = path_for(source);
    let hash = content_hash(origin, positions);
    // The largest cache of this many points: the header, a node per
    // point at most, and the order.
    let limit = 28 + (NODE_BYTES as u64 + 4) * (positions.len() as u64).max(1);
    let why = match crate::fsio::read_cache(&path, limit) {
        Ok(bytes) if !write => match decode(&bytes, hash, positions.len()) {
            Ok((mut tree, order)) => {
                tree.build_ms = started.elapsed().as_secs_f64() * 1e3;
                return (tree, order, CacheUse::Read(path));
            }
            Err(e) => {
                tracing::warn!(
                    "octree cache {}: {e}; building the octree (`vergence inspect {} --write-octree` replaces it)",
                    path.display(),
                    source.display()
                );
                format!("{}: {e}", path.display())
            }
        },
        Ok(_) => "rewritten".into(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => "no cache file".into(),
        Err(e) => {
            tracing::warn!("octree cache {}: {e}; building the octree", path.display());
            format!("{}: {e}", path.display())
        }
    };
    let (tree, order) = super::octree::build(positions);
    if !write {
        return (tree, order, CacheUse::NotUsed(why));
    }
    // Through the file layer: a fresh temporary file renamed over the
    // cache, never over one of this command's inputs.
    let used = match crate::fsio::write_bytes(&path, &encode(hash, &tree, &order)) {
        Ok(()) => CacheUse::Written(path),
        Err(e) => CacheUse::NotUsed(format!("cannot write: {e}")),
    };
    (tree, order, used)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud(n: usize) -> Vec<[f32; 3]> {
        let mut rng = crate::scene::factory::SplitMix64::new(5);
        (0..n)
            .map(|_| {
                [
                    (rng.unit() * 30.0) as f32,
                    (rng.unit() * 5.0) as f32,
                    (rng.unit() * 30.0) as f32,
                ]
            })
            .collect()
    }

    #[test]
    fn the_octree_survives_the_round_trip_and_other_points_are_refused() {
        let p = cloud(40_000);
        let (tree, order) = crate::scene::octree::build(&p);
        assert!(tree.nodes.len() > 1, "the test needs a tree with children");
        let hash = content_hash(DVec3::ZERO, &p);
        let bytes = encode(hash, &tree, &order);
        let (back, back_order) = decode(&bytes, hash, p.len()).unwrap();
        assert_eq!(back.nodes, tree.nodes);
        assert_eq!(back_order, order);
        // Moving one point, or the origin, changes the hash.
        let mut q = p.clone();
        q[123][1] += 0.001;
        assert_ne!(content_hash(DVec3::ZERO, &q), hash);
        assert_ne!(content_hash(DVec3::X, &p), hash);
        assert!(decode(&bytes, hash ^ 1, p.len()).is_err());
        assert!(decode(&bytes, hash, p.len() - 1).is_err());
    }

    #[test]
    fn every_truncation_and_flipped_byte_is_refused_or_harmless() {
        let p = cloud(20_000);
        let (tree, order) = crate::scene::octree::build(&p);
        let hash = content_hash(DVec3::ZERO, &p);
        let bytes = encode(hash, &tree, &order);
        for len in (0..bytes.len()).step_by(7) {
            assert!(decode(&bytes[..len], hash, p.len()).is_err(), "{len}");
        }
        // Flips in the header and the nodes (every order flip breaks the
        // permutation or is refused the same way).
        let nodes_end = 28 + tree.nodes.len() * NODE_BYTES;
        for at in (0..nodes_end).chain((nodes_end..bytes.len()).step_by(97)) {
            let mut b = bytes.clone();
            b[at] ^= 0x5a;
            if let Ok((t, o)) = decode(&b, hash, p.len()) {
                crate::fuzz_checks::check_octree(&t, &o, p.len());
            }
        }
    }
}
