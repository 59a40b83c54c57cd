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
//!
//! Sampling shells (spec § SHEL): an eye between two shells is answered from a path on each,
//! so the state keeps up to [`PATHS`] paths, shell `s` on path `s mod 3`. A query's two shells
//! are neighbours, so they never share a path, and a camera moving back and forth across one
//! shell boundary (bands `b` and `b + 1` use shells `b − 1`, `b` and `b + 1`) rebuilds no
//! path; a path handed to another shell decodes its `3 + 3·level` rows again.
//! Memory: one answer row and `3 + 3·L` rows a path (`L` the finest shell level) in the
//! caller's scratch ([`super::Pvis::scratch_bound`]), for VISB encoding 2 a 32 KiB memo of
//! context-tree lookups there too (emptied when the tree changes with the shell), plus a few
//! KiB of path state in the struct itself; no allocation.

use super::model::TreeCache;
use super::query::{Eye, Place, classify, everything, visible};
use super::visb::Visb;
use super::{Frustum, Pvis, Visible};
use crate::sphere::{Face, LatticePoint, MAX_LEVEL, children, cross, dot, root_face};

/// Paths a streaming state keeps at most: shell `s` uses path `s % PATHS` (see the module
/// documentation). One in a far-only reader (without feature `shells`), which has shell 0
/// only.
pub(super) const PATHS: usize = if cfg!(feature = "shells") { 3 } else { 1 };

/// Paths a state over `pvis` keeps: one per shell, at most [`PATHS`].
fn path_count(pvis: &Pvis<'_>) -> usize {
    (pvis.shell_count() as usize + 1).min(PATHS)
}

/// Row slots of one path: the root face's 3 corners and the 3 edge midpoints of the path's
/// face at each level above the leaf.
const fn path_rows(level: u32) -> usize {
    3 + 3 * level as usize
}

/// Rows of scratch a state over `pvis` needs: the answer and every path's slots.
pub(super) fn rows(pvis: &Pvis<'_>) -> usize {
    1 + path_count(pvis) * path_rows(pvis.max_level())
}

/// Slot of midpoint `j` (0 = ab, 1 = bc, 2 = ca) of the path's face at level `k`.
const fn mid_slot(k: usize, j: usize) -> u8 {
    (3 + 3 * k + j) as u8
}

/// Edge `j` of a face `(a, b, c)`: its two corners (0 = ab, 1 = bc, 2 = ca).
const EDGES: [[usize; 2]; 3] = [[0, 1], [1, 2], [2, 0]];

/// Corners of child `c` as indices into `[a, b, c, m_ab, m_bc, m_ca]` (spec § Faces).
pub(super) const CHILD_CORNERS: [[usize; 3]; 4] = [[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]];

/// No shell: a path not yet given one.
const NO_SHELL: u32 = u32::MAX;

/// One level of a cached path. The face's children are not kept (they are recomputed when
/// the path moves below it), so that three paths fit the C ABI's 8 KiB streaming block.
#[derive(Clone, Copy, Debug)]
struct PathLevel {
    face: Face,
    /// Row slots of the face's corners, within the path's slots.
    slots: [u8; 3],
    /// Split planes of the point-location tests: `m_ab × m_ca`, `m_bc × m_ab`, `m_ca × m_bc`.
    planes: [[f32; 3]; 3],
    /// Whether midpoint `j`'s row is decoded in its slot.
    mid_ready: [bool; 3],
    /// The child the path continues into.
    child: u8,
}

/// The path to one shell's leaf under the last eye.
#[derive(Clone, Copy, Debug)]
struct Path<'a> {
    /// The shell, or [`NO_SHELL`].
    shell: u32,
    /// Its rows.
    visb: Visb<'a>,
    /// Its level.
    level: u32,
    levels: [PathLevel; MAX_LEVEL as usize + 1],
    /// Valid levels of `levels` (0 before the first walk).
    depth: usize,
    octant: usize,
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
pub(super) fn origin_leaf_at(level: u32) -> [u32; 3] {
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
    /// Memo of context-tree lookups (VISB encoding 2; empty otherwise), for the tree of
    /// shell `cache_shell`.
    cache: TreeCache<'s>,
    cache_shell: u32,
    paths: [Path<'a>; PATHS],
    /// Rows of scratch a path's slots take.
    path_rows: usize,
    /// The band and the paths the answer slot holds the OR of, if it is valid.
    answer: Option<(u32, [usize; 2])>,
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
            slots: [0, 1, 2],
            planes: [[0.0; 3]; 3],
            mid_ready: [false; 3],
            child: 0,
        };
        let path = Path {
            shell: NO_SHELL,
            visb: pvis.visb,
            level: 0,
            levels: [level; MAX_LEVEL as usize + 1],
            depth: 0,
            octant: 0,
        };
        Streaming {
            pvis,
            rows,
            cache,
            cache_shell: NO_SHELL,
            paths: [path; PATHS],
            path_rows: path_rows(pvis.max_level()),
            answer: None,
            decoded: 0,
        }
    }

    /// Rows decoded since this state was made: 3 for the root of a shell's path, then up to 3
    /// per level a path changed at. A measure of how much a query cost.
    pub fn decoded_rows(&self) -> u64 {
        self.decoded
    }

    /// The patches visible from `eye` (spec § Query): the same answer as [`Pvis::query`].
    pub fn query(&mut self, eye: [f32; 3]) -> Visible<'_> {
        let pvis = self.pvis;
        let words = pvis.row_words();
        let Eye::Direction(d, band) = classify(&pvis, eye) else {
            self.answer = None;
            let leaf = origin_leaf_at(pvis.shell_level(pvis.shell_count()));
            return everything(&pvis, &mut self.rows[..words], leaf);
        };
        let [outer, inner] = band.shells(pvis.shell_count());
        let po = self.walk(outer, d);
        let pi = if inner == outer {
            po
        } else {
            self.walk(inner, d)
        };
        if self.answer != Some((band.band, [po, pi])) {
            let (answer, rest) = self.rows.split_at_mut(words);
            answer.fill(0);
            for p in [po, pi] {
                let path = &self.paths[p];
                let base = p * self.path_rows;
                // Corner slots lie in `rest`, which holds every path's slots
                // (`Pvis::scratch_bound`).
                for slot in path.levels[path.depth.saturating_sub(1)].slots {
                    let at = (base + slot as usize) * words;
                    let row = rest.get(at..at + words).unwrap_or(&[]);
                    for (w, x) in answer.iter_mut().zip(row) {
                        *w |= x;
                    }
                }
            }
            self.answer = Some((band.band, [po, pi]));
        }
        let leaf = |p: usize| {
            let path = &self.paths[p];
            path.levels[path.depth.saturating_sub(1)].face.views
        };
        let place = Place {
            band,
            leaves: [leaf(po), leaf(pi)],
        };
        visible(&pvis, place, &self.rows[..words])
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
        let place = v.place();
        out.copy_from_slice(v.bits());
        frustum.cull(&pvis, out);
        visible(&pvis, place, out)
    }

    /// Walks the path of `shell` (path `shell % PATHS`, handed to it if another shell had it)
    /// to the leaf under `d`; returns the path's index.
    fn walk(&mut self, shell: u32, d: [f32; 3]) -> usize {
        // `PATHS` is 1 in a far-only reader, whose only shell is 0.
        #[cfg_attr(not(feature = "shells"), allow(clippy::modulo_one))]
        let p = shell as usize % PATHS;
        if self.paths[p].shell != shell {
            let visb = self.pvis.visb_of(shell);
            let level = self.pvis.shell_level(shell).min(MAX_LEVEL);
            let path = &mut self.paths[p];
            (path.shell, path.visb, path.level, path.depth) = (shell, visb, level, 0);
        }
        let level = self.paths[p].level as usize;
        let oct = octant(d);
        if self.paths[p].depth == 0 || self.paths[p].octant != oct {
            self.enter_root(p, oct);
        }
        for k in 0..level {
            let path = &self.paths[p];
            let which = choose(d, &path.levels[k].planes);
            if k + 1 < path.depth && path.levels[k].child as usize == which {
                continue;
            }
            self.enter_child(p, k, which);
        }
        p
    }

    /// Starts path `p` at root face `oct`, decoding its three level-0 corners.
    fn enter_root(&mut self, p: usize, oct: usize) {
        let words = self.pvis.row_words();
        let face = root_face(oct);
        self.use_cache_for(p);
        let base = 1 + p * self.path_rows;
        for (i, &v) in face.views.iter().enumerate() {
            let slot = (base + i) * words;
            // The scratch holds every slot (`Pvis::scratch_bound`), so the row is there.
            if let Some(row) = self.rows.get_mut(slot..slot + words) {
                self.pvis.decode_row(
                    &self.paths[p].visb,
                    v,
                    face.lattice[i],
                    None,
                    row,
                    &mut self.cache,
                );
            }
        }
        self.decoded += 3;
        self.set_level(p, 0, face, [0, 1, 2]);
        self.paths[p].octant = oct;
    }

    /// Empties the tree cache if it holds another shell's lookups than path `p`'s.
    fn use_cache_for(&mut self, p: usize) {
        let shell = self.paths[p].shell;
        if self.cache_shell != shell {
            self.cache.clear();
            self.cache_shell = shell;
        }
    }

    /// Makes `face` (with corner rows in `slots`) path `p`'s face at level `k`.
    fn set_level(&mut self, p: usize, k: usize, face: Face, slots: [u8; 3]) {
        let path = &mut self.paths[p];
        let leaf = k == path.level as usize;
        let entry = &mut path.levels[k];
        entry.face = face;
        entry.slots = slots;
        entry.mid_ready = [false; 3];
        if !leaf {
            entry.planes = planes(&children(&face));
        }
        path.depth = k + 1;
        self.answer = None;
    }

    /// Moves path `p` below level `k` into child `which`, decoding the midpoints it needs.
    fn enter_child(&mut self, p: usize, k: usize, which: usize) {
        let words = self.pvis.row_words();
        let base = (1 + p * self.path_rows) * words;
        let kids = children(&self.paths[p].levels[k].face);
        let corners = CHILD_CORNERS[which];
        for &c in &corners {
            if c < 3 || self.paths[p].levels[k].mid_ready[c - 3] {
                continue;
            }
            self.use_cache_for(p);
            let j = c - 3;
            let entry = &self.paths[p].levels[k];
            let (mid, point) = mid(&kids, j);
            let [e0, e1] = EDGES[j];
            // The context orders the parents by view index (spec § Context).
            let (mut pa, mut pb) = (e0, e1);
            if entry.face.views[pa] > entry.face.views[pb] {
                core::mem::swap(&mut pa, &mut pb);
            }
            let (sa, sb) = (
                base + entry.slots[pa] as usize * words,
                base + entry.slots[pb] as usize * words,
            );
            let target = base + mid_slot(k, j) as usize * words;
            // Corner slots of level k are roots or midpoints of levels < k: all below target,
            // and every slot is in the scratch (`Pvis::scratch_bound`).
            let (lo, hi) = self.rows.split_at_mut(target.min(self.rows.len()));
            if let (Some(ra), Some(rb), Some(out)) = (
                lo.get(sa..sa + words),
                lo.get(sb..sb + words),
                hi.get_mut(..words),
            ) {
                let visb = self.paths[p].visb;
                self.pvis
                    .decode_row(&visb, mid, point, Some((ra, rb)), out, &mut self.cache);
            }
            self.decoded += 1;
            self.paths[p].levels[k].mid_ready[j] = true;
        }
        let entry = &self.paths[p].levels[k];
        let all = [
            entry.slots[0],
            entry.slots[1],
            entry.slots[2],
            mid_slot(k, 0),
            mid_slot(k, 1),
            mid_slot(k, 2),
        ];
        self.paths[p].levels[k].child = which as u8;
        self.set_level(p, k + 1, kids[which], corners.map(|c| all[c]));
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
                origin_leaf_at(level),
                locate([0.0; 3], level).views,
                "level {level}"
            );
        }
    }
}
