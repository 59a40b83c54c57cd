//! Final patch numbering and the triangle order it induces.
//!
//! Patches are numbered along a Z-order curve so that spatially near patches get near ids:
//! sorted by the Morton code of their bounding-box centre over the bounds of the whole mesh,
//! ties by their smallest triangle index. Triangles are then ordered by (patch id, input
//! index) with a stable counting sort, so every patch is one contiguous range.
//!
//! Cost: O(n) plus O(p log p) for sorting p patches.

use super::aabb::Aabb;
use super::morton::morton_code;

/// The numbering of a tiling: patch of each triangle, reordered triangles, patch ranges.
pub(crate) struct Numbering {
    /// Final patch id of each input triangle.
    pub patch_of: Vec<u32>,
    /// Input triangle indices sorted by (patch id, input index).
    pub order: Vec<u32>,
    /// Start of each patch's range in `order`, plus a final entry `n`.
    pub starts: Vec<u32>,
}

/// Numbers the patches. `root_of[t]` names the patch of triangle `t` by any id in
/// `0..root_of.len()`; `bbox(root)` gives that patch's box.
pub(crate) fn number_patches(root_of: &[u32], bbox: impl Fn(u32) -> Aabb) -> Numbering {
    let n = root_of.len();
    // The smallest triangle of each patch, found by the first visit in input order.
    const UNSEEN: u32 = u32::MAX;
    let mut first_triangle = vec![UNSEEN; n];
    let mut roots = Vec::new();
    for (t, &r) in root_of.iter().enumerate() {
        if first_triangle[r as usize] == UNSEEN {
            first_triangle[r as usize] = t as u32;
            roots.push(r);
        }
    }
    if roots.is_empty() {
        return Numbering {
            patch_of: Vec::new(),
            order: Vec::new(),
            starts: vec![0],
        };
    }
    let keyed: Vec<(u32, u32)> = roots
        .iter()
        .map(|&r| (r, first_triangle[r as usize]))
        .collect();
    let ids = final_ids(&keyed, bbox);

    // Reuse `first_triangle` as the map from root to final id.
    let final_id = &mut first_triangle;
    for (&(r, _), &id) in keyed.iter().zip(&ids) {
        final_id[r as usize] = id;
    }
    let patch_of: Vec<u32> = root_of.iter().map(|&r| final_id[r as usize]).collect();

    let mut counts = vec![0u32; keyed.len()];
    for &p in &patch_of {
        counts[p as usize] += 1;
    }
    let starts = starts_of(&counts);
    let mut order = vec![0u32; n];
    fill_order(&patch_of, &starts, &mut order);
    Numbering {
        patch_of,
        order,
        starts,
    }
}

/// Final ids of the patches `(root, smallest triangle)`: ranks in the order of the Morton
/// code of their box centres over the union of all boxes, ties by smallest triangle.
/// Smallest triangles must be distinct.
pub(crate) fn final_ids(patches: &[(u32, u32)], bbox: impl Fn(u32) -> Aabb) -> Vec<u32> {
    let Some(bounds) = patches
        .iter()
        .map(|&(r, _)| bbox(r))
        .reduce(|m, b| m.union(&b))
    else {
        return Vec::new();
    };
    let mut keyed: Vec<(u64, u32, usize)> = patches
        .iter()
        .enumerate()
        .map(|(i, &(r, first))| (morton_code(bbox(r).center(), &bounds), first, i))
        .collect();
    // Smallest triangles are distinct, so the key is total and the sort deterministic.
    keyed.sort_unstable();
    let mut ids = vec![0u32; patches.len()];
    for (id, &(_, _, i)) in keyed.iter().enumerate() {
        ids[i] = id as u32;
    }
    ids
}

/// Prefix sums of `counts` with a leading zero: where each patch's range starts, plus the end.
pub(crate) fn starts_of(counts: &[u32]) -> Vec<u32> {
    let mut starts = Vec::with_capacity(counts.len() + 1);
    let mut total = 0u32;
    starts.push(0);
    for &c in counts {
        total += c;
        starts.push(total);
    }
    starts
}

/// The stable counting sort: writes every triangle `t` into `order` at the next free place of
/// its patch's range, so ranges come out ascending by input index.
pub(crate) fn fill_order(patch_of: &[u32], starts: &[u32], order: &mut [u32]) {
    let mut next = starts.to_vec();
    for (t, &p) in patch_of.iter().enumerate() {
        order[next[p as usize] as usize] = t as u32;
        next[p as usize] += 1;
    }
}
