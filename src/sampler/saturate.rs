//! Saturated rows: the stored rows with every bit set that no query's answer depends on.
//!
//! A query answers the OR of the rows of its leaf face's three corners (spec/FORMAT.md,
//! § Query), never one row alone. So a view's row may hold any patch that every leaf face
//! around the view already answers through its corners: setting that bit changes no face's
//! answer. [`saturate`] sets all such bits. The result is the largest matrix with the same
//! answers; it depends on the answers alone (a bit a view held is one its faces answer).
//!
//! Why: the folds decide which corner of a face holds a patch (the cover fold one corner per
//! face, chosen over the whole sphere; the split fold one for the probe's guesses), which
//! leaves each patch's views a scattered subset of the region whose faces answer it. The
//! VISB coders predict a view's bits from its two parents' (spec/FORMAT.md, encodings 1 and
//! 2), and a scattered subset predicts poorly. Saturated, a patch's views are all those
//! whose every surrounding face answers it: a region, as its answering faces are. Measured
//! on the model zoo (BENCHMARKS.md, "Saturated rows"): every mode's file is smaller, the
//! default's by 4–45 %, with the same answers to every query.
//!
//! Only a reader that takes one view's row for what that view saw sees a difference; the
//! spec defines answers, not rows, and `bake --sampled-rows` keeps the rows as sampled.
//!
//! Cost: one pass per 64 patches over the leaf faces (three ORs each) and the views (four or
//! six ANDs each), with one word per leaf face of scratch; the bunny's whole default bake
//! takes the same time with it as without (1.00×, BENCHMARKS.md).

use super::VisibilityMatrix;
use super::supersample::faces_around;
use crate::sphere::{ViewIndex, view_count};

/// `rows` (every view of `level`, in index order) with every patch added to each view's row
/// that all the leaf faces of `level` having the view as a corner already answer (the OR of
/// their corners' rows). Every leaf face answers exactly what it answered before.
///
/// Deterministic; idempotent. Panics (caller contract) if `rows` does not hold exactly the
/// views of `level`.
pub fn saturate(mut rows: VisibilityMatrix, level: u32) -> VisibilityMatrix {
    assert_eq!(rows.views(), view_count(level), "rows of another level");
    let (faces, around) = faces_around(level);
    let mut answer = vec![0u64; faces.len()];
    // One word column at a time: the faces' answers first, all from the rows as given, so
    // that what one view gains never feeds another's (it would change nothing anyway: a
    // gained bit is one every face around the view already answers).
    for w in 0..rows.words_per_row() {
        for (a, face) in answer.iter_mut().zip(&faces) {
            *a = rows.or_word(face, w);
        }
        for (v, faces) in around.iter().enumerate() {
            let all = faces.iter().fold(!0u64, |a, &f| a & answer[f as usize]);
            rows.row_mut(v as ViewIndex)[w] |= all;
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::{Face, leaf_faces};
    use proptest::prelude::*;

    fn answer(rows: &VisibilityMatrix, face: &Face) -> Vec<u64> {
        rows.or_rows(&face.views)
    }

    /// Rows whose bits are set with probability `density / 256`, from `seed`.
    fn matrix(level: u32, patches: u32, density: u8, seed: u64) -> VisibilityMatrix {
        let mut m = VisibilityMatrix::new(view_count(level), patches);
        let mut rng = crate::test_kit::rng::Rng::new(seed);
        for v in 0..m.views() {
            for p in 0..patches {
                if (rng.next_u64() & 0xff) < u64::from(density) {
                    m.set(v, p);
                }
            }
        }
        m
    }

    proptest! {
        /// Every leaf face answers what it answered; every view keeps its bits; a bit is
        /// added exactly where every face around the view answers it; a second pass adds
        /// nothing.
        #[test]
        fn saturating_keeps_every_answer_and_adds_every_free_bit(
            level in 0u32..=3, patches in 1u32..=140, density in 0u8..=255, seed in any::<u64>(),
        ) {
            let rows = matrix(level, patches, density, seed);
            let full = saturate(rows.clone(), level);
            let faces = leaf_faces(level);
            for face in &faces {
                prop_assert_eq!(answer(&full, face), answer(&rows, face));
            }
            for v in 0..rows.views() {
                let around: Vec<&Face> = faces.iter().filter(|f| f.views.contains(&v)).collect();
                prop_assert!(around.len() == 4 || around.len() == 6);
                for p in 0..patches {
                    let free = around.iter().all(|f| {
                        answer(&rows, f)[p as usize / 64] >> (p % 64) & 1 == 1
                    });
                    prop_assert_eq!(full.get(v, p), rows.get(v, p) || free, "view {} patch {}", v, p);
                }
            }
            prop_assert_eq!(saturate(full.clone(), level), full);
        }
    }

    #[test]
    fn a_patch_held_by_every_edge_midpoint_fills_the_sphere() {
        // Level 1: every leaf face has an edge midpoint of level 0 as a corner, so a patch
        // held by the 12 midpoints is answered everywhere and the 6 level-0 views get it too;
        // one held by the level-0 views alone is not (the middle face of each octant has
        // none of them as a corner), so nothing is added.
        let mut rows = VisibilityMatrix::new(view_count(1), 3);
        for v in view_count(0)..view_count(1) {
            rows.set(v, 1);
        }
        for v in 0..view_count(0) {
            rows.set(v, 2);
        }
        let full = saturate(rows.clone(), 1);
        for v in 0..view_count(1) {
            assert!(full.get(v, 1) && !full.get(v, 0), "view {v}");
            assert_eq!(full.get(v, 2), rows.get(v, 2), "view {v}");
        }
    }

    #[test]
    fn one_view_s_patch_stays_its_own() {
        // A patch in one view's row alone: the faces around its neighbours do not all answer
        // it, so nothing is added.
        let mut rows = VisibilityMatrix::new(view_count(2), 70);
        rows.set(20, 66);
        assert_eq!(saturate(rows.clone(), 2), rows);
    }
}
