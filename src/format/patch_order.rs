//! Numbering patches by co-visibility, so that the VISB coder's neighbour contexts work.
//!
//! Encoding 1 codes bit `p` of a view with the bits of patch `p − 1` in the view and its
//! parents as context (spec "VISB — visibility", Context), so it gains when neighbouring ids
//! are seen from the same views. The tiling numbers patches along a Z-order curve, which
//! puts spatial neighbours together but also joins the two sides of thin parts and jumps
//! between curve cells. This orders them instead along a greedy nearest-neighbour tour of
//! their *signatures* (the column of the view × patch matrix: which views see the patch),
//! under Hamming distance: start at patch 0, repeatedly step to the unvisited patch whose
//! signature differs from the current one in the fewest views, ties to the lower id. On the
//! bunny (2000 patches, 1026 views) it shrinks the payload by ~13 % (spec, Rationale). Then
//! up to three rounds of 2-opt (reverse a segment wherever that shortens the tour) refine it,
//! within the same work budget.
//!
//! Cost: O(p² · v / 64) word operations for p patches and v views, parallel over the
//! candidates (deterministic: the minimum of (distance, id) does not depend on the split),
//! and p · v / 8 bytes of signatures. Above [`MAX_TOUR_WORK`] word operations the tour is
//! skipped and the tiling's numbering kept.

use rayon::prelude::*;

use super::ptch::RecordKey;
use crate::runtime::Patches;
use crate::tiling::{Patch, PatchId};
use crate::visibility::VisibilityMatrix;

/// Largest `p² · ceil(v / 64)` for which the tour is computed: 2^33 word operations, a few
/// seconds on two cores (e.g. 8,000 patches at 4,098 views, 20,000 at 1,026). Beyond it the
/// quadratic search would outgrow the rest of the bake.
pub const MAX_TOUR_WORK: u64 = 1 << 33;

/// The patches in Z-order of their bounding-sphere centres (Morton codes over the box of all
/// centres, ties to the lower id): the kind of spatial numbering a tiler gives, recomputed
/// from a file's patch table alone. `patchvis info --compare` measures generic compressors
/// on the matrix in this order too, because a file numbered by [`covisibility_order`] has
/// had its rows made easier for them as well. `order[i]` is the patch ranked `i`.
pub fn centre_order(centres: &[[f32; 3]]) -> Vec<PatchId> {
    let mut bounds = crate::tiling::Aabb {
        min: [f32::MAX; 3],
        max: [f32::MIN; 3],
    };
    for &c in centres {
        bounds.include(c);
    }
    let mut keyed: Vec<(u64, PatchId)> = centres
        .iter()
        .enumerate()
        .map(|(p, c)| {
            let code = crate::tiling::morton_code(c.map(f64::from), &bounds);
            (code, p as PatchId)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, p)| p).collect()
}

/// Puts back in tiling order, within the places `order` gave them, the patches that the
/// file cannot tell apart: those whose records a reader decodes bit for bit equal
/// (`patches` in the tiling's numbering, `order[i]` the tiling patch that gets file id `i`).
///
/// Why: a file stores no triangle ids, only each patch's count and bounds, so `patchvis
/// eval` finds a file's patches in the original mesh by tiling it again and matching
/// records. Small patches can share a quantised record (the airplane: 414 of its 1,000
/// patches share one with another), and the match takes each group in tiling order: this
/// makes that the file's order too, so evaluating against the original mesh is exact. The
/// groups only trade places among themselves, so the co-visibility tour keeps its shape.
pub fn keep_equal_records_in_order(patches: &[Patch], order: &mut [PatchId]) {
    let keys = super::ptch::writer_keys(patches);
    // (key, place): each group of equal keys, its places ascending.
    let mut places: Vec<(RecordKey, usize)> = order
        .iter()
        .enumerate()
        .map(|(i, &p)| (keys[p as usize], i))
        .collect();
    places.sort_unstable();
    let mut ids = Vec::new();
    for group in places.chunk_by(|a, b| a.0 == b.0) {
        if group.len() > 1 {
            ids.clear();
            ids.extend(group.iter().map(|&(_, i)| order[i]));
            ids.sort_unstable();
            for (&(_, i), &id) in group.iter().zip(&ids) {
                order[i] = id;
            }
        }
    }
}

/// A co-visibility numbering of the patches of `matrix`: `order[i]` is the patch that gets
/// id `i` (pass it to `Tiling::renumbered` and `VisibilityMatrix::with_patch_order`).
/// `None` when the tour would cost more than [`MAX_TOUR_WORK`]: keep the current numbering.
/// Deterministic: depends on the matrix alone.
pub fn covisibility_order(matrix: &VisibilityMatrix) -> Option<Vec<PatchId>> {
    let patches = matrix.patches() as usize;
    let views = matrix.views() as usize;
    let words = views.div_ceil(64).max(1);
    let work = (patches as u64)
        .saturating_mul(patches as u64)
        .saturating_mul(words as u64);
    if work > MAX_TOUR_WORK {
        return None;
    }
    // Signature of patch p: bit v of words[p·words ..] is "view v sees p".
    let mut signatures = vec![0u64; patches * words];
    for v in 0..views {
        for p in Patches::of_bits(matrix.row(v as u32)) {
            signatures[p as usize * words + v / 64] |= 1 << (v % 64);
        }
    }
    let signature = |p: u32| &signatures[p as usize * words..][..words];
    let mut order = Vec::with_capacity(patches);
    if patches == 0 {
        return Some(order);
    }
    // Unvisited patches in increasing id order (kept sorted: `remove` shifts, which costs
    // less than the distance scan it follows).
    let mut unvisited: Vec<PatchId> = (1..patches as PatchId).collect();
    let mut current: PatchId = 0;
    order.push(current);
    while !unvisited.is_empty() {
        let here = signature(current);
        let (_, _, at) = unvisited
            .par_iter()
            .enumerate()
            .map(|(at, &q)| {
                let distance: u32 = here
                    .iter()
                    .zip(signature(q))
                    .map(|(a, b)| (a ^ b).count_ones())
                    .sum();
                (distance, q, at)
            })
            .min()
            .expect("unvisited is not empty");
        current = unvisited.remove(at);
        order.push(current);
    }
    // 2-opt: reverse segments while that shortens the tour, as many rounds as the work
    // budget left over by the tour allows (each costs about 2·p²·words), at most
    // `TWO_OPT_ROUNDS`.
    let round_work = 2 * work;
    let rounds = ((MAX_TOUR_WORK - work) / round_work.max(1)).min(TWO_OPT_ROUNDS);
    let distance = |a: PatchId, b: PatchId| -> u32 {
        signature(a)
            .iter()
            .zip(signature(b))
            .map(|(x, y)| (x ^ y).count_ones())
            .sum()
    };
    for _ in 0..rounds {
        if !two_opt_round(&mut order, distance) {
            break;
        }
    }
    Some(order)
}

/// Most 2-opt rounds [`covisibility_order`] runs; on the bunny the third changes little.
const TWO_OPT_ROUNDS: u64 = 3;

/// One first-improvement 2-opt pass over the open tour `order`: for every `i < j`, reverse
/// `order[i + 1..=j]` when that makes the tour shorter. Returns whether anything changed.
/// Sequential and deterministic.
fn two_opt_round(order: &mut [PatchId], distance: impl Fn(PatchId, PatchId) -> u32) -> bool {
    let n = order.len();
    let mut improved = false;
    for i in 0..n.saturating_sub(2) {
        for j in i + 2..n {
            let d = |a: usize, b: usize| i64::from(distance(order[a], order[b]));
            let (before, after) = if j + 1 < n {
                (d(i, i + 1) + d(j, j + 1), d(i, j) + d(i + 1, j + 1))
            } else {
                (d(i, i + 1), d(i, j))
            };
            if after < before {
                order[i + 1..=j].reverse();
                improved = true;
            }
        }
    }
    improved
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn matrix(views: u32, patches: u32, bits: &[bool]) -> VisibilityMatrix {
        let mut m = VisibilityMatrix::new(views, patches);
        for v in 0..views {
            for p in 0..patches {
                if bits[(v * patches + p) as usize % bits.len().max(1)] {
                    m.set(v, p);
                }
            }
        }
        m
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The tour names every patch once, starts at 0, and renumbering by it keeps each
        /// view's set of patches (as old ids).
        #[test]
        fn the_tour_is_a_permutation_that_keeps_every_row(
            views in 1u32..80, patches in 1u32..150,
            bits in proptest::collection::vec(any::<bool>(), 1..500),
        ) {
            let m = matrix(views, patches, &bits);
            let order = covisibility_order(&m).unwrap();
            prop_assert_eq!(order[0], 0);
            let mut sorted = order.clone();
            sorted.sort_unstable();
            prop_assert_eq!(sorted, (0..patches).collect::<Vec<_>>());
            let renumbered = m.with_patch_order(&order);
            for v in 0..views {
                for (i, &old) in order.iter().enumerate() {
                    prop_assert_eq!(renumbered.get(v, i as u32), m.get(v, old));
                }
                // No stray bits past the last patch.
                let last = renumbered.row(v).last().copied().unwrap_or(0);
                if patches % 64 != 0 {
                    prop_assert_eq!(last >> (patches % 64), 0);
                }
            }
        }
    }

    fn patch(first: u32, center: [f32; 3]) -> Patch {
        Patch {
            first,
            count: 1,
            area: 1.0,
            center,
            radius: 1.0,
            cone_axis: [0.0, 0.0, 1.0],
            cone_cos: 0.5,
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Patches of equal records end up in tiling order within the places the order gave
        /// their group; every other patch keeps its place.
        #[test]
        fn equal_records_keep_their_tiling_order(
            // Few distinct centres, so that many patches share a record; any order of them.
            (centres, mut order) in proptest::collection::vec(0u8..5, 1..60).prop_flat_map(|c| {
                let ids: Vec<PatchId> = (0..c.len() as u32).collect();
                (Just(c), Just(ids).prop_shuffle())
            }),
        ) {
            let patches: Vec<Patch> = centres
                .iter()
                .enumerate()
                .map(|(i, &c)| patch(i as u32, [f32::from(c) * 10.0, 0.0, 0.0]))
                .collect();
            let before = order.clone();
            keep_equal_records_in_order(&patches, &mut order);
            let key = |p: PatchId| centres[p as usize];
            for (i, (&a, &b)) in before.iter().zip(&order).enumerate() {
                prop_assert_eq!(key(a), key(b), "place {} changed groups", i);
            }
            for i in 0..order.len() {
                for j in i + 1..order.len() {
                    if key(order[i]) == key(order[j]) {
                        prop_assert!(order[i] < order[j], "places {} and {}", i, j);
                    }
                }
            }
        }
    }

    #[test]
    fn the_tour_steps_to_the_nearest_signature() {
        // Patches 0 and 2 are seen from the same views, 1 and 3 from the others: the tour
        // must pair them (0, 2, then 1 or 3 — 1 by the lower id — then 3).
        let mut m = VisibilityMatrix::new(4, 4);
        for v in 0..4 {
            for p in 0..4 {
                if (v < 2) == (p % 2 == 0) {
                    m.set(v, p);
                }
            }
        }
        assert_eq!(covisibility_order(&m).unwrap(), vec![0, 2, 1, 3]);
    }

    #[test]
    fn too_much_work_keeps_the_numbering() {
        // 2^17 patches × 1 word: 2^34 > MAX_TOUR_WORK.
        let m = VisibilityMatrix::new(1, 1 << 17);
        assert!(covisibility_order(&m).is_none());
    }

    #[test]
    fn centre_order_walks_the_z_curve_with_ties_to_the_lower_id() {
        // Corners of a unit square in z = 0 (Z-order: (0,0), (1,0), (0,1), (1,1)), given
        // out of order, one of them twice.
        let centres = [
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
        ];
        assert_eq!(centre_order(&centres), vec![3, 2, 4, 1, 0]);
        assert!(centre_order(&[]).is_empty());
    }
}
