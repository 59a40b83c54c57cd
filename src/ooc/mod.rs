//! Out-of-core mesh access: a triangle mesh seen through a memory map.
//!
//! Binary little-endian PLY with fixed-size records is used in place (zero copy); other
//! inputs are converted to the same internal layout.

use std::path::{Path, PathBuf};

/// Axis-aligned bounds of a mesh's vertices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Componentwise minimum.
    pub min: [f32; 3],
    /// Componentwise maximum.
    pub max: [f32; 3],
}

/// A triangle mesh opened for reading.
pub struct Mesh {
    path: PathBuf,
    // Placeholder storage until the memory-mapped layout lands; the public API is fixed.
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
    bounds: Bounds,
}

/// Why a mesh could not be opened: names the file, the position and what was expected.
#[derive(Debug)]
pub struct MeshError {
    path: PathBuf,
}

impl std::fmt::Display for MeshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.path.display())
    }
}

impl std::error::Error for MeshError {}

impl Mesh {
    /// Opens and validates the mesh at `path`.
    pub fn open(path: &Path) -> Result<Mesh, MeshError> {
        todo!("{}", path.display())
    }
    /// A mesh held in memory (tests, generated meshes). Validates like [`Mesh::open`]: every
    /// index below `positions.len()`, every coordinate finite. `name` stands in for the path
    /// in error messages.
    pub fn from_memory(
        name: &str,
        positions: Vec<[f32; 3]>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Mesh, MeshError> {
        let path = PathBuf::from(name);
        if triangles.is_empty()
            || triangles
                .iter()
                .flatten()
                .any(|&i| i as usize >= positions.len())
        {
            return Err(MeshError { path });
        }
        if positions.is_empty() || positions.iter().flatten().any(|c| !c.is_finite()) {
            return Err(MeshError { path });
        }
        let mut bounds = Bounds {
            min: positions[0],
            max: positions[0],
        };
        for p in &positions {
            for k in 0..3 {
                bounds.min[k] = bounds.min[k].min(p[k]);
                bounds.max[k] = bounds.max[k].max(p[k]);
            }
        }
        Ok(Mesh {
            path,
            positions,
            triangles,
            bounds,
        })
    }
    /// The file this mesh was read from.
    pub fn path(&self) -> &Path {
        &self.path
    }
    /// Number of vertices.
    pub fn vertex_count(&self) -> u32 {
        self.positions.len() as u32
    }
    /// Number of triangles.
    pub fn triangle_count(&self) -> u32 {
        self.triangles.len() as u32
    }
    /// Position of vertex `v`.
    pub fn position(&self, v: u32) -> [f32; 3] {
        self.positions[v as usize]
    }
    /// Vertex indices of triangle `t` (all below `vertex_count()`).
    pub fn triangle(&self, t: u32) -> [u32; 3] {
        self.triangles[t as usize]
    }
    /// Bounds of all vertices.
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }
}
