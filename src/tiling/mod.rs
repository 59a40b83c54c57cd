//! Tiling: grouping triangles into compact, edge-connected patches (Meruvia 2002, §3.1).

use crate::ooc::Mesh;

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
    /// Bounding sphere radius.
    pub radius: f32,
    /// Normal cone axis (unit, or zero when the cone is degenerate).
    pub cone_axis: [f32; 3],
    /// Cosine of the normal cone's half-angle; `-1` means the normals span every direction.
    pub cone_cos: f32,
}

/// The result of tiling a mesh.
#[derive(Clone, Debug)]
pub struct Tiling {
    /// Patch of each triangle, indexed by the input triangle index.
    pub patch_of: Vec<PatchId>,
    /// The reordered mesh: `order[i]` is the input triangle placed at position `i`.
    pub order: Vec<u32>,
    /// The patches, with ranges into `order`.
    pub patches: Vec<Patch>,
}

/// Why tiling failed.
#[derive(Debug, thiserror::Error)]
pub enum TilingError {
    /// The mesh has no triangles.
    #[error("the mesh has no triangles")]
    NoTriangles,
    /// Zero patches were asked for.
    #[error("the patch count must be at least 1")]
    ZeroPatches,
}

/// Tiles `mesh` into `min(target, triangles)` patches with the seed paper's greedy fusion.
pub fn tile(mesh: &Mesh, target: u32) -> Result<Tiling, TilingError> {
    let _ = (mesh, target);
    todo!()
}
