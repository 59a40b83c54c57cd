//! Reading VISB (spec § VISB): raw rows (encoding 0) or rows coded along the sphere hierarchy
//! (encoding 1), and the two ways of decoding the latter.
//!
//! Encoding 1 codes each view's bits with a static-model binary range coder whose context is
//! the view's two parent views' bits (the endpoints of the sphere edge it splits), so one view
//! decodes from its parents' rows alone ([`Visb::decode_row`], used when the parents' rows are
//! at hand: streaming and expanded queries). Without them, [`Visb::or_rows_lockstep`] decodes a
//! view together with its whole ancestor closure bit by bit in lock step — the contexts only
//! look at patch `p` and `p − 1`, so each ancestor needs a decoder state and two bits, not a
//! row — which keeps [`crate::runtime::Pvis::view_row`] and the stateless query free of
//! scratch beyond the output row. Cost: decoding one bit is one range-coder step; lock step
//! decodes the `3 + 3·level` views of the closure.

use super::coder::{RangeDecoder, context};
use super::consts::{CHECKPOINT_INTERVAL, CONTEXTS, MAX_LANES, MAX_VARINT_LEN};
use crate::sphere::{level_of, parents};

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
    /// Encoding 1.
    Hierarchical {
        /// `(level + 1) × CONTEXTS` little-endian `u16` probabilities, each in `1..4096`.
        probs: &'a [u8],
        /// `ceil(views / CHECKPOINT_INTERVAL)` little-endian `u32` record offsets.
        checkpoints: &'a [u8],
        /// The view records: LEB128 length, then that many code bytes.
        records: &'a [u8],
    },
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

/// The 32 probabilities of `level`, widened for the decoder's multiply.
pub(crate) fn level_probs(probs: &[u8], level: u32) -> [u32; CONTEXTS] {
    let start = level as usize * CONTEXTS * 2;
    core::array::from_fn(|c| {
        let i = start + 2 * c;
        // Validated at parse: present and in 1..4096. The fallback keeps this total.
        probs
            .get(i..i + 2)
            .map_or(2048, |b| u16::from_le_bytes([b[0], b[1]]) as u32)
    })
}

impl<'a> Visb<'a> {
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

    /// Decodes the row of `view` (encoding 1) into `out` (`ceil(patch_count / 64)` words),
    /// given its parents' decoded rows (`None` for a level-0 view).
    pub(crate) fn decode_row(
        &self,
        view: u32,
        parent_rows: Option<(&[u64], &[u64])>,
        out: &mut [u64],
        patch_count: u32,
    ) {
        let Visb::Hierarchical { probs, .. } = *self else {
            return;
        };
        let probs = level_probs(probs, level_of(view));
        let mut d = RangeDecoder::new(self.code(view));
        let (mut x_prev, mut a_prev, mut b_prev) = (0u64, 0u64, 0u64);
        let mut left = patch_count;
        for (w, word) in out.iter_mut().enumerate() {
            let n = left.min(64);
            left -= n;
            let (aw, bw) = match parent_rows {
                Some((a, b)) => (
                    a.get(w).copied().unwrap_or(0),
                    b.get(w).copied().unwrap_or(0),
                ),
                None => (0, 0),
            };
            let mut x = 0u64;
            for j in 0..n {
                let (a, b) = (aw >> j & 1, bw >> j & 1);
                let bit = d.bit(probs[context(a, b, x_prev, a_prev, b_prev)]);
                x |= bit << j;
                (x_prev, a_prev, b_prev) = (bit, a, b);
            }
            *word = x;
        }
    }

    /// ORs the rows of `targets` (encoding 1) into `out`, decoding them and their ancestors in
    /// lock step. `targets` must be views of the file (`< view_count(level)`) whose ancestor
    /// closure has at most `MAX_LANES` views — true of a leaf's corners and of any single view.
    pub(crate) fn or_rows_lockstep(&self, targets: &[u32], out: &mut [u64], patch_count: u32) {
        let Visb::Hierarchical { probs, .. } = *self else {
            return;
        };
        let mut views = [0u32; MAX_LANES];
        let n = ancestor_closure(targets, &mut views);
        let views = &views[..n];
        let mut lanes: [Lane<'a>; MAX_LANES] = core::array::from_fn(|_| Lane::default());
        for (lane, &v) in lanes.iter_mut().zip(views) {
            lane.decoder = RangeDecoder::new(self.code(v));
            lane.probs = level_probs(probs, level_of(v));
            lane.parents = parents(v).map(|[a, b]| {
                // Parents precede their children in ascending order, so they are found.
                let find = |p| views.iter().position(|&x| x == p).unwrap_or(0) as u8;
                (find(a), find(b))
            });
            lane.target = targets.contains(&v);
        }
        let lanes = &mut lanes[..n];
        for p in 0..patch_count {
            let mut acc = 0u64;
            for i in 0..lanes.len() {
                let (a, b, a_prev, b_prev) = match lanes[i].parents {
                    Some((pa, pb)) => {
                        let (pa, pb) = (&lanes[pa as usize], &lanes[pb as usize]);
                        (pa.bit, pb.bit, pa.prev, pb.prev)
                    }
                    None => (0, 0, 0, 0),
                };
                let lane = &mut lanes[i];
                let ctx = context(a, b, lane.bit, a_prev, b_prev);
                // `lane.bit` still holds the bit at p − 1 until it is overwritten here.
                lane.prev = lane.bit;
                lane.bit = lane.decoder.bit(lane.probs[ctx]);
                if lane.target {
                    acc |= lane.bit;
                }
            }
            if let Some(word) = out.get_mut(p as usize / 64) {
                *word |= acc << (p % 64);
            }
        }
    }
}

/// One view being decoded in lock step.
#[derive(Clone, Copy, Debug)]
struct Lane<'a> {
    decoder: RangeDecoder<'a>,
    probs: [u32; CONTEXTS],
    /// Lane indices of the parents (`None` at level 0).
    parents: Option<(u8, u8)>,
    /// Bit at the current patch (after this lane's step) or the previous one (before it).
    bit: u64,
    /// Bit at the previous patch, valid after this lane's step.
    prev: u64,
    target: bool,
}

impl Default for Lane<'_> {
    fn default() -> Self {
        Lane {
            decoder: RangeDecoder::new(&[]),
            probs: [2048; CONTEXTS],
            parents: None,
            bit: 0,
            prev: 0,
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
    out[..n].sort_unstable();
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
