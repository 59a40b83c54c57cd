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
    let mut bounds: Option<Aabb> = None;
    for &r in &roots {
        let b = bbox(r);
        bounds = Some(bounds.map_or(b, |m| m.union(&b)));
    }
    let Some(bounds) = bounds else {
        return Numbering {
            patch_of: Vec::new(),
            order: Vec::new(),
            starts: vec![0],
        };
    };
    let mut keyed: Vec<(u64, u32, u32)> = roots
        .iter()
        .map(|&r| {
            (
                morton_code(bbox(r).center(), &bounds),
                first_triangle[r as usize],
                r,
            )
        })
        .collect();
    // Smallest triangles are distinct, so the key is total and the sort deterministic.
    keyed.sort_unstable();

    // Reuse `first_triangle` as the map from root to final id.
    let final_id = &mut first_triangle;
    for (id, &(_, _, r)) in keyed.iter().enumerate() {
        final_id[r as usize] = id as u32;
    }
    let patch_of: Vec<u32> = root_of.iter().map(|&r| final_id[r as usize]).collect();

    let mut starts = vec![0u32; keyed.len() + 1];
    for &p in &patch_of {
        starts[p as usize + 1] += 1;
    }
    for i in 0..keyed.len() {
        starts[i + 1] += starts[i];
    }
    let mut next = starts.clone();
    let mut order = vec![0u32; n];
    for (t, &p) in patch_of.iter().enumerate() {
        order[next[p as usize] as usize] = t as u32;
        next[p as usize] += 1;
    }
    Numbering {
        patch_of,
        order,
        starts,
    }
}
