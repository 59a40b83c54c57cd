//! Reading VISB (spec § VISB): raw rows (encoding 0) or rows coded along the sphere hierarchy
//! (encodings 1 and 2), and the two ways of decoding the latter.
//!
//! Encodings 1 and 2 code each view's bits with a static-model binary range coder whose
//! probabilities depend on the view's two parent views' bits (the endpoints of the sphere edge
//! it splits) near the patch and on its own earlier bits (`model`: a table, or a context
//! tree), so one view decodes from its parents' rows alone ([`Visb::decode_row`], used when
//! the parents' rows are at hand: streaming and expanded queries). Without them,
//! [`Visb::or_rows_lockstep`] decodes a view together with its whole ancestor closure bit by
//! bit in lock step — the contexts only look a few patches around `p`, so each ancestor needs
//! a decoder state and its last 64 bits, not a row — which keeps
//! [`crate::runtime::Pvis::view_row`] and the stateless query free of scratch beyond the output
//! row. Cost: decoding one bit is one range-coder step plus a key and a (memoised) tree walk;
//! lock step decodes the `3 + 3·level` views of the closure.
//!
//! Where a checked body's model, checkpoints and records lie follows from its fixed fields
//! ([`Visb::at`]): parse reads VISB and every shell's payload so once it has checked them, and
//! a query opens a shell's rows again the same way.

use super::coder::RangeDecoder;
use super::consts::{
    CHECKPOINT_INTERVAL, CONTEXTS, ENCODING_HIERARCHICAL, ENCODING_RAW, MAX_LANES, MAX_VARINT_LEN,
    VISB_HEADER_LEN, row_bytes,
};
use super::model::{TreeCache, ViewModel, ViewState, tree_features};
use super::ptch::{Axis, PatchTable};
use crate::sphere::{LatticePoint, lattice_point, level_of, parents, view_count};

/// The VISB payload of a validated file.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Visb<'a> {
    /// Encoding 0: `views × row_bytes` bytes of rows.
    Raw {
        /// The rows.
        rows: &'a [u8],
        /// Bytes per row.
        row_bytes: usize,
    },
    /// Encodings 1 and 2: range-coded rows, each view given its parents.
    Hierarchical {
        /// What predicts each bit.
        model: Model<'a>,
        /// `ceil(views / CHECKPOINT_INTERVAL)` little-endian `u32` record offsets.
        checkpoints: &'a [u8],
        /// The view records: LEB128 length, then that many code bytes.
        records: &'a [u8],
    },
}

/// The probability model of a range-coded payload.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Model<'a> {
    /// Encoding 1: `(level + 1) × CONTEXTS` little-endian `u16` probabilities, each in `1..4096`.
    Table(&'a [u8]),
    /// Encoding 2: the context tree's validated nodes (little-endian `u16`s), and the PTCH
    /// records the facing features read.
    Tree {
        /// The nodes.
        nodes: &'a [u8],
        /// The patch table.
        patches: PatchTable<'a>,
        /// The features the tree tests: other key bits cannot change a walk, so lookups mask
        /// them off (which lets more keys share a cache entry).
        used: u32,
    },
}

impl<'a> Model<'a> {
    /// The model a decoder of the view at lattice point `point` uses.
    fn for_point(&self, point: LatticePoint) -> ViewModel<'a> {
        match *self {
            Model::Table(probs) => ViewModel::Table(level_probs(probs, point.level)),
            Model::Tree {
                nodes,
                patches,
                used,
            } => ViewModel::Tree {
                nodes,
                patches,
                used,
                lattice: point.coords,
                level: point.level,
            },
        }
    }

    /// The cone axis the facing feature of patch `p` reads (zero for encoding 1, which does
    /// not use it).
    #[inline(always)]
    fn facing_axis(&self, p: u32) -> Axis {
        match *self {
            Model::Table(_) => Axis::Int([0; 3]),
            Model::Tree { patches, .. } => patches.facing_axis(p),
        }
    }
}

/// The lattice point of `view`, which a decoder's model reads (a view of the file has one;
/// zero coordinates stand in otherwise).
pub(crate) fn point_of(view: u32) -> LatticePoint {
    lattice_point(view).unwrap_or(LatticePoint {
        level: level_of(view),
        coords: [0; 3],
    })
}

/// Reads an unsigned LEB128 of at most `MAX_VARINT_LEN` bytes at `pos`; returns the value and
/// its length, or `None` if it runs past the data or is longer.
pub(crate) fn read_varint(data: &[u8], pos: usize) -> Option<(u32, usize)> {
    let mut value = 0u32;
    for i in 0..MAX_VARINT_LEN {
        let byte = *data.get(pos.checked_add(i)?)?;
        value |= u32::from(byte & 0x7F) << (7 * i);
        if byte & 0x80 == 0 {
            return Some((value, i + 1));
        }
    }
    None
}

/// The 32 little-endian `u16` probabilities of `level` (validated at parse: present and in
/// `1..4096`). Borrowed, not widened into an array: a lock-step decoder keeps a model per
/// lane, 24 of them at level 7, in a microcontroller's stack.
pub(crate) fn level_probs(probs: &[u8], level: u32) -> &[u8; 2 * CONTEXTS] {
    let start = level as usize * CONTEXTS * 2;
    probs
        .get(start..start + 2 * CONTEXTS)
        .and_then(|b| b.try_into().ok())
        // The fallback (probability ½) keeps this total.
        .unwrap_or(&HALF)
}

/// 32 probabilities of ½.
pub(crate) const HALF: [u8; 2 * CONTEXTS] = {
    let mut table = [0u8; 2 * CONTEXTS];
    let mut i = 0;
    while i < CONTEXTS {
        table[2 * i + 1] = 2048u16.to_le_bytes()[1];
        i += 1;
    }
    table
};

impl<'a> Visb<'a> {
    /// The rows of a VISB `body` (from its `encoding` field to its end) that parse validated,
    /// for the views of `level` and rows of `patch_count` bits whose patch table is `patches`.
    /// Where each part lies follows from the fields before it (§ VISB), so this reads no
    /// record.
    pub(crate) fn at(
        body: &'a [u8],
        level: u32,
        patch_count: u32,
        patches: PatchTable<'a>,
    ) -> Visb<'a> {
        // Each part is cut off the front of the rest; parse checked that every cut fits.
        let cut = |rest: &'a [u8], n: usize| rest.split_at_checked(n).unwrap_or_default();
        let (fixed, rest) = cut(body, VISB_HEADER_LEN as usize);
        // `encoding` is 0, 1 or 2 (little-endian): its first byte says which.
        let (model, rest) = match fixed.first().map_or(0, |&e| u32::from(e)) {
            ENCODING_RAW => {
                return Visb::Raw {
                    rows: rest,
                    row_bytes: row_bytes(patch_count) as usize,
                };
            }
            ENCODING_HIERARCHICAL => {
                let (probs, rest) = cut(rest, (level as usize + 1) * CONTEXTS * 2);
                (Model::Table(probs), rest)
            }
            _ => {
                // `node_count` is at most 1,024: its two low bytes hold it.
                let (count, rest) = cut(rest, 4);
                let count = count.first_chunk().map_or(0, |&b| u16::from_le_bytes(b));
                let (nodes, rest) = cut(rest, 2 * usize::from(count));
                let used = tree_features(nodes);
                (
                    Model::Tree {
                        nodes,
                        patches,
                        used,
                    },
                    rest,
                )
            }
        };
        let (checkpoints, records) = cut(
            rest,
            4 * view_count(level).div_ceil(CHECKPOINT_INTERVAL) as usize,
        );
        Visb::Hierarchical {
            model,
            checkpoints,
            records,
        }
    }

    /// The code bytes of `view` (encoding 1); empty for encoding 0 or an impossible lookup.
    pub(crate) fn code(&self, view: u32) -> &'a [u8] {
        let Visb::Hierarchical {
            checkpoints,
            records,
            ..
        } = *self
        else {
            return &[];
        };
        let k = (view / CHECKPOINT_INTERVAL) as usize * 4;
        let Some(cp) = checkpoints.get(k..k + 4) else {
            return &[];
        };
        let mut pos = u32::from_le_bytes([cp[0], cp[1], cp[2], cp[3]]) as usize;
        // Walk the length prefixes from the checkpoint; parse checked every one of them.
        for _ in 0..view % CHECKPOINT_INTERVAL {
            let Some((len, n)) = read_varint(records, pos) else {
                return &[];
            };
            pos += n + len as usize;
        }
        match read_varint(records, pos) {
            Some((len, n)) => records.get(pos + n..pos + n + len as usize).unwrap_or(&[]),
            None => &[],
        }
    }

    /// Decodes the row of `view` (encodings 1 and 2), whose lattice point is `point`
    /// ([`point_of`]; a caller that walks the face hierarchy has it at hand), into `out`
    /// (`ceil(patch_count / 64)` words), given its parents' decoded rows (`None` for a
    /// level-0 view).
    pub(crate) fn decode_row(
        &self,
        view: u32,
        point: LatticePoint,
        parent_rows: Option<(&[u64], &[u64])>,
        out: &mut [u64],
        patch_count: u32,
        cache: &mut TreeCache<'_>,
    ) {
        let Visb::Hierarchical { model, .. } = *self else {
            return;
        };
        let model = model.for_point(point);
        let (ra, rb) = parent_rows.unwrap_or((&[], &[]));
        let mut d = RangeDecoder::new(self.code(view));
        let mut state = ViewState::default();
        let word = |r: &[u64], i: usize| r.get(i).copied().unwrap_or(0);
        // The parents' 5-bit windows around the patch (bit i: patch p − 2 + i), slid one patch
        // per bit from a stream of each parent's bits two patches ahead. Decoded rows have no
        // bits past the last patch, so the stream needs no end test.
        let (mut wa, mut wb) = (
            ((word(ra, 0) & 3) << 3) as u32,
            ((word(rb, 0) & 3) << 3) as u32,
        );
        let mut first = 0u32;
        for (w, out_word) in out.iter_mut().enumerate() {
            let n = patch_count.saturating_sub(first).min(64);
            let ahead_a = word(ra, w) >> 2 | word(ra, w + 1) << 62;
            let ahead_b = word(rb, w) >> 2 | word(rb, w + 1) << 62;
            let front = model.front_bits(first, n);
            let mut x = 0u64;
            for j in 0..n {
                wa = wa >> 1 | ((ahead_a >> j & 1) as u32) << 4;
                wb = wb >> 1 | ((ahead_b >> j & 1) as u32) << 4;
                let f = (front >> j & 1) as u32;
                let bit = d.bit(model.p0_facing(wa, wb, state, f, cache)) as u32;
                x |= u64::from(bit) << j;
                state.push(bit, wa >> 2 & 1, wb >> 2 & 1);
            }
            *out_word = x;
            first += n;
        }
    }

    /// ORs the rows of `targets` (encodings 1 and 2) into `out`, decoding them and their
    /// ancestors in lock step. `targets` must be views of the file (`< view_count(level)`)
    /// whose ancestor closure has at most `MAX_LANES` views — true of a leaf's corners and of
    /// any single view.
    ///
    /// A bit's features reach two patches ahead in the parents' rows, so a view of level `l`
    /// runs `2·l` patches behind the level-0 views: at step `t` it decodes patch `t − 2·l`,
    /// when every ancestor (lower level, processed earlier in the step) is at least two
    /// patches ahead. Each lane keeps its last 64 bits, enough for any window a child reads.
    pub(crate) fn or_rows_lockstep(&self, targets: &[u32], out: &mut [u64], patch_count: u32) {
        let Visb::Hierarchical { model, .. } = *self else {
            return;
        };
        let mut views = [0u32; MAX_LANES];
        let n = ancestor_closure(targets, &mut views);
        let views = &views[..n];
        let mut lanes = [Lane::default(); MAX_LANES];
        let mut max_lag = 0;
        for (lane, &v) in lanes.iter_mut().zip(views) {
            lane.decoder = RangeDecoder::new(self.code(v));
            lane.model = model.for_point(point_of(v));
            lane.lag = 2 * level_of(v);
            max_lag = max_lag.max(lane.lag);
            lane.parents = parents(v).map(|[a, b]| {
                // Parents precede their children in ascending order, so they are found.
                let find = |p| views.iter().position(|&x| x == p).unwrap_or(0) as u8;
                (find(a), find(b))
            });
            lane.target = targets.contains(&v);
        }
        let lanes = &mut lanes[..n];
        let mut slots = [0u64; 256];
        let mut cache = TreeCache::new(&mut slots);
        // Lanes are in level order and the lanes of one level decode the same patch, so the
        // patch's axis (unpacked from a compact table) is read once per level and step.
        let mut axis = (u32::MAX, Axis::Int([0; 3]));
        for t in 0..patch_count + max_lag {
            for i in 0..lanes.len() {
                let Some(p) = t.checked_sub(lanes[i].lag).filter(|&p| p < patch_count) else {
                    continue;
                };
                let (wa, wb) = match lanes[i].parents {
                    Some((pa, pb)) => (lanes[pa as usize].window(p), lanes[pb as usize].window(p)),
                    None => (0, 0),
                };
                if axis.0 != p {
                    axis = (p, model.facing_axis(p));
                }
                let lane = &mut lanes[i];
                let front = lane.model.front(axis.1);
                let bit = lane
                    .decoder
                    .bit(lane.model.p0_facing(wa, wb, lane.state, front, &mut cache))
                    as u32;
                lane.state.push(bit, wa >> 2 & 1, wb >> 2 & 1);
                lane.history = lane.history << 1 | u64::from(bit);
                lane.decoded = p + 1;
                if let (true, Some(word)) = (lane.target, out.get_mut(p as usize / 64)) {
                    *word |= u64::from(bit) << (p % 64);
                }
            }
        }
    }
}

/// One view being decoded in lock step.
#[derive(Clone, Copy, Debug)]
struct Lane<'a> {
    decoder: RangeDecoder<'a>,
    model: ViewModel<'a>,
    /// Lane indices of the parents (`None` at level 0).
    parents: Option<(u8, u8)>,
    /// Steps this lane runs behind the level-0 lanes: twice its level.
    lag: u32,
    /// Patches decoded so far.
    decoded: u32,
    /// Bit `i`: the bit at patch `decoded − 1 − i`.
    history: u64,
    state: ViewState,
    target: bool,
}

impl Lane<'_> {
    /// This lane's 5-bit window around patch `p` (bit `i`: patch `p − 2 + i`; 0 outside the
    /// row). Every patch of the window below `patch_count` is already decoded: `history`
    /// holds it, newest patch in bit 0, and zeros before patch 0; patches past the end are
    /// shifted in as zeros.
    #[inline(always)]
    fn window(&self, p: u32) -> u32 {
        // Bit 0 of `h` is patch p + 2, bit 4 patch p − 2: the window reversed.
        let shift = i64::from(self.decoded) - 1 - (i64::from(p) + 2);
        let h = if shift >= 0 {
            self.history.checked_shr(shift as u32).unwrap_or(0)
        } else {
            self.history.checked_shl((-shift) as u32).unwrap_or(0)
        };
        REVERSE5[(h & 31) as usize] as u32
    }
}

/// `REVERSE5[x]` is the 5-bit `x` with its bits in reverse order.
const REVERSE5: [u8; 32] = {
    let mut table = [0u8; 32];
    let mut x = 0;
    while x < 32 {
        let mut r = 0;
        let mut i = 0;
        while i < 5 {
            r |= ((x >> i) & 1) << (4 - i);
            i += 1;
        }
        table[x] = r as u8;
        x += 1;
    }
    table
};

impl Default for Lane<'_> {
    fn default() -> Self {
        Lane {
            decoder: RangeDecoder::new(&[]),
            model: ViewModel::Table(&HALF),
            parents: None,
            lag: 0,
            decoded: 0,
            history: 0,
            state: ViewState::default(),
            target: false,
        }
    }
}

/// The views of `targets` and all their ancestors, ascending (so parents come before
/// children), in `out`; returns how many. Stops adding at `out.len()` views, which the
/// exhaustive test of `MAX_LANES` shows never happens for a leaf's corners.
pub(crate) fn ancestor_closure(targets: &[u32], out: &mut [u32]) -> usize {
    let mut n = 0;
    let push = |v: u32, out: &mut [u32], n: &mut usize| {
        if !out[..*n].contains(&v) && *n < out.len() {
            out[*n] = v;
            *n += 1;
        }
    };
    for &t in targets {
        push(t, out, &mut n);
    }
    let mut i = 0;
    while i < n {
        if let Some([a, b]) = parents(out[i]) {
            push(a, out, &mut n);
            push(b, out, &mut n);
        }
        i += 1;
    }
    // Insertion sort: at most `MAX_LANES` views, and a few hundred bytes less code than
    // `sort_unstable` where code size counts (the WebAssembly and microcontroller builds).
    for i in 1..n {
        let mut j = i;
        while j > 0 && out[j - 1] > out[j] {
            out.swap(j - 1, j);
            j -= 1;
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::{Face, MAX_LEVEL, children, root_faces};

    /// `MAX_LANES` bounds the ancestor closure of every leaf of every level: checked
    /// exhaustively (131,072 leaves at level 7), so the lock-step decoder never drops a lane.
    #[test]
    fn every_leaf_closure_fits_max_lanes() {
        let mut faces: Vec<Face> = root_faces().to_vec();
        for level in 0..=MAX_LEVEL {
            let mut out = [0u32; MAX_LANES + 1];
            let worst = faces
                .iter()
                .map(|f| ancestor_closure(&f.views, &mut out))
                .max()
                .unwrap();
            assert_eq!(worst, 3 + 3 * level as usize, "level {level}");
            if level < MAX_LEVEL {
                faces = faces.iter().flat_map(children).collect();
            }
        }
    }

    #[test]
    fn varints_are_bounded() {
        assert_eq!(read_varint(&[0x85, 0x01], 0), Some((133, 2)));
        assert_eq!(read_varint(&[0x80, 0x80, 0x80, 0x80, 0x01], 0), None);
        assert_eq!(read_varint(&[0x80], 0), None);
    }
}
