//! The VISB writer for encoding 2 (spec § VISB, encoding 2): each view's row range-coded with
//! probabilities from a context tree over the bit's features (`crate::runtime` model: the
//! parents' bits two patches either side, the view's two previous bits, which parent it last
//! followed, the patch's facing, the level).
//!
//! Three passes: count how often each distinct key saw a 0 and a 1 (parallel over views),
//! grow a decision tree on those counts — greedily the feature whose split codes the bits in
//! the fewest bits, kept only where the subtree saves more than its nodes cost in the file
//! (16 bits each), the minimum-description-length rule — then code every view through the
//! serialised tree, with the very walk a reader does. Deterministic: the counts are sums, the
//! keys are sorted, ties go to the lower feature. Cost: one key per bit (twice), a tree build
//! over the distinct keys (≤ 2^23, ~10^5 in practice), one tree walk per bit.

use super::visb::{RangeEncoder, append_records};
use crate::runtime::consts::*;
use crate::runtime::model::{
    FEATURES, LEAF, MAX_TREE_DEPTH, MAX_TREE_NODES, ViewState, facing, key, tree_p0, window,
};
use crate::sphere::{lattice_point, level_of, parents};
use crate::visibility::VisibilityMatrix;
use rayon::prelude::*;
use std::collections::{HashMap, VecDeque};

/// Bits a tree node costs in the file.
const NODE_BITS: f64 = 16.0;

/// Encodes `matrix` (rows of `view_count(level)` views over the patches whose facing axes are
/// `axes`, spec § Features `front`) as a VISB body with encoding 2.
pub fn encode_tree(matrix: &VisibilityMatrix, axes: &[[f32; 3]]) -> Vec<u8> {
    let views = matrix.views();
    let nodes = build_tree(matrix, axes);
    let mut out = Vec::new();
    out.extend_from_slice(&ENCODING_TREE.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&(nodes.len() as u32).to_le_bytes());
    let tree: Vec<u8> = nodes.iter().flat_map(|n| n.to_le_bytes()).collect();
    out.extend_from_slice(&tree);
    append_records(&mut out, views, |v, code| {
        let mut enc = RangeEncoder::new(code);
        for_each_key(matrix, v, axes, |k, x| enc.bit(x as u64, tree_p0(&tree, k)));
        enc.finish();
    });
    out
}

/// Calls `f(key, bit)` for every patch of `view` in patch order, computing each key exactly as
/// the reader does (`crate::runtime::model`).
pub(crate) fn for_each_key(
    matrix: &VisibilityMatrix,
    view: u32,
    axes: &[[f32; 3]],
    mut f: impl FnMut(u32, u32),
) {
    let n = matrix.patches();
    let row = matrix.row(view);
    let parent_rows = parents(view).map(|[a, b]| (matrix.row(a), matrix.row(b)));
    let lattice = lattice_point(view).map_or([0.0; 3], |l| l.coords.map(f64::from));
    let level = level_of(view);
    let mut state = ViewState::default();
    for p in 0..n {
        let (wa, wb) = parent_rows.map_or((0, 0), |(ra, rb)| {
            (window(ra, p as i64, n), window(rb, p as i64, n))
        });
        let k = key(wa, wb, state, facing(axes[p as usize], lattice), level);
        let x = (row[p as usize / 64] >> (p % 64) & 1) as u32;
        f(k, x);

        state.push(x, wa >> 2 & 1, wb >> 2 & 1);
    }
}

/// Counts per distinct key, sorted by key.
fn key_counts(matrix: &VisibilityMatrix, axes: &[[f32; 3]]) -> Vec<(u32, [u64; 2])> {
    let counts = (0..matrix.views())
        .into_par_iter()
        .fold(HashMap::<u32, [u64; 2]>::new, |mut m, v| {
            for_each_key(matrix, v, axes, |k, x| {
                m.entry(k).or_default()[x as usize] += 1
            });
            m
        })
        .reduce(HashMap::new, |mut a, b| {
            for (k, c) in b {
                let e = a.entry(k).or_default();
                e[0] += c[0];
                e[1] += c[1];
            }
            a
        });
    let mut counts: Vec<_> = counts.into_iter().collect();
    counts.sort_unstable_by_key(|&(k, _)| k);
    counts
}

/// The probability of a 0 a leaf with these counts stores: the empirical frequency in units of
/// `1 / 2^PROB_BITS`, rounded and clamped to `1..2^PROB_BITS` (½ for no samples).
fn leaf_p0([n0, n1]: [u64; 2]) -> u16 {
    let one = 1u64 << PROB_BITS;
    let n = n0 + n1;
    (n0 * one + n / 2)
        .checked_div(n)
        .map_or((one / 2) as u16, |p| p.clamp(1, one - 1) as u16)
}

/// Bits that coding these counts with the leaf's stored probability takes.
fn leaf_bits(c: [u64; 2]) -> f64 {
    let p0 = leaf_p0(c) as f64 / (1u64 << PROB_BITS) as f64;
    -(c[0] as f64 * p0.log2() + c[1] as f64 * (1.0 - p0).log2())
}

/// A grown tree before serialisation.
enum Grown {
    Leaf([u64; 2]),
    Split(u32, Box<[Grown; 2]>),
}

impl Grown {
    fn nodes(&self) -> usize {
        match self {
            Grown::Leaf(_) => 1,
            Grown::Split(_, c) => 1 + c[0].nodes() + c[1].nodes(),
        }
    }
}

fn total(samples: &[(u32, [u64; 2])]) -> [u64; 2] {
    samples
        .iter()
        .fold([0, 0], |t, (_, c)| [t[0] + c[0], t[1] + c[1]])
}

/// Grows the subtree for `samples` over the features in `free`; returns it and its cost in
/// bits (codes plus `node_bits` per node). A split stays only if it pays for its nodes.
fn grow(samples: &[(u32, [u64; 2])], free: u32, node_bits: f64) -> (Grown, f64) {
    let here = total(samples);
    let leaf_cost = leaf_bits(here) + node_bits;
    let mut best: Option<(f64, u32)> = None;
    for f in (0..FEATURES).filter(|f| free >> f & 1 == 1) {
        let mut split = [[0u64; 2]; 2];
        for (k, c) in samples {
            let side = &mut split[(k >> f & 1) as usize];
            side[0] += c[0];
            side[1] += c[1];
        }
        if split.iter().any(|s| s[0] + s[1] == 0) {
            continue;
        }
        let bits = leaf_bits(split[0]) + leaf_bits(split[1]);
        if best.is_none_or(|(b, _)| bits < b) {
            best = Some((bits, f));
        }
    }
    let Some((bits, f)) = best else {
        return (Grown::Leaf(here), leaf_cost);
    };
    // The best split's own leaves do not pay for their two nodes: stop here (a subtree below
    // could still pay, but seldom does; this keeps the build linear in practice).
    if leaf_bits(here) - bits <= 2.0 * node_bits {
        return (Grown::Leaf(here), leaf_cost);
    }
    let (zeros, ones): (Vec<_>, Vec<_>) = samples.iter().partition(|(k, _)| k >> f & 1 == 0);
    let rest = free & !(1 << f);
    let (l, lc) = grow(&zeros, rest, node_bits);
    let (r, rc) = grow(&ones, rest, node_bits);
    let split_cost = lc + rc + node_bits;
    if split_cost < leaf_cost {
        (Grown::Split(f, Box::new([l, r])), split_cost)
    } else {
        (Grown::Leaf(here), leaf_cost)
    }
}

/// The serialised tree for `matrix`: nodes in breadth-first order (so children follow their
/// parent and siblings are adjacent), at most `MAX_TREE_NODES`.
fn build_tree(matrix: &VisibilityMatrix, axes: &[[f32; 3]]) -> Vec<u16> {
    let samples = key_counts(matrix, axes);
    let mut node_bits = NODE_BITS;
    let mut root = grow(&samples, (1 << FEATURES) - 1, node_bits).0;
    // Over the node limit (only on very large matrices): price nodes higher until it fits.
    while root.nodes() > MAX_TREE_NODES as usize {
        node_bits *= 2.0;
        root = grow(&samples, (1 << FEATURES) - 1, node_bits).0;
    }
    let mut out = Vec::new();
    let mut queue = VecDeque::from([&root]);
    let mut next = 1u16;
    while let Some(node) = queue.pop_front() {
        match node {
            Grown::Leaf(c) => out.push(LEAF | leaf_p0(*c)),
            Grown::Split(f, children) => {
                out.push((*f as u16) << 10 | next);
                next += 2;
                queue.extend(children.iter());
            }
        }
    }
    debug_assert!(out.len() <= MAX_TREE_NODES as usize && FEATURES <= MAX_TREE_DEPTH);
    out
}
