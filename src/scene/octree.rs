//! A point cloud's level-of-detail octree, after Potree (Schütz, "Potree:
//! Rendering Large Point Clouds in Web Browsers", TU Wien 2016): every node
//! holds its own subsample of the points in its cube — one point per cell
//! of a [`GRID`]³ grid over the cube — and its children refine with the
//! rest, so each point lies in exactly one node and drawing a node with its
//! ancestors shows the cube at the node's spacing. The points are reordered
//! so every node's own points are one contiguous range.
//!
//! Build: Morton codes (21 bits per axis) over the cloud's bounding cube,
//! one parallel sort, then top-down: in a node's Morton-sorted range the
//! first point of every run sharing its top `3 · (depth + log2 GRID)` code
//! bits is that grid cell's first point; a stable partition moves those to
//! the front (the node's own), and the rest, still sorted, split into the
//! eight children by the next three bits. Children build in parallel.
//!
//! Per frame ([`Octree::select`]): nodes in either eye's frustum, largest
//! projected cube first (edge over distance to the nearer eye), until the
//! point budget is spent; a node is only taken after its parent.

use crate::view::frustum::Frustum;
use crate::view::StereoRig;
use glam::DVec3;
use rayon::prelude::*;

/// Grid cells per axis of a node's subsample.
pub const GRID: u32 = 128;
/// log2 of [`GRID`].
const GRID_BITS: u32 = 7;
/// A node with at most this many points keeps them all (a leaf).
pub const LEAF_POINTS: usize = 16_384;
/// Morton bits per axis.
const BITS: u32 = 21;
/// No child.
pub const NONE: u32 = u32::MAX;

/// One node: its cube (relative to the cloud's origin), its own points and
/// its children.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// The cube's low corner, relative to the cloud's origin.
    pub lo: [f32; 3],
    /// The cube's edge, metres.
    pub size: f32,
    /// Its own points: `first..first + count` of the reordered cloud.
    pub first: u32,
    /// How many.
    pub count: u32,
    /// Children by octant (bit 0 x, bit 1 y, bit 2 z); [`NONE`]: empty.
    pub children: [u32; 8],
}

/// The octree of a cloud; node 0 is the root (absent for an empty cloud).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Octree {
    /// The nodes, parents before children.
    pub nodes: Vec<Node>,
    /// Milliseconds the build took (or reading it from its cache).
    pub build_ms: f64,
    /// For a cloud loaded from a file: whether the octree came from its
    /// cache file (`scene::octree_cache`).
    pub cache: Option<CacheUse>,
}

/// Where the octree of a cloud loaded from a file came from (for
/// `stats.json` and `inspect`).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CacheUse {
    /// Read from this cache file.
    Read(std::path::PathBuf),
    /// Built and written to this cache file.
    Written(std::path::PathBuf),
    /// Built; no cache file was used (why).
    NotUsed(String),
}

/// Interleaves the low 21 bits of `v` with two zero bits between each.
fn spread(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The Morton code of cell `c` (x in bit 0 of each triple).
pub fn morton(c: [u32; 3]) -> u64 {
    spread(c[0] as u64) | spread(c[1] as u64) << 1 | spread(c[2] as u64) << 2
}

/// The bounding cube (low corner, edge) of `positions`.
fn cube(positions: &[[f32; 3]]) -> ([f32; 3], f32) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max);
    // A little slack so the far faces' points stay inside the last cell.
    (lo, (size * (1.0 + 1e-6)).max(1e-3))
}

/// Builds the octree of a cloud's `positions` (offsets from its origin).
/// Returns it with the order the points must take for its nodes' ranges:
/// point i of the reordered cloud is `positions[order[i]]` (the cloud
/// applies it: `PointCloud::with_octree` in the points module).
pub fn build(positions: &[[f32; 3]]) -> (Octree, Vec<u32>) {
    let started = std::time::Instant::now();
    let n = positions.len();
    if n == 0 {
        return (Octree::default(), Vec::new());
    }
    let (lo, size) = cube(positions);
    let cells = (1u64 << BITS) as f32;
    let scale = cells / size;
    let mut keyed: Vec<(u64, u32)> = positions
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let c = |k: usize| (((p[k] - lo[k]) * scale) as u32).min((1 << BITS) - 1);
            (morton([c(0), c(1), c(2)]), i as u32)
        })
        .collect();
    keyed.par_sort_unstable();
    let mut order: Vec<u32> = Vec::with_capacity(n);
    let nodes = build_node(&mut keyed, lo, size, 0, &mut order);
    drop(keyed);
    let tree = Octree {
        nodes,
        build_ms: started.elapsed().as_secs_f64() * 1e3,
        cache: None,
    };
    (tree, order)
}

/// Builds the subtree of the Morton-sorted `keyed` (the points of the cube
/// at `lo`, edge `size`, depth `depth`), appending its points' original
/// indices to `order` in node order: a node's own points, then each
/// child's subtree. Returns the subtree's nodes, root first; `first` and
/// child links count from where `order` and the list stood on entry.
fn build_node(
    keyed: &mut [(u64, u32)],
    lo: [f32; 3],
    size: f32,
    depth: u32,
    order: &mut Vec<u32>,
) -> Vec<Node> {
    let base_order = order.len() as u32;
    let mut node = Node {
        lo,
        size,
        first: base_order,
        count: 0,
        children: [NONE; 8],
    };
    if keyed.len() <= LEAF_POINTS || depth + GRID_BITS >= BITS {
        node.count = keyed.len() as u32;
        order.extend(keyed.iter().map(|k| k.1));
        return vec![node];
    }
    // The first point of every grid cell is this node's; a stable
    // partition keeps both parts in Morton order.
    let cell_shift = 3 * (BITS - depth - GRID_BITS);
    let mut own = Vec::new();
    let mut rest = Vec::with_capacity(keyed.len());
    let mut last = None;
    for &k in keyed.iter() {
        let cell = k.0 >> cell_shift;
        if last != Some(cell) {
            own.push(k);
            last = Some(cell);
        } else {
            rest.push(k);
        }
    }
    node.count = own.len() as u32;
    order.extend(own.iter().map(|k| k.1));
    let own_len = own.len();
    keyed[..own_len].copy_from_slice(&own);
    keyed[own_len..].copy_from_slice(&rest);
    drop((own, rest));
    // The children: the runs of the rest sharing the next three bits.
    let child_shift = 3 * (BITS - depth - 1);
    let mut parts: Vec<(usize, &mut [(u64, u32)])> = Vec::new();
    let mut tail = &mut keyed[own_len..];
    while !tail.is_empty() {
        let oct = ((tail[0].0 >> child_shift) & 7) as usize;
        let len = tail
            .iter()
            .position(|k| ((k.0 >> child_shift) & 7) as usize != oct)
            .unwrap_or(tail.len());
        let (head, t) = std::mem::take(&mut tail).split_at_mut(len);
        parts.push((oct, head));
        tail = t;
    }
    let half = size * 0.5;
    let built: Vec<(usize, Vec<Node>, Vec<u32>)> = parts
        .into_par_iter()
        .map(|(oct, part)| {
            let clo = [
                lo[0] + if oct & 1 != 0 { half } else { 0.0 },
                lo[1] + if oct & 2 != 0 { half } else { 0.0 },
                lo[2] + if oct & 4 != 0 { half } else { 0.0 },
            ];
            let mut sub = Vec::with_capacity(part.len());
            let nodes = build_node(part, clo, half, depth + 1, &mut sub);
            (oct, nodes, sub)
        })
        .collect();
    let mut out = vec![node];
    for (oct, nodes, sub) in built {
        let base = out.len() as u32;
        let shift = order.len() as u32;
        out[0].children[oct] = base;
        out.extend(nodes.into_iter().map(|mut n| {
            n.first += shift;
            for c in &mut n.children {
                if *c != NONE {
                    *c += base;
                }
            }
            n
        }));
        order.extend(sub);
    }
    out
}

/// A node's priority in the heap (its projected size), ordered by value.
#[derive(Clone, Copy, PartialEq)]
struct Ranked(f64, u32);

impl Eq for Ranked {}

impl PartialOrd for Ranked {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Ranked {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0).then(other.1.cmp(&self.1))
    }
}

/// What a frame draws of the cloud.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Selection {
    /// The nodes taken, in the order taken.
    pub nodes: Vec<u32>,
    /// Their points (at most the budget).
    pub points: u64,
}

impl Octree {
    /// World box of node `i` of a cloud at `origin`.
    pub fn world_box(&self, origin: DVec3, i: u32) -> (DVec3, DVec3) {
        let n = &self.nodes[i as usize];
        let lo = origin + DVec3::new(n.lo[0] as f64, n.lo[1] as f64, n.lo[2] as f64);
        (lo, lo + DVec3::splat(n.size as f64))
    }

    /// The nodes `rig` draws of a cloud at `origin` within `budget` points:
    /// starting at the root, the node of largest projected size (cube edge
    /// over its distance from the nearer eye) among those whose parents are
    /// taken and that lie in either eye's frustum (near plane `near`), as
    /// long as its points still fit the budget.
    pub fn select(&self, origin: DVec3, rig: &StereoRig, near: f64, budget: u64) -> Selection {
        let mut out = Selection::default();
        if self.nodes.is_empty() {
            return out;
        }
        let frusta: Vec<Frustum> = rig
            .views
            .iter()
            .filter_map(|v| Frustum::from_view(v, near, None).ok())
            .collect();
        let eyes: Vec<DVec3> = rig.views.iter().map(|v| v.pose.position).collect();
        let rank = |i: u32| -> Option<Ranked> {
            let (lo, hi) = self.world_box(origin, i);
            if !frusta.iter().any(|f| f.planes.keeps_box(lo, hi)) {
                return None;
            }
            let centre = (lo + hi) * 0.5;
            let reach = (hi - lo).length() * 0.5;
            let d = eyes
                .iter()
                .map(|e| (centre.distance(*e) - reach).max(1e-3))
                .fold(f64::INFINITY, f64::min);
            Some(Ranked((hi.x - lo.x) / d, i))
        };
        let mut heap = std::collections::BinaryHeap::new();
        heap.extend(rank(0));
        while let Some(Ranked(_, i)) = heap.pop() {
            let n = &self.nodes[i as usize];
            if out.points + n.count as u64 > budget {
                break;
            }
            out.points += n.count as u64;
            out.nodes.push(i);
            heap.extend(
                n.children
                    .iter()
                    .filter(|&&c| c != NONE)
                    .filter_map(|&c| rank(c)),
            );
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parts of a cloud the octree sees or reorders.
    #[derive(Default)]
    struct Points {
        origin: DVec3,
        positions: Vec<[f32; 3]>,
        colors: Vec<[u8; 4]>,
        classification: Vec<u8>,
    }

    impl Points {
        fn len(&self) -> usize {
            self.positions.len()
        }
    }

    /// [`build`] with its order applied to `c`.
    fn build_into(c: &mut Points) -> Octree {
        let (tree, order) = build(&c.positions);
        c.positions = order.iter().map(|&i| c.positions[i as usize]).collect();
        c.colors = order.iter().map(|&i| c.colors[i as usize]).collect();
        c.classification = order
            .iter()
            .map(|&i| c.classification[i as usize])
            .collect();
        tree
    }

    fn cloud(n: usize, seed: u64) -> Points {
        let mut rng = crate::scene::factory::SplitMix64::new(seed);
        let mut c = Points {
            origin: DVec3::new(100.0, 0.0, -50.0),
            ..Points::default()
        };
        for i in 0..n {
            // Clustered: half the points in a small corner, as scans are.
            let s = if i % 2 == 0 { 40.0 } else { 3.0 };
            c.positions.push([
                (rng.unit() * s) as f32,
                (rng.unit() * s * 0.25) as f32,
                (rng.unit() * s) as f32,
            ]);
            c.colors.push([(i % 256) as u8, 0, 0, 0]);
            c.classification.push((i % 7) as u8);
        }
        c
    }

    #[test]
    fn morton_interleaves_the_axes() {
        assert_eq!(morton([1, 0, 0]), 1);
        assert_eq!(morton([0, 1, 0]), 2);
        assert_eq!(morton([0, 0, 1]), 4);
        assert_eq!(morton([3, 0, 0]), 0b1001);
        let m = (1 << BITS) - 1;
        assert_eq!(morton([m, m, m]), (1u64 << 63) - 1);
    }

    /// Against brute force: every point in exactly one node, inside its
    /// cube; a node's own points one per grid cell (unless a leaf); the
    /// children inside their parent; the points a permutation of the input.
    #[test]
    fn every_point_lies_in_one_node_inside_its_cube() {
        let mut c = cloud(200_000, 3);
        let before: std::collections::HashSet<[u32; 3]> =
            c.positions.iter().map(|p| p.map(f32::to_bits)).collect();
        let t = build_into(&mut c);
        assert!(t.nodes.len() > 8, "{} nodes", t.nodes.len());
        let mut covered = vec![false; c.len()];
        for (i, n) in t.nodes.iter().enumerate() {
            let range = n.first as usize..(n.first + n.count) as usize;
            let mut cells = std::collections::HashSet::new();
            for k in range {
                assert!(!covered[k], "point {k} in two nodes");
                covered[k] = true;
                let p = c.positions[k];
                for (v, lo) in p.iter().zip(n.lo) {
                    assert!(*v >= lo - 1e-3 && *v <= lo + n.size + 1e-3, "node {i}");
                }
                let cell = [0, 1, 2].map(|a| ((p[a] - n.lo[a]) / n.size * GRID as f32) as i64);
                let leaf = n.children.iter().all(|&ch| ch == NONE);
                assert!(
                    leaf || cells.insert(cell),
                    "node {i}: two points in one cell"
                );
            }
            for &ch in n.children.iter().filter(|&&ch| ch != NONE) {
                let k = &t.nodes[ch as usize];
                assert!(ch as usize > i && (k.size - n.size * 0.5).abs() < 1e-6);
            }
        }
        assert!(covered.iter().all(|&v| v));
        let after: std::collections::HashSet<[u32; 3]> =
            c.positions.iter().map(|p| p.map(f32::to_bits)).collect();
        assert_eq!(before, after);
        // Colours and classes moved with their points.
        assert!(c.colors.iter().zip(&c.classification).count() == c.len());
    }

    #[test]
    fn selection_keeps_the_budget_parents_first_nearer_first() {
        let mut c = cloud(200_000, 5);
        let t = build_into(&mut c);
        let profile = crate::view::profile::HmdProfile::load("valve-index").unwrap();
        // A head inside the cloud's big box, looking across it.
        let pose = crate::view::Pose {
            position: c.origin + DVec3::new(20.0, 5.0, 45.0),
            ..Default::default()
        };
        let rig = profile.rig(pose);
        let all = t.select(c.origin, &rig, 0.05, u64::MAX);
        let everything: u64 = t.nodes.iter().map(|n| n.count as u64).sum();
        assert!(all.points > 0 && all.points <= everything);
        for budget in [1_000u64, 20_000, 60_000] {
            let s = t.select(c.origin, &rig, 0.05, budget);
            assert!(s.points <= budget, "{} over {budget}", s.points);
            // Parents before children.
            let taken: std::collections::HashSet<u32> = s.nodes.iter().copied().collect();
            for (k, &i) in s.nodes.iter().enumerate() {
                for &ch in t.nodes[i as usize]
                    .children
                    .iter()
                    .filter(|&&ch| ch != NONE)
                {
                    if let Some(at) = s.nodes.iter().position(|&x| x == ch) {
                        assert!(at > k);
                    }
                }
                assert!(
                    i == 0
                        || t.nodes.iter().any(|p| p.children.contains(&i)
                            && taken
                                .contains(&(t.nodes.iter().position(|q| q == p).unwrap() as u32)))
                );
            }
            // A larger budget refines what a smaller one took.
            let more = t.select(c.origin, &rig, 0.05, budget * 2);
            assert!(s.nodes.iter().all(|i| more.nodes.contains(i)));
        }
    }
}
