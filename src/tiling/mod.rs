//! Tiling: grouping triangles into compact, edge-connected patches (Meruvia 2002, §3.1).
//!
//! Every triangle starts as a patch; the smallest patch by area repeatedly fuses with the
//! edge-adjacent patch that keeps the union's bounding-box diagonal shortest, lengthened by
//! the spread of the union's normals so that patches stay flat, until the target count
//! remains (`greedy.rs`). Connectivity comes from shared edges, built by sorting
//! (`adjacency.rs`). Patches never span connected components unless there are more components
//! than patches asked for; then whole components fuse along Morton-order proximity links
//! (`components.rs`). Final ids follow a Z-order curve and triangles are reordered patch by
//! patch (`reorder.rs`); each patch gets its area, bounding sphere and normal cone (`bounds.rs`).
//!
//! Cost: O(n log n) time for n triangles; memory about [`IN_CORE_BYTES_PER_TRIANGLE`] per
//! triangle at the peak (while the adjacency is built), on top of the mapped mesh.
//!
//! Meshes whose connectivity does not fit a memory budget are tiled out of core with the
//! same objective (`out_of_core.rs`): triangles sorted along a Z-order curve by an external
//! merge sort (`external_sort.rs`), consecutive chunks tiled independently (`chunks.rs`),
//! then the small graph of chunk patches fused down to the target; the per-triangle outputs
//! live in memory-mapped temporary files (`triangle_map.rs`). [`tile_with`] picks the
//! strategy by the budget; [`TilingQuality`] (`quality.rs`) makes the two comparable.
//!
//! **Invariant**: the result depends only on the mesh, the target and (out of core) the
//! memory budget, never on the thread count (the fusions are sequential; parallel parts are
//! per-element, per-chunk with fixed chunk boundaries, or sort by total keys).

mod aabb;
mod adjacency;
mod bounds;
mod chunks;
mod components;
mod external_sort;
mod greedy;
mod morton;
mod out_of_core;
mod quality;
mod queue;
mod renumber;
mod reorder;
mod triangle_map;

#[cfg(test)]
mod tests;

use rayon::prelude::*;

use crate::ooc::Mesh;
pub(crate) use aabb::Aabb;
pub(crate) use bounds::{bounding_sphere, corners, cross_normal, first_with_area, patch_bounds};
use greedy::{Fusion, Shape};
pub(crate) use morton::morton_code;
pub use quality::TilingQuality;
pub use renumber::renumbered_patches;
pub use triangle_map::TriangleMap;

/// Peak heap of the in-core tiling per triangle, an upper bound with margin: measured 136 to
/// 140 bytes with a counting allocator on 1.0M–1.6M-triangle meshes (`tests/tiling_scale.rs`
/// asserts it): the sorted edge entries, the neighbour lists, the fusion state (96 bytes a
/// patch with its normal sum) and the two output maps. [`TilingMode::Auto`] tiles in core
/// when this times the triangle count fits.
pub const IN_CORE_BYTES_PER_TRIANGLE: u64 = 160;

/// Index of a patch, `0..patch_count`.
pub type PatchId = u32;

/// One patch after reordering: its triangles are `first..first + count` of the reordered mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Patch {
    /// First triangle in the reordered mesh.
    pub first: u32,
    /// Number of triangles.
    pub count: u32,
    /// Total surface area.
    pub area: f64,
    /// Bounding sphere centre.
    pub center: [f32; 3],
    /// Bounding sphere radius; every vertex of the patch is inside, with a small margin for
    /// `f32` tests.
    pub radius: f32,
    /// Normal cone axis (unit, or zero when the cone is degenerate). The cone bounds normal
    /// directions only and has no apex: backface tests must use the bounding sphere.
    pub cone_axis: [f32; 3],
    /// Cosine of the normal cone's half-angle; `-1` means the normals span every direction.
    pub cone_cos: f32,
}

/// Facts about the input that a tiling reports: how connected the mesh was, whether
/// connected components had to share patches, and how the tiling ran.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TilingStats {
    /// Connected components of the mesh (through shared edges).
    pub components: u32,
    /// Fusions of two patches that lie in different components; non-zero only when
    /// `components` exceeds the patch count asked for.
    pub merged_components: u32,
    /// True when the out-of-core algorithm ran.
    pub out_of_core: bool,
    /// Chunks the out-of-core algorithm tiled independently (0 in core).
    pub chunks: u32,
}

/// The result of tiling a mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Tiling {
    /// Patch of each triangle, indexed by the input triangle index. Derefs to `&[PatchId]`;
    /// memory-mapped when tiled out of core.
    pub patch_of: TriangleMap,
    /// The reordered mesh: `order[i]` is the input triangle placed at position `i`. Derefs
    /// to `&[u32]`; memory-mapped when tiled out of core.
    pub order: TriangleMap,
    /// The patches, with ranges into `order`.
    pub patches: Vec<Patch>,
    /// Connectivity facts gathered on the way.
    pub stats: TilingStats,
    /// Patch sizes and compactness.
    pub quality: TilingQuality,
}

impl Tiling {
    /// Where each patch starts in [`Tiling::order`], and the triangle count after the last:
    /// patch `p` holds positions `starts[p]..starts[p + 1]`.
    pub fn starts(&self) -> Vec<u32> {
        let mut starts: Vec<u32> = self.patches.iter().map(|p| p.first).collect();
        starts.push(self.order.len() as u32);
        starts
    }
}

/// Which algorithm [`tile_with`] runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TilingMode {
    /// In core when [`in_core_bytes`] fits the budget, else out of core.
    #[default]
    Auto,
    /// The seed algorithm on the whole mesh, whatever the budget.
    InCore,
    /// Chunked tiling within the budget, whatever the mesh size.
    OutOfCore,
}

/// How to tile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TilingOptions {
    /// The algorithm.
    pub mode: TilingMode,
    /// Heap bytes the tiling may use (the mapped mesh and temporary files not counted). The
    /// out-of-core tiling sizes its sort runs and chunks from it; budgets below a few MiB
    /// work but tile in many small chunks.
    pub memory_budget: u64,
}

/// Why tiling failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TilingError {
    /// The mesh has no triangles.
    #[error("the mesh has no triangles")]
    NoTriangles,
    /// Zero patches were asked for.
    #[error("the patch count must be at least 1")]
    ZeroPatches,
    /// A temporary file of the out-of-core tiling could not be created, written or read.
    #[error("out-of-core tiling: temporary file for {what} failed: {kind}")]
    TempStorage {
        /// What the file held.
        what: &'static str,
        /// The operating system's reason.
        kind: std::io::ErrorKind,
    },
}

/// Estimated peak heap of the in-core tiling of `triangles` triangles.
pub fn in_core_bytes(triangles: u32) -> u64 {
    u64::from(triangles) * IN_CORE_BYTES_PER_TRIANGLE
}

/// Tiles `mesh` into `min(target, triangles)` patches with the algorithm `options` choose:
/// the seed algorithm ([`tile`]) when it fits the budget (or is asked for), else the
/// out-of-core approximation with the same objective, within the budget.
///
/// The output is deterministic: the same for every run and every rayon thread count.
pub fn tile_with(mesh: &Mesh, target: u32, options: &TilingOptions) -> Result<Tiling, TilingError> {
    let in_core = match options.mode {
        TilingMode::InCore => true,
        TilingMode::OutOfCore => false,
        TilingMode::Auto => in_core_bytes(mesh.triangle_count()) <= options.memory_budget,
    };
    if in_core {
        tile(mesh, target)
    } else {
        out_of_core::tile(mesh, target, options.memory_budget)
    }
}

/// Tiles `mesh` into `min(target, triangles)` patches with the seed paper's greedy fusion.
///
/// The output is deterministic: the same for every run and every rayon thread count.
pub fn tile(mesh: &Mesh, target: u32) -> Result<Tiling, TilingError> {
    let n = mesh.triangle_count();
    if n == 0 {
        return Err(TilingError::NoTriangles);
    }
    if target == 0 {
        return Err(TilingError::ZeroPatches);
    }
    let target = target.min(n);

    let neighbours = adjacency::triangle_neighbours(mesh);
    let components = components::count_components(&neighbours);

    let seeds = (0..n)
        .into_par_iter()
        .map(|t| Shape::of_triangle(bounds::corners(mesh, t)));
    let mut fusion = Fusion::new(seeds, neighbours);
    let seeds: Vec<u32> = (0..n).collect();
    fusion.fuse(&seeds, target);

    let merged_components = merge_components(&mut fusion, target);
    debug_assert_eq!(fusion.alive(), target);

    let root_of: Vec<u32> = (0..n).map(|t| fusion.patch_of(t)).collect();
    let numbering = reorder::number_patches(&root_of, |r| fusion.bbox(r));
    drop(fusion);
    drop(root_of);
    let stats = TilingStats {
        components,
        merged_components,
        out_of_core: false,
        chunks: 0,
    };
    Ok(finish(
        mesh,
        TriangleMap::from_vec(numbering.patch_of),
        TriangleMap::from_vec(numbering.order),
        &numbering.starts,
        stats,
    ))
}

/// Goes on fusing when the greedy stopped above `target` because every remaining patch is a
/// whole connected component: links the components by Morton-order proximity and fuses over
/// those links. Returns the number of fusions across components.
fn merge_components(fusion: &mut Fusion, target: u32) -> u32 {
    if fusion.alive() <= target {
        return 0;
    }
    let alive = fusion.alive_ids();
    let boxed: Vec<(u32, Aabb)> = alive.iter().map(|&p| (p, fusion.bbox(p))).collect();
    let Some(all) = boxed.iter().map(|(_, b)| *b).reduce(|m, b| m.union(&b)) else {
        return 0;
    };
    for (p, links) in components::proximity_links(&boxed, &all) {
        fusion.set_neighbours(p, links);
    }
    fusion.fuse(&alive, target)
}

/// Per-patch bounds and quality over the patch ranges `starts` of `order`.
fn finish(
    mesh: &Mesh,
    patch_of: TriangleMap,
    order: TriangleMap,
    starts: &[u32],
    stats: TilingStats,
) -> Tiling {
    let (patches, diagonal_squared): (Vec<Patch>, Vec<f64>) = starts
        .par_windows(2)
        .map(|w| bounds::patch_bounds(mesh, &order[w[0] as usize..w[1] as usize], w[0]))
        .unzip();
    let quality = TilingQuality::measure(&patches, &diagonal_squared);
    Tiling {
        patch_of,
        order,
        patches,
        stats,
        quality,
    }
}
