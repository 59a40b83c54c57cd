//! The VISB writer for encoding 1 (spec § VISB, encoding 1): each view's row range-coded with
//! static per-level context probabilities, the context being the view's two parent views' bits
//! (the endpoints of the sphere edge it splits) and its own previous bit.
//!
//! Two passes over the matrix: count each `(level, context)`'s zeros and ones, turn the counts into
//! 12-bit probabilities, then code every view independently — so a reader can decode any view from
//! its parents' rows alone. The range encoder is the exact inverse of the reader's `RangeDecoder`
//! (`runtime/coder.rs`) and ends each code on the shortest byte string whose zero-extension lies in
//! the final interval. Output is deterministic. Cost: two passes of one context computation per
//! bit, plus one coder step per bit in the second.

use crate::runtime::consts::*;
use crate::runtime::context;
use crate::sphere::{level_of, parents};
use crate::visibility::VisibilityMatrix;
use rayon::prelude::*;

/// Encodes `matrix` (rows of `view_count(level)` views) as a VISB body with encoding 1.
pub fn encode_hierarchical(matrix: &VisibilityMatrix, level: u32) -> Vec<u8> {
    let views = matrix.views();
    let probs = probabilities(matrix, level);
    let mut out = Vec::new();
    out.extend_from_slice(&ENCODING_HIERARCHICAL.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    for p in probs.iter().flatten() {
        out.extend_from_slice(&p.to_le_bytes());
    }
    append_records(&mut out, views, |v, code| {
        encode_view(matrix, v, &probs[level_of(v) as usize], code)
    });
    out
}

/// Appends the checkpoints and view records of encodings 1 and 2 (spec § VISB, encoding 1) to
/// `out`: `code(v, buf)` range-codes view `v` into the empty `buf`. Views are coded in
/// parallel and laid out in view order.
pub(crate) fn append_records(
    out: &mut Vec<u8>,
    views: u32,
    code: impl Fn(u32, &mut Vec<u8>) + Sync,
) {
    let codes: Vec<Vec<u8>> = (0..views)
        .into_par_iter()
        .map(|v| {
            let mut buf = Vec::new();
            code(v, &mut buf);
            buf
        })
        .collect();
    let checkpoints_at = out.len();
    out.resize(
        checkpoints_at + 4 * views.div_ceil(CHECKPOINT_INTERVAL) as usize,
        0,
    );
    let records_at = out.len();
    for (v, code) in (0..views).zip(&codes) {
        if v.is_multiple_of(CHECKPOINT_INTERVAL) {
            let k = checkpoints_at + 4 * (v / CHECKPOINT_INTERVAL) as usize;
            let offset = u32::try_from(out.len() - records_at).expect("VISB over 4 GiB");
            out[k..k + 4].copy_from_slice(&offset.to_le_bytes());
        }
        write_varint(out, code.len() as u32);
        out.extend_from_slice(code);
    }
}

/// Calls `f(context, bit)` for every patch of `view`, in patch order.
fn for_each_bit(matrix: &VisibilityMatrix, view: u32, mut f: impl FnMut(usize, u64)) {
    let row = matrix.row(view);
    let parent_rows = parents(view).map(|[a, b]| (matrix.row(a), matrix.row(b)));
    let bit = |r: &[u64], p: usize| r[p / 64] >> (p % 64) & 1;
    let (mut x_prev, mut a_prev, mut b_prev) = (0, 0, 0);
    for p in 0..matrix.patches() as usize {
        let (a, b) = parent_rows.map_or((0, 0), |(ra, rb)| (bit(ra, p), bit(rb, p)));
        let x = bit(row, p);
        f(context(a, b, x_prev, a_prev, b_prev), x);
        (x_prev, a_prev, b_prev) = (x, a, b);
    }
}

/// The static model: for each level and context, the probability of a 0 in units of
/// `1 / 2^PROB_BITS` — the empirical frequency (which minimises the coded size), rounded and
/// clamped to `1..2^PROB_BITS`; 2048 for contexts that never occur.
pub fn probabilities(matrix: &VisibilityMatrix, level: u32) -> Vec<[u16; CONTEXTS]> {
    let mut counts = vec![[[0u64; 2]; CONTEXTS]; level as usize + 1];
    for v in 0..matrix.views() {
        let c = &mut counts[level_of(v) as usize];
        for_each_bit(matrix, v, |ctx, x| c[ctx][x as usize] += 1);
    }
    let one = 1u64 << PROB_BITS;
    counts
        .iter()
        .map(|level| {
            level.map(|[n0, n1]| {
                let n = n0 + n1;
                (n0 * one + n / 2)
                    .checked_div(n)
                    .map_or((one / 2) as u16, |p| p.clamp(1, one - 1) as u16)
            })
        })
        .collect()
}

/// Range-codes the row of `view` into `out` (spec § Range coder, encoder).
fn encode_view(matrix: &VisibilityMatrix, view: u32, probs: &[u16; CONTEXTS], out: &mut Vec<u8>) {
    let mut enc = RangeEncoder::new(out);
    for_each_bit(matrix, view, |ctx, x| enc.bit(x, probs[ctx] as u32));
    enc.finish();
}

/// The encoder matching the reader's `RangeDecoder` (`runtime/coder.rs`): `low` is a 32-bit window
/// (plus a carry bit) onto the code, whose earlier bytes are already in `out`.
pub(crate) struct RangeEncoder<'o> {
    out: &'o mut Vec<u8>,
    start: usize,
    low: u64,
    range: u32,
}

impl<'o> RangeEncoder<'o> {
    pub(crate) fn new(out: &'o mut Vec<u8>) -> Self {
        let start = out.len();
        RangeEncoder {
            out,
            start,
            low: 0,
            range: u32::MAX,
        }
    }

    /// Adds one to the bytes already written (a carry out of `low`). The code value stays
    /// below 1, so the carry never runs past the view's first byte.
    fn carry(&mut self) {
        for byte in self.out[self.start..].iter_mut().rev() {
            *byte = byte.wrapping_add(1);
            if *byte != 0 {
                return;
            }
        }
        unreachable!("range coder carry past the start of the code");
    }

    pub(crate) fn bit(&mut self, bit: u64, p0: u32) {
        let bound = (self.range >> PROB_BITS) * p0;
        if bit == 0 {
            self.range = bound;
        } else {
            self.low += bound as u64;
            self.range -= bound;
        }
        if self.low >> 32 != 0 {
            self.carry();
            self.low &= 0xFFFF_FFFF;
        }
        while self.range < RANGE_TOP {
            self.out.push((self.low >> 24) as u8);
            self.low = (self.low << 8) & 0xFFFF_FFFF;
            self.range <<= 8;
        }
    }

    /// Ends the code: picks the value in `[low, low + range)` with the most trailing zero
    /// bits, writes its 4 bytes and drops every trailing zero byte (the decoder reads zeros
    /// past the end).
    pub(crate) fn finish(mut self) {
        let high = self.low + self.range as u64 - 1;
        let mut value = self.low;
        for k in (0..=32).rev() {
            let mask = (1u64 << k) - 1;
            let v = (self.low + mask) & !mask;
            if v <= high {
                value = v;
                break;
            }
        }
        if value >> 32 != 0 {
            self.carry();
            value &= 0xFFFF_FFFF;
        }
        self.out.extend_from_slice(&(value as u32).to_be_bytes());
        while self.out.len() > self.start && self.out.last() == Some(&0) {
            self.out.pop();
        }
    }
}

/// Appends `value` as an unsigned LEB128.
fn write_varint(out: &mut Vec<u8>, mut value: u32) {
    while value >= 0x80 {
        out.push((value as u8 & 0x7F) | 0x80);
        value >>= 7;
    }
    out.push(value as u8);
}
