//! Expanded queries (spec § Query, expanded): every view decoded once into a caller-provided
//! table, plus the split planes and midpoints of every inner face of the sphere hierarchy, so a
//! query is `level` steps of at most 3 dot products and an OR of 3 rows.
//!
//! Cost: [`super::Pvis::expand`] decodes each view once from its parents' rows (views are
//! numbered coarse to fine, so parents come first) and builds the face table by walking the
//! hierarchy; a query is `O(level + P/64)` with no decoding, and a query landing in the same
//! leaf as the previous one skips the OR. Memory: [`super::Pvis::expanded_bound`] words.

use super::query::{Eye, classify, everything, visible};
use super::streaming::{CHILD_CORNERS, choose, mids, octant, planes};
use super::{Pvis, Visible};
use crate::sphere::{Face, children, parents, root_faces};

/// Corner views of the 8 root faces by octant (spec § Faces): `(X, Y, Z)` for octants of
/// positive orientation, else `(X, Z, Y)`, with `±X = 0/1, ±Y = 2/3, ±Z = 4/5`. Equal to
/// `root_faces()[o].views` (tested), without computing the faces on every query.
const ROOT_VIEWS: [[u32; 3]; 8] = {
    let mut out = [[0; 3]; 8];
    let mut o = 0;
    while o < 8 {
        let (x, y, z) = ((o & 1) as u32, (o >> 1 & 1) as u32, (o >> 2 & 1) as u32);
        out[o] = if (x + y + z) % 2 == 0 {
            [x, 2 + y, 4 + z]
        } else {
            [x, 4 + z, 2 + y]
        };
        o += 1;
    }
    out
};

/// `u32`s per inner-face record: 3 planes of 3 `f32` (as bits), then the 3 midpoint views.
const FACE_U32S: usize = 12;

/// Words per inner-face record.
const FACE_WORDS: usize = FACE_U32S / 2;

/// Inner faces (levels `0..level`) before level `k`: `8·(4^k − 1)/3`.
const fn faces_before(k: u32) -> usize {
    8 * ((1usize << (2 * k)) - 1) / 3
}

/// Table words for a file: the answer row, every view's row, the inner-face records.
pub(super) const fn words(level: u32, views: u32, row_words: usize) -> usize {
    (1 + views as usize) * row_words + FACE_WORDS * faces_before(level)
}

/// A file with every view decoded: see the module documentation. Made by [`Pvis::expand`].
#[derive(Debug)]
pub struct Expanded<'a, 't> {
    pvis: Pvis<'a>,
    table: &'t mut [u64],
    /// The leaf whose corners' OR the answer row holds, if any.
    answered: Option<[u32; 3]>,
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
        let views = pvis.sampling.views as usize;
        for v in 0..views {
            let at = (1 + v) * words;
            let (done, rest) = table.split_at_mut(at);
            let row = |p: u32| {
                let s = (1 + p as usize) * words;
                &done[s..s + words]
            };
            let parent_rows = parents(v as u32).map(|[a, b]| (row(a), row(b)));
            pvis.decode_row(v as u32, parent_rows, &mut rest[..words]);
        }
        let faces = &mut table[(1 + views) * words..need];
        for (octant, face) in root_faces().iter().enumerate() {
            build(face, 0, octant, pvis.sampling.level, faces);
        }
        Expanded {
            pvis,
            table,
            answered: None,
        }
    }

    /// The decoded row of `view`: bit `p % 64` of word `p / 64` is patch `p`.
    ///
    /// # Panics
    /// If `view >= views`.
    pub fn row(&self, view: u32) -> &[u64] {
        assert!(view < self.pvis.sampling.views, "view {view} out of range");
        let words = self.pvis.row_words();
        let at = (1 + view as usize) * words;
        &self.table[at..at + words]
    }

    /// The patches visible from `eye` (spec § Query): the same answer as [`Pvis::query`].
    pub fn query(&mut self, eye: [f32; 3]) -> Visible<'_> {
        let pvis = self.pvis;
        let words = pvis.row_words();
        let Eye::Direction(d, inside_sphere) = classify(&pvis, eye) else {
            self.answered = None;
            return everything(&pvis, &mut self.table[..words]);
        };
        let level = pvis.sampling.level;
        let oct = octant(d);
        let mut corners = ROOT_VIEWS[oct];
        let mut index = oct;
        let face_table = (1 + pvis.sampling.views as usize) * words;
        for k in 0..level {
            let at = face_table + FACE_WORDS * (faces_before(k) + index);
            let record = &self.table[at..at + FACE_WORDS];
            let u = |i: usize| (record[i / 2] >> (32 * (i % 2))) as u32;
            let f = |i: usize| f32::from_bits(u(i));
            let planes = [[f(0), f(1), f(2)], [f(3), f(4), f(5)], [f(6), f(7), f(8)]];
            let which = choose(d, &planes);
            let all = [corners[0], corners[1], corners[2], u(9), u(10), u(11)];
            corners = CHILD_CORNERS[which].map(|c| all[c]);
            index = 4 * index + which;
        }
        if self.answered != Some(corners) {
            let (answer, rows) = self.table.split_at_mut(words);
            let row = |v: u32| &rows[v as usize * words..(v as usize + 1) * words];
            let (a, b, c) = (row(corners[0]), row(corners[1]), row(corners[2]));
            for (i, w) in answer.iter_mut().enumerate() {
                *w = a[i] | b[i] | c[i];
            }
            self.answered = Some(corners);
        }
        visible(&pvis, inside_sphere, corners, &self.table[..words])
    }
}

/// Writes the records of `face` (at level `k`, index `index` within its level) and of its
/// descendants above `level`. Recursion depth is at most `MAX_LEVEL`.
fn build(face: &Face, k: u32, index: usize, level: u32, faces: &mut [u64]) {
    if k >= level {
        return;
    }
    let kids = children(face);
    let p = planes(&kids);
    let m = mids(&kids);
    let mut u = [0u32; FACE_U32S];
    for (i, x) in p.iter().flatten().enumerate() {
        u[i] = x.to_bits();
    }
    u[9..].copy_from_slice(&m);
    let at = FACE_WORDS * (faces_before(k) + index);
    for (i, word) in faces[at..at + FACE_WORDS].iter_mut().enumerate() {
        *word = u64::from(u[2 * i]) | u64::from(u[2 * i + 1]) << 32;
    }
    for (c, kid) in kids.iter().enumerate() {
        build(kid, k + 1, 4 * index + c, level, faces);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn root_views_are_the_root_faces() {
        for (o, face) in root_faces().iter().enumerate() {
            assert_eq!(ROOT_VIEWS[o], face.views, "octant {o}");
        }
    }
}
