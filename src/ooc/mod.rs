//! Out-of-core mesh access: a triangle mesh seen through a memory map.
//!
//! [`Mesh::open`] maps the file and validates it once; after that [`Mesh::position`] and
//! [`Mesh::triangle`] cannot fail and read straight from the bytes. A binary little-endian PLY
//! with fixed-size records is used in place, zero copy (`ply::in_place`); every other PLY is
//! converted once (`ply::convert`) into an owned copy with the same strided layout, so both
//! cases share one code path: a byte slice, the offset of vertex 0's `x`, `y`, `z` and of
//! triangle 0's indices, and two strides.
//!
//! Cost: opening the 1.9 MB bunny in place is one validation pass (about a millisecond in
//! release); a query is a multiply-add and three little-endian loads.
//!
//! Files: `error.rs` (errors with positions), `mmap.rs` (the map, the crate's only `unsafe`),
//! `ply/` (header, in-place and converting readers), `write_ply.rs` (`--mesh-out`).

mod error;
mod mmap;
mod ply;
pub mod write_ply;

use std::fs::File;
use std::path::{Path, PathBuf};

use error::Fault;
pub use error::{ErrorPosition, MeshError, MeshErrorKind};
use mmap::MeshBytes;

/// Axis-aligned bounds of a mesh's vertices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Componentwise minimum.
    pub min: [f32; 3],
    /// Componentwise maximum.
    pub max: [f32; 3],
}

/// Where vertex 0's coordinates and triangle 0's indices sit in the bytes, and the strides to
/// the next ones. All values little-endian; validated at open so that every vertex below
/// `vertex_count` and every triangle below `triangle_count` lies inside the bytes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Layout {
    pub(crate) x: usize,
    pub(crate) y: usize,
    pub(crate) z: usize,
    pub(crate) vertex_stride: usize,
    /// First of three consecutive `u32` indices.
    pub(crate) index: usize,
    pub(crate) face_stride: usize,
}

/// Bytes per vertex and per triangle in the owned (converted) layout: `f32 x, y, z` and
/// `u32 a, b, c`, densely packed.
const OWNED_RECORD_BYTES: usize = 12;

/// A triangle mesh opened for reading.
pub struct Mesh {
    path: PathBuf,
    bytes: MeshBytes,
    layout: Layout,
    vertex_count: u32,
    triangle_count: u32,
    bounds: Bounds,
    /// True when `bytes` is the file's own records (no conversion).
    in_place: bool,
}

impl Mesh {
    /// Opens and validates the mesh at `path`.
    pub fn open(path: &Path) -> Result<Mesh, MeshError> {
        let extension = path.extension().map(|e| e.to_string_lossy().to_lowercase());
        if extension.as_deref() != Some("ply") {
            let found = match &extension {
                Some(e) => format!("unsupported file type '.{e}'"),
                None => "unsupported file type (no extension)".to_string(),
            };
            return Err(Fault::new(
                MeshErrorKind::UnsupportedFormat,
                None,
                format!("{found}: expected .ply"),
            )
            .in_file(path));
        }
        let file = File::open(path).map_err(|e| MeshError::io(path, &e))?;
        let metadata = file.metadata().map_err(|e| MeshError::io(path, &e))?;
        if metadata.is_dir() {
            let err = std::io::Error::from(std::io::ErrorKind::IsADirectory);
            return Err(MeshError::io(path, &err));
        }
        if metadata.len() == 0 {
            return Err(Fault::at_byte(
                MeshErrorKind::Empty,
                0,
                "the file is empty (0 bytes), expected a PLY header",
            )
            .in_file(path));
        }
        let bytes = MeshBytes::open(&file, metadata.len()).map_err(|e| MeshError::io(path, &e))?;
        Mesh::from_bytes(path.to_path_buf(), bytes)
    }

    /// Reads a PLY file's bytes: in place when the layout allows, else converted.
    fn from_bytes(path: PathBuf, bytes: MeshBytes) -> Result<Mesh, MeshError> {
        let (schema, body) = ply::read(&bytes).map_err(|f| f.in_file(&path))?;
        match body {
            ply::Body::InPlace {
                layout,
                triangle_count,
                bounds,
            } => Ok(Mesh {
                path,
                in_place: bytes.is_file_backed(),
                bytes,
                layout,
                vertex_count: schema.vertex_count,
                triangle_count,
                bounds,
            }),
            ply::Body::Converted {
                positions,
                triangles,
                bounds,
            } => {
                drop(bytes);
                Mesh::owned(path, &positions, &triangles, bounds)
            }
        }
    }

    /// A mesh held in memory (tests, generated meshes). Validates like [`Mesh::open`]: every
    /// index below `positions.len()`, every coordinate finite. `name` stands in for the path
    /// in error messages.
    pub fn from_memory(
        name: &str,
        positions: Vec<[f32; 3]>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Mesh, MeshError> {
        use MeshErrorKind::*;
        let path = PathBuf::from(name);
        let fail = |kind, message: String| Err(Fault::new(kind, None, message).in_file(&path));
        if positions.is_empty() {
            return fail(NoVertices, "0 vertices, expected at least 1".into());
        }
        let Ok(vertex_count) = u32::try_from(positions.len()) else {
            return fail(
                TooLarge,
                format!(
                    "{} vertices, expected at most {}",
                    positions.len(),
                    u32::MAX
                ),
            );
        };
        if triangles.is_empty() {
            return fail(
                NoFaces,
                format!("point cloud: the mesh has {vertex_count} vertices but no faces"),
            );
        }
        if u32::try_from(triangles.len()).is_err() {
            return fail(
                TooLarge,
                format!(
                    "{} triangles, expected at most {}",
                    triangles.len(),
                    u32::MAX
                ),
            );
        }
        let mut bounds = ply::BoundsBuilder::new();
        for (v, p) in positions.iter().enumerate() {
            if !p.iter().all(|c| c.is_finite()) {
                return fail(
                    NonFinite,
                    format!("vertex {v} is {p:?}, expected finite coordinates"),
                );
            }
            bounds.add(*p);
        }
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(i) = tri.iter().find(|&&i| i >= vertex_count) {
                return fail(
                    BadIndex,
                    format!(
                        "triangle {t} has vertex index {i}, expected < {vertex_count} vertices"
                    ),
                );
            }
        }
        Mesh::owned(path, &positions, &triangles, bounds.finish())
    }

    /// Stores validated positions and triangles in the owned layout.
    fn owned(
        path: PathBuf,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
        bounds: Bounds,
    ) -> Result<Mesh, MeshError> {
        let vertex_bytes = positions.len() * OWNED_RECORD_BYTES;
        let len = vertex_bytes + triangles.len() * OWNED_RECORD_BYTES;
        let bytes = MeshBytes::filled(len, |out| {
            let (vertex_out, triangle_out) = out.split_at_mut(vertex_bytes);
            for (record, p) in vertex_out
                .chunks_exact_mut(OWNED_RECORD_BYTES)
                .zip(positions)
            {
                for (field, c) in record.chunks_exact_mut(4).zip(p) {
                    field.copy_from_slice(&c.to_le_bytes());
                }
            }
            for (record, t) in triangle_out
                .chunks_exact_mut(OWNED_RECORD_BYTES)
                .zip(triangles)
            {
                for (field, i) in record.chunks_exact_mut(4).zip(t) {
                    field.copy_from_slice(&i.to_le_bytes());
                }
            }
        })
        .map_err(|e| MeshError::io(&path, &e))?;
        Ok(Mesh {
            path,
            bytes,
            layout: Layout {
                x: 0,
                y: 4,
                z: 8,
                vertex_stride: OWNED_RECORD_BYTES,
                index: vertex_bytes,
                face_stride: OWNED_RECORD_BYTES,
            },
            // Both counts were checked against u32 by the caller.
            vertex_count: positions.len() as u32,
            triangle_count: triangles.len() as u32,
            bounds,
            in_place: false,
        })
    }

    /// The file this mesh was read from.
    pub fn path(&self) -> &Path {
        &self.path
    }
    /// Number of vertices.
    pub fn vertex_count(&self) -> u32 {
        self.vertex_count
    }
    /// Number of triangles.
    pub fn triangle_count(&self) -> u32 {
        self.triangle_count
    }
    /// True when the mesh is served from the file's own memory-mapped records, zero copy;
    /// false when it was converted (or could not be mapped and was read into memory).
    pub fn is_mapped(&self) -> bool {
        self.in_place
    }

    /// Position of vertex `v`.
    ///
    /// `v` must be below [`vertex_count`](Self::vertex_count): debug builds assert it; release
    /// builds panic or return another record's bytes, never read out of bounds.
    #[inline]
    pub fn position(&self, v: u32) -> [f32; 3] {
        debug_assert!(v < self.vertex_count, "vertex {v} of {}", self.vertex_count);
        let bytes: &[u8] = &self.bytes;
        let l = &self.layout;
        let base = v as usize * l.vertex_stride;
        [
            f32::from_le_bytes(four(bytes, base + l.x)),
            f32::from_le_bytes(four(bytes, base + l.y)),
            f32::from_le_bytes(four(bytes, base + l.z)),
        ]
    }

    /// Vertex indices of triangle `t` (all below `vertex_count()`).
    ///
    /// `t` must be below [`triangle_count`](Self::triangle_count), as for [`position`](Self::position).
    #[inline]
    pub fn triangle(&self, t: u32) -> [u32; 3] {
        debug_assert!(
            t < self.triangle_count,
            "triangle {t} of {}",
            self.triangle_count
        );
        let bytes: &[u8] = &self.bytes;
        let at = self.layout.index + t as usize * self.layout.face_stride;
        let s = &bytes[at..at + 12];
        [
            u32::from_le_bytes(four(s, 0)),
            u32::from_le_bytes(four(s, 4)),
            u32::from_le_bytes(four(s, 8)),
        ]
    }

    /// Bounds of all vertices.
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }
}

impl std::fmt::Debug for Mesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Mesh")
            .field("path", &self.path)
            .field("vertex_count", &self.vertex_count)
            .field("triangle_count", &self.triangle_count)
            .field("bounds", &self.bounds)
            .field("is_mapped", &self.in_place)
            .finish()
    }
}

/// The four bytes at `at`: one bounds check, then a fixed-size copy the compiler turns into a
/// single load.
#[inline]
pub(crate) fn four(bytes: &[u8], at: usize) -> [u8; 4] {
    let s = &bytes[at..at + 4];
    [s[0], s[1], s[2], s[3]]
}

#[cfg(test)]
mod tests;
