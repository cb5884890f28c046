//! Bounding volume hierarchy over instance AABBs, stored structure-of-arrays.
//!
//! Build: recursive median split on the longest axis of the centroid bounds
//! (a kd-tree style object split, Wald & Havran 2006 discuss its quality
//! trade-off against SAH), with `select_nth_unstable` per node and
//! `rayon::join` on the two halves. Splitting always at `count / 2` makes the
//! topology a function of the instance count only, so node indices (depth
//! first, left child right after its parent) are known before the geometry
//! is sorted, and every subtree owns a contiguous range of `order`: a node
//! accepted whole emits `order[first .. first + count]` without more tests.
//!
//! Refit: instance bounds change, topology stays; leaves are recomputed in
//! parallel, inner nodes bottom-up (children have larger indices than their
//! parent, so a reverse sweep sees children first). Node bounds are exact
//! unions (min/max), which is what keeps hierarchy results equal to brute
//! force (see `Plane::max_over_box`).

use glam::DVec3;
use rayon::prelude::*;

/// Errors raised while building or refitting a hierarchy.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BvhError {
    /// An instance box has a non-finite coordinate or min > max.
    #[error("instance {index} has invalid bounds min {min:?} max {max:?}")]
    InvalidBounds {
        /// Instance index.
        index: usize,
        /// Box minimum.
        min: DVec3,
        /// Box maximum.
        max: DVec3,
    },
    /// More instances than `u32` indices can name.
    #[error("{0} instances exceed the u32 index range")]
    TooMany(usize),
    /// Refit got a different number of boxes than the build.
    #[error("refit with {got} boxes, hierarchy has {expected}")]
    CountMismatch {
        /// Instances in the hierarchy.
        expected: usize,
        /// Boxes passed to refit.
        got: usize,
    },
}

/// Axis-aligned boxes stored as six coordinate arrays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SoaBounds {
    /// Minimum x, y, z per box.
    pub min: [Vec<f64>; 3],
    /// Maximum x, y, z per box.
    pub max: [Vec<f64>; 3],
}

impl SoaBounds {
    /// Number of boxes.
    pub fn len(&self) -> usize {
        self.min[0].len()
    }

    /// True when there are no boxes.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Box `i` as (min, max).
    #[inline(always)]
    pub fn get(&self, i: usize) -> (DVec3, DVec3) {
        (
            DVec3::new(self.min[0][i], self.min[1][i], self.min[2][i]),
            DVec3::new(self.max[0][i], self.max[1][i], self.max[2][i]),
        )
    }

    /// Boxes gathered as `self[idx[k]]`, built in parallel.
    fn gather(src: &[(DVec3, DVec3)], idx: Option<&[u32]>) -> SoaBounds {
        let n = src.len();
        let pick = |k: usize| idx.map_or(k, |o| o[k] as usize);
        let col = |f: &(dyn Fn(&(DVec3, DVec3)) -> f64 + Sync)| -> Vec<f64> {
            (0..n)
                .into_par_iter()
                .with_min_len(4096)
                .map(|k| f(&src[pick(k)]))
                .collect()
        };
        SoaBounds {
            min: [col(&|b| b.0.x), col(&|b| b.0.y), col(&|b| b.0.z)],
            max: [col(&|b| b.1.x), col(&|b| b.1.y), col(&|b| b.1.z)],
        }
    }
}

fn validate(bounds: &[(DVec3, DVec3)]) -> Result<(), BvhError> {
    if bounds.len() > u32::MAX as usize {
        return Err(BvhError::TooMany(bounds.len()));
    }
    match bounds
        .par_iter()
        .position_any(|(lo, hi)| !(lo.is_finite() && hi.is_finite() && lo.cmple(*hi).all()))
    {
        Some(index) => Err(BvhError::InvalidBounds {
            index,
            min: bounds[index].0,
            max: bounds[index].1,
        }),
        None => Ok(()),
    }
}

/// The hierarchy. Node `i` covers `order[first .. first + count]` of
/// `nodes[i]`; it is a leaf when `count <= leaf_size`, otherwise its
/// children are `i + 1` and `right`.
#[derive(Clone, Debug)]
pub struct Bvh {
    /// Largest number of instances in a leaf.
    pub leaf_size: usize,
    /// Instance bounds in instance-index order (used by brute force).
    pub instances: SoaBounds,
    /// Instance bounds in hierarchy order: `ordered[k] = instances[order[k]]`.
    pub ordered: SoaBounds,
    /// Instance index at each hierarchy position.
    pub order: Vec<u32>,
    /// Nodes in depth-first order, one cache line each.
    pub nodes: Vec<Node>,
    /// Precomputed bitset words of the block roots (the largest nodes of at
    /// most [`SORT_BLOCK`] instances): `(word index, bits)` pairs in word
    /// order. Accepting a node at or above block level ORs its pairs in, one
    /// atomic per word instead of one bit write per instance; with
    /// instances numbered in spatial order that is ~30× fewer writes.
    pub block_words: Vec<(u32, u64)>,
    /// Per node, the range of `block_words` covering it, or `None` below
    /// block level.
    pub node_words: Vec<Option<(u32, u32)>>,
    /// Hierarchy position of each instance (the inverse of `order`), built
    /// by the first [`Bvh::update`].
    rank: Vec<u32>,
    /// Per node its parent (the root its own), and per hierarchy position
    /// its leaf; built by the first [`Bvh::update`].
    parent: Vec<u32>,
    leaf_of: Vec<u32>,
}

/// One hierarchy node: bounds and topology packed into one 64-byte cache
/// line. Instance bounds are structure-of-arrays (scanned linearly by brute
/// force and leaves), but a traversal visits nodes sparsely, and one line
/// per node costs one memory access where six coordinate arrays cost six.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Node {
    /// Box minimum.
    pub lo: DVec3,
    /// Box maximum.
    pub hi: DVec3,
    /// First hierarchy position of the node's range in `order`.
    pub first: u32,
    /// Number of instances under the node.
    pub count: u32,
    /// Right child of an inner node (its left child is the next node); 0
    /// for leaves.
    pub right: u32,
}

/// Centroid record sorted during the build (f32 relative to the scene
/// centre is plenty to order boxes; the stored bounds stay f64).
#[derive(Clone, Copy)]
struct Rec {
    c: [f32; 3],
    idx: u32,
}

const PAR_SPLIT: usize = 8192;

/// Largest number of instances in a block root (see [`Bvh::block_words`]).
pub const SORT_BLOCK: u32 = 2048;

type BlockWords = (Vec<(u32, u64)>, Vec<Option<(u32, u32)>>);

/// Builds [`Bvh::block_words`] and [`Bvh::node_words`].
fn block_words(
    order: &[u32],
    first: &[u32],
    count: &[u32],
    right: &[u32],
    leaf: usize,
) -> BlockWords {
    let mut node_words = vec![None; first.len()];
    if order.is_empty() {
        return (Vec::new(), node_words);
    }
    let mut roots = Vec::new();
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        if count[i] <= SORT_BLOCK || count[i] as usize <= leaf {
            roots.push(i);
        } else {
            stack.push(i + 1);
            stack.push(right[i] as usize);
        }
    }
    roots.sort_unstable_by_key(|&i| first[i]);
    let per_root: Vec<Vec<(u32, u64)>> = roots
        .par_iter()
        .map(|&i| {
            let s = first[i] as usize;
            let mut ids = order[s..s + count[i] as usize].to_vec();
            ids.sort_unstable();
            let mut pairs: Vec<(u32, u64)> = Vec::new();
            for id in ids {
                let (w, b) = (id >> 6, 1u64 << (id & 63));
                match pairs.last_mut() {
                    Some(last) if last.0 == w => last.1 |= b,
                    _ => pairs.push((w, b)),
                }
            }
            pairs
        })
        .collect();
    let mut words = Vec::with_capacity(per_root.iter().map(Vec::len).sum());
    for (&i, pairs) in roots.iter().zip(per_root) {
        let start = words.len() as u32;
        words.extend(pairs);
        node_words[i] = Some((start, words.len() as u32));
    }
    // Ancestors of block roots cover the contiguous run of their roots.
    for i in (0..first.len()).rev() {
        if node_words[i].is_none() && count[i] > SORT_BLOCK && count[i] as usize > leaf {
            if let (Some(l), Some(r)) = (node_words[i + 1], node_words[right[i] as usize]) {
                node_words[i] = Some((l.0, r.1));
            }
        }
    }
    (words, node_words)
}

fn order_rec(recs: &mut [Rec], leaf: usize) {
    if recs.len() <= leaf {
        return;
    }
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for r in recs.iter() {
        for a in 0..3 {
            lo[a] = lo[a].min(r.c[a]);
            hi[a] = hi[a].max(r.c[a]);
        }
    }
    let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    let mid = recs.len() / 2;
    recs.select_nth_unstable_by(mid, |a, b| a.c[axis].total_cmp(&b.c[axis]));
    let (l, r) = recs.split_at_mut(mid);
    if l.len() + r.len() > PAR_SPLIT {
        rayon::join(|| order_rec(l, leaf), || order_rec(r, leaf));
    } else {
        order_rec(l, leaf);
        order_rec(r, leaf);
    }
}

fn topology(
    first: u32,
    count: u32,
    leaf: u32,
    f: &mut Vec<u32>,
    c: &mut Vec<u32>,
    r: &mut Vec<u32>,
) {
    let me = f.len();
    f.push(first);
    c.push(count);
    r.push(0);
    if count > leaf {
        let lc = count / 2;
        topology(first, lc, leaf, f, c, r);
        r[me] = f.len() as u32;
        topology(first + lc, count - lc, leaf, f, c, r);
    }
}

impl Bvh {
    /// Builds the hierarchy over world boxes `(min, max)` with leaves of at
    /// most `leaf_size` instances (clamped to at least 1), using the current
    /// rayon pool.
    pub fn build(bounds: &[(DVec3, DVec3)], leaf_size: usize) -> Result<Bvh, BvhError> {
        validate(bounds)?;
        let leaf = leaf_size.max(1);
        let n = bounds.len();
        let center = if n == 0 {
            DVec3::ZERO
        } else {
            let (lo, hi) = bounds.par_iter().map(|b| (b.0, b.1)).reduce(
                || (DVec3::INFINITY, DVec3::NEG_INFINITY),
                |a, b| (a.0.min(b.0), a.1.max(b.1)),
            );
            (lo + hi) * 0.5
        };
        let mut recs: Vec<Rec> = bounds
            .par_iter()
            .enumerate()
            .with_min_len(4096)
            .map(|(i, (lo, hi))| {
                let c = (*lo + *hi) * 0.5 - center;
                Rec {
                    c: [c.x as f32, c.y as f32, c.z as f32],
                    idx: i as u32,
                }
            })
            .collect();
        let ((), (first, count, right)) = rayon::join(
            || order_rec(&mut recs, leaf),
            || {
                let cap = if n == 0 { 1 } else { 2 * n.div_ceil(leaf) + 1 };
                let (mut f, mut c, mut r) = (
                    Vec::with_capacity(cap),
                    Vec::with_capacity(cap),
                    Vec::with_capacity(cap),
                );
                topology(0, n as u32, leaf as u32, &mut f, &mut c, &mut r);
                (f, c, r)
            },
        );
        let order: Vec<u32> = recs.into_iter().map(|r| r.idx).collect();
        let (instances, ordered) = rayon::join(
            || SoaBounds::gather(bounds, None),
            || SoaBounds::gather(bounds, Some(&order)),
        );
        let (block_words, node_words) = block_words(&order, &first, &count, &right, leaf);
        let nodes = (0..first.len())
            .map(|i| Node {
                lo: DVec3::ZERO,
                hi: DVec3::ZERO,
                first: first[i],
                count: count[i],
                right: right[i],
            })
            .collect();
        let mut bvh = Bvh {
            leaf_size: leaf,
            instances,
            ordered,
            order,
            nodes,
            block_words,
            node_words,
            rank: Vec::new(),
            parent: Vec::new(),
            leaf_of: Vec::new(),
        };
        bvh.refit_nodes();
        Ok(bvh)
    }

    /// Number of instances.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// True when the hierarchy holds no instances.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// True when node `i` is a leaf.
    #[inline]
    pub fn is_leaf(&self, i: usize) -> bool {
        self.nodes[i].count as usize <= self.leaf_size
    }

    /// Replaces every instance's bounds (instances moved) and refits the
    /// node bounds; the topology is kept.
    pub fn refit(&mut self, bounds: &[(DVec3, DVec3)]) -> Result<(), BvhError> {
        if bounds.len() != self.len() {
            return Err(BvhError::CountMismatch {
                expected: self.len(),
                got: bounds.len(),
            });
        }
        validate(bounds)?;
        let order = &self.order;
        let (instances, ordered) = rayon::join(
            || SoaBounds::gather(bounds, None),
            || SoaBounds::gather(bounds, Some(order)),
        );
        self.instances = instances;
        self.ordered = ordered;
        self.refit_nodes();
        Ok(())
    }

    /// Replaces the bounds of the instances in `moved` (instance index,
    /// new box) and refits the node bounds; the others keep theirs and
    /// the topology is kept. Answers as [`Bvh::refit`] with every box
    /// given, touching only the moved instances' entries.
    pub fn update(&mut self, moved: &[(u32, (DVec3, DVec3))]) -> Result<(), BvhError> {
        if let Some(&(i, _)) = moved.iter().find(|m| m.0 as usize >= self.len()) {
            return Err(BvhError::CountMismatch {
                expected: self.len(),
                got: i as usize + 1,
            });
        }
        let boxes: Vec<(DVec3, DVec3)> = moved.iter().map(|m| m.1).collect();
        if let Err(BvhError::InvalidBounds { index, min, max }) = validate(&boxes) {
            return Err(BvhError::InvalidBounds {
                index: moved[index].0 as usize,
                min,
                max,
            });
        }
        if self.rank.len() != self.len() {
            self.index_for_updates();
        }
        for &(i, (lo, hi)) in moved {
            let k = self.rank[i as usize] as usize;
            for (set, at) in [(&mut self.instances, i as usize), (&mut self.ordered, k)] {
                for a in 0..3 {
                    set.min[a][at] = lo[a];
                    set.max[a][at] = hi[a];
                }
            }
        }
        // Few moved: refit their leaves and those leaves' ancestors only;
        // many: every node, in parallel.
        if moved.len() * 8 > self.node_count() {
            self.refit_nodes();
            return Ok(());
        }
        let mut dirty: Vec<u32> = Vec::with_capacity(moved.len() * 4);
        let mut marked = std::collections::HashSet::with_capacity(moved.len() * 4);
        for &(i, _) in moved {
            let mut n = self.leaf_of[self.rank[i as usize] as usize];
            while marked.insert(n) {
                dirty.push(n);
                if n == 0 {
                    break;
                }
                n = self.parent[n as usize];
            }
        }
        // Children come after their parent in depth-first order.
        dirty.sort_unstable_by(|a, b| b.cmp(a));
        for n in dirty {
            let i = n as usize;
            let b = if self.is_leaf(i) {
                let s = self.nodes[i].first as usize;
                let e = s + self.nodes[i].count as usize;
                (s..e).fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |acc, k| {
                    let (lo, hi) = self.ordered.get(k);
                    (acc.0.min(lo), acc.1.max(hi))
                })
            } else {
                let (l, r) = (
                    &self.nodes[i + 1],
                    &self.nodes[self.nodes[i].right as usize],
                );
                (l.lo.min(r.lo), l.hi.max(r.hi))
            };
            self.nodes[i].lo = b.0;
            self.nodes[i].hi = b.1;
        }
        Ok(())
    }

    /// Builds `rank`, `parent` and `leaf_of` (what [`Bvh::update`] walks).
    fn index_for_updates(&mut self) {
        self.rank = vec![0; self.len()];
        for (k, &i) in self.order.iter().enumerate() {
            self.rank[i as usize] = k as u32;
        }
        self.parent = vec![0; self.node_count()];
        self.leaf_of = vec![0; self.len()];
        for i in 0..self.node_count() {
            if self.is_leaf(i) {
                let s = self.nodes[i].first as usize;
                let e = s + self.nodes[i].count as usize;
                for k in s..e {
                    self.leaf_of[k] = i as u32;
                }
            } else {
                self.parent[i + 1] = i as u32;
                self.parent[self.nodes[i].right as usize] = i as u32;
            }
        }
    }

    fn refit_nodes(&mut self) {
        let n_nodes = self.node_count();
        let leaf_boxes: Vec<Option<(DVec3, DVec3)>> = (0..n_nodes)
            .into_par_iter()
            .with_min_len(1024)
            .map(|i| {
                if !self.is_leaf(i) {
                    return None;
                }
                let s = self.nodes[i].first as usize;
                let e = s + self.nodes[i].count as usize;
                let mut acc = (DVec3::INFINITY, DVec3::NEG_INFINITY);
                for k in s..e {
                    let (lo, hi) = self.ordered.get(k);
                    acc = (acc.0.min(lo), acc.1.max(hi));
                }
                Some(acc)
            })
            .collect();
        for i in (0..n_nodes).rev() {
            let b = match leaf_boxes[i] {
                Some(b) => b,
                None => {
                    let (l, r) = (
                        &self.nodes[i + 1],
                        &self.nodes[self.nodes[i].right as usize],
                    );
                    (l.lo.min(r.lo), l.hi.max(r.hi))
                }
            };
            self.nodes[i].lo = b.0;
            self.nodes[i].hi = b.1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn boxes(n: usize, seed: u64) -> Vec<(DVec3, DVec3)> {
        let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let c = DVec3::new(next(), next(), next()) * 200.0 - 100.0;
                let h = DVec3::new(next(), next(), next()) * 2.0 + 0.01;
                (c - h, c + h)
            })
            .collect()
    }

    proptest! {
        /// Moving a few instances refits only their leaves' paths to the
        /// root, yet every node ends with the box a full refit gives.
        #[test]
        fn a_partial_update_gives_the_nodes_of_a_full_refit(
            n in 1usize..3000,
            leaf in 1usize..17,
            seed in 0u64..1000,
            moves in proptest::collection::vec((0usize..3000, -50.0f64..50.0), 1..12),
        ) {
            let start = boxes(n, seed);
            let mut partial = Bvh::build(&start, leaf).unwrap();
            let mut all = start.clone();
            let mut moved = Vec::new();
            for (i, d) in moves {
                let i = i % n;
                let b = (all[i].0 + DVec3::splat(d), all[i].1 + DVec3::splat(d));
                all[i] = b;
                moved.push((i as u32, b));
            }
            // Twice: the second update finds the index maps built.
            partial.update(&moved).unwrap();
            partial.update(&moved).unwrap();
            let mut full = Bvh::build(&start, leaf).unwrap();
            full.refit(&all).unwrap();
            prop_assert_eq!(&partial.nodes, &full.nodes);
            prop_assert_eq!(&partial.instances, &full.instances);
            prop_assert_eq!(&partial.ordered, &full.ordered);
        }
    }
}
