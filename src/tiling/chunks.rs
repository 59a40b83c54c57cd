//! One chunk of the out-of-core tiling: the seed algorithm on a run of spatially sorted
//! triangles, stopped early at the chunk's quota of patches.
//!
//! The chunk's triangles get their areas, boxes and sorted-edge adjacency (links inside the
//! chunk only), then the same greedy fusion as in core ([`super::greedy`]) runs until the
//! quota remains or only whole pieces are left (parts of the chunk not edge-connected inside
//! it; they may still connect through other chunks, so they are never merged here). Every
//! edge of the chunk whose two vertices are also used by another chunk is reported as a
//! border candidate, once per chunk, and the links between the chunk's own patches are
//! returned with them, so the caller can link the chunk's patches to other
//! chunks' patches by sorting these edges.
//!
//! Cost: as the in-core tiling of the chunk, O(c log c) for c triangles; peak heap about
//! [`CHUNK_BYTES_PER_TRIANGLE`] per triangle.

use rayon::prelude::*;

use super::adjacency::{edge_vertices, triangle_neighbours_in};
use super::bounds;
use super::greedy::{Fusion, Shape};
use crate::ooc::Mesh;

/// Peak heap of [`tile_chunk`] per triangle of the chunk, an upper bound with a wide margin:
/// two chunks of 0.4M–0.5M triangles peaked at 107–111 MiB, about 115 bytes per triangle
/// (`tests/tiling_scale.rs`), before the fusion nodes took 24 bytes more for their normal
/// sums. The adjacency's sorted edge entries dominate (48 bytes), then the neighbour lists
/// and the fusion nodes. The margin covers meshes with long neighbour lists (non-manifold
/// fans, duplicates).
pub(crate) const CHUNK_BYTES_PER_TRIANGLE: u64 = 200;

/// A patch of one chunk, as the patch graph sees it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ChunkPatch {
    /// Area, box and normal sum, as the fusion of the patch graph starts from them.
    pub shape: Shape,
    /// Smallest input triangle index of the patch (the tie-break of the final numbering).
    pub min_triangle: u32,
    pub count: u32,
}

/// What tiling one chunk yields.
pub(crate) struct ChunkTiling {
    /// Patch (index into `patches`) of each triangle of the chunk, in chunk order.
    pub patch_of: Vec<u32>,
    pub patches: Vec<ChunkPatch>,
    /// Neighbours of each patch inside the chunk (indices into `patches`, ascending).
    pub links: Vec<Vec<u32>>,
    /// Border candidates: `(edge key, input triangle)`, one triangle per edge.
    pub border: Vec<(u64, u32)>,
}

/// Tiles the chunk of input triangles `triangles` into `quota(chunk area)` patches (or more,
/// when the chunk falls into more pieces). `shared(v)` tells whether vertex `v` is also used
/// by another chunk.
pub(crate) fn tile_chunk(
    mesh: &Mesh,
    triangles: &[u32],
    quota: impl FnOnce(f64) -> u32,
    shared: impl Fn(u32) -> bool,
) -> ChunkTiling {
    let count = triangles.len() as u32;
    let mut border = Vec::new();
    let neighbours = triangle_neighbours_in(
        mesh,
        count,
        |i| triangles[i as usize],
        |key, i| {
            if edge_vertices(key).iter().all(|&v| shared(v)) {
                border.push((key, triangles[i as usize]));
            }
        },
    );

    let seeds = triangles
        .par_iter()
        .map(|&t| Shape::of_triangle(bounds::corners(mesh, t)));
    let mut fusion = Fusion::new(seeds, neighbours);
    // Summed in chunk order, so the quota does not depend on the thread count.
    let chunk_area: f64 = (0..count).map(|p| fusion.shape(p).area).sum();
    let seeds: Vec<u32> = (0..count).collect();
    fusion.fuse(&seeds, quota(chunk_area).clamp(1, count));
    drop(seeds);

    // Number the pieces by their first triangle in chunk order.
    const UNSEEN: u32 = u32::MAX;
    let mut piece_of_root = vec![UNSEEN; count as usize];
    let mut patch_of = Vec::with_capacity(count as usize);
    let mut patches: Vec<ChunkPatch> = Vec::new();
    for (i, &t) in triangles.iter().enumerate() {
        let root = fusion.patch_of(i as u32);
        let slot = &mut piece_of_root[root as usize];
        if *slot == UNSEEN {
            *slot = patches.len() as u32;
            patches.push(ChunkPatch {
                shape: *fusion.shape(root),
                min_triangle: t,
                count: 0,
            });
        }
        let patch = &mut patches[*slot as usize];
        patch.min_triangle = patch.min_triangle.min(t);
        patch.count += 1;
        patch_of.push(*slot);
    }
    // Links between the chunk's patches: a patch graph without them would only know the
    // links across chunk borders.
    let mut roots = vec![0u32; patches.len()];
    for (i, &p) in patch_of.iter().enumerate() {
        roots[p as usize] = fusion.patch_of(i as u32);
    }
    let links = roots
        .iter()
        .map(|&r| {
            let mut list: Vec<u32> = fusion
                .neighbour_patches(r)
                .iter()
                .map(|&q| piece_of_root[q as usize])
                .collect();
            list.sort_unstable();
            list
        })
        .collect();
    ChunkTiling {
        patch_of,
        patches,
        links,
        border,
    }
}
