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
//! The fold: every coarse row starts as the coarse view's own row (level `L`'s views are a
//! prefix of level `L + K`'s); then the row of every fine view `u` that is not a coarse view is
//! OR'd into the corners of the smallest level-`L` cell holding it ([`fold_targets`]):
//! - `u` lies on a level-`L` edge (strictly between its endpoints): the edge's **two
//!   endpoints**. At `K = 1` every fine view is such an edge midpoint.
//! - otherwise `u` lies strictly inside a level-`L` face: that face's **three corners**
//!   (`sphere::locate(direction(u), L)`).
//!
//! With centroid finer views (`bake --finer-views centroids`, `finer.rs`), each finer view
//! lies strictly inside one level-`L` face and goes to its three corners: the coverage below
//! holds as for a face-interior vertex. The `*_views` folds take the pass's layout
//! ([`PassViews`]); the others fold sphere vertices.
//!
//! Both are decided on the integer lattice of `sphere::numbering` (a level-`L + K` point lies
//! on a level-`L` edge exactly when one of its coordinates is a multiple of `2^K`), not with
//! floating point.
//!
//! **Coverage.** Let `d` be any direction and `F = locate(d, L)`; the query answers the OR of
//! `F`'s corner rows. Every fine view `u` lying in the closed face `F` is covered:
//! - `u` is a corner of `F`: its own row is one of the OR'd rows.
//! - `u` lies on an edge of `F`: it is OR'd into that edge's endpoints, both corners of `F`.
//! - `u` is strictly inside `F`: it is OR'd into all three corners of `F`.
//!
//! So the answer for `d` contains the row of every fine sample of `F`: the fold is exactly as
//! conservative as the fine level, in view space, while the file keeps level `L`'s rows. The
//! rows a fine view lands in are exactly the corners shared by every face that holds it (both
//! faces of an edge share only its endpoints): never a corner of a face that does not hold it,
//! which would cost culling for no guarantee (an earlier fold sent edge views to the three
//! corners of one adjacent face: 1.9 points less culling on the bunny, BENCHMARKS.md).
//! Coverage alone would need only one of those shared corners; using all of them keeps the
//! fold free of an arbitrary choice and symmetric around the fine view. The coarse views' own
//! rows are not spread to their neighbours: every face having such a view as a corner ORs its
//! row anyway. With `K = 0` there is nothing to fold and the rows are returned unchanged.
//!
//! With the probe pass of `bake --conservative` a fine view's row is what it showed plus
//! what the probe guessed the cameras around it may see. [`split_fold`] folds the two apart:
//! what it showed as above, and each guessed patch no target holds yet into one target only
//! (one suffices for the coverage above), the one whose faces least often answer it already.
//!
//! The fine rows may be sampled with a pixel threshold (`bake --fold-min-pixels T`: the fine
//! views report only patches covering at least `T` pixels) while the coarse rows keep every
//! pixel: [`fold_into`] takes the coarse rows and the fine rows separately. The coverage above
//! then holds for the patches a fine sample sees with at least `T` pixels.
//!
//! Cost: sampling is `view_count(L + K) / view_count(L)` ≈ `4^K` times the plain bake (plus
//! one plain pass over level `L` with a threshold); the fold is one lattice look-up (plus one
//! point location for face-interior views) and 2 or 3 row ORs per fine view.

use super::VisibilityMatrix;
use super::finer::{FinerViews, PassViews};
use crate::sphere::{
    LatticePoint, ViewIndex, direction, lattice_point, leaf_faces, locate, view_count, view_index,
};

/// The finest extra level [`supersample_rows`] is meant for: `K = 2` already samples 16× the
/// views of the stored level; more than that is cheaper as a finer stored level.
pub const MAX_VIEW_SUPERSAMPLE: u32 = 2;

/// The coarse views (of `level`) whose rows receive fine view `u`'s row in the fold: the two
/// endpoints of the level-`level` edge `u` lies on, or else the three corners of the
/// level-`level` face `u` lies in (see the module documentation); a view of `level` itself
/// receives only its own row. `u` must be a view of some level up to `sphere::MAX_LEVEL`
/// (caller contract).
pub fn fold_targets(u: ViewIndex, level: u32) -> FoldTargets {
    if u < view_count(level) {
        return FoldTargets::Vertex(u);
    }
    let p = lattice_point(u).expect("fold_targets: view beyond the finest sphere level");
    // `p` is new at its own level `p.level > level`; on the level-`level` lattice scale it is
    // `coords / step` with `step = 2^(p.level - level)`.
    let step = 1i32 << (p.level - level);
    let on_line = p.coords.iter().position(|c| c % step == 0);
    let Some(t) = on_line else {
        return FoldTargets::Face(locate(direction(u), level).views);
    };
    // |c_t| is a multiple of `step`, and so is |c_u| + |c_w| (the coordinates' absolute values
    // sum to 2^p.level); neither of c_u, c_w is (else all three would be and `u` would be a
    // coarse vertex), so both are nonzero. The edge's endpoints round |c_u| down and up to
    // multiples of `step` along the line |c_t| = const, keeping the signs.
    let (iu, iw) = ((t + 1) % 3, (t + 2) % 3);
    let (cu, cw) = (p.coords[iu], p.coords[iw]);
    let r = cu.abs() % step;
    let endpoint = |du: i32| {
        let mut coords = p.coords;
        coords[iu] = cu.signum() * (cu.abs() + du);
        coords[iw] = cw.signum() * (cw.abs() - du);
        view_index(LatticePoint {
            level,
            coords: coords.map(|c| c / step),
        })
    };
    let (a, b) = (endpoint(-r), endpoint(step - r));
    FoldTargets::Edge([a.min(b), a.max(b)])
}

/// Where a fine view's row goes in the fold: see [`fold_targets`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FoldTargets {
    /// The view is a coarse view: its own row.
    Vertex(ViewIndex),
    /// The view lies on a coarse edge: its two endpoints (smaller index first).
    Edge([ViewIndex; 2]),
    /// The view lies inside a coarse face: its three corners (in `locate`'s order).
    Face([ViewIndex; 3]),
}

impl FoldTargets {
    /// The coarse views, as a slice.
    pub fn views(&self) -> &[ViewIndex] {
        match self {
            FoldTargets::Vertex(v) => core::slice::from_ref(v),
            FoldTargets::Edge(e) => e,
            FoldTargets::Face(f) => f,
        }
    }
}

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
    let coarse_views = view_count(level);
    let mut coarse = VisibilityMatrix::new(coarse_views, fine.patches());
    for v in 0..coarse_views.min(fine.views()) {
        coarse.row_mut(v).copy_from_slice(fine.row(v));
    }
    fold_into(coarse, fine, fine_level, level)
}

/// Which coarse views receive a fine view's row in the fold.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FoldCorners {
    /// All of its [`fold_targets`]: the corners shared by every face holding it.
    #[default]
    All,
    /// Only the first of them (the smaller endpoint of an edge, `locate`'s first corner of a
    /// face): the coverage argument needs just one shared corner, and each one left out is a
    /// row that stays smaller (more culling, fewer patches for queries near the view from
    /// faces that do not hold it).
    One,
    /// For a pass with the probe (`bake --conservative`), whose finer views also report what
    /// they showed before the probe added anything ([`split_fold`]): what a finer view showed
    /// goes to all of its targets, as with [`FoldCorners::All`]; each patch only the probe
    /// added, and that none of the targets holds yet, goes to the one target whose faces gain
    /// the fewest new answers.
    Split,
    /// Each patch a finer view shows, and no face holding it answers yet, goes to one stored
    /// view per face, chosen across the whole sphere so that the fewest faces that do not
    /// need it answer it ([`cover_fold`]).
    Cover,
}

/// [`supersample_rows`] with the coarse views' rows given separately: returns `coarse` with
/// the row of every fine view that is not a coarse view OR'd into its [`fold_targets`]. The
/// coarse rows of `fine` are not used, so the fine pass may be sampled with a pixel threshold
/// while `coarse` keeps every pixel.
///
/// Panics (caller contract) if `fine_level < level`, `fine` does not have one row per view of
/// `fine_level`, `coarse` not one per view of `level`, or their patch counts differ.
pub fn fold_into(
    coarse: VisibilityMatrix,
    fine: &VisibilityMatrix,
    fine_level: u32,
    level: u32,
) -> VisibilityMatrix {
    fold_into_with(coarse, fine, fine_level, level, FoldCorners::All)
}

/// [`fold_into`] sending each fine view's row to the coarse views `corners` picks
/// ([`FoldCorners::Split`] needs the rows before the probe too: [`split_fold`]; here it folds
/// as [`FoldCorners::All`]).
///
/// Panics under the same caller contracts as [`fold_into`].
pub fn fold_into_with(
    coarse: VisibilityMatrix,
    fine: &VisibilityMatrix,
    fine_level: u32,
    level: u32,
    corners: FoldCorners,
) -> VisibilityMatrix {
    let views = PassViews::new(level, fine_level, FinerViews::Midpoints);
    fold_views(coarse, fine, &views, corners)
}

/// [`fold_into_with`] of a pass whose finer views are `views` (`fine` has one row per slot of
/// the pass, `coarse` one per view of the stored level).
///
/// Panics under the same caller contracts as [`fold_into`].
pub fn fold_views(
    mut coarse: VisibilityMatrix,
    fine: &VisibilityMatrix,
    views: &PassViews,
    corners: FoldCorners,
) -> VisibilityMatrix {
    check_shapes(&coarse, fine, views);
    if corners == FoldCorners::Cover {
        return cover_fold_views(coarse, fine, views);
    }
    for u in views.finer_range() {
        let row = fine.row(u);
        let targets = views.targets(u);
        let chosen = match corners {
            FoldCorners::All | FoldCorners::Split => targets.views(),
            FoldCorners::One => &targets.views()[..1],
            FoldCorners::Cover => unreachable!("the cover fold returned above"),
        };
        for &corner in chosen {
            for (dst, &src) in coarse.row_mut(corner).iter_mut().zip(row) {
                *dst |= src;
            }
        }
    }
    coarse
}

/// Checks the fold's caller contracts: one row of `fine` per slot of `views`, one row of
/// `coarse` per stored view, the same patches.
fn check_shapes(coarse: &VisibilityMatrix, fine: &VisibilityMatrix, views: &PassViews) {
    assert_eq!(
        fine.views(),
        views.slots(),
        "the fine matrix must have one row per view of level {}",
        views.fine_level()
    );
    assert_eq!(
        coarse.views(),
        view_count(views.level()),
        "the coarse matrix must have one row per view of level {}",
        views.level()
    );
    assert_eq!(coarse.patches(), fine.patches(), "patch counts differ");
}

/// The split fold ([`FoldCorners::Split`]) of the rows of a pass with the probe: `coarse` the
/// stored views' own rows, `full` every view's row of level `fine_level` (probe included),
/// `seen` the same views' rows before the probe. First `seen` is folded as
/// [`FoldCorners::All`] folds; then every patch of a finer view's `full` row that none of its
/// [`fold_targets`] holds is added to the target whose closed faces at `level` least often
/// answer it already (ties: the smaller view index).
///
/// Coverage is [`FoldCorners::One`]'s for the probe's additions and [`FoldCorners::All`]'s
/// for what the views showed: a face's corners together hold every finer view's `full` row
/// in the face, and what a finer view showed is in every corner shared by the faces holding
/// it. Why: the probe's additions are guesses about the cameras around a view, each one
/// spread to every target costs the culling of every face around those targets (about 3
/// points on the zoo, BENCHMARKS.md); what the views showed is spread to all of them, which
/// keeps the redundancy that covers the probe's own misses (the exposed engine loses 1–2
/// points of identical views without it).
///
/// Deterministic: the views are taken in index order. Panics under [`fold_into`]'s caller
/// contracts, or if `full` and `seen` differ in shape.
pub fn split_fold(
    coarse: VisibilityMatrix,
    full: &VisibilityMatrix,
    seen: &VisibilityMatrix,
    fine_level: u32,
    level: u32,
) -> VisibilityMatrix {
    let views = PassViews::new(level, fine_level, FinerViews::Midpoints);
    split_fold_views(coarse, full, seen, &views)
}

/// [`split_fold`] of a pass whose finer views are `views`.
///
/// Panics under [`split_fold`]'s caller contracts.
pub fn split_fold_views(
    coarse: VisibilityMatrix,
    full: &VisibilityMatrix,
    seen: &VisibilityMatrix,
    views: &PassViews,
) -> VisibilityMatrix {
    assert_eq!(
        (full.views(), full.patches()),
        (seen.views(), seen.patches()),
        "the full and the seen rows differ in shape"
    );
    let mut coarse = fold_views(coarse, seen, views, FoldCorners::All);
    // The closed faces around every stored view.
    let (faces, around) = faces_around(views.level());
    for u in views.finer_range() {
        let targets = views.targets(u);
        let targets = targets.views();
        for (w, &word) in full.row(u).iter().enumerate() {
            let mut missing = word;
            for &t in targets {
                missing &= !coarse.row(t)[w];
            }
            while missing != 0 {
                let bit = 1u64 << missing.trailing_zeros();
                missing &= !bit;
                let answers = |f: u32| {
                    faces[f as usize]
                        .iter()
                        .any(|&c| coarse.row(c)[w] & bit != 0)
                };
                let cost =
                    |t: ViewIndex| around[t as usize].iter().filter(|&&f| !answers(f)).count();
                let best = targets
                    .iter()
                    .copied()
                    .min_by_key(|&t| (cost(t), t))
                    .expect("a fold has a target");
                coarse.row_mut(best)[w] |= bit;
            }
        }
    }
    coarse
}

/// The leaf faces of `level` by their corner views, and for every stored view the indices of
/// the faces it is a corner of.
pub(super) fn faces_around(level: u32) -> (Vec<[ViewIndex; 3]>, Vec<Vec<u32>>) {
    let faces: Vec<[ViewIndex; 3]> = leaf_faces(level).iter().map(|f| f.views).collect();
    let mut around = vec![Vec::new(); view_count(level) as usize];
    for (i, face) in faces.iter().enumerate() {
        for &corner in face {
            around[corner as usize].push(i as u32);
        }
    }
    (faces, around)
}

/// The cover fold ([`FoldCorners::Cover`]): `coarse` (the stored views' own rows) with, for
/// every patch, the fewest-waste set of stored views added that makes every closed face at
/// `level` answer every patch a finer view (of `fine`, level `fine_level`) lying in it shows.
///
/// A face *needs* a patch when a finer view in the closed face shows it and none of its
/// corners holds it. Patch by patch, each face still needing it (in index order) gets it
/// added to the one corner that serves the most faces needing it per face made to answer it
/// for nothing (`needing / (wasted + ½)`, ties: the smaller view index); the faces around
/// that corner then answer it. So coverage is [`FoldCorners::One`]'s — a face's corners
/// together hold the row of every finer view in the face — while the corners are chosen for
/// all the faces at once: on the zoo's plain rows this keeps within 0.7 points the culling of
/// per-face rows, where folding into every shared corner loses 3–7 points (BENCHMARKS.md,
/// "The probe with the cover fold").
///
/// Deterministic: patches, faces and candidate corners are taken in index order. Holds one
/// row per leaf face while folding (about twice the stored rows). Panics under
/// [`fold_into`]'s caller contracts.
pub fn cover_fold(
    coarse: VisibilityMatrix,
    fine: &VisibilityMatrix,
    fine_level: u32,
    level: u32,
) -> VisibilityMatrix {
    let views = PassViews::new(level, fine_level, FinerViews::Midpoints);
    check_shapes(&coarse, fine, &views);
    cover_fold_views(coarse, fine, &views)
}

/// [`cover_fold`] of a pass whose finer views are `views`.
fn cover_fold_views(
    mut coarse: VisibilityMatrix,
    fine: &VisibilityMatrix,
    views: &PassViews,
) -> VisibilityMatrix {
    let (faces, around) = faces_around(views.level());
    let words = coarse.words_per_row();
    // What each face needs: the OR of its finer views' rows.
    let mut need = vec![0u64; faces.len() * words];
    for u in views.finer_range() {
        let targets = views.targets(u);
        let targets = targets.views();
        let row = fine.row(u);
        for &f in &around[targets[0] as usize] {
            if targets.iter().all(|t| faces[f as usize].contains(t)) {
                let dst = &mut need[f as usize * words..][..words];
                for (d, &s) in dst.iter_mut().zip(row) {
                    *d |= s;
                }
            }
        }
    }
    let mut pending: [Vec<u32>; 64] = core::array::from_fn(|_| Vec::new());
    for w in 0..words {
        let answered = |coarse: &VisibilityMatrix, f: u32| coarse.or_word(&faces[f as usize], w);
        for list in &mut pending {
            list.clear();
        }
        for f in 0..faces.len() as u32 {
            let mut missing = need[f as usize * words + w] & !answered(&coarse, f);
            while missing != 0 {
                let b = missing.trailing_zeros();
                missing &= missing - 1;
                pending[b as usize].push(f);
            }
        }
        for (b, list) in pending.iter().enumerate() {
            let bit = 1u64 << b;
            for &f in list {
                if answered(&coarse, f) & bit != 0 {
                    continue;
                }
                // (needing, wasted) of adding the patch to corner `c`.
                let score = |coarse: &VisibilityMatrix, c: ViewIndex| {
                    let (mut needing, mut wasted) = (0u64, 0u64);
                    for &g in &around[c as usize] {
                        if answered(coarse, g) & bit == 0 {
                            if need[g as usize * words + w] & bit != 0 {
                                needing += 1;
                            } else {
                                wasted += 1;
                            }
                        }
                    }
                    (needing, wasted)
                };
                let mut corners = faces[f as usize];
                corners.sort_unstable();
                let mut best = corners[0];
                let (mut best_needing, mut best_wasted) = score(&coarse, best);
                for &c in &corners[1..] {
                    let (needing, wasted) = score(&coarse, c);
                    // needing / (wasted + ½) larger, compared without division.
                    if needing * (2 * best_wasted + 1) > best_needing * (2 * wasted + 1) {
                        (best, best_needing, best_wasted) = (c, needing, wasted);
                    }
                }
                coarse.row_mut(best)[w] |= bit;
            }
        }
    }
    coarse
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::Face;
    use crate::test_kit::rng::Rng;
    use proptest::prelude::*;

    /// A fine matrix whose rows are pseudo-random (seeded by `seed`), ~1/8 of bits set.
    fn random_matrix(views: u32, patches: u32, seed: u64) -> VisibilityMatrix {
        let mut m = VisibilityMatrix::new(views, patches);
        let mut rng = Rng::new(seed);
        for v in 0..views {
            for p in 0..patches {
                if rng.next_u64().is_multiple_of(8) {
                    m.set(v, p);
                }
            }
        }
        m
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
    fn one_fine_view_marks_exactly_its_fold_targets() {
        let (level, fine_level, patch) = (2, 4, 77);
        for u in 0..view_count(fine_level) {
            let mut fine = VisibilityMatrix::new(view_count(fine_level), 100);
            fine.set(u, patch);
            let coarse = supersample_rows(&fine, fine_level, level);
            let expected = fold_targets(u, level);
            for v in 0..view_count(level) {
                assert_eq!(
                    coarse.get(v, patch),
                    expected.views().contains(&v),
                    "u {u} v {v}"
                );
                // No other patch is ever set.
                let bits: u32 = coarse.row(v).iter().map(|w| w.count_ones()).sum();
                assert_eq!(bits, u32::from(coarse.get(v, patch)), "u {u} v {v}");
            }
        }
    }

    #[test]
    fn fold_targets_are_the_corners_shared_by_every_face_holding_the_view() {
        // Minimality and soundness together, checked geometrically: a fine view goes to
        // exactly the coarse views that are corners of every closed leaf face containing it
        // (1 face inside a face, the 2 faces of an edge: their 2 shared endpoints).
        for (level, fine_level) in [(0, 1), (0, 2), (1, 2), (1, 3), (2, 3), (2, 4), (3, 5)] {
            let faces = leaf_faces(level);
            let (mut on_edges, mut inside) = (0, 0);
            for u in view_count(level)..view_count(fine_level) {
                let holding: Vec<&Face> = faces
                    .iter()
                    .filter(|f| in_closed_face(f, direction(u), 1e-5))
                    .collect();
                let mut shared: Vec<u32> = holding[0]
                    .views
                    .iter()
                    .copied()
                    .filter(|c| holding.iter().all(|f| f.views.contains(c)))
                    .collect();
                shared.sort_unstable();
                let mut got = fold_targets(u, level).views().to_vec();
                got.sort_unstable();
                assert_eq!(got, shared, "level {level}/{fine_level}: view {u}");
                match holding.len() {
                    1 => inside += 1,
                    2 => on_edges += 1,
                    n => panic!("view {u} lies in {n} faces"),
                }
            }
            // Level L has 12·4^L edges, each split into 2^K pieces by 2^K − 1 fine views;
            // the rest of the new views are face interiors.
            let k = fine_level - level;
            let edges = 12 * (1u32 << (2 * level));
            assert_eq!(
                on_edges,
                edges * ((1 << k) - 1),
                "level {level}/{fine_level}"
            );
            assert_eq!(
                inside + on_edges,
                view_count(fine_level) - view_count(level)
            );
        }
    }

    #[test]
    fn at_one_extra_level_every_fine_view_folds_into_its_two_parents() {
        for level in 0..=4 {
            for u in view_count(level)..view_count(level + 1) {
                let parents = crate::sphere::parents(u).expect("a new view has parents");
                assert_eq!(
                    fold_targets(u, level),
                    FoldTargets::Edge(parents),
                    "view {u}"
                );
            }
        }
    }

    #[test]
    fn folding_into_one_corner_still_covers_every_fine_view_of_a_closed_face() {
        for (level, fine_level) in [(1, 2), (2, 3), (2, 4)] {
            let fine = random_matrix(view_count(fine_level), 70, 11 + u64::from(fine_level));
            let prefix = {
                let mut m = VisibilityMatrix::new(view_count(level), 70);
                for v in 0..view_count(level) {
                    m.row_mut(v).copy_from_slice(fine.row(v));
                }
                m
            };
            let one = fold_into_with(prefix.clone(), &fine, fine_level, level, FoldCorners::One);
            let all = fold_into(prefix, &fine, fine_level, level);
            let (mut smaller, mut bits_one, mut bits_all) = (0, 0u32, 0u32);
            for v in 0..view_count(level) {
                // One corner's rows are subsets of all corners' rows.
                assert!(row_contains(all.row(v), one.row(v)), "view {v}");
                smaller += usize::from(all.row(v) != one.row(v));
                bits_one += one.row(v).iter().map(|w| w.count_ones()).sum::<u32>();
                bits_all += all.row(v).iter().map(|w| w.count_ones()).sum::<u32>();
            }
            assert!(smaller > 0 && bits_one < bits_all);
            for face in leaf_faces(level) {
                let answer = answer_of(&one, &face);
                for u in 0..view_count(fine_level) {
                    if in_closed_face(&face, direction(u), 1e-5) {
                        assert!(
                            row_contains(&answer, fine.row(u)),
                            "face {:?} view {u}",
                            face.views
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn fold_into_keeps_the_given_coarse_rows_and_ignores_the_fine_ones() {
        let (level, fine_level) = (1, 2);
        let fine = random_matrix(view_count(fine_level), 70, 3);
        let coarse = random_matrix(view_count(level), 70, 4);
        let folded = fold_into(coarse.clone(), &fine, fine_level, level);
        let mut expected = coarse;
        for u in view_count(level)..view_count(fine_level) {
            for &c in fold_targets(u, level).views() {
                for (d, &s) in expected.row_mut(c).iter_mut().zip(fine.row(u)) {
                    *d |= s;
                }
            }
        }
        assert_eq!(folded, expected);
        // The fine matrix's own coarse rows were random and different: they were not used.
        assert_ne!(fine.row(0), folded.row(0));
    }

    #[test]
    fn the_split_fold_covers_every_face_and_spreads_only_what_the_views_showed() {
        for (level, fine_level) in [(0, 1), (1, 2), (2, 3), (1, 3)] {
            let views = view_count(fine_level);
            let full = random_matrix(views, 70, 5 + u64::from(fine_level));
            // What the views showed: about half of each row.
            let mask = random_matrix(views, 70, 17 + u64::from(level));
            let mut seen = full.clone();
            for (s, (&f, &m)) in seen
                .words_mut()
                .iter_mut()
                .zip(full.words().iter().zip(mask.words()))
            {
                *s = f & !m;
            }
            let own = full.prefix(view_count(level));
            let split = split_fold(own.clone(), &full, &seen, fine_level, level);
            let all = fold_into(own.clone(), &full, fine_level, level);
            let (mut bits_split, mut bits_all) = (0, 0);
            for v in 0..view_count(level) {
                assert!(row_contains(split.row(v), own.row(v)), "view {v}");
                assert!(row_contains(all.row(v), split.row(v)), "view {v}");
                bits_split += split.row(v).iter().map(|w| w.count_ones()).sum::<u32>();
                bits_all += all.row(v).iter().map(|w| w.count_ones()).sum::<u32>();
            }
            assert!(bits_split < bits_all, "{level}/{fine_level}");
            for u in view_count(level)..views {
                for &t in fold_targets(u, level).views() {
                    assert!(
                        row_contains(split.row(t), seen.row(u)),
                        "view {u} target {t}"
                    );
                }
            }
            for face in leaf_faces(level) {
                let answer = answer_of(&split, &face);
                for u in 0..views {
                    if in_closed_face(&face, direction(u), 1e-5) {
                        assert!(row_contains(&answer, full.row(u)), "{:?} {u}", face.views);
                    }
                }
            }
        }
    }

    /// The OR of `rows`' rows of `face`'s corners.
    fn answer_of(rows: &VisibilityMatrix, face: &Face) -> Vec<u64> {
        rows.or_rows(&face.views)
    }

    #[test]
    fn the_cover_fold_covers_every_face_with_fewer_bits_than_every_corner() {
        for (level, fine_level) in [(0, 1), (1, 2), (2, 3), (1, 3), (2, 4)] {
            let views = view_count(fine_level);
            // Sparse rows (1/64 of the bits), as real rows are away from the silhouettes.
            let mut fine = VisibilityMatrix::new(views, 150);
            let mut rng = Rng::new(23 + u64::from(fine_level));
            for v in 0..views {
                for p in 0..150 {
                    if rng.next_u64().is_multiple_of(64) {
                        fine.set(v, p);
                    }
                }
            }
            let own = fine.prefix(view_count(level));
            let cover = fold_into_with(own.clone(), &fine, fine_level, level, FoldCorners::Cover);
            let all = fold_into(own.clone(), &fine, fine_level, level);
            for v in 0..view_count(level) {
                assert!(row_contains(cover.row(v), own.row(v)), "view {v}");
            }
            for face in leaf_faces(level) {
                let answer = answer_of(&cover, &face);
                for u in 0..views {
                    if in_closed_face(&face, direction(u), 1e-5) {
                        assert!(row_contains(&answer, fine.row(u)), "{:?} {u}", face.views);
                    }
                }
            }
            // Fewer bits in the rows, and fewer (face, patch) answers.
            let answers = |rows: &VisibilityMatrix| -> u32 {
                leaf_faces(level)
                    .iter()
                    .map(|f| {
                        answer_of(rows, f)
                            .iter()
                            .map(|w| w.count_ones())
                            .sum::<u32>()
                    })
                    .sum()
            };
            assert!(
                cover.count_ones() < all.count_ones(),
                "{level}/{fine_level}: {} against {}",
                cover.count_ones(),
                all.count_ones()
            );
            assert!(answers(&cover) < answers(&all), "{level}/{fine_level}");
        }
    }

    #[test]
    fn the_cover_fold_adds_nothing_a_face_already_answers() {
        // Every fine view shows only what the coarse corners of its faces already show: the
        // fold has nothing to add.
        let (level, fine_level) = (1, 3);
        let mut fine = VisibilityMatrix::new(view_count(fine_level), 70);
        for v in 0..view_count(fine_level) {
            fine.set(v, 5);
            fine.set(v, 69);
        }
        let own = fine.prefix(view_count(level));
        assert_eq!(cover_fold(own.clone(), &fine, fine_level, level), own);
    }

    #[test]
    fn every_fine_view_in_a_closed_face_is_covered_by_its_corners() {
        // The coverage argument of the module documentation, checked exhaustively: for every
        // leaf face F at `level`, the OR of F's folded corner rows contains the row of every
        // fine view lying geometrically in the closed face (edges and corners included).
        for (level, fine_level) in [(0, 1), (0, 2), (1, 2), (2, 3), (2, 4), (3, 5)] {
            let fine = random_matrix(view_count(fine_level), 70, 99 + u64::from(fine_level));
            let coarse = supersample_rows(&fine, fine_level, level);
            for face in leaf_faces(level) {
                let answer = answer_of(&coarse, &face);
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
            let answer = answer_of(&coarse, &face);
            for u in 0..view_count(fine_level) {
                let du = direction(u);
                if locate(du, level).views == face.views || in_closed_face(&face, du, 1e-5) {
                    prop_assert!(row_contains(&answer, fine.row(u)), "fine view {}", u);
                }
            }
        }
    }
}
