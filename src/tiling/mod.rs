//! Tiling: grouping triangles into compact, edge-connected patches (Meruvia 2002, §3.1).
//!
//! Every triangle starts as a patch; the smallest patch by area repeatedly fuses with the
//! edge-adjacent patch that keeps the union's bounding-box diagonal shortest, until the target
//! count remains (`greedy.rs`). Connectivity comes from shared edges, built by sorting
//! (`adjacency.rs`). Patches never span connected components unless there are more components
//! than patches asked for; then whole components fuse along Morton-order proximity links
//! (`components.rs`). Final ids follow a Z-order curve and triangles are reordered patch by
//! patch (`reorder.rs`); each patch gets its area, bounding sphere and normal cone (`bounds.rs`).
//!
//! Cost: O(n log n) time for n triangles; memory about 130 bytes per triangle at the peak
//! (while the adjacency is built), on top of the mesh.
//! **Invariant**: the result depends only on the mesh and the target, never on the thread
//! count (the fusion is sequential; parallel parts are per-element or sort by total keys).

mod aabb;
mod adjacency;
mod bounds;
mod components;
mod greedy;
mod morton;
mod queue;
mod reorder;

#[cfg(test)]
mod test_meshes;
#[cfg(test)]
mod tests;

use rayon::prelude::*;

use crate::ooc::Mesh;
use aabb::Aabb;
use greedy::Fusion;

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

/// Facts about the input that a tiling reports: how connected the mesh was and whether
/// connected components had to share patches.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TilingStats {
    /// Connected components of the mesh (through shared edges).
    pub components: u32,
    /// Fusions of two patches that lie in different components; non-zero only when
    /// `components` exceeds the patch count asked for.
    pub merged_components: u32,
}

/// The result of tiling a mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Tiling {
    /// Patch of each triangle, indexed by the input triangle index.
    pub patch_of: Vec<PatchId>,
    /// The reordered mesh: `order[i]` is the input triangle placed at position `i`.
    pub order: Vec<u32>,
    /// The patches, with ranges into `order`.
    pub patches: Vec<Patch>,
    /// Connectivity facts gathered on the way.
    pub stats: TilingStats,
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

    let (area, bbox): (Vec<f64>, Vec<Aabb>) = (0..n)
        .into_par_iter()
        .map(|t| {
            let p = bounds::corners(mesh, t);
            (bounds::triangle_area(p), Aabb::of_triangle(p))
        })
        .unzip();
    let neighbours = adjacency::triangle_neighbours(mesh);
    let components = components::count_components(&neighbours);

    let mut fusion = Fusion::new(area, bbox, neighbours);
    let seeds: Vec<u32> = (0..n).collect();
    fusion.fuse(&seeds, target);

    let mut merged_components = 0;
    if fusion.alive() > target {
        // Every remaining patch is a whole component; link them by proximity and go on.
        let alive = fusion.alive_ids();
        let boxed: Vec<(u32, Aabb)> = alive.iter().map(|&p| (p, fusion.bbox(p))).collect();
        // `alive > target >= 1`, so there is a first box to start the union from.
        let all = boxed
            .iter()
            .map(|(_, b)| *b)
            .reduce(|m, b| m.union(&b))
            .unwrap_or(Aabb {
                min: [0.0; 3],
                max: [0.0; 3],
            });
        for (p, links) in components::proximity_links(&boxed, &all) {
            fusion.set_neighbours(p, links);
        }
        merged_components = fusion.fuse(&alive, target);
    }
    debug_assert_eq!(fusion.alive(), target);

    let root_of: Vec<u32> = (0..n).map(|t| fusion.patch_of(t)).collect();
    let numbering = reorder::number_patches(&root_of, |r| fusion.bbox(r));
    let patches: Vec<Patch> = numbering
        .starts
        .par_windows(2)
        .map(|w| {
            let range = &numbering.order[w[0] as usize..w[1] as usize];
            bounds::patch_bounds(mesh, range, w[0])
        })
        .collect();
    Ok(Tiling {
        patch_of: numbering.patch_of,
        order: numbering.order,
        patches,
        stats: TilingStats {
            components,
            merged_components,
        },
    })
}
