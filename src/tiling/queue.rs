//! The fusion queue: which patch is the smallest, with lazy invalidation.
//!
//! Entries are `(area, patch id, version)` packed into one `u128` whose integer order is the
//! order the greedy needs: area by `f64::total_cmp`, then id, then version. A patch whose
//! version has moved on is stale and skipped by the caller, so entries are never updated in
//! place.
//!
//! Two structures share the work, because the starting patches (one per triangle) outnumber
//! everything pushed later: the seeds are sorted once and consumed front to back, and only
//! fused patches go through a heap. The heap is 4-ary rather than binary: the four children of
//! a node are 64 contiguous bytes, so a pop touches half as many cache lines on the
//! million-entry heaps of large meshes (measured against std `BinaryHeap` holding every seed:
//! docs/benchmarks/tiling.md).
//!
//! Cost: O(n log n) to sort the seeds; O(log m) per push and pop for m queued entries.

use rayon::prelude::*;

/// Heap arity; four 16-byte entries fill a 64-byte cache line.
const ARITY: usize = 4;

/// A packed queue entry; smaller pops first.
pub(crate) type Entry = u128;

/// Packs `(area, id, version)` so that integer order is (total order of area, id, version).
pub(crate) fn entry(area: f64, id: u32, version: u32) -> Entry {
    // The standard map from `total_cmp` order to unsigned order: flip all bits of negatives,
    // only the sign bit of the rest.
    let bits = area.to_bits();
    let ordered = if bits >> 63 == 1 {
        !bits
    } else {
        bits | 1 << 63
    };
    (u128::from(ordered) << 64) | (u128::from(id) << 32) | u128::from(version)
}

/// The patch id and version of an entry.
pub(crate) fn id_and_version(e: Entry) -> (u32, u32) {
    ((e >> 32) as u32, e as u32)
}

/// Seeds sorted once, plus a 4-ary min-heap of later entries.
pub(crate) struct FusionQueue {
    seeds: Vec<Entry>,
    next_seed: usize,
    heap: Vec<Entry>,
}

impl FusionQueue {
    /// A queue holding `seeds` (in any order).
    pub fn new(mut seeds: Vec<Entry>) -> FusionQueue {
        // Entries are distinct (ids are), so the unstable sort is deterministic.
        seeds.par_sort_unstable();
        FusionQueue {
            seeds,
            next_seed: 0,
            heap: Vec::new(),
        }
    }

    /// Adds an entry.
    pub fn push(&mut self, e: Entry) {
        let mut i = self.heap.len();
        self.heap.push(e);
        while i > 0 {
            let parent = (i - 1) / ARITY;
            if self.heap[parent] <= e {
                break;
            }
            self.heap[i] = self.heap[parent];
            i = parent;
        }
        self.heap[i] = e;
    }

    /// Removes and returns the smallest entry.
    pub fn pop(&mut self) -> Option<Entry> {
        let seed = self.seeds.get(self.next_seed).copied();
        match (seed, self.heap.first().copied()) {
            (Some(s), Some(h)) if h < s => self.pop_heap(),
            (Some(s), _) => {
                self.next_seed += 1;
                Some(s)
            }
            (None, _) => self.pop_heap(),
        }
    }

    fn pop_heap(&mut self) -> Option<Entry> {
        let last = self.heap.pop()?;
        let Some(&top) = self.heap.first() else {
            return Some(last);
        };
        // Move the hole at the root down to where `last` belongs.
        let n = self.heap.len();
        let mut i = 0;
        loop {
            let first_child = ARITY * i + 1;
            if first_child >= n {
                break;
            }
            let end = (first_child + ARITY).min(n);
            let mut c = first_child;
            for k in first_child + 1..end {
                if self.heap[k] < self.heap[c] {
                    c = k;
                }
            }
            if self.heap[c] >= last {
                break;
            }
            self.heap[i] = self.heap[c];
            i = c;
        }
        self.heap[i] = last;
        Some(top)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_order_by_area_then_id_then_version() {
        assert!(entry(0.0, 9, 9) < entry(1e-300, 0, 0));
        assert!(entry(1.0, 1, 5) < entry(1.0, 2, 0));
        assert!(entry(1.0, 1, 5) < entry(1.0, 1, 6));
        assert!(entry(2.0, 0, 0) < entry(f64::INFINITY, 0, 0));
        assert_eq!(id_and_version(entry(3.5, 7, 11)), (7, 11));
    }

    #[test]
    fn pops_in_sorted_order_across_seeds_and_heap() {
        let mut rng = crate::test_kit::rng::Rng::new(3);
        let seeds: Vec<Entry> = (0..500)
            .map(|i| entry(f64::from(rng.signed()).abs(), i, 0))
            .collect();
        let mut q = FusionQueue::new(seeds.clone());
        let mut all = seeds;
        let mut out = Vec::new();
        for i in 0..2000u32 {
            if i % 3 == 0 {
                if let Some(e) = q.pop() {
                    out.push(e);
                }
            } else {
                let e = entry(f64::from(rng.signed()).abs() * 2.0, 1000 + i, 1);
                all.push(e);
                q.push(e);
            }
        }
        while let Some(e) = q.pop() {
            out.push(e);
        }
        all.sort_unstable();
        let mut sorted_out = out.clone();
        sorted_out.sort_unstable();
        assert_eq!(sorted_out, all);
        // Each pop is the minimum of what was queued at the time, so pops never go below the
        // minimum still queued; once pushes stop, the tail is sorted.
        let tail = &out[out.len() - 1000..];
        assert!(tail.windows(2).all(|w| w[0] < w[1]));
    }
}
