//! Parallel hierarchy traversal and brute-force scans, marking kept
//! instances in a shared bitset over instance indices: unions of several
//! volumes are free (the same bits are set again) and the final list comes
//! out sorted without a sort. The bitset lives in the caller's
//! [`super::Culler`] and is reused frame after frame, so a frame allocates
//! nothing once the buffers have grown.

use std::sync::{Mutex, MutexGuard};

use rayon::prelude::*;

use super::bvh::Bvh;
use super::volume::{Class, Volume};

/// Visibility bits over instance indices: one private bitset per worker
/// thread (plain stores, no atomics; a slot is locked once per task,
/// uncontended), OR-ed together when the list is extracted.
#[derive(Debug, Default)]
pub struct Marks {
    slots: Vec<Mutex<Vec<u64>>>,
    words: usize,
}

impl Marks {
    /// Clears the bits and sizes them for `n` instances and the current
    /// rayon pool (one slot per worker; a caller outside the pool shares
    /// slot 0 through its lock).
    pub fn reset(&mut self, n: usize) {
        let words = n.div_ceil(64);
        let slots = rayon::current_num_threads().max(1);
        if self.words != words || self.slots.len() != slots {
            self.slots = (0..slots).map(|_| Mutex::new(vec![0; words])).collect();
            self.words = words;
        } else {
            self.slots.par_iter_mut().for_each(|s| lock_mut(s).fill(0));
        }
    }

    /// The calling thread's slot, locked.
    fn slot(&self) -> MutexGuard<'_, Vec<u64>> {
        let i = rayon::current_thread_index().unwrap_or(0) % self.slots.len();
        self.slots[i].lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Writes the kept instance indices, ascending, into `out` (replacing its
    /// contents), in parallel over blocks of the bitset. Folds the other
    /// slots into slot 0 on the way, so call [`Marks::reset`] before reuse.
    pub fn extract_into(&mut self, out: &mut Vec<u32>) {
        const WORDS: usize = 1024;
        // Pass 1: fold every slot into slot 0 and count, per block of words.
        let mut slots: Vec<&mut Vec<u64>> = self.slots.iter_mut().map(lock_mut).collect();
        let (head, others) = slots.split_at_mut(1);
        let others: Vec<&Vec<u64>> = others.iter().map(|s| &**s).collect();
        let merged: &mut Vec<u64> = head[0];
        let counts: Vec<usize> = merged
            .par_chunks_mut(WORDS)
            .enumerate()
            .map(|(c, words)| {
                let mut n = 0;
                for (j, w) in words.iter_mut().enumerate() {
                    let i = c * WORDS + j;
                    *w = others.iter().fold(*w, |a, s| a | s[i]);
                    n += w.count_ones() as usize;
                }
                n
            })
            .collect();
        let merged: &Vec<u64> = merged;
        let total = counts.iter().sum();
        // Only growth is zero-filled; every kept element is overwritten.
        out.resize(total, 0);
        let mut pieces = Vec::with_capacity(counts.len());
        let mut rest: &mut [u32] = out;
        for &c in &counts {
            let (head, tail) = rest.split_at_mut(c);
            pieces.push(head);
            rest = tail;
        }
        // Pass 2: write the set bits' indices into each block's slice.
        pieces
            .into_par_iter()
            .zip(merged.par_chunks(WORDS))
            .enumerate()
            .for_each(|(ci, (dst, words))| {
                let mut k = 0;
                for (j, &w) in words.iter().enumerate() {
                    let base = ((ci * WORDS + j) * 64) as u32;
                    let mut w = w;
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

fn lock_mut(m: &mut Mutex<Vec<u64>>) -> &mut Vec<u64> {
    m.get_mut().unwrap_or_else(|e| e.into_inner())
}

/// Per-task writer into the worker's private bitset.
struct Writer<'a> {
    bits: &'a mut [u64],
    tests: u64,
}

impl Writer<'_> {
    #[inline]
    fn set(&mut self, i: u32) {
        self.bits[(i >> 6) as usize] |= 1u64 << (i & 63);
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
            w.bits[word as usize] |= bits;
        }
        return;
    }
    let s = bvh.nodes[node].first as usize;
    let e = s + bvh.nodes[node].count as usize;
    for &i in &bvh.order[s..e] {
        w.set(i);
    }
}

fn walk<V: Volume>(bvh: &Bvh, vol: &V, node: usize, mask: u8, w: &mut Writer) {
    let (lo, hi) = (bvh.nodes[node].lo, bvh.nodes[node].hi);
    w.tests += 1;
    match vol.classify(lo, hi, mask) {
        Class::Outside => {}
        Class::Inside => accept(bvh, node, w),
        Class::Partial(m) => {
            if bvh.is_leaf(node) {
                let s = bvh.nodes[node].first as usize;
                let e = s + bvh.nodes[node].count as usize;
                w.tests += (e - s) as u64;
                for k in s..e {
                    let (a, b) = bvh.ordered.get(k);
                    if vol.keeps(a, b, m) {
                        w.set(bvh.order[k]);
                    }
                }
            } else {
                walk(bvh, vol, node + 1, m, w);
                walk(bvh, vol, bvh.nodes[node].right as usize, m, w);
            }
        }
    }
}

fn run_task<V: Volume>(bvh: &Bvh, vol: &V, t: Task, marks: &Marks) -> u64 {
    // No rayon calls below, so this thread cannot pick up another task
    // while holding its slot.
    let mut slot = marks.slot();
    let mut w = Writer {
        bits: &mut slot,
        tests: 0,
    };
    match t {
        Task::Walk(node, mask) => walk(bvh, vol, node as usize, mask, &mut w),
        Task::Accept(node) => accept(bvh, node as usize, &mut w),
    }
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
        if bvh.nodes[node].count <= grain || bvh.is_leaf(node) {
            tasks.push(Task::Walk(node as u32, mask));
            continue;
        }
        let (lo, hi) = (bvh.nodes[node].lo, bvh.nodes[node].hi);
        serial_tests += 1;
        match vol.classify(lo, hi, mask) {
            Class::Outside => {}
            Class::Inside => tasks.push(Task::Accept(node as u32)),
            Class::Partial(m) => {
                stack.push((bvh.nodes[node].right as usize, m));
                stack.push((node + 1, m));
            }
        }
    }
    let tests: u64 = if threads == 1 {
        tasks.iter().map(|t| run_task(bvh, vol, *t, marks)).sum()
    } else {
        tasks
            .par_iter()
            .map(|t| run_task(bvh, vol, *t, marks))
            .sum()
    };
    tests + serial_tests
}

/// Tests every instance against every volume in `vols` (no hierarchy, no
/// early out: each volume is tested, as per-eye culling would) and ORs the
/// union into `marks`; returns the number of tests. Parallel over blocks of
/// 4096 instances.
pub fn brute<V: Volume>(bvh: &Bvh, vols: &[V], marks: &Marks) -> u64 {
    let n = bvh.len();
    const BLOCK: usize = 4096;
    let inst = &bvh.instances;
    (0..n.div_ceil(BLOCK)).into_par_iter().for_each(|b| {
        let mut slot = marks.slot();
        for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
            let (a, bb) = inst.get(i);
            let mut keep = false;
            for v in vols {
                keep |= v.keeps(a, bb, v.full_mask());
            }
            slot[i >> 6] |= u64::from(keep) << (i & 63);
        }
    });
    (n * vols.len()) as u64
}
