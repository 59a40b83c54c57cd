//! The mesh regrouped patch by patch for tiled sampling: each patch's distinct vertices in
//! one contiguous run and its triangles as indices into that run.
//!
//! A view then transforms only the vertices of the patches it draws, and a patch's vertices
//! and triangles sit together in memory, so skipped patches cost nothing and drawn ones stream
//! through the cache. Vertices on a patch border appear once per patch that uses them (about
//! `2·sqrt(triangles per patch)` extra per patch); both copies hold the same `f32` position,
//! so they project to bit-identical screen vertices and the mesh stays watertight.
//! Cost: one pass over the triangles plus a sort per patch; 12 bytes per triangle and
//! 12 bytes per patch vertex (about 18 bytes per triangle on a typical mesh).

use crate::ooc::Mesh;
use crate::tiling::Tiling;
use rayon::prelude::*;

/// One patch's distinct vertices and its triangles' corners as indices into them.
type PatchPart = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// Vertices and triangles grouped by patch; triangle `first + k` of patch `p` (in the tiling's
/// order) is input triangle `order[first + k]`.
#[derive(Debug)]
pub(crate) struct PatchMesh {
    /// Distinct vertices of every patch, patch after patch.
    positions: Vec<[f32; 3]>,
    /// `positions[vertex_start[p]..vertex_start[p + 1]]` are patch `p`'s vertices.
    vertex_start: Vec<usize>,
    /// Corners of reordered triangle `i`, as indices into its patch's vertex run.
    triangles: Vec<[u32; 3]>,
    /// `triangle_start[p]..triangle_start[p + 1]` are patch `p`'s reordered triangles.
    triangle_start: Vec<usize>,
}

impl PatchMesh {
    /// Regroups `mesh` by the patches of `tiling` (which must be a tiling of `mesh`).
    pub(crate) fn new(mesh: &Mesh, tiling: &Tiling) -> PatchMesh {
        assert_eq!(
            tiling.order.len(),
            mesh.triangle_count() as usize,
            "the tiling must cover the mesh's triangles"
        );
        let per_patch: Vec<PatchPart> = tiling
            .patches
            .par_iter()
            .map(|patch| {
                let range = patch.first as usize..(patch.first + patch.count) as usize;
                let corners: Vec<[u32; 3]> = tiling.order[range]
                    .iter()
                    .map(|&t| mesh.triangle(t))
                    .collect();
                let mut distinct: Vec<u32> = corners.iter().flatten().copied().collect();
                distinct.sort_unstable();
                distinct.dedup();
                let local = |v: u32| distinct.binary_search(&v).unwrap_or(0) as u32;
                let triangles = corners.iter().map(|c| c.map(local)).collect();
                let positions = distinct.iter().map(|&v| mesh.position(v)).collect();
                (positions, triangles)
            })
            .collect();
        let mut vertex_start = Vec::with_capacity(per_patch.len() + 1);
        let mut triangle_start = Vec::with_capacity(per_patch.len() + 1);
        let (mut positions, mut triangles) = (Vec::new(), Vec::new());
        vertex_start.push(0);
        triangle_start.push(0);
        for (p, t) in per_patch {
            positions.extend_from_slice(&p);
            triangles.extend_from_slice(&t);
            vertex_start.push(positions.len());
            triangle_start.push(triangles.len());
        }
        PatchMesh {
            positions,
            vertex_start,
            triangles,
            triangle_start,
        }
    }

    /// Number of patches.
    pub(crate) fn patch_count(&self) -> usize {
        self.vertex_start.len() - 1
    }

    /// Patch `p`'s vertices.
    pub(crate) fn vertices(&self, p: usize) -> &[[f32; 3]] {
        &self.positions[self.vertex_start[p]..self.vertex_start[p + 1]]
    }

    /// Patch `p`'s triangles (local corner indices) and the reordered index of the first.
    pub(crate) fn triangles(&self, p: usize) -> (usize, &[[u32; 3]]) {
        let start = self.triangle_start[p];
        (start, &self.triangles[start..self.triangle_start[p + 1]])
    }

    /// Heap bytes held.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.positions.len() * 12
            + self.triangles.len() * 12
            + (self.vertex_start.len() + self.triangle_start.len()) * 8
    }
}
