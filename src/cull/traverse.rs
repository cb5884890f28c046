//! Parallel hierarchy traversal and brute-force scans, marking kept
//! instances in a shared bitset over instance indices: unions of several
//! volumes are free (the same bits are set again) and the final list comes
//! out sorted without a sort. The bitset lives in the caller's
//! [`super::Culler`] and is reused frame after frame, so a frame allocates
//! nothing once the buffers have grown.

use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

use rayon::prelude::*;

use super::bvh::Bvh;
use super::volume::{Class, Volume};

/// Visibility bits over instance indices, shared by the worker threads.
#[derive(Debug, Default)]
pub struct Marks {
    bits: Vec<AtomicU64>,
}

impl Marks {
    /// Clears the bits and sizes them for `n` instances.
    pub fn reset(&mut self, n: usize) {
        let words = n.div_ceil(64);
        if self.bits.len() != words {
            self.bits = (0..words).map(|_| AtomicU64::new(0)).collect();
        } else {
            self.bits.par_chunks(4096).for_each(|c| c.iter().for_each(|w| w.store(0, Relaxed)));
        }
    }

    /// Writes the kept instance indices, ascending, into `out` (replacing its
    /// contents), in parallel over blocks of the bitset.
    pub fn extract_into(&self, out: &mut Vec<u32>) {
        const WORDS: usize = 1024;
        let counts: Vec<usize> = self
            .bits
            .par_chunks(WORDS)
            .map(|c| c.iter().map(|w| w.load(Relaxed).count_ones() as usize).sum())
            .collect();
        let total = counts.iter().sum();
        out.clear();
        out.resize(total, 0);
        let mut slices = Vec::with_capacity(counts.len());
        let mut rest: &mut [u32] = out;
        for &c in &counts {
            let (head, tail) = rest.split_at_mut(c);
            slices.push(head);
            rest = tail;
        }
        self.bits.par_chunks(WORDS).zip(slices).enumerate().for_each(|(ci, (words, dst))| {
            let mut k = 0;
            for (wi, w) in words.iter().enumerate() {
                let base = ((ci * WORDS + wi) * 64) as u32;
                let mut w = w.load(Relaxed);
                if w == u64::MAX {
                    // Whole word visible: a straight run of 64 indices.
                    for (j, d) in dst[k..k + 64].iter_mut().enumerate() {
                        *d = base + j as u32;
                    }
                    k += 64;
                    continue;
                }
                while w != 0 {
                    dst[k] = base + w.trailing_zeros();
                    k += 1;
                    w &= w - 1;
                }
            }
        });
    }
}

/// Per-task writer: gathers bits of the current word in a register and
/// publishes them with one atomic OR when the word changes, so coherent
/// index runs cost one atomic per 64 instances.
struct Writer<'a> {
    bits: &'a [AtomicU64],
    word: usize,
    val: u64,
    tests: u64,
}

impl<'a> Writer<'a> {
    fn new(bits: &'a [AtomicU64]) -> Self {
        Writer { bits, word: 0, val: 0, tests: 0 }
    }

    #[inline]
    fn set(&mut self, i: u32) {
        let w = (i >> 6) as usize;
        if w != self.word {
            self.flush();
            self.word = w;
        }
        self.val |= 1u64 << (i & 63);
    }

    #[inline]
    fn flush(&mut self) {
        if self.val != 0 {
            self.bits[self.word].fetch_or(self.val, Relaxed);
            self.val = 0;
        }
    }
}

/// Unit of parallel work: walk a subtree with a mask, or accept it whole.
#[derive(Clone, Copy)]
enum Task {
    Walk(u32, u8),
    Accept(u32),
}

/// Keeps every instance below `node`: precomputed block words at or above
/// block level, single bits below it.
fn accept(bvh: &Bvh, node: usize, w: &mut Writer) {
    if let Some((s, e)) = bvh.node_words[node] {
        for &(word, bits) in &bvh.block_words[s as usize..e as usize] {
            w.bits[word as usize].fetch_or(bits, Relaxed);
        }
        return;
    }
    let s = bvh.first[node] as usize;
    let e = s + bvh.count[node] as usize;
    for &i in &bvh.order[s..e] {
        w.set(i);
    }
}

fn walk<V: Volume>(bvh: &Bvh, vol: &V, node: usize, mask: u8, w: &mut Writer) {
    let (lo, hi) = bvh.nodes.get(node);
    w.tests += 1;
    match vol.classify(lo, hi, mask) {
        Class::Outside => {}
        Class::Inside => accept(bvh, node, w),
        Class::Partial(m) => {
            if bvh.is_leaf(node) {
                let s = bvh.first[node] as usize;
                let e = s + bvh.count[node] as usize;
                w.tests += (e - s) as u64;
                for k in s..e {
                    let (a, b) = bvh.ordered.get(k);
                    if vol.keeps(a, b, m) {
                        w.set(bvh.order[k]);
                    }
                }
            } else {
                walk(bvh, vol, node + 1, m, w);
                walk(bvh, vol, bvh.right[node] as usize, m, w);
            }
        }
    }
}

fn run_task<V: Volume>(bvh: &Bvh, vol: &V, t: Task, bits: &[AtomicU64]) -> u64 {
    let mut w = Writer::new(bits);
    match t {
        Task::Walk(node, mask) => walk(bvh, vol, node as usize, mask, &mut w),
        Task::Accept(node) => accept(bvh, node as usize, &mut w),
    }
    w.flush();
    w.tests
}

/// Culls the hierarchy against `vol` in the current rayon pool, OR-ing kept
/// instances into `marks`; returns the number of tests. The top of the tree
/// is walked serially until subtrees are small enough to balance over the
/// threads.
pub fn traverse<V: Volume>(bvh: &Bvh, vol: &V, marks: &Marks) -> u64 {
    if bvh.is_empty() {
        return 0;
    }
    let threads = rayon::current_num_threads().max(1);
    let grain = (bvh.len() / (threads * 32)).max(2048) as u32;
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
    let bits = &marks.bits[..];
    let tests: u64 = if threads == 1 {
        tasks.iter().map(|t| run_task(bvh, vol, *t, bits)).sum()
    } else {
        tasks.par_iter().map(|t| run_task(bvh, vol, *t, bits)).sum()
    };
    tests + serial_tests
}

/// Tests every instance against every volume in `vols` (no hierarchy, no
/// early out: each volume is tested, as per-eye culling would) and ORs the
/// union into `marks`; returns the number of tests. Parallel over blocks of
/// 4096 instances.
pub fn brute<V: Volume>(bvh: &Bvh, vols: &[V], marks: &Marks) -> u64 {
    let n = bvh.len();
    const BLOCK_WORDS: usize = 64;
    let inst = &bvh.instances;
    marks.bits.par_chunks(BLOCK_WORDS).enumerate().for_each(|(bi, words)| {
        let start = bi * BLOCK_WORDS * 64;
        let end = (start + BLOCK_WORDS * 64).min(n);
        let mut val = 0u64;
        for i in start..end {
            let (a, b) = inst.get(i);
            let mut keep = false;
            for v in vols {
                keep |= v.keeps(a, b, v.full_mask());
            }
            val |= u64::from(keep) << (i & 63);
            if i & 63 == 63 || i + 1 == end {
                words[(i - start) >> 6].fetch_or(val, Relaxed);
                val = 0;
            }
        }
    });
    (n * vols.len()) as u64
}
