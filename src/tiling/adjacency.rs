//! Triangle adjacency through shared edges, built by sorting rather than hashing.
//!
//! Every triangle contributes its edges as `(edge key, triangle)` pairs, the key packing the
//! unordered vertex pair; sorting the pairs puts the triangles of each edge next to each other.
//! This is the connectivity graph the seed paper's patch creation starts from (Meruvia 2002,
//! §3.1). Rules for imperfect input:
//! - an edge shared by k ≥ 3 triangles (non-manifold) connects all of them (see
//!   [`FAN_WINDOW`] for very large k);
//! - a triangle with a repeated vertex index still connects through its remaining valid edge;
//!   a triangle with three equal indices has no edge and stays alone;
//! - duplicate triangles share edges and are therefore neighbours;
//! - orientation is ignored, so inconsistently oriented neighbours still connect.
//!
//! Cost: O(n log n) for the (parallel, deterministic) sort, O(n) for the rest; transiently
//! 16 bytes per edge entry plus the adjacency itself.

use rayon::prelude::*;

use crate::ooc::Mesh;

/// On an edge shared by more triangles than this plus one, each triangle is linked to the next
/// `FAN_WINDOW` triangles of that edge (by index) instead of to all of them. The triangles stay
/// one connected set while the cost stays linear; meshes with such fans (thousands of copies of
/// a triangle) would otherwise need a quadratic number of links. Below the window every
/// triangle of the edge is linked to every other, which covers all non-manifold edges seen in
/// practice (3–4 triangles).
pub(crate) const FAN_WINDOW: usize = 8;

/// Key for an unused edge slot (an edge whose two vertices are equal); sorts last.
const NO_EDGE: u64 = u64::MAX;

/// Neighbour lists, one per triangle: sorted, without duplicates, without the triangle itself.
pub(crate) fn triangle_neighbours(mesh: &Mesh) -> Vec<Vec<u32>> {
    triangle_neighbours_in(mesh, mesh.triangle_count(), |t| t, |_, _| {})
}

/// The key of the edge between vertices `a != b`: the unordered pair packed into a `u64`.
pub(crate) fn edge_key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
}

/// The two vertices of an edge key.
pub(crate) fn edge_vertices(key: u64) -> [u32; 2] {
    [(key >> 32) as u32, key as u32]
}

/// Neighbour lists of a subset of the mesh: `count` triangles, local triangle `i` being mesh
/// triangle `global(i)`; lists hold local indices and only links inside the subset. Calls
/// `on_edge(key, i)` once per distinct edge of the subset, in key order, with the smallest
/// local triangle `i` on it (the out-of-core tiling matches edges across chunks with these).
pub(crate) fn triangle_neighbours_in(
    mesh: &Mesh,
    count: u32,
    global: impl Fn(u32) -> u32 + Sync,
    mut on_edge: impl FnMut(u64, u32),
) -> Vec<Vec<u32>> {
    let n = count as usize;
    let mut entries = vec![(NO_EDGE, u32::MAX); 3 * n];
    entries
        .par_chunks_mut(3)
        .enumerate()
        .for_each(|(t, slots)| {
            let v = mesh.triangle(global(t as u32));
            for (k, slot) in slots.iter_mut().enumerate() {
                let (a, b) = (v[k], v[(k + 1) % 3]);
                if a != b {
                    *slot = (edge_key(a, b), t as u32);
                }
            }
        });
    // The whole pair is the sort key, so equal elements are identical and the result does not
    // depend on the thread count.
    entries.par_sort_unstable();
    let used = entries.partition_point(|&(key, _)| key != NO_EDGE);
    entries.truncate(used);
    // A triangle like [a, b, a] lists the edge {a, b} twice; it counts once.
    entries.dedup();
    for run in entries.chunk_by(|x, y| x.0 == y.0) {
        on_edge(run[0].0, run[0].1);
    }

    // Two passes over the same links: count, then fill a compressed (CSR) layout.
    let mut degree = vec![0usize; n];
    for_each_link(&entries, |a, b| {
        degree[a as usize] += 1;
        degree[b as usize] += 1;
    });
    let mut offsets = Vec::with_capacity(n + 1);
    let mut total = 0usize;
    offsets.push(0);
    for d in &degree {
        total += d;
        offsets.push(total);
    }
    let mut fill = offsets[..n].to_vec();
    let mut flat = vec![0u32; total];
    for_each_link(&entries, |a, b| {
        flat[fill[a as usize]] = b;
        fill[a as usize] += 1;
        flat[fill[b as usize]] = a;
        fill[b as usize] += 1;
    });
    drop(entries);

    offsets
        .par_windows(2)
        .map(|w| {
            let mut list = flat[w[0]..w[1]].to_vec();
            // Triangles sharing two or three edges (duplicates) were linked once per edge.
            list.sort_unstable();
            list.dedup();
            list
        })
        .collect()
}

/// Calls `link(a, b)` once per linked pair `a < b` of triangles on a common edge; `entries`
/// is sorted and free of duplicates.
fn for_each_link(entries: &[(u64, u32)], mut link: impl FnMut(u32, u32)) {
    for run in entries.chunk_by(|x, y| x.0 == y.0) {
        for (i, &(_, a)) in run.iter().enumerate() {
            for &(_, b) in run.iter().skip(i + 1).take(FAN_WINDOW) {
                link(a, b);
            }
        }
    }
}
