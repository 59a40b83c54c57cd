//! Expanded queries (spec § Query, expanded): every view decoded once into a caller-provided
//! table, plus the split planes of every inner face of the sphere hierarchy, the corner views
//! of every leaf and every leaf's answer (the OR of its corners' rows), so a query is at most
//! `level` steps of 3 dot products (only the face index travels down the levels) and one leaf
//! lookup; the answer borrows the leaf's row.
//!
//! Cost: [`super::Pvis::expand`] decodes each view once from its parents' rows (views are
//! numbered coarse to fine, so parents come first), builds the face table by walking the
//! hierarchy and ORs each leaf's three rows; a query is `O(level)` with no decoding and no
//! copy. Memory: [`super::Pvis::expanded_bound`] words, of which the leaf answers are
//! `8·4^level` rows (at 2000 patches and level 4, 512 KiB of 1,075 KiB), stored because reading
//! a leaf's three rows and ORing them was about a quarter of a query (BENCHMARKS.md).
//!
//! Sampling shells (spec § SHEL): every shell's views are decoded and every shell's leaves and
//! leaf answers stored; the faces and the grid go down to the finest shell level. A query walks
//! once, to the finer of its band's two shells' levels, and takes the coarser shell's leaf as
//! that leaf's ancestor (its index shifted right by two bits a level); between two shells it
//! ORs their two stored answers into the answer row (one pass over a row), else it borrows the
//! stored row as before.
//!
//! Start grid: every split plane passes through the origin, so in an octant's central
//! (gnomonic) projection onto `|x| + |y| + |z| = 1` every face boundary is a straight line.
//! A `GRID × GRID` grid over `(u, v) = (|x|, |y|) / (|x| + |y| + |z|)` per octant stores, for
//! each cell, the deepest face whose walk decisions are the same for every direction in the
//! cell widened by more than the rounding of `(u, v)`, with a margin larger than the rounding
//! of the walk's dot products; a query starts the walk there. The answer is therefore the
//! walk's answer bit for bit (cells touching a boundary just start higher up), and a random
//! eye mostly walks no level at all. Cost: 8·`GRID`² cells of 2 bytes (256 KiB), built
//! in `expand` by evaluating the planes at each cell's 4 corners.

use super::consts::MAX_SHELLS;
use super::frustum::{Bounds, Frustum};
use super::query::{Eye, Place, classify, everything, origin_leaf, visible};
use super::shells::Band;
use super::streaming::{choose, octant, planes};
use super::{Pvis, Visible};
use crate::sphere::{Face, children, parents, root_faces, view_count};

/// `u32`s per inner-face record: its 3 split planes of 3 `f32` (as bits), and one of padding
/// so a record is a whole number of words.
const FACE_U32S: usize = 10;

/// Words per inner-face record.
const FACE_WORDS: usize = FACE_U32S / 2;

/// Faces of level `k`: `8·4^k`.
const fn faces_at(k: u32) -> usize {
    8 << (2 * k)
}

/// Inner faces (levels `0..level`) before level `k`: `8·(4^k − 1)/3`.
const fn faces_before(k: u32) -> usize {
    (faces_at(k) - 8) / 3
}

/// Words of the leaf table: the 3 corner views of each of the `8·4^level` leaves.
const fn leaf_words(level: u32) -> usize {
    (3 * faces_at(level)).div_ceil(2)
}

/// Cells per side of each octant's start grid: 128 leaves a level-4 leaf ~32 cells, so most
/// cells skip the whole walk, at 256 KiB for the grid (64² `u32` cells were 104 ns per random
/// query at 2000 patches, 128² `u16` cells are 91 ns; BENCHMARKS.md).
const GRID: usize = 128;

/// Grid entries (`u16`) per table word.
const ENTRIES_PER_WORD: usize = 4;

/// Words of the start grid: one `u16` per cell of each octant.
const GRID_WORDS: usize = 8 * GRID * GRID / ENTRIES_PER_WORD;

/// Bit position of the level in a grid entry; the face index within that level is below it.
const ENTRY_LEVEL_SHIFT: u32 = 13;

/// The deepest level a grid entry names: its `8·4^5 = 2^13` face indices fill the bits below
/// [`ENTRY_LEVEL_SHIFT`]; deeper starts are stored as their level-5 ancestor.
const MAX_GRID_LEVEL: u32 = 5;

/// How far (in `u`, `v`) a cell is widened before it is classified: more than the rounding
/// of the query's `(u, v)` (`|x|·(GRID/s)` with `s` a sum of 3 non-negative terms: under 4
/// ulp of a value ≤ 1, i.e. < 2.4·10⁻⁷).
const WIDEN: f64 = 1.0 / (1u32 << 20) as f64;

/// The least `|d̂ · p| / max|pᵢ|` (`d̂` on `|x| + |y| + |z| = 1`) a cell must keep from a
/// plane for the walk's binary32 sign to be exact: the walk's dot product rounds by at most
/// `γ₃·Σ|dᵢ pᵢ| ≤ 1.8·10⁻⁷·s·max|pᵢ|`.
const MARGIN: f64 = 1.0 / (1u32 << 20) as f64;

/// The range of `s = |x| + |y| + |z|` where the grid is used: inside it neither the query's
/// `(u, v)` nor the walk's products overflow or go subnormal; outside it the walk starts at
/// the root.
const GRID_S_RANGE: (f32, f32) = (1e-18, 1e18);

/// Where one shell's parts of the table start, in words: its rows, its leaves' corner views
/// and its leaves' answers (the OR of their corners' rows).
#[derive(Clone, Copy, Debug, Default)]
struct ShellParts {
    level: u32,
    rows: usize,
    leaves: usize,
    answers: usize,
}

/// Where the parts of the table start, in words: after the answer row come every shell's rows,
/// the inner-face records (down to the finest shell level), the start grid, and each shell's
/// leaf corners and answers, which end at `end`.
#[derive(Clone, Copy, Debug)]
struct Layout {
    /// The finest shell level: the faces and the grid go down to it.
    level: u32,
    faces: usize,
    grid: usize,
    shells: [ShellParts; MAX_SHELLS as usize + 1],
    end: usize,
}

fn layout(pvis: &Pvis<'_>) -> Layout {
    let words = pvis.row_words();
    let count = pvis.shell_count().min(MAX_SHELLS) as usize + 1;
    let mut shells = [ShellParts::default(); MAX_SHELLS as usize + 1];
    let mut at = words;
    for (s, parts) in shells[..count].iter_mut().enumerate() {
        parts.level = pvis.shell_level(s as u32);
        parts.rows = at;
        at += view_count(parts.level) as usize * words;
    }
    let level = shells[..count].iter().map(|s| s.level).max().unwrap_or(0);
    let faces = at;
    let grid = faces + FACE_WORDS * faces_before(level);
    at = grid + GRID_WORDS;
    for parts in &mut shells[..count] {
        parts.leaves = at;
        parts.answers = at + leaf_words(parts.level);
        at = parts.answers + faces_at(parts.level) * words;
    }
    Layout {
        level,
        faces,
        grid,
        shells,
        end: at,
    }
}

/// Table words for a file (see [`Layout`]).
pub(super) fn words(pvis: &Pvis<'_>) -> usize {
    layout(pvis).end + super::frustum::bounds_words(pvis.row_words())
}

/// A file with every view decoded: see the module documentation. Made by [`Pvis::expand`].
#[derive(Debug)]
pub struct Expanded<'a, 't> {
    pvis: Pvis<'a>,
    table: &'t mut [u64],
    at: Layout,
}

impl<'a, 't> Expanded<'a, 't> {
    pub(super) fn new(pvis: Pvis<'a>, table: &'t mut [u64]) -> Self {
        let need = pvis.expanded_bound();
        assert!(
            table.len() >= need,
            "table holds {} words, {need} needed (Pvis::expanded_bound)",
            table.len()
        );
        let words = pvis.row_words();
        let at = layout(&pvis);
        let count = pvis.shell_count() as usize + 1;
        let mut slots = [0u64; super::model::TREE_CACHE_WORDS];
        for (s, parts) in at.shells[..count].iter().enumerate() {
            // Each shell has its own tree: a fresh memo.
            slots.fill(0);
            let mut cache = super::model::TreeCache::new(&mut slots);
            let visb = pvis.visb_of(s as u32);
            for v in 0..view_count(parts.level) as usize {
                let (done, rest) = table.split_at_mut(parts.rows + v * words);
                let row = |p: u32| {
                    let s = parts.rows + p as usize * words;
                    &done[s..s + words]
                };
                let parent_rows = parents(v as u32).map(|[a, b]| (row(a), row(b)));
                let point = super::visb::point_of(v as u32);
                pvis.decode_row(
                    &visb,
                    v as u32,
                    point,
                    parent_rows,
                    &mut rest[..words],
                    &mut cache,
                );
            }
        }
        let (front, back) = table[..at.end].split_at_mut(at.grid);
        let faces = &mut front[at.faces..];
        let (grid, shells) = back.split_at_mut(GRID_WORDS);
        for parts in &at.shells[..count] {
            let leaves = &mut shells
                [parts.leaves - at.grid - GRID_WORDS..parts.answers - at.grid - GRID_WORDS];
            leaves.fill(0);
            for (octant, face) in root_faces().iter().enumerate() {
                build(face, 0, octant, parts.level, faces, leaves);
            }
        }
        build_grid(faces, at.level, grid);
        // Every leaf's answer, so that a query ORs nothing (see the module documentation).
        for parts in &at.shells[..count] {
            let (corners, answers) = table[..at.end].split_at_mut(parts.answers);
            let leaves = &corners[parts.leaves..];
            let answers = &mut answers[..faces_at(parts.level) * words];
            for (leaf, answer) in answers.chunks_exact_mut(words.max(1)).enumerate() {
                let views = leaf_views(leaves, leaf);
                let row = |v: u32| &corners[parts.rows + v as usize * words..][..words];
                let (a, b, c) = (row(views[0]), row(views[1]), row(views[2]));
                for (w, ((a, b), c)) in answer.iter_mut().zip(a.iter().zip(b).zip(c)) {
                    *w = a | b | c;
                }
            }
        }
        // The patch bounds of `query_in_frustum`, after everything above.
        let bounds = super::frustum::bounds_words(words);
        super::frustum::build_bounds(&pvis, &mut table[at.end..at.end + bounds]);
        Expanded { pvis, table, at }
    }

    /// The decoded row of `view` of the sampling sphere: bit `p % 64` of word `p / 64` is
    /// patch `p`.
    ///
    /// # Panics
    /// If `view >= views`.
    pub fn row(&self, view: u32) -> &[u64] {
        self.shell_row(0, view)
    }

    /// The decoded row of `view` of shell `s` (0 is the sampling sphere).
    ///
    /// # Panics
    /// If `s > pvis.shell_count()` or `view >= pvis.shell(s).views`.
    pub fn shell_row(&self, s: u32, view: u32) -> &[u64] {
        assert!(s <= self.pvis.shell_count(), "shell {s} out of range");
        let parts = self.at.shells[s as usize];
        assert!(view < view_count(parts.level), "view {view} out of range");
        let words = self.pvis.row_words();
        let at = parts.rows + view as usize * words;
        &self.table[at..at + words]
    }

    /// The patches visible from `eye` (spec § Query): the same answer as [`Pvis::query`].
    pub fn query(&mut self, eye: [f32; 3]) -> Visible<'_> {
        let words = self.pvis.row_words();
        let (row, t) = self.table[..self.at.end].split_at_mut(words);
        answer(&self.pvis, &self.at, t, row, eye)
    }

    /// [`Expanded::query`] through a shared table: the answer is the leaf's row in the table,
    /// or is written to `scratch` (an eye between two shells, or one that gets every patch).
    /// Several threads can query one expanded file this way, each with a scratch of its own.
    ///
    /// # Panics
    /// If `scratch.len() < pvis.row_words()`.
    pub fn query_shared<'s>(&'s self, eye: [f32; 3], scratch: &'s mut [u64]) -> Visible<'s> {
        let words = self.pvis.row_words();
        let t = &self.table[words..self.at.end];
        answer(&self.pvis, &self.at, t, &mut scratch[..words], eye)
    }

    /// [`Expanded::query`]'s answer without the patches `frustum` drops (spec § Frustum
    /// culling): the same bits as [`Frustum::cull`] on that answer, from the patch bounds
    /// `expand` stored. Borrows the leaf's row when the frustum holds the whole model and one
    /// shell answers, else writes the table's answer row. Cost: a few sphere tests, plus 64
    /// patch tests per block of patches the frustum's boundary crosses.
    pub fn query_in_frustum(&mut self, eye: [f32; 3], frustum: &Frustum) -> Visible<'_> {
        let pvis = self.pvis;
        let words = pvis.row_words();
        let end = self.at.end + super::frustum::bounds_words(words);
        // The answer row comes first; `t` is the rest, shifted by one row.
        let (row, t) = self.table[..end].split_at_mut(words);
        let (t, bounds) = t.split_at(self.at.end - words);
        let bounds = Bounds::new(bounds);
        let tests = bounds.tests(frustum);
        let Eye::Direction(d, band) = classify(&pvis, eye) else {
            let place = everything(&pvis, row, origin_leaf(&pvis)).place();
            if let Some(tests) = tests {
                for (w, word) in row.iter_mut().enumerate() {
                    *word = bounds.cull_word(frustum, &tests, w, *word);
                }
            }
            return visible(&pvis, place, row);
        };
        let (place, [a, b]) = locate(&self.at, t, words, d, band, pvis.shell_count());
        if b.is_empty() && tests.is_none() {
            return visible(&pvis, place, a);
        }
        for (w, (out, &x)) in row.iter_mut().zip(a).enumerate() {
            let bits = x | b.get(w).copied().unwrap_or(0);
            *out = match &tests {
                Some(tests) => bounds.cull_word(frustum, tests, w, bits),
                None => bits,
            };
        }
        visible(&pvis, place, row)
    }
}

/// The answer to `eye` (spec § Query) from the expanded table `t` (the table after its first
/// row): a leaf's row of `t`, or the OR of two written to `row` (`row_words` words), as is
/// every patch for an eye that gets them all.
#[inline(always)]
fn answer<'x>(
    pvis: &Pvis<'_>,
    at: &Layout,
    t: &'x [u64],
    row: &'x mut [u64],
    eye: [f32; 3],
) -> Visible<'x> {
    let words = pvis.row_words();
    let Eye::Direction(d, band) = classify(pvis, eye) else {
        return everything(pvis, row, origin_leaf(pvis));
    };
    let (place, [a, b]) = locate(at, t, words, d, band, pvis.shell_count());
    if b.is_empty() {
        return visible(pvis, place, a);
    }
    for (w, (x, y)) in row.iter_mut().zip(a.iter().zip(b)) {
        *w = x | y;
    }
    visible(pvis, place, row)
}

/// The leaves of `d` on the shells of `band` and their stored answers (the second empty where
/// one shell answers), in the table `t` less its first `words` (the answer row). One walk, to
/// the finer of the two shells' levels: a coarser shell's leaf is that leaf's ancestor.
#[inline(always)]
fn locate<'t>(
    at: &Layout,
    t: &'t [u64],
    words: usize,
    d: [f32; 3],
    band: Band,
    k: u32,
) -> (Place, [&'t [u64]; 2]) {
    let part = |from: usize, to: usize| t.get(from - words..to - words).unwrap_or(&[]);
    let [outer, inner] = band.shells(k);
    let [so, si] = [outer, inner].map(|s| at.shells[(s as usize).min(MAX_SHELLS as usize)]);
    let level = so.level.max(si.level);
    let (mut start, mut index) = grid_start(d, part(at.grid, at.grid + GRID_WORDS));
    if start > level {
        index >>= 2 * (start - level);
        start = level;
    }
    let leaf = walk(d, part(at.faces, at.grid), level, start, index);
    let answer = |parts: &ShellParts| {
        let index = leaf >> (2 * (level - parts.level));
        let corners = leaf_views(part(parts.leaves, parts.answers), index);
        let from = parts.answers + index * words;
        (corners, part(from, from + words))
    };
    let (leaf_o, row_o) = answer(&so);
    if inner == outer {
        let place = Place {
            band,
            leaves: [leaf_o; 2],
        };
        return (place, [row_o, &[]]);
    }
    let (leaf_i, row_i) = answer(&si);
    let place = Place {
        band,
        leaves: [leaf_o, leaf_i],
    };
    (place, [row_o, row_i])
}

/// The corner views of leaf `index` in the leaf table.
#[inline(always)]
fn leaf_views(leaves: &[u64], index: usize) -> [u32; 3] {
    [0, 1, 2].map(|i| {
        let u = 3 * index + i;
        leaves
            .get(u / 2)
            .map_or(0, |w| (w >> (32 * (u % 2))) as u32)
    })
}

/// Writes the records of `face` (at level `k`, index `index` within its level) and of its
/// descendants above `level` into `faces`, and the corners of the leaves below it into
/// `leaves`. Recursion depth is at most `MAX_LEVEL`.
fn build(face: &Face, k: u32, index: usize, level: u32, faces: &mut [u64], leaves: &mut [u64]) {
    if k >= level {
        for (i, &v) in face.views.iter().enumerate() {
            let u = 3 * index + i;
            leaves[u / 2] |= u64::from(v) << (32 * (u % 2));
        }
        return;
    }
    let kids = children(face);
    let mut u = [0u32; FACE_U32S];
    for (i, x) in planes(&kids).iter().flatten().enumerate() {
        u[i] = x.to_bits();
    }
    let at = FACE_WORDS * (faces_before(k) + index);
    for (i, word) in faces[at..at + FACE_WORDS].iter_mut().enumerate() {
        *word = u64::from(u[2 * i]) | u64::from(u[2 * i + 1]) << 32;
    }
    for (c, kid) in kids.iter().enumerate() {
        build(kid, k + 1, 4 * index + c, level, faces, leaves);
    }
}

/// The leaf index the walk reaches for `d` from face `index` at level `start`.
#[inline(always)]
fn walk(d: [f32; 3], faces: &[u64], level: u32, start: u32, mut index: usize) -> usize {
    // Only the face index is carried down the levels (the corners are looked up once, at the
    // leaf), so each level is one record load, three dot products and a table lookup.
    let mut level_start = FACE_WORDS * faces_before(start);
    for k in start..level {
        let at = level_start + FACE_WORDS * index;
        // One bounds check for the record rather than one per field.
        let Some(record) = faces
            .get(at..at + FACE_WORDS)
            .and_then(|r| <&[u64; FACE_WORDS]>::try_from(r).ok())
        else {
            break;
        };
        let f = |i: usize| f32::from_bits((record[i / 2] >> (32 * (i % 2))) as u32);
        let planes = [[f(0), f(1), f(2)], [f(3), f(4), f(5)], [f(6), f(7), f(8)]];
        index = 4 * index + choose(d, &planes);
        level_start += FACE_WORDS * faces_at(k);
    }
    index
}

/// Grid cell of `d` (octant and `(u, v)` cell, see the module documentation), or `None` where
/// `s = |x| + |y| + |z|` is outside [`GRID_S_RANGE`].
#[inline(always)]
fn cell(d: [f32; 3]) -> Option<usize> {
    let (ax, ay) = (d[0].abs(), d[1].abs());
    let s = (ax + ay) + d[2].abs();
    if !(s > GRID_S_RANGE.0 && s < GRID_S_RANGE.1) {
        return None;
    }
    let r = GRID as f32 / s;
    // `as` saturates; u, v ≤ 1 but may round up to exactly 1.
    let i = ((ax * r) as usize).min(GRID - 1);
    let j = ((ay * r) as usize).min(GRID - 1);
    Some((octant(d) * GRID + i) * GRID + j)
}

/// Where the walk for `d` starts: the level and the face index within it.
#[inline(always)]
fn grid_start(d: [f32; 3], grid: &[u64]) -> (u32, usize) {
    let entry = cell(d).and_then(|c| {
        grid.get(c / ENTRIES_PER_WORD)
            .map(|w| (w >> (16 * (c % ENTRIES_PER_WORD))) as u16)
    });
    match entry {
        Some(e) => (
            u32::from(e >> ENTRY_LEVEL_SHIFT),
            usize::from(e & ((1 << ENTRY_LEVEL_SHIFT) - 1)),
        ),
        None => (0, octant(d)),
    }
}

/// Fills the start grid (see the module documentation) from the face records: for each cell
/// the walk is followed while every plane it tests has the same sign, with [`MARGIN`], at all
/// 4 corners of the cell widened by [`WIDEN`] — the plane's dot product is affine in `(u, v)`,
/// so the corners bound it over the cell.
fn build_grid(faces: &[u64], level: u32, grid: &mut [u64]) {
    grid.fill(0);
    let step = 1.0 / GRID as f64;
    for oct in 0..8 {
        let sign = |bit: usize| if oct >> bit & 1 == 0 { 1.0 } else { -1.0 };
        let signs = [sign(0), sign(1), sign(2)];
        for i in 0..GRID {
            for j in 0..GRID {
                let (u0, v0) = (i as f64 * step - WIDEN, j as f64 * step - WIDEN);
                let (u1, v1) = (u0 + step + 2.0 * WIDEN, v0 + step + 2.0 * WIDEN);
                let corners = [(u0, v0), (u1, v0), (u0, v1), (u1, v1)]
                    .map(|(u, v)| [signs[0] * u, signs[1] * v, signs[2] * (1.0 - u - v)]);
                let (mut k, mut index) = walk_cell(faces, level, oct, &corners);
                if k > MAX_GRID_LEVEL {
                    index >>= 2 * (k - MAX_GRID_LEVEL);
                    k = MAX_GRID_LEVEL;
                }
                let c = (oct * GRID + i) * GRID + j;
                let entry = (k << ENTRY_LEVEL_SHIFT) as u16 | index as u16;
                grid[c / ENTRIES_PER_WORD] |= u64::from(entry) << (16 * (c % ENTRIES_PER_WORD));
            }
        }
    }
}

/// The walk of [`Expanded::query`] from root `oct` as far as it is the same for every point
/// in the convex hull of `corners`: the level reached and the face index there.
fn walk_cell(faces: &[u64], level: u32, oct: usize, corners: &[[f64; 3]; 4]) -> (u32, usize) {
    let mut index = oct;
    for k in 0..level {
        let at = FACE_WORDS * (faces_before(k) + index);
        let f = |i: usize| f64::from(f32::from_bits((faces[at + i / 2] >> (32 * (i % 2))) as u32));
        let mut which = 3;
        for t in 0..3 {
            let p = [f(3 * t), f(3 * t + 1), f(3 * t + 2)];
            let margin = MARGIN * p[0].abs().max(p[1].abs()).max(p[2].abs());
            let dots = corners.map(|q| q[0] * p[0] + q[1] * p[1] + q[2] * p[2]);
            if dots.iter().all(|&x| x > margin) {
                which = t;
                break;
            }
            if !dots.iter().all(|&x| x < -margin) {
                return (k, index);
            }
        }
        index = 4 * index + which;
    }
    (level, index)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::{direction, locate, normalize};
    use crate::test_kit::rng::Rng;

    /// The walk started from the grid reaches the same leaf as the walk from the root and as
    /// `sphere::locate`, at levels 0 to 5, for every vertex of the next level (so every face
    /// corner and edge midpoint), points along every leaf edge, those nudged by a few ulp and
    /// by 10⁻⁷–10⁻⁴, scaled by 2⁻⁴⁰–2⁴⁰, and seeded random directions.
    #[test]
    fn grid_start_is_exact_on_and_near_boundaries() {
        let mut rng = Rng::new(0x2545_F491_4F6C_DD1D);
        let mut next = || rng.signed();
        let ulps = |x: f32, n: i32| {
            if x == 0.0 {
                x
            } else {
                f32::from_bits((x.to_bits() as i32 + n) as u32)
            }
        };
        for level in 0..=6u32 {
            let mut faces = vec![0u64; FACE_WORDS * faces_before(level)];
            let mut leaves = vec![0u64; leaf_words(level)];
            for (oct, face) in root_faces().iter().enumerate() {
                build(face, 0, oct, level, &mut faces, &mut leaves);
            }
            let mut grid = vec![!0u64; GRID_WORDS];
            build_grid(&faces, level, &mut grid);
            let corners = |index: usize| {
                [0, 1, 2].map(|i| {
                    let u = 3 * index + i;
                    (leaves[u / 2] >> (32 * (u % 2))) as u32
                })
            };
            let mut base: Vec<[f32; 3]> = (0..4 * 4u32.pow((level + 1).min(6)) + 2)
                .map(direction)
                .collect();
            let mut leaf_faces = root_faces().to_vec();
            for _ in 0..level {
                leaf_faces = leaf_faces.iter().flat_map(children).collect();
            }
            for f in &leaf_faces {
                for e in 0..3 {
                    let (a, b) = (f.directions[e], f.directions[(e + 1) % 3]);
                    for t in [0.125f32, 0.3, 0.71] {
                        base.push([0, 1, 2].map(|i| a[i] * (1.0 - t) + b[i] * t));
                    }
                }
            }
            for _ in 0..4000 {
                base.push([next(), next(), next()]);
            }
            let (mut pure, mut checked) = (0usize, 0usize);
            for &b in &base {
                let mut dirs = vec![b];
                for n in [-3, -1, 1, 3] {
                    for i in 0..3 {
                        let mut d = b;
                        d[i] = ulps(d[i], n);
                        dirs.push(d);
                    }
                }
                for eps in [1e-7f32, 1e-6, 1e-5, 1e-4] {
                    dirs.push(normalize([
                        b[0] + eps * next(),
                        b[1] + eps * next(),
                        b[2] + eps * next(),
                    ]));
                }
                for scale in [2f32.powi(-40), 0.5, 3.0, 2f32.powi(40)] {
                    dirs.push(b.map(|x| x * scale));
                }
                for d in dirs {
                    let (start, index) = grid_start(d, &grid);
                    let from_grid = walk(d, &faces, level, start, index);
                    let from_root = walk(d, &faces, level, 0, octant(d));
                    assert_eq!(from_grid, from_root, "level {level}, {d:?}");
                    assert_eq!(
                        corners(from_grid),
                        locate(d, level).views,
                        "level {level}, {d:?}"
                    );
                    pure += usize::from(start == level);
                    checked += 1;
                }
            }
            // The grid must also pay: most random-ish directions skip the whole walk at low
            // levels.
            if level <= 2 {
                assert!(
                    pure * 2 > checked,
                    "level {level}: {pure}/{checked} start at the leaf"
                );
            }
        }
    }
}
