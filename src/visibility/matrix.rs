//! Which patches each sampling view sees: one row of bits per view, the sampler's output and
//! the format writer's input. Rows are plain `u64` words (bit `p % 64` of word `p / 64` is
//! patch `p`), the layout the reader's answers use too.

use crate::tiling::PatchId;
use rayon::prelude::*;

/// Which patches each view sees: one row of `patches` bits per view.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VisibilityMatrix {
    views: u32,
    patches: u32,
    words_per_row: usize,
    /// Row after row, `words_per_row` words each.
    bits: Vec<u64>,
}

impl VisibilityMatrix {
    /// An all-zero matrix.
    pub fn new(views: u32, patches: u32) -> Self {
        let words_per_row = (patches as usize).div_ceil(64);
        VisibilityMatrix {
            views,
            patches,
            words_per_row,
            bits: vec![0; words_per_row * views as usize],
        }
    }
    /// Number of views (rows).
    pub fn views(&self) -> u32 {
        self.views
    }
    /// Number of patches (bits per row).
    pub fn patches(&self) -> u32 {
        self.patches
    }
    /// Words per row: `patches.div_ceil(64)`.
    pub fn words_per_row(&self) -> usize {
        self.words_per_row
    }
    /// Every row, one after the other (`views × words_per_row` words).
    pub fn words(&self) -> &[u64] {
        &self.bits
    }
    /// Every row, mutable (for samplers that fill rows in parallel).
    pub fn words_mut(&mut self) -> &mut [u64] {
        &mut self.bits
    }
    /// The first `views` rows (at most all of them): a coarser sphere level's matrix, since
    /// level `l`'s views are a prefix of level `l + 1`'s.
    pub fn prefix(&self, views: u32) -> VisibilityMatrix {
        let views = views.min(self.views);
        VisibilityMatrix {
            views,
            patches: self.patches,
            words_per_row: self.words_per_row,
            bits: self.bits[..views as usize * self.words_per_row].to_vec(),
        }
    }
    /// Number of (view, patch) pairs set.
    pub fn count_ones(&self) -> u64 {
        self.bits.iter().map(|w| u64::from(w.count_ones())).sum()
    }
    /// Row of `view`: bit `p % 64` of word `p / 64` is patch `p`; bits past `patches` are zero.
    pub fn row(&self, view: u32) -> &[u64] {
        let start = view as usize * self.words_per_row;
        &self.bits[start..start + self.words_per_row]
    }
    /// Mutable row of `view`.
    pub fn row_mut(&mut self, view: u32) -> &mut [u64] {
        let start = view as usize * self.words_per_row;
        &mut self.bits[start..start + self.words_per_row]
    }
    /// Word `word` of the OR of the rows of `views`: with a leaf face's three corners, that
    /// word of the answer of a query in the face (spec § Query).
    pub fn or_word(&self, views: &[u32], word: usize) -> u64 {
        views.iter().fold(0, |a, &v| a | self.row(v)[word])
    }
    /// The OR of the rows of `views` ([`Self::or_word`] for every word).
    pub fn or_rows(&self, views: &[u32]) -> Vec<u64> {
        (0..self.words_per_row)
            .map(|w| self.or_word(views, w))
            .collect()
    }
    /// Whether `view` sees `patch`.
    pub fn get(&self, view: u32, patch: PatchId) -> bool {
        self.row(view)[patch as usize / 64] >> (patch % 64) & 1 == 1
    }
    /// Marks `patch` seen from `view`.
    pub fn set(&mut self, view: u32, patch: PatchId) {
        self.row_mut(view)[patch as usize / 64] |= 1 << (patch % 64);
    }

    /// The same visibility with the patches renumbered: patch `i` of the result is patch
    /// `order[i]` of `self` (see [`crate::tiling::Tiling::renumbered`]). O(views × patches).
    ///
    /// Panics (caller contract) if `order` does not have one entry per patch or names a
    /// patch that does not exist.
    pub fn with_patch_order(&self, order: &[PatchId]) -> VisibilityMatrix {
        assert_eq!(order.len(), self.patches as usize, "one entry per patch");
        let mut out = VisibilityMatrix::new(self.views, self.patches);
        let words = self.words_per_row;
        if words == 0 {
            return out;
        }
        out.bits
            .par_chunks_mut(words)
            .zip(self.bits.par_chunks(words))
            .for_each(|(to, from)| {
                for (i, &old) in order.iter().enumerate() {
                    let bit = from[old as usize / 64] >> (old % 64) & 1;
                    to[i / 64] |= bit << (i % 64);
                }
            });
        out
    }
}
