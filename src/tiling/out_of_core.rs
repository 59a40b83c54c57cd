//! Out-of-core tiling: the seed algorithm's objective in bounded memory.
//!
//! 1. **Spatial sort.** Triangles are sorted by the Morton code of their centroid (ties by
//!    index) with an external merge sort ([`super::external_sort`]); the order goes to a
//!    mapped temporary file. While it is written, each vertex is marked with the chunk that
//!    uses it, or as shared when two chunks do.
//! 2. **Chunks.** Consecutive runs of [`Plan::chunk_triangles`] sorted triangles (compact
//!    regions, as Z-order runs are) are tiled independently by the greedy fusion
//!    ([`super::chunks`]) down to [`QUOTA_MULTIPLE`] times their share of the target: by area,
//!    and never below their share by triangle count (so the quotas add up to at least the
//!    target). [`CHUNKS_AT_ONCE`] chunks run in parallel.
//! 3. **Borders.** Each chunk returns the links between its own patches, and reports its edges whose both vertices are shared (only those can
//!    be shared with another chunk), once per chunk. An external sort of these `(edge, triangle)`
//!    records puts the chunks' copies of an edge next to each other; consecutive copies link
//!    their chunk patches. No hash map over edges is ever built.
//! 4. **Patch graph.** The chunk patches with their areas, boxes and links form a small graph;
//!    the same greedy fusion ([`super::greedy`]) runs on it down to the target, then the same
//!    component rule as in core: a patch never spans two connected components unless the mesh
//!    has more components than the target; then components fuse along Morton-order proximity
//!    links ([`super::components`]). Chunk patches are edge-connected and their links are
//!    exactly the mesh's adjacency between them, so both rules hold for triangles as in core.
//! 5. **Numbering and reorder** as in core ([`super::reorder`]): final ids along a Z-order
//!    curve, ties by smallest triangle; `patch_of` is rewritten in place and the counting sort
//!    reuses the spatial order's file for `order`. Per-patch bounds as in core.
//!
//! The approximation: a patch of the result is a union of chunk patches, so it cannot cut a
//! chunk patch; chunk patches are [`QUOTA_MULTIPLE`] times smaller than the final ones, which
//! keeps the cost in compactness small (BENCHMARKS.md, "Tiling (issue 4)").
//!
//! Memory: the sort buffer, then [`CHUNKS_AT_ONCE`] chunks, are sized from the budget; on top
//! only the patch graph (about 100 bytes per chunk patch) and per-patch records. Every
//! per-triangle or per-vertex array is a mapped temporary file ([`TriangleMap`]).
//! **Limit:** the patch graph holds every piece a chunk could not fuse, and pieces that are
//! whole components are never merged inside a chunk. A mesh of millions of disconnected
//! triangles (an unwelded triangle soup) therefore gets a patch graph of millions of nodes
//! and can exceed the budget; welded scans and CAD meshes give a few pieces per chunk.
//! Cost: O(n log n) time; about 40 bytes of temporary files per triangle at the peak.

use std::io;

use rayon::prelude::*;

use super::aabb::Aabb;
use super::chunks::{self, CHUNK_BYTES_PER_TRIANGLE, ChunkPatch, ChunkTiling};
use super::external_sort::ExternalSort;
use super::greedy::Fusion;
use super::morton::morton_code;
use super::{
    Tiling, TilingError, TilingStats, TriangleMap, bounds, components, finish, merge_components,
    reorder,
};
use crate::ooc::Mesh;

/// Chunks stop at this multiple of their share of the target. Larger leaves the patch-graph
/// fusion more freedom (final patches are unions of chunk patches) at a cost in graph size
/// only; 16 gives patch graphs of tens of thousands of nodes and keeps the median compactness
/// within a few per cent of the in-core tiling on the subdivided bunny (BENCHMARKS.md).
pub(crate) const QUOTA_MULTIPLE: u64 = 16;

/// Chunks tiled at the same time; each gets its share of the chunk budget. The chunk size
/// depends on this constant and the budget only, never on the thread count, so the result is
/// the same for any number of threads; two matches the fusion (sequential per chunk) to two
/// cores.
pub(crate) const CHUNKS_AT_ONCE: usize = 2;

/// Triangles whose sort keys are computed together before they enter the external sort:
/// big enough for parallel work, small enough (1.5 MiB of keys) to disappear in the budget.
const KEY_BLOCK: usize = 1 << 16;

/// Vertex mark: not used by any chunk yet. Marks `1..` name the chunk (plus one) using it.
const UNUSED: u32 = 0;
/// Vertex mark: used by more than one chunk.
const SHARED: u32 = u32::MAX;

/// How the budget is split.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Plan {
    /// Triangles per chunk.
    pub chunk_triangles: usize,
    /// Bytes of the spatial sort's in-memory buffer.
    pub sort_bytes: usize,
    /// Bytes of the border-edge sort's buffer.
    pub border_bytes: usize,
    /// Bytes of file buffers of a sort.
    pub io_bytes: usize,
}

impl Plan {
    /// The split of `budget` heap bytes: half for the spatial sort's buffer (it runs alone);
    /// three quarters for the chunks, which run next to the border sort's sixteenth and the
    /// growing list of chunk patches; a sixteenth for file buffers.
    pub fn for_budget(budget: u64) -> Plan {
        let budget = usize::try_from(budget).unwrap_or(usize::MAX);
        let per_chunk = budget / 4 * 3 / CHUNKS_AT_ONCE;
        Plan {
            chunk_triangles: (per_chunk / CHUNK_BYTES_PER_TRIANGLE as usize).max(1),
            sort_bytes: budget / 2,
            border_bytes: budget / 16,
            io_bytes: budget / 16,
        }
    }
}

/// Tiles `mesh` into `min(target, triangles)` patches within about `budget` bytes of heap.
pub(crate) fn tile(mesh: &Mesh, target: u32, budget: u64) -> Result<Tiling, TilingError> {
    let n = mesh.triangle_count();
    if n == 0 {
        return Err(TilingError::NoTriangles);
    }
    if target == 0 {
        return Err(TilingError::ZeroPatches);
    }
    let target = target.min(n);
    let plan = Plan::for_budget(budget);

    let (spatial, marks, total_area) =
        spatial_order(mesh, &plan).map_err(temp("the spatial sort"))?;
    let (mut patch_of, patches, graph, chunk_count) =
        tile_chunks(mesh, target, total_area, &spatial, &marks, &plan)?;
    drop(marks);

    let components = components::count_components(&graph);
    let mut fusion = Fusion::new(patches.par_iter().map(|p| p.shape), graph);
    let seeds: Vec<u32> = (0..patches.len() as u32).collect();
    fusion.fuse(&seeds, target);
    let merged_components = merge_components(&mut fusion, target);
    debug_assert_eq!(fusion.alive(), target);

    // Number the fused patches; smallest triangle of each from its chunk patches.
    let root_of: Vec<u32> = seeds.iter().map(|&s| fusion.patch_of(s)).collect();
    let mut min_triangle = vec![u32::MAX; patches.len()];
    for (p, &r) in patches.iter().zip(&root_of) {
        min_triangle[r as usize] = min_triangle[r as usize].min(p.min_triangle);
    }
    let roots: Vec<(u32, u32)> = seeds
        .iter()
        .filter(|&&s| root_of[s as usize] == s)
        .map(|&s| (s, min_triangle[s as usize]))
        .collect();
    let ids = reorder::final_ids(&roots, |r| fusion.bbox(r));
    drop(fusion);
    let mut final_of_root = min_triangle;
    for (&(r, _), &id) in roots.iter().zip(&ids) {
        final_of_root[r as usize] = id;
    }
    let final_of: Vec<u32> = root_of.iter().map(|&r| final_of_root[r as usize]).collect();
    let mut counts = vec![0u32; roots.len()];
    for (p, &f) in patches.iter().zip(&final_of) {
        counts[f as usize] += p.count;
    }
    let starts = reorder::starts_of(&counts);

    patch_of
        .par_chunks_mut(KEY_BLOCK)
        .for_each(|block| block.iter_mut().for_each(|p| *p = final_of[*p as usize]));
    // The spatial order is no longer needed; its file becomes the reordered mesh.
    let mut order = spatial;
    reorder::fill_order(&patch_of, &starts, &mut order);

    let stats = TilingStats {
        components,
        merged_components,
        out_of_core: true,
        chunks: chunk_count,
    };
    Ok(finish(mesh, patch_of, order, &starts, stats))
}

/// The error for a failed temporary file holding `what`.
fn temp(what: &'static str) -> impl Fn(io::Error) -> TilingError {
    move |e| TilingError::TempStorage {
        what,
        kind: e.kind(),
    }
}

/// Step 1: triangles in Morton order of their centroids, vertex chunk marks, and the total
/// area (summed block by block in input order, so it is the same for any thread count).
fn spatial_order(mesh: &Mesh, plan: &Plan) -> io::Result<(TriangleMap, TriangleMap, f64)> {
    let n = mesh.triangle_count() as usize;
    // A cube around the mesh: over the bare bounds, a thin axis (a terrain's height, noise
    // on a plane) would get as many bits as the long ones and the curve's first splits would
    // cut along it, making chunks scattered checkerboards instead of compact regions.
    let b = mesh.bounds();
    let side = (0..3).fold(0.0f32, |m, k| m.max(b.max[k] - b.min[k]));
    let bounds = Aabb {
        min: b.min,
        max: std::array::from_fn(|k| b.min[k] + side),
    };
    let mut sort = ExternalSort::<(u64, u32)>::new(plan.sort_bytes, plan.io_bytes);
    let mut total_area = 0.0;
    for start in (0..n).step_by(KEY_BLOCK) {
        let end = (start + KEY_BLOCK).min(n);
        let keyed: Vec<(u64, f64)> = (start as u32..end as u32)
            .into_par_iter()
            .map(|t| {
                let p = bounds::corners(mesh, t);
                let centroid = std::array::from_fn(|k| {
                    (f64::from(p[0][k]) + f64::from(p[1][k]) + f64::from(p[2][k])) / 3.0
                });
                (morton_code(centroid, &bounds), bounds::triangle_area(p))
            })
            .collect();
        for (t, &(code, area)) in (start as u32..).zip(&keyed) {
            sort.push((code, t))?;
            total_area += area;
        }
    }
    let mut sorted = sort.finish()?;

    let mut spatial = TriangleMap::mapped_zeroed(n)?;
    let mut marks = TriangleMap::mapped_zeroed(mesh.vertex_count() as usize)?;
    let mut i = 0;
    while let Some((_, t)) = sorted.next()? {
        spatial[i] = t;
        // Chunk numbers fit: there are at most `n < 2^32 - 1` chunks.
        let mark = (i / plan.chunk_triangles) as u32 + 1;
        for v in mesh.triangle(t) {
            let m = &mut marks[v as usize];
            if *m == UNUSED {
                *m = mark;
            } else if *m != mark {
                *m = SHARED;
            }
        }
        i += 1;
    }
    Ok((spatial, marks, total_area))
}

/// Steps 2 and 3: tiles the chunks, writes each triangle's chunk patch into the returned
/// map, and links chunk patches across chunk borders. Returns the map, the chunk patches,
/// their neighbour lists and the number of chunks.
#[allow(clippy::type_complexity)]
fn tile_chunks(
    mesh: &Mesh,
    target: u32,
    total_area: f64,
    spatial: &[u32],
    marks: &[u32],
    plan: &Plan,
) -> Result<(TriangleMap, Vec<ChunkPatch>, Vec<Vec<u32>>, u32), TilingError> {
    let n = spatial.len();
    let size = plan.chunk_triangles;
    let chunk_count = n.div_ceil(size);
    let quota = |area: f64, count: usize| -> u32 {
        let target = target as f64;
        let by_count = (target * count as f64 / n as f64).ceil();
        let by_area = if total_area > 0.0 && total_area.is_finite() {
            (QUOTA_MULTIPLE as f64 * target * area / total_area).ceil()
        } else {
            QUOTA_MULTIPLE as f64 * by_count
        };
        // `as` saturates; the chunk clamps to its triangle count.
        by_area.max(by_count) as u32
    };

    let mut patch_of = TriangleMap::mapped_zeroed(n).map_err(temp("chunk patches"))?;
    let mut patches: Vec<ChunkPatch> = Vec::new();
    let mut graph: Vec<Vec<u32>> = Vec::new();
    let mut border = ExternalSort::<(u64, u32)>::new(plan.border_bytes, plan.io_bytes);
    let range = |c: usize| c * size..((c + 1) * size).min(n);
    for first in (0..chunk_count).step_by(CHUNKS_AT_ONCE) {
        let batch: Vec<ChunkTiling> = (first..(first + CHUNKS_AT_ONCE).min(chunk_count))
            .into_par_iter()
            .map(|c| {
                let triangles = &spatial[range(c)];
                chunks::tile_chunk(
                    mesh,
                    triangles,
                    |area| quota(area, triangles.len()),
                    |v| marks[v as usize] == SHARED,
                )
            })
            .collect();
        for (c, chunk) in (first..).zip(batch) {
            let base = patches.len() as u32;
            for (&t, &p) in spatial[range(c)].iter().zip(&chunk.patch_of) {
                patch_of[t as usize] = base + p;
            }
            patches.extend_from_slice(&chunk.patches);
            graph.extend(
                (chunk.links.into_iter()).map(|l| l.into_iter().map(|q| base + q).collect()),
            );
            for &e in &chunk.border {
                border.push(e).map_err(temp("border edges"))?;
            }
        }
    }

    let mut sorted = border.finish().map_err(temp("border edges"))?;
    let mut previous: Option<(u64, u32)> = None;
    while let Some((key, t)) = sorted.next().map_err(temp("border edges"))? {
        if let Some((previous_key, u)) = previous
            && previous_key == key
        {
            // Copies of one edge come from distinct chunks, hence distinct chunk patches;
            // linking consecutive copies connects them all.
            let (a, b) = (patch_of[u as usize], patch_of[t as usize]);
            if a != b {
                graph[a as usize].push(b);
                graph[b as usize].push(a);
            }
        }
        previous = Some((key, t));
    }
    for list in &mut graph {
        list.sort_unstable();
        list.dedup();
    }
    Ok((patch_of, patches, graph, chunk_count as u32))
}
