//! Streaming queries (spec § Query, streaming): descend the sphere's face hierarchy to the
//! leaf under the eye, decoding each child corner that is an edge midpoint from the edge's two
//! endpoints, and keep the whole path — faces, split planes and decoded rows — for the next
//! query.
//!
//! Meruvia 2002 §3.3.1 locates the face in at most 4 tests per level; here the tests reuse the
//! cached planes of the path, and only levels below the first one where the eye changed child
//! are recomputed. A camera that stays in its leaf therefore costs `level` plane tests; moving
//! to a neighbouring leaf decodes at most 3 rows per level changed (usually 0–3 in total: the
//! midpoints of a face are kept while the eye moves among its children).
//! Memory: `4 + 3·level` rows in the caller's scratch ([`super::Pvis::scratch_bound`]), for
//! VISB encoding 2 a 32 KiB memo of context-tree lookups there too, plus a few KiB of path
//! state in the struct itself; no allocation.

use super::model::TreeCache;
use super::query::{Eye, classify, everything, visible};
use super::{Frustum, Pvis, Visible};
use crate::sphere::{Face, LatticePoint, MAX_LEVEL, children, cross, dot, root_face};

/// Row slots the streaming state keeps: the answer, the root face's 3 corners, and the 3 edge
/// midpoints of the path's face at each level above the leaf.
pub(super) const fn slots(level: u32) -> usize {
    4 + 3 * level as usize
}

/// Slot of the answer row.
const ANSWER: usize = 0;

/// Slot of midpoint `j` (0 = ab, 1 = bc, 2 = ca) of the path's face at level `k`.
const fn mid_slot(k: usize, j: usize) -> u8 {
    (4 + 3 * k + j) as u8
}

/// Edge `j` of a face `(a, b, c)`: its two corners (0 = ab, 1 = bc, 2 = ca).
const EDGES: [[usize; 2]; 3] = [[0, 1], [1, 2], [2, 0]];

/// Corners of child `c` as indices into `[a, b, c, m_ab, m_bc, m_ca]` (spec § Faces).
pub(super) const CHILD_CORNERS: [[usize; 3]; 4] = [[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]];

/// One level of the cached path.
#[derive(Clone, Copy, Debug)]
struct PathLevel {
    face: Face,
    /// Row slots of the face's corners.
    slots: [u8; 3],
    /// The face's children (unused at the leaf level).
    kids: [Face; 4],
    /// Split planes of the point-location tests: `m_ab × m_ca`, `m_bc × m_ab`, `m_ca × m_bc`.
    planes: [[f32; 3]; 3],
    /// Whether midpoint `j`'s row is decoded in its slot.
    mid_ready: [bool; 3],
    /// The child the path continues into.
    child: u8,
}

/// The child of a face the locate tests choose for `d` (spec § Point location, step 2).
#[inline(always)]
pub(super) fn choose(d: [f32; 3], planes: &[[f32; 3]; 3]) -> usize {
    if dot(d, planes[0]) >= 0.0 {
        0
    } else if dot(d, planes[1]) >= 0.0 {
        1
    } else if dot(d, planes[2]) >= 0.0 {
        2
    } else {
        3
    }
}

/// The root octant of `d` (spec § Point location, step 1).
#[inline(always)]
pub(super) fn octant(d: [f32; 3]) -> usize {
    // `≥ 0` is positive; NaN compares false and so counts as negative.
    let negative = |c: f32| usize::from(c.partial_cmp(&0.0).is_none_or(|o| o.is_lt()));
    negative(d[0]) | negative(d[1]) << 1 | negative(d[2]) << 2
}

/// The split planes of `face`, from its children's corner directions (bit-identical to
/// [`crate::sphere::locate`]'s).
pub(super) fn planes(kids: &[Face; 4]) -> [[f32; 3]; 3] {
    let (mab, mca, mbc) = (
        kids[0].directions[1],
        kids[0].directions[2],
        kids[1].directions[2],
    );
    [cross(mab, mca), cross(mbc, mab), cross(mca, mbc)]
}

/// Midpoint `j` (0 = `m_ab`, 1 = `m_bc`, 2 = `m_ca`) of a face, from its children: its view
/// and its lattice point (at the children's level, the midpoint's own).
fn mid(kids: &[Face; 4], j: usize) -> (u32, LatticePoint) {
    let (kid, corner) = [(0, 1), (1, 2), (0, 2)][j % 3];
    (kids[kid].views[corner], kids[kid].lattice[corner])
}

/// The views of the leaf that [`crate::sphere::locate`] gives the zero direction (the
/// conservative answer reports them): every plane test of a zero vector is `0 ≥ 0`, so the
/// path stays in child 0 of root face 0. Walked through [`children`], which the streaming
/// path links anyway, rather than through `locate`, which it otherwise does not need.
pub(super) fn origin_leaf(level: u32) -> [u32; 3] {
    let mut face = root_face(0);
    for _ in 0..level {
        face = children(&face)[0];
    }
    face.views
}

/// Streaming query state: see the module documentation. Made by [`Pvis::streaming`].
#[derive(Debug)]
pub struct Streaming<'a, 's> {
    pvis: Pvis<'a>,
    rows: &'s mut [u64],
    /// Memo of context-tree lookups (VISB encoding 2; empty otherwise).
    cache: TreeCache<'s>,
    path: [PathLevel; MAX_LEVEL as usize + 1],
    /// Valid levels of `path` (0 before the first query).
    depth: usize,
    octant: usize,
    /// Whether the answer slot holds the OR of the leaf's corners.
    answer_valid: bool,
    /// Rows decoded so far (for measurements).
    decoded: u64,
}

impl<'a, 's> Streaming<'a, 's> {
    pub(super) fn new(pvis: Pvis<'a>, rows: &'s mut [u64]) -> Self {
        let need = pvis.scratch_bound();
        assert!(
            rows.len() >= need,
            "scratch holds {} words, {need} needed (Pvis::scratch_bound)",
            rows.len()
        );
        let (rows, cache) = rows[..need].split_at_mut(need - pvis.tree_cache_words());
        cache.fill(0);
        let cache = TreeCache::new(cache);
        let root = root_face(0);
        let level = PathLevel {
            face: root,
            slots: [1, 2, 3],
            kids: [root; 4],
            planes: [[0.0; 3]; 3],
            mid_ready: [false; 3],
            child: 0,
        };
        Streaming {
            pvis,
            rows,
            cache,
            path: [level; MAX_LEVEL as usize + 1],
            depth: 0,
            octant: 0,
            answer_valid: false,
            decoded: 0,
        }
    }

    /// Rows decoded since this state was made: 3 for the root, then up to 3 per level the
    /// path changed at. A measure of how much a query cost.
    pub fn decoded_rows(&self) -> u64 {
        self.decoded
    }

    /// The patches visible from `eye` (spec § Query): the same answer as [`Pvis::query`].
    pub fn query(&mut self, eye: [f32; 3]) -> Visible<'_> {
        let pvis = self.pvis;
        let words = pvis.row_words();
        let Eye::Direction(d, inside_sphere) = classify(&pvis, eye) else {
            self.answer_valid = false;
            return everything(
                &pvis,
                &mut self.rows[..words],
                origin_leaf(pvis.sampling.level),
            );
        };
        // Parse checked the level; the bound lets the compiler drop the path's index checks.
        let level = (pvis.sampling.level as usize).min(MAX_LEVEL as usize);
        let oct = octant(d);
        if self.depth == 0 || self.octant != oct {
            self.enter_root(oct);
        }
        for k in 0..level {
            let which = choose(d, &self.path[k].planes);
            if k + 1 < self.depth && self.path[k].child as usize == which {
                continue;
            }
            self.enter_child(k, which);
        }
        let leaf = &self.path[level];
        if !self.answer_valid {
            let [a, b, c] = leaf.slots.map(|s| s as usize * words);
            let (answer, rest) = self.rows.split_at_mut(words);
            // Corner slots are ≥ 1, so they lie in `rest`, shifted by one row (and hold a
            // whole row: `Pvis::scratch_bound`).
            let row = |at: usize| rest.get(at - words..at).unwrap_or(&[]);
            let rows = row(a).iter().zip(row(b)).zip(row(c));
            for (w, ((x, y), z)) in answer.iter_mut().zip(rows) {
                *w = x | y | z;
            }
            self.answer_valid = true;
        }
        let views = self.path[level].face.views;
        visible(&pvis, inside_sphere, views, &self.rows[ANSWER..words])
    }

    /// `u64` words of one row of the file: what [`Streaming::query_in_frustum`]'s `out`
    /// needs.
    pub fn row_words(&self) -> usize {
        self.pvis.row_words()
    }

    /// [`Streaming::query`]'s answer without the patches `frustum` drops (spec § Frustum
    /// culling), written to `out` (at least [`Pvis::row_words`] words; the cached answer is
    /// kept for the next query). Costs one record decode and sphere test per visible patch
    /// more than `query`.
    ///
    /// # Panics
    /// If `out.len() < pvis.row_words()`.
    pub fn query_in_frustum<'o>(
        &mut self,
        eye: [f32; 3],
        frustum: &Frustum,
        out: &'o mut [u64],
    ) -> Visible<'o> {
        let pvis = self.pvis;
        let words = pvis.row_words();
        assert!(
            out.len() >= words,
            "out holds {} words, {words} needed (Pvis::row_words)",
            out.len()
        );
        let out = &mut out[..words];
        let v = self.query(eye);
        let (inside_sphere, leaf) = (v.inside_sphere, v.leaf);
        out.copy_from_slice(v.bits());
        frustum.cull(&pvis, out);
        visible(&pvis, inside_sphere, leaf, out)
    }

    /// Starts the path at root face `oct`, decoding its three level-0 corners.
    fn enter_root(&mut self, oct: usize) {
        let words = self.pvis.row_words();
        let face = root_face(oct);
        for (i, &v) in face.views.iter().enumerate() {
            let slot = (1 + i) * words;
            // The scratch holds every slot (`Pvis::scratch_bound`), so the row is there.
            if let Some(row) = self.rows.get_mut(slot..slot + words) {
                self.pvis
                    .decode_row(v, face.lattice[i], None, row, &mut self.cache);
            }
        }
        self.decoded += 3;
        self.set_level(0, face, [1, 2, 3]);
        self.octant = oct;
    }

    /// Makes `face` (with corner rows in `slots`) the path's face at level `k`.
    fn set_level(&mut self, k: usize, face: Face, slots: [u8; 3]) {
        let leaf = k == self.pvis.sampling.level as usize;
        let entry = &mut self.path[k];
        entry.face = face;
        entry.slots = slots;
        entry.mid_ready = [false; 3];
        if !leaf {
            entry.kids = children(&face);
            entry.planes = planes(&entry.kids);
        }
        self.depth = k + 1;
        self.answer_valid = false;
    }

    /// Moves the path below level `k` into child `which`, decoding the midpoints it needs.
    fn enter_child(&mut self, k: usize, which: usize) {
        let words = self.pvis.row_words();
        let corners = CHILD_CORNERS[which];
        for &c in &corners {
            if c < 3 || self.path[k].mid_ready[c - 3] {
                continue;
            }
            let j = c - 3;
            let entry = &self.path[k];
            let (mid, point) = mid(&entry.kids, j);
            let [e0, e1] = EDGES[j];
            // The context orders the parents by view index (spec § Context).
            let (mut pa, mut pb) = (e0, e1);
            if entry.face.views[pa] > entry.face.views[pb] {
                core::mem::swap(&mut pa, &mut pb);
            }
            let (sa, sb) = (
                entry.slots[pa] as usize * words,
                entry.slots[pb] as usize * words,
            );
            let target = mid_slot(k, j) as usize * words;
            // Corner slots of level k are roots or midpoints of levels < k: all below target,
            // and every slot is in the scratch (`Pvis::scratch_bound`).
            let (lo, hi) = self.rows.split_at_mut(target.min(self.rows.len()));
            if let (Some(ra), Some(rb), Some(out)) = (
                lo.get(sa..sa + words),
                lo.get(sb..sb + words),
                hi.get_mut(..words),
            ) {
                self.pvis
                    .decode_row(mid, point, Some((ra, rb)), out, &mut self.cache);
            }
            self.decoded += 1;
            self.path[k].mid_ready[j] = true;
        }
        let entry = &self.path[k];
        let all = [
            entry.slots[0],
            entry.slots[1],
            entry.slots[2],
            mid_slot(k, 0),
            mid_slot(k, 1),
            mid_slot(k, 2),
        ];
        let face = entry.kids[which];
        self.path[k].child = which as u8;
        self.set_level(k + 1, face, corners.map(|c| all[c]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::locate;

    /// The conservative answer's leaf, found without point location, is the one point
    /// location gives the zero direction, at every level.
    #[test]
    fn origin_leaf_is_where_locate_puts_the_zero_direction() {
        for level in 0..=MAX_LEVEL {
            assert_eq!(
                origin_leaf(level),
                locate([0.0; 3], level).views,
                "level {level}"
            );
        }
    }
}
