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
//! Every range is rearranged in place (one scratch buffer of the cloud's
//! length for the partitions; long ranges partition in parallel chunks by
//! prefix sums of each chunk's count), so at the end the sorted keys'
//! indices are the points' new order.
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

/// The bounding cube (low corner, edge) of `positions` (a parallel
/// reduction).
fn cube(positions: &[[f32; 3]]) -> ([f32; 3], f32) {
    let (lo, hi) = positions
        .par_chunks(1 << 16)
        .map(|chunk| {
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for p in chunk {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            (lo, hi)
        })
        .reduce(
            || ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
            |(a, b), (c, d)| {
                (
                    [0, 1, 2].map(|k| a[k].min(c[k])),
                    [0, 1, 2].map(|k| b[k].max(d[k])),
                )
            },
        );
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max);
    // A little slack so the far faces' points stay inside the last cell.
    (lo, (size * (1.0 + 1e-6)).max(1e-3))
}

/// A point's Morton code and its index in the cloud as given.
type Keyed = (u64, u32);

/// The Morton code of the cell holding `p` in the cube at `lo` with
/// `scale` cells per metre.
fn key(p: &[f32; 3], lo: [f32; 3], scale: f32) -> u64 {
    let c = |k: usize| (((p[k] - lo[k]) * scale) as u32).min((1 << BITS) - 1);
    morton([c(0), c(1), c(2)])
}

/// Ranges at least this long partition in parallel chunks.
const PARALLEL_RANGE: usize = 1 << 17;

/// Builds the octree of a cloud's `positions` (offsets from its origin).
/// Returns it with the order the points must take for its nodes' ranges:
/// point i of the reordered cloud is `positions[order[i]]` (the cloud
/// applies it: `PointCloud::with_octree` in the points module).
pub fn build(positions: &[[f32; 3]]) -> (Octree, Vec<u32>) {
    build_with(positions, PARALLEL_RANGE)
}

/// [`build`], ranges of at least `parallel_range` points partitioned in
/// parallel (a parameter so tests reach that path with small clouds).
fn build_with(positions: &[[f32; 3]], parallel_range: usize) -> (Octree, Vec<u32>) {
    let started = std::time::Instant::now();
    let n = positions.len();
    if n == 0 {
        return (Octree::default(), Vec::new());
    }
    let (lo, size) = cube(positions);
    let scale = (1u64 << BITS) as f32 / size;
    let mut keyed: Vec<Keyed> = positions
        .par_iter()
        .enumerate()
        .map(|(i, p)| (key(p, lo, scale), i as u32))
        .collect();
    keyed.par_sort_unstable();
    let mut scratch: Vec<Keyed> = vec![(0, 0); n];
    let at = Place {
        lo,
        size,
        depth: 0,
        first: 0,
    };
    let nodes = build_node(&mut keyed, &mut scratch, at, parallel_range);
    drop(scratch);
    // Every node's range was rearranged in place into its own points, then
    // its children's ranges: the keys' indices are the order.
    let order: Vec<u32> = keyed.par_iter().map(|k| k.1).collect();
    let tree = Octree {
        nodes,
        build_ms: started.elapsed().as_secs_f64() * 1e3,
        cache: None,
    };
    (tree, order)
}

/// Where a node's range lies: its cube, its depth and its first point in
/// the whole cloud's order.
#[derive(Clone, Copy)]
struct Place {
    lo: [f32; 3],
    size: f32,
    depth: u32,
    first: u32,
}

/// Builds the subtree of the Morton-sorted `keyed` (the points of the cube
/// at `at`), rearranging `keyed` in place into the subtree's order: the
/// node's own points, then each child's range in octant order (`scratch`,
/// as long as `keyed`, is the partition's room). Returns the subtree's
/// nodes, root first, child links counting from the subtree's root.
fn build_node(
    keyed: &mut [Keyed],
    scratch: &mut [Keyed],
    at: Place,
    parallel_range: usize,
) -> Vec<Node> {
    let mut node = Node {
        lo: at.lo,
        size: at.size,
        first: at.first,
        count: keyed.len() as u32,
        children: [NONE; 8],
    };
    if keyed.len() <= LEAF_POINTS || at.depth + GRID_BITS >= BITS {
        return vec![node];
    }
    // The first point of every grid cell is this node's; a stable
    // partition keeps both parts in Morton order.
    let cell_shift = 3 * (BITS - at.depth - GRID_BITS);
    let own_len = if keyed.len() >= parallel_range {
        partition_parallel(keyed, scratch, cell_shift)
    } else {
        partition(keyed, scratch, cell_shift)
    };
    node.count = own_len as u32;
    // The children: the runs of the rest sharing the next three bits (the
    // rest is sorted, so each run's end is a binary search).
    let child_shift = 3 * (BITS - at.depth - 1);
    let octant = |k: &Keyed| ((k.0 >> child_shift) & 7) as usize;
    let mut parts: Vec<(usize, u32, &mut [Keyed], &mut [Keyed])> = Vec::new();
    let (_, mut tail) = keyed.split_at_mut(own_len);
    let (_, mut room) = scratch.split_at_mut(own_len);
    let mut first = at.first + own_len as u32;
    while !tail.is_empty() {
        let oct = octant(&tail[0]);
        let len = tail.partition_point(|k| octant(k) <= oct);
        let (head, t) = std::mem::take(&mut tail).split_at_mut(len);
        let (head_room, r) = std::mem::take(&mut room).split_at_mut(len);
        parts.push((oct, first, head, head_room));
        first += len as u32;
        tail = t;
        room = r;
    }
    let half = at.size * 0.5;
    let built: Vec<(usize, Vec<Node>)> = parts
        .into_par_iter()
        .map(|(oct, first, part, part_room)| {
            let lo = [
                at.lo[0] + if oct & 1 != 0 { half } else { 0.0 },
                at.lo[1] + if oct & 2 != 0 { half } else { 0.0 },
                at.lo[2] + if oct & 4 != 0 { half } else { 0.0 },
            ];
            let child = Place {
                lo,
                size: half,
                depth: at.depth + 1,
                first,
            };
            (oct, build_node(part, part_room, child, parallel_range))
        })
        .collect();
    let mut out = vec![node];
    for (oct, nodes) in built {
        let base = out.len() as u32;
        out[0].children[oct] = base;
        out.extend(nodes.into_iter().map(|mut n| {
            for c in &mut n.children {
                if *c != NONE {
                    *c += base;
                }
            }
            n
        }));
    }
    out
}

/// Whether `keyed[i]` is the first of its grid cell (cells: the codes'
/// bits above `cell_shift`).
fn opens_cell(keyed: &[Keyed], i: usize, cell_shift: u32) -> bool {
    i == 0 || keyed[i].0 >> cell_shift != keyed[i - 1].0 >> cell_shift
}

/// The stable partition of `keyed` into its cells' first points, then the
/// rest, through `scratch`; returns how many came first.
fn partition(keyed: &mut [Keyed], scratch: &mut [Keyed], cell_shift: u32) -> usize {
    let mut own = 0;
    for i in 0..keyed.len() {
        if opens_cell(keyed, i, cell_shift) {
            scratch[own] = keyed[i];
            own += 1;
        }
    }
    let mut rest = own;
    for i in 0..keyed.len() {
        if !opens_cell(keyed, i, cell_shift) {
            scratch[rest] = keyed[i];
            rest += 1;
        }
    }
    keyed.copy_from_slice(scratch);
    own
}

/// [`partition`] over chunks in parallel: each chunk counts its cells'
/// first points, the counts' prefix sums give every chunk its place in both
/// parts, and the chunks write there at once.
fn partition_parallel(keyed: &mut [Keyed], scratch: &mut [Keyed], cell_shift: u32) -> usize {
    let chunk = keyed
        .len()
        .div_ceil(4 * rayon::current_num_threads())
        .max(1 << 12);
    let view: &[Keyed] = keyed;
    let starts: Vec<usize> = (0..view.len()).step_by(chunk).collect();
    let owns: Vec<usize> = starts
        .par_iter()
        .map(|&s| {
            (s..(s + chunk).min(view.len()))
                .filter(|&i| opens_cell(view, i, cell_shift))
                .count()
        })
        .collect();
    let own_total: usize = owns.iter().sum();
    // Each chunk's room in the first part and in the rest.
    let (mut own_room, mut rest_room) = scratch.split_at_mut(own_total);
    let mut jobs = Vec::with_capacity(starts.len());
    for (&s, &own) in starts.iter().zip(&owns) {
        let len = (s + chunk).min(view.len()) - s;
        let (o, or) = std::mem::take(&mut own_room).split_at_mut(own);
        let (r, rr) = std::mem::take(&mut rest_room).split_at_mut(len - own);
        own_room = or;
        rest_room = rr;
        jobs.push((s, len, o, r));
    }
    jobs.into_par_iter().for_each(|(s, len, o, r)| {
        let (mut a, mut b) = (0, 0);
        for i in s..s + len {
            if opens_cell(view, i, cell_shift) {
                o[a] = view[i];
                a += 1;
            } else {
                r[b] = view[i];
                b += 1;
            }
        }
    });
    keyed
        .par_chunks_mut(chunk)
        .zip(scratch.par_chunks(chunk))
        .for_each(|(k, s)| k.copy_from_slice(s));
    own_total
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

    /// The octree the plain way, for comparison: per node its cells'
    /// first points, then the rest filtered octant by octant into
    /// children built one after another, the order appended as it goes.
    fn reference(positions: &[[f32; 3]]) -> (Vec<Node>, Vec<u32>) {
        fn node(
            keyed: Vec<Keyed>,
            lo: [f32; 3],
            size: f32,
            depth: u32,
            nodes: &mut Vec<Node>,
            order: &mut Vec<u32>,
        ) -> u32 {
            let at = nodes.len();
            nodes.push(Node {
                lo,
                size,
                first: order.len() as u32,
                count: keyed.len() as u32,
                children: [NONE; 8],
            });
            if keyed.len() <= LEAF_POINTS || depth + GRID_BITS >= BITS {
                order.extend(keyed.iter().map(|k| k.1));
                return at as u32;
            }
            let shift = 3 * (BITS - depth - GRID_BITS);
            let firsts: Vec<bool> = (0..keyed.len())
                .map(|i| i == 0 || keyed[i].0 >> shift != keyed[i - 1].0 >> shift)
                .collect();
            let own: Vec<u32> = (0..keyed.len())
                .filter(|&i| firsts[i])
                .map(|i| keyed[i].1)
                .collect();
            nodes[at].count = own.len() as u32;
            order.extend(own);
            let child_shift = 3 * (BITS - depth - 1);
            let half = size * 0.5;
            for oct in 0..8usize {
                let part: Vec<Keyed> = (0..keyed.len())
                    .filter(|&i| !firsts[i] && ((keyed[i].0 >> child_shift) & 7) as usize == oct)
                    .map(|i| keyed[i])
                    .collect();
                if part.is_empty() {
                    continue;
                }
                let clo = [0, 1, 2].map(|k| lo[k] + if oct & (1 << k) != 0 { half } else { 0.0 });
                let c = node(part, clo, half, depth + 1, nodes, order);
                nodes[at].children[oct] = c;
            }
            at as u32
        }
        let (lo, size) = cube(positions);
        let scale = (1u64 << BITS) as f32 / size;
        let mut keyed: Vec<Keyed> = positions
            .iter()
            .enumerate()
            .map(|(i, p)| (key(p, lo, scale), i as u32))
            .collect();
        keyed.sort();
        let (mut nodes, mut order) = (Vec::new(), Vec::new());
        node(keyed, lo, size, 0, &mut nodes, &mut order);
        (nodes, order)
    }

    /// The in-place build, with its ranges partitioned serially or in
    /// parallel chunks (cells straddling the chunks' edges), gives the
    /// plain build's nodes and order exactly.
    #[test]
    fn the_in_place_build_equals_the_plain_one() {
        for (n, seed) in [(1usize, 1u64), (20_000, 2), (200_000, 3), (120_000, 8)] {
            let c = cloud(n, seed);
            let (nodes, order) = reference(&c.positions);
            for parallel_range in [usize::MAX, PARALLEL_RANGE, 1 << 10] {
                let (t, o) = build_with(&c.positions, parallel_range);
                assert!(
                    t.nodes == nodes,
                    "{n} points, parallel from {parallel_range}: nodes"
                );
                assert!(
                    o == order,
                    "{n} points, parallel from {parallel_range}: order"
                );
            }
        }
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
