//! Expanded queries (spec § Query, expanded): every view decoded once into a caller-provided
//! table, plus the split planes of every inner face of the sphere hierarchy and the corner views
//! of every leaf, so a query is `level` steps of 3 dot products (only the face index travels
//! down the levels), one leaf lookup and an OR of 3 rows.
//!
//! Cost: [`super::Pvis::expand`] decodes each view once from its parents' rows (views are
//! numbered coarse to fine, so parents come first) and builds the face table by walking the
//! hierarchy; a query is `O(level + P/64)` with no decoding, and a query landing in the same
//! leaf as the previous one skips the OR. Memory: [`super::Pvis::expanded_bound`] words.

use super::query::{Eye, classify, everything, visible};
use super::streaming::{choose, octant, planes};
use super::{Pvis, Visible};
use crate::sphere::{Face, children, parents, root_faces};

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

/// Table words for a file: the answer row, every view's row, the inner-face records, the leaf
/// corners.
pub(super) const fn words(level: u32, views: u32, row_words: usize) -> usize {
    (1 + views as usize) * row_words + FACE_WORDS * faces_before(level) + leaf_words(level)
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
        let level = pvis.sampling.level;
        let (faces, leaves) =
            table[(1 + views) * words..need].split_at_mut(FACE_WORDS * faces_before(level));
        leaves.fill(0);
        for (octant, face) in root_faces().iter().enumerate() {
            build(face, 0, octant, level, faces, leaves);
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
        let rows_end = (1 + pvis.sampling.views as usize) * words;
        let (faces, leaves) = self.table[rows_end..].split_at(FACE_WORDS * faces_before(level));
        // Only the face index is carried down the levels (the corners are looked up once, at
        // the leaf), so each level is one record load, three dot products and a table lookup.
        let mut index = octant(d);
        let mut level_start = 0;
        for k in 0..level {
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
        let corner = |i: usize| {
            let u = 3 * index + i;
            leaves
                .get(u / 2)
                .map_or(0, |w| (w >> (32 * (u % 2))) as u32)
        };
        let corners = [corner(0), corner(1), corner(2)];
        if self.answered != Some(corners) {
            let (answer, rows) = self.table.split_at_mut(words);
            let row = |v: u32| &rows[v as usize * words..(v as usize + 1) * words];
            let (a, b, c) = (row(corners[0]), row(corners[1]), row(corners[2]));
            // Zipped, so the loop has no bounds checks and vectorises.
            for (w, ((a, b), c)) in answer.iter_mut().zip(a.iter().zip(b).zip(c)) {
                *w = a | b | c;
            }
            self.answered = Some(corners);
        }
        visible(&pvis, inside_sphere, corners, &self.table[..words])
    }
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
