//! View supersampling: sample the sphere `K` levels finer than the file stores, then fold the
//! fine rows into the coarse ones, so that a query anywhere in a leaf face sees every patch
//! that any fine sample in that face saw.
//!
//! Why: a query at direction `d` answers the OR of the rows of the three corners of
//! `sphere::locate(d, L)` (Meruvia 2002, §3.3). A patch visible from the inside of a face but
//! from none of its corners is missed, whatever the rasterization (measured in BENCHMARKS.md,
//! "Quality (issue 6)": conservative rasterization alone does not remove these misses).
//! Sampling at level `L + K` and folding puts the fine views' findings into the level-`L`
//! corners, at the file size of level `L`.
//!
//! The fold: every coarse row starts as the fine row of the same view (level `L`'s views are a
//! prefix of level `L + K`'s); then every fine view `u` that is not a coarse view is located
//! at level `L` (`sphere::locate(direction(u), L)`) and its row is OR'd into the rows of that
//! face's three corners.
//!
//! **Coverage.** Let `d` be any direction and `F = locate(d, L)`; the query answers the OR of
//! `F`'s corner rows. Every fine view `u` lying in the closed face `F` is covered:
//! - `u` is a corner of `F`: its own row is one of the OR'd rows.
//! - `u` is strictly inside `F`: it is located in `F` and OR'd into all three corners.
//! - `u` lies on an edge of `F` (strictly between its endpoints; coarse vertices are the only
//!   fine views at corners): it is located in `F` or in the face across that edge, and
//!   either way OR'd into that face's corners, which include both endpoints of the edge —
//!   corners of `F`.
//!
//! So the answer for `d` contains the row of every fine sample of `F`: the fold is exactly as
//! conservative as the fine level, in view space, while the file keeps level `L`'s rows. The
//! coarse views' own rows are not spread to their neighbours: every face having such a view as
//! a corner ORs its row anyway, so spreading would only cost culling. With `K = 0` there is
//! nothing to fold and the rows are returned unchanged.
//!
//! Cost: sampling is `view_count(L + K) / view_count(L)` ≈ `4^K` times the plain bake; the fold
//! is one point location (`L` levels of 3 sign tests) and 3 row ORs per fine view.

use super::VisibilityMatrix;
use crate::sphere::{direction, locate, view_count};

/// The finest extra level [`supersample_rows`] is meant for: `K = 2` already samples 16× the
/// views of the stored level; more than that is cheaper as a finer stored level.
pub const MAX_VIEW_SUPERSAMPLE: u32 = 2;

/// Folds the rows of a level-`fine_level` sampling (`fine`, one row per view of that level)
/// into rows for the views of `level`, so that the corners of every level-`level` face
/// together see every patch that a fine view lying in that face saw (see the module
/// documentation for the argument). `fine_level == level` returns the rows unchanged.
///
/// Panics (caller contract) if `fine_level < level` or `fine` does not have one row per view
/// of `fine_level`.
pub fn supersample_rows(fine: &VisibilityMatrix, fine_level: u32, level: u32) -> VisibilityMatrix {
    assert!(
        fine_level >= level,
        "fine level {fine_level} is coarser than the stored level {level}"
    );
    assert_eq!(
        fine.views(),
        view_count(fine_level),
        "the fine matrix must have one row per view of level {fine_level}"
    );
    let coarse_views = view_count(level);
    let mut coarse = VisibilityMatrix::new(coarse_views, fine.patches());
    for v in 0..coarse_views {
        coarse.row_mut(v).copy_from_slice(fine.row(v));
    }
    for u in coarse_views..fine.views() {
        let face = locate(direction(u), level);
        let row = fine.row(u);
        for corner in face.views {
            for (dst, &src) in coarse.row_mut(corner).iter_mut().zip(row) {
                *dst |= src;
            }
        }
    }
    coarse
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::{Face, children, root_faces};
    use proptest::prelude::*;

    /// A fine matrix whose rows are pseudo-random (xorshift from `seed`), ~1/8 of bits set.
    fn random_matrix(views: u32, patches: u32, seed: u64) -> VisibilityMatrix {
        let mut m = VisibilityMatrix::new(views, patches);
        let mut s = seed | 1;
        for v in 0..views {
            for p in 0..patches {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                if s.is_multiple_of(8) {
                    m.set(v, p);
                }
            }
        }
        m
    }

    fn leaves(level: u32) -> Vec<Face> {
        let mut faces = root_faces().to_vec();
        for _ in 0..level {
            faces = faces.iter().flat_map(children).collect();
        }
        faces
    }

    fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }

    /// Whether unit direction `d` lies in the closed spherical triangle `face`, allowing
    /// `slack` for rounding (fine views on an edge sit on it only up to f32 rounding).
    fn in_closed_face(face: &Face, d: [f32; 3], slack: f32) -> bool {
        let [a, b, c] = face.directions;
        dot(d, cross(a, b)) >= -slack
            && dot(d, cross(b, c)) >= -slack
            && dot(d, cross(c, a)) >= -slack
    }

    fn row_contains(big: &[u64], small: &[u64]) -> bool {
        big.iter().zip(small).all(|(&b, &s)| s & !b == 0)
    }

    #[test]
    fn zero_extra_levels_is_identity() {
        for level in 0..=3 {
            let fine = random_matrix(view_count(level), 130, 7 + u64::from(level));
            assert_eq!(supersample_rows(&fine, level, level), fine);
        }
    }

    #[test]
    fn one_fine_view_marks_exactly_its_face_corners() {
        let (level, fine_level, patch) = (2, 3, 77);
        for u in 0..view_count(fine_level) {
            let mut fine = VisibilityMatrix::new(view_count(fine_level), 100);
            fine.set(u, patch);
            let coarse = supersample_rows(&fine, fine_level, level);
            let expected: Vec<u32> = if u < view_count(level) {
                // A coarse view keeps its own row and spreads it nowhere.
                vec![u]
            } else {
                locate(direction(u), level).views.to_vec()
            };
            for v in 0..view_count(level) {
                assert_eq!(coarse.get(v, patch), expected.contains(&v), "u {u} v {v}");
                // No other patch is ever set.
                let bits: u32 = coarse.row(v).iter().map(|w| w.count_ones()).sum();
                assert_eq!(bits, u32::from(coarse.get(v, patch)), "u {u} v {v}");
            }
        }
    }

    #[test]
    fn every_fine_view_in_a_closed_face_is_covered_by_its_corners() {
        // The coverage argument of the module documentation, checked exhaustively: for every
        // leaf face F at `level`, the OR of F's folded corner rows contains the row of every
        // fine view lying geometrically in the closed face (edges and corners included).
        for (level, fine_level) in [(0, 1), (0, 2), (1, 2), (2, 3), (2, 4), (3, 5)] {
            let fine = random_matrix(view_count(fine_level), 70, 99 + u64::from(fine_level));
            let coarse = supersample_rows(&fine, fine_level, level);
            for face in leaves(level) {
                let mut answer = vec![0u64; 2];
                for c in face.views {
                    for (a, &w) in answer.iter_mut().zip(coarse.row(c)) {
                        *a |= w;
                    }
                }
                let mut covered = 0;
                for u in 0..view_count(fine_level) {
                    if in_closed_face(&face, direction(u), 1e-5) {
                        covered += 1;
                        assert!(
                            row_contains(&answer, fine.row(u)),
                            "level {level}/{fine_level}: face {:?} misses fine view {u}",
                            face.views
                        );
                    }
                }
                // A face at `fine_level - level` levels up holds (2^k + 1)(2^k + 2)/2 fine
                // views: the check above really looked at all of them.
                let n = (1u32 << (fine_level - level)) + 1;
                assert_eq!(covered, n * (n + 1) / 2, "face {:?}", face.views);
            }
        }
    }

    proptest! {
        /// Random query directions: the folded corner rows of `locate(d, L)` contain the row
        /// of every fine view located in that face and of every fine view lying in it.
        #[test]
        fn random_directions_see_every_fine_sample_of_their_face(
            x in -1.0f32..1.0, y in -1.0f32..1.0, z in -1.0f32..1.0, extra in 1u32..=2,
        ) {
            prop_assume!(x * x + y * y + z * z > 1e-3);
            let level = 2;
            let fine_level = level + extra;
            let fine = random_matrix(view_count(fine_level), 90, 5);
            let coarse = supersample_rows(&fine, fine_level, level);
            let face = locate([x, y, z], level);
            let mut answer = vec![0u64; 2];
            for c in face.views {
                for (a, &w) in answer.iter_mut().zip(coarse.row(c)) {
                    *a |= w;
                }
            }
            for u in 0..view_count(fine_level) {
                let du = direction(u);
                if locate(du, level).views == face.views || in_closed_face(&face, du, 1e-5) {
                    prop_assert!(row_contains(&answer, fine.row(u)), "fine view {}", u);
                }
            }
        }
    }
}
