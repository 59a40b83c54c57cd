//! The probability models of VISB encodings 1 and 2 (spec § Context, § Context tree): what a
//! bit is predicted from, and how that becomes the probability the range coder uses.
//!
//! Both look only at the view's two parent rows and the view's own earlier bits, so a view
//! still decodes from its parents alone. Encoding 1 indexes a 32-entry table per level with
//! five of those bits. Encoding 2 computes a wider *key* of [`FEATURES`] binary features — the
//! parents' bits two patches either side, the view's two previous bits, which parent the view
//! followed where they last disagreed, the patch's facing against the view, and the level —
//! and finds the probability at a leaf of a binary decision tree stored in the file, so the
//! writer spends table bytes only on the distinctions that pay. Cost per bit: a handful of
//! shifts for the key, then one node read per tree level (≤ [`MAX_TREE_DEPTH`]).

use super::consts::{CONTEXTS, PROB_BITS};
use super::ptch::{Axis, PatchTable};

/// Binary features in an encoding-2 key (§ Context tree, Features).
pub const FEATURES: u32 = 23;

/// Most nodes an encoding-2 tree may have (§ Resource limits): child indices are 10 bits.
pub const MAX_TREE_NODES: u32 = 1024;

/// Longest root-to-leaf path of an encoding-2 tree, in internal nodes (§ Resource limits).
pub const MAX_TREE_DEPTH: u32 = 32;

/// Set in a tree node that is a leaf (§ Context tree, Nodes).
pub const LEAF: u16 = 0x8000;

/// The features the internal nodes of a tree test, as bits (feature `f` is bit `f`): other
/// key bits cannot change a walk, so lookups mask them off.
pub(crate) fn tree_features(nodes: &[u8]) -> u32 {
    nodes
        .chunks_exact(2)
        .map(|pair| u16::from_le_bytes([pair[0], pair[1]]))
        .filter(|node| node & LEAF == 0)
        .fold(0, |used, node| {
            used | 1u32.checked_shl(u32::from(node >> 10)).unwrap_or(0)
        })
}

/// Feature bit positions in a key (§ Context tree, Features). The layout lets a decoder build
/// a key from three packed fields: the parents' 5-bit windows ([`window`]) and the view's
/// [`ViewState::bits`]; the positions that only those fields set are named here for the
/// spec and the tests.
#[allow(dead_code)]
pub mod feature {
    /// Bits `A + i`, `i = 0..5`: parent `a`'s bit at patch `p − 2 + i` (so `A + 2` is the patch
    /// itself).
    pub const A: u32 = 0;
    /// Bits `B + i`, `i = 0..5`: parent `b`'s bit at patch `p − 2 + i`.
    pub const B: u32 = 5;
    /// The view's own bit at the previous patch.
    pub const X1: u32 = 10;
    /// The view's own bit two patches back.
    pub const X2: u32 = 11;
    /// At the last earlier patch where the parents disagreed, the view agreed with `a`.
    pub const FOLLOWED_A: u32 = 12;
    /// At the last earlier patch where the parents disagreed, the view agreed with `b`.
    pub const FOLLOWED_B: u32 = 13;
    /// The view differed from both parents, where they agreed, at one of the
    /// [`super::SURPRISE_WINDOW`] (7) previous patches.
    pub const SURPRISED: u32 = 14;
    /// The patch's normal-cone axis points towards the view (positive dot product, [`super::facing`]).
    pub const FRONT: u32 = 15;
    /// Bits `LEVEL + k`, `k = 0..7`: the view's level is above `k`.
    pub const LEVEL: u32 = 16;
}

/// A bit `p` of a row of `len` bits, 0 outside `0..len`.
#[inline(always)]
#[cfg_attr(not(feature = "bake"), allow(dead_code))] // the writer's, and the tests'
pub fn row_bit(row: &[u64], p: i64, len: u32) -> u32 {
    if p < 0 || p >= len as i64 {
        return 0;
    }
    row.get(p as usize / 64)
        .map_or(0, |w| (w >> (p as u64 % 64) & 1) as u32)
}

/// The 5-bit window of `row` around `p`: bit `i` is the row's bit at `p − 2 + i`.
#[inline(always)]
#[cfg_attr(not(feature = "bake"), allow(dead_code))] // the writer's, and the tests'
pub fn window(row: &[u64], p: i64, len: u32) -> u32 {
    (0..5).fold(0, |w, i| w | row_bit(row, p - 2 + i, len) << i)
}

/// How many previous patches a surprise still sets feature [`feature::SURPRISED`] for.
pub const SURPRISE_WINDOW: u32 = 7;

/// What an encoding-2 decoder carries from bit to bit of one view besides the parents' rows.
#[derive(Clone, Copy, Debug, Default)]
pub struct ViewState {
    /// Key bits `X1..=SURPRISED`, shifted down to bit 0: the view's previous two bits, which
    /// parent it followed where they last disagreed, and whether a surprise is recent.
    pub bits: u32,
    /// Bit `i`: patch `p − 1 − i` was a *surprise* — the parents agreed there and the view
    /// did not (the last [`SURPRISE_WINDOW`] patches).
    pub surprises: u32,
}

impl ViewState {
    /// Records the decoded `bit` at a patch where the parents' bits were `a` and `b`.
    /// Branch-free: the bits are as unpredictable as the data.
    #[inline(always)]
    pub fn push(&mut self, bit: u32, a: u32, b: u32) {
        let own = (self.bits << 1 | bit) & 3;
        let disagree = a ^ b;
        // Where the parents disagree the view follows `a` (1) or `b` (2); else no change.
        let followed = 1 + (bit ^ a);
        let follow = (self.bits >> 2 & 3)
            ^ ((followed ^ (self.bits >> 2 & 3)) & 0u32.wrapping_sub(disagree));
        let surprise = (disagree ^ 1) & (bit ^ a);
        self.surprises = (self.surprises << 1 | surprise) & ((1 << SURPRISE_WINDOW) - 1);
        self.bits = own | follow << 2 | u32::from(self.surprises != 0) << 4;
    }
}

/// The encoding-2 key of a bit (§ Context tree, Features) from the parents' windows `wa`, `wb`
/// ([`window`]), the view's [`ViewState`], the patch's [`facing`] bit and the view's level.
#[inline(always)]
pub fn key(wa: u32, wb: u32, state: ViewState, facing: u32, level: u32) -> u32 {
    use feature::*;
    wa << A | wb << B | state.bits << X1 | facing << FRONT | ((1u32 << level.min(7)) - 1) << LEVEL
}

/// The encoding-1 context (§ Context) of the bit whose encoding-2 key is `key`:
/// `16·a + 8·b + 4·x₋₁ + 2·a₋₁ + b₋₁`.
#[inline(always)]
pub fn table_context(key: u32) -> usize {
    use feature::*;
    let bit = |i: u32| (key >> i & 1) as usize;
    bit(A + 2) << 4 | bit(B + 2) << 3 | bit(X1) << 2 | bit(A + 1) << 1 | bit(B + 1)
}

/// Feature [`feature::FRONT`] of a patch with cone axis `q` seen from a view at lattice point
/// `v` (§ Sampling sphere, Lattice): `(q.x·v.x + q.y·v.y) + q.z·v.z > 0` in binary64, the
/// `f32` components widened. Each product is exact (24 + 8 significant bits), so only the two
/// additions round, identically everywhere, fused multiply-add or not. The definition, as the
/// writer evaluates it; the reader reaches the same bit through [`Axis::front`] without
/// binary64 arithmetic.
#[inline(always)]
#[cfg_attr(not(feature = "bake"), allow(dead_code))] // the writer's, and the tests'
pub fn facing(q: [f32; 3], v: [f64; 3]) -> u32 {
    u32::from((f64::from(q[0]) * v[0] + f64::from(q[1]) * v[1]) + f64::from(q[2]) * v[2] > 0.0)
}

/// Node `i` of a tree (little-endian `u16`s), or a leaf of probability ½ past the end.
#[inline(always)]
fn node(nodes: &[u8], i: usize) -> u16 {
    nodes
        .get(2 * i..2 * i + 2)
        .map_or(LEAF | 2048, |b| u16::from_le_bytes([b[0], b[1]]))
}

/// The probability of a 0 that the tree `nodes` gives to `key` (§ Context tree, Walk): from
/// node 0, an internal node with feature `f` and first child `c` leads to `c + bit f of key`,
/// until a leaf. Bounded by [`MAX_TREE_DEPTH`] steps even on an unvalidated tree.
#[inline(always)]
pub fn tree_p0(nodes: &[u8], key: u32) -> u32 {
    let mut i = 0usize;
    for _ in 0..=MAX_TREE_DEPTH {
        let n = node(nodes, i);
        if n & LEAF != 0 {
            return u32::from(n & 0x0FFF).max(1);
        }
        let f = u32::from(n >> 10 & 0x1F);
        i = usize::from(n & 0x3FF) + (key >> f & 1) as usize;
    }
    1 << (PROB_BITS - 1)
}

/// Words of the tree cache a [`super::Streaming`] keeps in its scratch (32 KiB).
pub const TREE_CACHE_WORDS: usize = 4096;

/// A direct-mapped memo of [`tree_p0`] over caller-provided words: the same keys recur within
/// a row and across rows (the key holds the level, so rows of every level share it), so most
/// bits skip the walk. An entry holds `key + 1` (0: empty) above the probability; the slice
/// must start zeroed. Its largest power-of-two prefix of at least 2 words is used; a shorter
/// slice (an encoding without a tree gets an empty one) disables the memo.
#[derive(Debug)]
pub(crate) struct TreeCache<'c> {
    slots: &'c mut [u64],
    /// `32 − log2(slots.len())`: the hash's top bits index the slots.
    shift: u32,
}

impl<'c> TreeCache<'c> {
    /// A cache over `slots` (all zero).
    pub(crate) fn new(slots: &'c mut [u64]) -> Self {
        let bits = slots.len().checked_ilog2().unwrap_or(0).min(31);
        let used = if bits == 0 { 0 } else { 1usize << bits };
        TreeCache {
            slots: &mut slots[..used],
            shift: 32 - bits,
        }
    }

    /// Forgets every entry, for lookups in another tree.
    pub(crate) fn clear(&mut self) {
        self.slots.fill(0);
    }

    /// [`tree_p0`]`(nodes, key)`, from the cache when it holds `key`. Every call on one cache
    /// must pass the same tree.
    #[inline(always)]
    pub(crate) fn p0(&mut self, nodes: &[u8], key: u32) -> u32 {
        // Multiplicative hash; its top bits pick the slot (with no slots, `get_mut` fails).
        let slot = (u64::from(key.wrapping_mul(0x9E37_79B1)) >> self.shift) as usize;
        let tag = u64::from(key + 1) << 32;
        let Some(entry) = self.slots.get_mut(slot) else {
            return tree_p0(nodes, key);
        };
        if *entry >> 32 == tag >> 32 {
            return *entry as u32;
        }
        let p0 = tree_p0(nodes, key);
        *entry = tag | u64::from(p0);
        p0
    }
}

/// A view's model: the encoding-1 table of its level, or the encoding-2 tree with what the
/// key needs from the view.
#[derive(Clone, Copy, Debug)]
pub(crate) enum ViewModel<'a> {
    /// Encoding 1: the level's 32 probabilities.
    Table(&'a [u8; 2 * CONTEXTS]),
    /// Encoding 2.
    Tree {
        /// The tree's nodes.
        nodes: &'a [u8],
        /// The patch table, for the cone axes.
        patches: PatchTable<'a>,
        /// The features the tree tests (a mask of key bits).
        used: u32,
        /// The view's lattice point.
        lattice: [i32; 3],
        /// The view's level.
        level: u32,
    },
}

impl ViewModel<'_> {
    /// The facing bit of a patch with cone axis `axis` (as [`PatchTable::facing_axis`] reads
    /// it) for this view; 0 for encoding 1, which does not use it.
    #[inline(always)]
    pub fn front(&self, axis: Axis) -> u32 {
        match *self {
            ViewModel::Table(_) => 0,
            ViewModel::Tree { lattice, .. } => axis.front(lattice),
        }
    }

    /// The probability of a 0 for a bit with parents' windows `wa`, `wb`, `state` and the
    /// patch's facing bit `front` ([`Self::front`], [`Self::front_bits`]); tree walks go
    /// through `cache`, which must only ever see this file's tree.
    #[inline(always)]
    pub fn p0_facing(
        &self,
        wa: u32,
        wb: u32,
        state: ViewState,
        front: u32,
        cache: &mut TreeCache<'_>,
    ) -> u32 {
        match *self {
            ViewModel::Table(probs) => {
                let c = table_context(key(wa, wb, state, 0, 0)) & (CONTEXTS - 1);
                u32::from(u16::from_le_bytes([probs[2 * c], probs[2 * c + 1]]))
            }
            ViewModel::Tree {
                nodes, level, used, ..
            } => cache.p0(nodes, key(wa, wb, state, front, level) & used),
        }
    }

    /// The facing bits of patches `first..first + n` (`n ≤ 64`), bit `i` for patch `first + i`;
    /// 0 for encoding 1, which does not use them.
    #[inline]
    pub fn front_bits(&self, first: u32, n: u32) -> u64 {
        match *self {
            ViewModel::Table(_) => 0,
            ViewModel::Tree {
                patches, lattice, ..
            } => (0..n).fold(0, |bits, i| {
                bits | u64::from(patches.facing_axis(first + i).front(lattice)) << i
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_place_every_feature() {
        let mut s = ViewState::default();
        s.push(1, 1, 0); // followed a
        s.push(0, 0, 0);
        s.push(1, 0, 0); // a surprise
        s.push(0, 1, 1); // another
        use feature::*;
        assert_eq!(s.bits, 0b1_01_10);
        let k = key(0b00100, 0b01000, s, 1, 3);
        assert_eq!(
            k,
            1 << (A + 2)
                | 1 << (B + 3)
                | 1 << X2
                | 1 << FOLLOWED_A
                | 1 << SURPRISED
                | 1 << FRONT
                | 0b111 << LEVEL
        );
        assert_eq!(table_context(1 << (A + 2) | 1 << (B + 1)), 0b10001);
    }

    #[test]
    fn facing_is_exact_at_the_threshold() {
        let q = [1.0, 0.0, 0.0];
        assert_eq!(facing(q, [1.0, 0.0, 0.0]), 1);
        assert_eq!(facing(q, [-1.0, 0.0, 0.0]), 0);
        assert_eq!(
            facing(q, [0.0, 1.0, 0.0]),
            0,
            "perpendicular is not in front"
        );
        assert_eq!(facing([0.0; 3], [1.0, 0.0, 0.0]), 0);
        // Exact products: 3·0.1f32 = 0.30000000447… < 0.3f32 = 0.30000001192…, a difference
        // binary32 arithmetic would round away.
        assert_eq!(facing([0.1, -0.3, 0.0], [3.0, 1.0, 0.0]), 0);
        assert_eq!(facing([-0.1, 0.3, 0.0], [3.0, 1.0, 0.0]), 1);
        for (q, v) in [
            ([1.0, 0.0, 0.0], [1, 0, 0]),
            ([1.0, 0.0, 0.0], [-1, 0, 0]),
            ([1.0, 0.0, 0.0], [0, 1, 0]),
            ([0.0; 3], [1, 0, 0]),
            ([0.1, -0.3, 0.0], [3, 1, 0]),
            ([-0.1, 0.3, 0.0], [3, 1, 0]),
        ] {
            assert_eq!(Axis::Float(q).front(v), facing(q, v.map(f64::from)));
        }
    }

    /// The integer axes of a compact table give `facing`'s bit in `i32`, for every axis of
    /// the widest table against lattice points of every level.
    #[test]
    fn integer_axes_face_as_in_binary64() {
        let m = (1 << 15) - 1;
        let mut rng = crate::test_kit::rng::Rng::new(15);
        for _ in 0..200_000 {
            let mut r = |n: i32| (rng.next_u64() % (2 * n as u64 + 1)) as i32 - n;
            let (x, y) = (r(m), r(m));
            let z = (m - x.abs() - y.abs()).max(-m);
            let a = [x, y, z];
            let (vx, vy) = (r(128), r(64));
            let v = [vx, vy, 128 - vx.abs() - vy.abs()];
            assert_eq!(
                Axis::Int(a).front(v),
                facing(a.map(|c| c as f32), v.map(f64::from)),
                "{a:?} · {v:?}"
            );
        }
    }

    #[test]
    fn walks_stop_on_cycles_and_missing_nodes() {
        // Node 0 tests feature 0 and points at itself: bounded, falls back to ½.
        let cyclic = 0u16.to_le_bytes();
        assert_eq!(tree_p0(&cyclic, 0), 2048);
        assert_eq!(tree_p0(&[], 5), 2048);
        let mut t = Vec::new();
        for n in [1u16, LEAF | 100, LEAF | 3000] {
            t.extend_from_slice(&n.to_le_bytes());
        }
        assert_eq!(tree_p0(&t, 0), 100);
        assert_eq!(tree_p0(&t, 1), 3000);
    }
}
