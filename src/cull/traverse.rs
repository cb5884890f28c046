//! Parallel hierarchy traversal and brute-force scans, producing a bitset
//! over instance indices (so unions of several volumes are a bitwise OR and
//! the final list comes out sorted without a sort).

use rayon::prelude::*;

use super::bvh::Bvh;
use super::volume::{Class, Volume};

/// Visibility bits over instance indices plus the number of tests done.
pub struct Hits {
    /// Bit `i` set when instance `i` is kept.
    pub bits: Vec<u64>,
    /// Volume tests performed (nodes plus instances).
    pub tests: u64,
}

impl Hits {
    /// No instance kept yet, room for `n` instances.
    pub fn empty(n: usize) -> Hits {
        Hits { bits: vec![0; n.div_ceil(64)], tests: 0 }
    }

    /// Union with another result (bitwise OR, tests added).
    pub fn merge(mut self, other: Hits) -> Hits {
        self.bits.iter_mut().zip(&other.bits).for_each(|(a, b)| *a |= *b);
        self.tests += other.tests;
        self
    }

    #[inline]
    fn set(&mut self, i: u32) {
        self.bits[(i >> 6) as usize] |= 1u64 << (i & 63);
    }

    /// The kept instance indices, ascending, extracted in parallel.
    pub fn to_sorted_indices(&self) -> Vec<u32> {
        const WORDS: usize = 1024;
        let counts: Vec<usize> =
            self.bits.par_chunks(WORDS).map(|c| c.iter().map(|w| w.count_ones() as usize).sum()).collect();
        let total = counts.iter().sum();
        let mut out = vec![0u32; total];
        let mut slices = Vec::with_capacity(counts.len());
        let mut rest: &mut [u32] = &mut out;
        for &c in &counts {
            let (head, tail) = rest.split_at_mut(c);
            slices.push(head);
            rest = tail;
        }
        self.bits.par_chunks(WORDS).zip(slices).enumerate().for_each(|(ci, (words, dst))| {
            let mut k = 0;
            for (wi, &w) in words.iter().enumerate() {
                let base = ((ci * WORDS + wi) * 64) as u32;
                let mut w = w;
                while w != 0 {
                    dst[k] = base + w.trailing_zeros();
                    k += 1;
                    w &= w - 1;
                }
            }
        });
        out
    }
}

/// Unit of parallel work: walk a subtree with a mask, or accept it whole.
#[derive(Clone, Copy)]
enum Task {
    Walk(u32, u8),
    Accept(u32),
}

fn accept(bvh: &Bvh, node: usize, hits: &mut Hits) {
    let s = bvh.first[node] as usize;
    let e = s + bvh.count[node] as usize;
    for &i in &bvh.order[s..e] {
        hits.set(i);
    }
}

fn walk<V: Volume>(bvh: &Bvh, vol: &V, node: usize, mask: u8, hits: &mut Hits) {
    let (lo, hi) = bvh.nodes.get(node);
    hits.tests += 1;
    match vol.classify(lo, hi, mask) {
        Class::Outside => {}
        Class::Inside => accept(bvh, node, hits),
        Class::Partial(m) => {
            if bvh.is_leaf(node) {
                let s = bvh.first[node] as usize;
                let e = s + bvh.count[node] as usize;
                hits.tests += (e - s) as u64;
                for k in s..e {
                    let (a, b) = bvh.ordered.get(k);
                    if vol.keeps(a, b, m) {
                        hits.set(bvh.order[k]);
                    }
                }
            } else {
                walk(bvh, vol, node + 1, m, hits);
                walk(bvh, vol, bvh.right[node] as usize, m, hits);
            }
        }
    }
}

/// Culls the hierarchy against `vol` in the current rayon pool. The top of
/// the tree is walked serially until subtrees are small enough to balance
/// over the threads; each worker fills its own bitset, merged by OR.
pub fn traverse<V: Volume>(bvh: &Bvh, vol: &V) -> Hits {
    let n = bvh.len();
    let threads = rayon::current_num_threads().max(1);
    let grain = (n / (threads * 32)).max(2048) as u32;
    let mut tasks = Vec::new();
    let mut serial_tests = 0u64;
    let mut stack = vec![(0usize, vol.full_mask())];
    while let Some((node, mask)) = stack.pop() {
        if bvh.count[node] <= grain || bvh.is_leaf(node) {
            tasks.push(Task::Walk(node as u32, mask));
            continue;
        }
        let (lo, hi) = bvh.nodes.get(node);
        serial_tests += 1;
        match vol.classify(lo, hi, mask) {
            Class::Outside => {}
            Class::Inside => tasks.push(Task::Accept(node as u32)),
            Class::Partial(m) => {
                stack.push((bvh.right[node] as usize, m));
                stack.push((node + 1, m));
            }
        }
    }
    let hits = if threads == 1 || tasks.len() <= 1 {
        let mut h = Hits::empty(n);
        for t in tasks {
            run_task(bvh, vol, t, &mut h);
        }
        h
    } else {
        tasks
            .par_iter()
            .with_min_len(4)
            .fold(
                || Hits::empty(n),
                |mut h, t| {
                    run_task(bvh, vol, *t, &mut h);
                    h
                },
            )
            .reduce_with(Hits::merge)
            .unwrap_or_else(|| Hits::empty(n))
    };
    Hits { bits: hits.bits, tests: hits.tests + serial_tests }
}

fn run_task<V: Volume>(bvh: &Bvh, vol: &V, t: Task, h: &mut Hits) {
    match t {
        Task::Walk(node, mask) => walk(bvh, vol, node as usize, mask, h),
        Task::Accept(node) => accept(bvh, node as usize, h),
    }
}

/// Tests every instance against every volume in `vols` (no hierarchy, no
/// early out: each volume is tested, as per-eye culling would) and keeps
/// the union. Parallel over blocks of 4096 instances.
pub fn brute<V: Volume>(bvh: &Bvh, vols: &[V]) -> Hits {
    let n = bvh.len();
    let mut bits = vec![0u64; n.div_ceil(64)];
    const BLOCK_WORDS: usize = 64;
    let inst = &bvh.instances;
    bits.par_chunks_mut(BLOCK_WORDS).enumerate().for_each(|(bi, words)| {
        let start = bi * BLOCK_WORDS * 64;
        let end = (start + BLOCK_WORDS * 64).min(n);
        for i in start..end {
            let (a, b) = inst.get(i);
            let mut keep = false;
            for v in vols {
                keep |= v.keeps(a, b, v.full_mask());
            }
            if keep {
                words[(i - start) >> 6] |= 1u64 << (i & 63);
            }
        }
    });
    Hits { bits, tests: (n * vols.len()) as u64 }
}
