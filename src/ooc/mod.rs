//! Out-of-core mesh access: a triangle mesh seen through a memory map.
//!
//! [`Mesh::open`] maps the file and validates it once; after that [`Mesh::position`] and
//! [`Mesh::triangle`] cannot fail and read straight from the bytes. A binary little-endian PLY
//! with fixed-size records is used in place, zero copy (`ply::in_place`). Every other input
//! (other PLY flavours, OBJ, STL, glTF 2.0) is converted once, streaming, into a cache file in this
//! crate's own layout (`cache.rs`: `f32 x, y, z` and `u32 a, b, c` records), which is then
//! mapped; the next open of the same unchanged file (same bytes) maps the cache directly.
//! Both cases share one code path: a byte slice, the offset of vertex 0's `x`, `y`, `z` and of
//! triangle 0's indices, and two strides. Every input must be a regular file: a FIFO or a
//! device is refused before it is opened.
//!
//! **Invariant:** the heap holds nothing that grows with the mesh, on any path: the input is
//! mapped, converters stream through fixed buffers, STL welding partitions its table to fit
//! [`OpenOptions::memory_budget`]. Only the page cache grows.
//!
//! Cost: opening the 1.9 MB bunny in place is one validation pass (about a millisecond in
//! release); a query is a multiply-add and three little-endian loads.
//!
//! The map itself, read-only with a copying fallback where a file cannot be mapped, is
//! `crate::mapped::FileBytes`: this module holds no `unsafe` code.
//!
//! Files: `error.rs` (errors with positions), `cache.rs` (conversion cache files, keyed by
//! an XXH64 hash of the content), `ply/` (header, in-place and converting readers), `obj.rs`,
//! `stl.rs`, `gltf_mesh.rs` (converters), `text.rs` (line scanning and number parsing for the
//! text formats), `attributes/` (normals, texture coordinates, colours and materials, read
//! again from the source for `--mesh-out`).

pub mod attributes;
mod cache;
mod error;
mod gltf_mesh;
mod obj;
mod ply;
mod stl;
mod text;

use std::path::{Path, PathBuf};

pub use cache::default_cache_dir;
use cache::{CacheKey, CacheSource, CacheWriter};
use error::Fault;
pub use error::{ErrorPosition, MeshError, MeshErrorKind};

use crate::mapped::{Backing, FileBytes};
pub use crate::mapped::{open_regular, read_regular};

/// Axis-aligned bounds of a mesh's vertices: of those its triangles use ([`Mesh::bounds`]).
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
const OWNED_RECORD_BYTES: usize = cache::RECORD_BYTES;

/// Triangles per task of the pass that finds the used vertices' bounds: large enough that a
/// task's setup is lost in its work.
const USED_BOUNDS_BATCH: usize = 1 << 16;

/// Default heap budget for opening a mesh when the caller gives none: 512 MiB.
pub const DEFAULT_MEMORY_BUDGET: u64 = 512 << 20;

/// How [`Mesh::open_with`] opens a mesh.
#[derive(Clone, Debug)]
pub struct OpenOptions {
    /// Where conversion caches are kept; `None` converts into an unnamed temporary file every
    /// time (nothing is reused, nothing is left behind).
    pub cache_dir: Option<PathBuf>,
    /// Heap bytes the conversion may use (STL welding sizes its tables by it); the mesh
    /// itself is never on the heap.
    pub memory_budget: u64,
}

impl Default for OpenOptions {
    /// The [`default_cache_dir`] and [`DEFAULT_MEMORY_BUDGET`].
    fn default() -> OpenOptions {
        OpenOptions {
            cache_dir: Some(default_cache_dir()),
            memory_budget: DEFAULT_MEMORY_BUDGET,
        }
    }
}

/// Where a mesh's bytes come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshSource {
    /// The input file's own records, mapped (binary little-endian PLY).
    InPlace,
    /// A conversion cache from an earlier open of the same unchanged file, mapped.
    CacheHit,
    /// Converted by this open, into a cache file (or a temporary file), mapped.
    Converted,
    /// Built in memory by [`Mesh::from_memory`].
    Memory,
}

/// The input formats, by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum InputFormat {
    Ply,
    Obj,
    Stl,
    /// `.gltf` or `.glb`; the content (GLB magic or JSON) decides which.
    Gltf,
}

impl InputFormat {
    fn of(path: &Path) -> Result<InputFormat, Fault> {
        let extension = path.extension().map(|e| e.to_string_lossy().to_lowercase());
        match extension.as_deref() {
            Some("ply") => Ok(InputFormat::Ply),
            Some("obj") => Ok(InputFormat::Obj),
            Some("stl") => Ok(InputFormat::Stl),
            Some("gltf" | "glb") => Ok(InputFormat::Gltf),
            other => {
                let found = match other {
                    Some(e) => format!("unsupported file type '.{e}'"),
                    None => "unsupported file type (no extension)".to_string(),
                };
                Err(Fault::new(
                    MeshErrorKind::UnsupportedFormat,
                    None,
                    format!("{found}: expected .ply, .obj, .stl, .gltf or .glb"),
                ))
            }
        }
    }

    fn name(self) -> &'static str {
        match self {
            InputFormat::Ply => "a PLY header",
            InputFormat::Obj => "OBJ statements",
            InputFormat::Stl => "an STL header",
            InputFormat::Gltf => "glTF JSON or a GLB header",
        }
    }
}

/// A triangle mesh opened for reading.
pub struct Mesh {
    path: PathBuf,
    bytes: FileBytes,
    layout: Layout,
    vertex_count: u32,
    triangle_count: u32,
    bounds: Bounds,
    source: MeshSource,
    /// What was read differently from what the file says (e.g. a binary STL count), each one
    /// line naming the file.
    warnings: Vec<String>,
}

impl Mesh {
    /// Opens and validates the mesh at `path` with [`OpenOptions::default`].
    pub fn open(path: &Path) -> Result<Mesh, MeshError> {
        Mesh::open_with(path, &OpenOptions::default())
    }

    /// Opens and validates the mesh at `path` (`.ply`, `.obj`, `.stl`, `.gltf` or `.glb`).
    pub fn open_with(path: &Path, options: &OpenOptions) -> Result<Mesh, MeshError> {
        let format = InputFormat::of(path).map_err(|f| f.in_file(path))?;
        // A FIFO would block the open, a device never end: regular files only.
        let (file, metadata) = open_regular(path).map_err(|e| MeshError::io(path, &e))?;
        if metadata.len() == 0 {
            return Err(Fault::at_byte(
                MeshErrorKind::Empty,
                0,
                format!("the file is empty (0 bytes), expected {}", format.name()),
            )
            .in_file(path));
        }
        let bytes = FileBytes::open(&file, metadata.len(), Backing::Input(path))
            .map_err(|e| MeshError::io(path, &e))?;
        // Without a canonical path the cache cannot be named: convert.
        let source = CacheSource::of(path, metadata.len()).ok();
        let cache_dir = options.cache_dir.as_deref().filter(|_| source.is_some());
        Mesh::from_bytes(
            path.to_path_buf(),
            bytes,
            format,
            cache_dir,
            source,
            options.memory_budget,
        )
    }

    /// Serves `bytes` in place, from a cache, or converted into one.
    fn from_bytes(
        path: PathBuf,
        bytes: FileBytes,
        format: InputFormat,
        cache_dir: Option<&Path>,
        source: Option<CacheSource>,
        memory_budget: u64,
    ) -> Result<Mesh, MeshError> {
        let parsed = match format {
            InputFormat::Ply => {
                let parsed = ply::parse(&bytes).map_err(|f| f.in_file(&path))?;
                if let Some(body) = ply::in_place(&bytes, &parsed).map_err(|f| f.in_file(&path))? {
                    let source = if bytes.is_file_backed() {
                        MeshSource::InPlace
                    } else {
                        MeshSource::Converted
                    };
                    return Ok(Mesh::served(
                        path,
                        bytes,
                        body.layout,
                        (parsed.schema.vertex_count, body.triangle_count),
                        source,
                    ));
                }
                Some(parsed)
            }
            InputFormat::Obj | InputFormat::Stl | InputFormat::Gltf => None,
        };
        // Checked before the cache, so that a cache hit warns as the conversion did.
        let warnings: Vec<String> = match format {
            InputFormat::Stl => stl::count_warning(&bytes)
                .map(|w| format!("{}: {w}", path.display()))
                .into_iter()
                .collect(),
            _ => Vec::new(),
        };
        let gltf = match format {
            InputFormat::Gltf => {
                let glb = path
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
                Some(gltf_mesh::parse(&bytes, glb).map_err(|f| f.in_file(&path))?)
            }
            _ => None,
        };
        // A cache keyed by this file alone would go stale when an external buffer changes.
        let cache_dir =
            cache_dir.filter(|_| !gltf.as_ref().is_some_and(|g| g.has_external_buffers()));
        // The key hashes every byte, so it is computed only when a cache will be used.
        let key = cache_dir.and(source).map(|s| s.key(&bytes));
        if let (Some(dir), Some(key)) = (cache_dir, &key) {
            let cached = dir.join(key.file_name());
            if let Ok((file, metadata)) = open_regular(&cached) {
                let hit = FileBytes::open(&file, metadata.len(), Backing::Input(&cached))
                    .ok()
                    .and_then(|map| Mesh::from_cache(&path, map, Some(key), MeshSource::CacheHit));
                if let Some(mesh) = hit {
                    return Ok(Mesh { warnings, ..mesh });
                }
            }
        }
        let cache_error = |e: std::io::Error| Fault::cache(e).in_file(&path);
        let mut sink = CacheWriter::create(cache_dir, key).map_err(cache_error)?;
        let bounds = match (format, &parsed) {
            (InputFormat::Ply, Some(parsed)) => ply::convert(&bytes, parsed, &mut sink),
            (InputFormat::Obj, _) => obj::convert(&bytes, &mut sink),
            (InputFormat::Stl, _) => stl::convert(&bytes, &mut sink, memory_budget),
            (InputFormat::Gltf, _) => {
                let parsed = gltf.as_ref().expect("glTF input is parsed above");
                let dir = path.parent().unwrap_or(Path::new("."));
                gltf_mesh::convert(&bytes, parsed, dir, &mut sink)
            }
            (InputFormat::Ply, None) => unreachable!("PLY input is parsed above"),
        }
        .map_err(|f| f.in_file(&path))?;
        drop(bytes);
        let file = sink.finish(bounds).map_err(cache_error)?;
        let len = file.metadata().map_err(cache_error)?.len();
        let map = FileBytes::open(&file, len, Backing::CacheOf(&path)).map_err(cache_error)?;
        let mesh = Mesh::from_cache(&path, map, None, MeshSource::Converted).ok_or_else(|| {
            let err = std::io::Error::other("the cache file just written does not read back");
            Fault::cache(err).in_file(&path)
        })?;
        Ok(Mesh { warnings, ..mesh })
    }

    /// Serves a cache file; `None` when it is stale, damaged or not for `key`.
    fn from_cache(
        path: &Path,
        bytes: FileBytes,
        key: Option<&CacheKey>,
        source: MeshSource,
    ) -> Option<Mesh> {
        let head = cache::read_header(&bytes, key)?;
        let index = head.vertices_at + head.vertex_count as usize * OWNED_RECORD_BYTES;
        // One sequential pass: a damaged cache must not make `triangle` return indices that
        // `position` would refuse.
        let indices_ok = bytes[index..][..head.triangle_count as usize * OWNED_RECORD_BYTES]
            .chunks_exact(4)
            .all(|i| u32::from_le_bytes(four(i, 0)) < head.vertex_count);
        if !indices_ok || head.vertex_count == 0 || head.triangle_count == 0 {
            return None;
        }
        let layout = Layout {
            x: head.vertices_at,
            y: head.vertices_at + 4,
            z: head.vertices_at + 8,
            vertex_stride: OWNED_RECORD_BYTES,
            index,
            face_stride: OWNED_RECORD_BYTES,
        };
        let counts = (head.vertex_count, head.triangle_count);
        Some(Mesh::served(
            path.to_path_buf(),
            bytes,
            layout,
            counts,
            source,
        ))
    }

    /// The mesh in `bytes` at `layout`, validated, of `counts` vertices and triangles, with
    /// the bounds of the vertices its triangles use: one pass over the triangles, in
    /// parallel (a minimum and a maximum are exact, so any split gives the same bounds). A
    /// vertex no triangle uses, which real exports carry, decides nothing: not the camera,
    /// not the working frame, not the out-of-core tiling's order.
    fn served(
        path: PathBuf,
        bytes: FileBytes,
        layout: Layout,
        (vertex_count, triangle_count): (u32, u32),
        source: MeshSource,
    ) -> Mesh {
        use rayon::prelude::*;
        let mut mesh = Mesh {
            path,
            bytes,
            layout,
            vertex_count,
            triangle_count,
            bounds: Bounds {
                min: [0.0; 3],
                max: [0.0; 3],
            },
            source,
            warnings: Vec::new(),
        };
        let merge = |mut a: ply::BoundsBuilder, b: ply::BoundsBuilder| {
            let b = b.finish();
            a.add(b.min);
            a.add(b.max);
            a
        };
        mesh.bounds = (0..triangle_count)
            .into_par_iter()
            .with_min_len(USED_BOUNDS_BATCH)
            .fold(ply::BoundsBuilder::new, |mut b, t| {
                for v in mesh.triangle(t) {
                    b.add(mesh.position(v));
                }
                b
            })
            .reduce(ply::BoundsBuilder::new, merge)
            .finish();
        mesh
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
        for (v, p) in positions.iter().enumerate() {
            if !p.iter().all(|c| c.is_finite()) {
                return fail(
                    NonFinite,
                    format!("vertex {v} is {p:?}, expected finite coordinates"),
                );
            }
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
        Mesh::owned(path, &positions, &triangles)
    }

    /// Stores validated positions and triangles in the owned layout.
    fn owned(
        path: PathBuf,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
    ) -> Result<Mesh, MeshError> {
        let vertex_bytes = positions.len() * OWNED_RECORD_BYTES;
        let len = vertex_bytes + triangles.len() * OWNED_RECORD_BYTES;
        let bytes = FileBytes::filled(len, |out| {
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
        let layout = Layout {
            x: 0,
            y: 4,
            z: 8,
            vertex_stride: OWNED_RECORD_BYTES,
            index: vertex_bytes,
            face_stride: OWNED_RECORD_BYTES,
        };
        // Both counts were checked against u32 by the caller.
        let counts = (positions.len() as u32, triangles.len() as u32);
        Ok(Mesh::served(
            path,
            bytes,
            layout,
            counts,
            MeshSource::Memory,
        ))
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
    /// false when it was converted (see [`source`](Self::source) for whether a cache was hit).
    pub fn is_mapped(&self) -> bool {
        self.source == MeshSource::InPlace
    }
    /// Where the mesh's bytes come from: in place, a cache hit, a fresh conversion, memory.
    pub fn source(&self) -> MeshSource {
        self.source
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

    /// Bounds of the vertices the triangles use: a vertex no triangle uses is left out.
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }

    /// This mesh with every position `p` moved to `(p - origin) · scale` (in `f64`, rounded
    /// once to `f32`), same triangles, in an unnamed temporary file: streaming, like a
    /// conversion. The bake's working frame for coordinates `f32` cameras cannot handle
    /// (`bake::frame`).
    pub fn transformed(&self, origin: [f64; 3], scale: f64) -> Result<Mesh, MeshError> {
        let failed = |e: std::io::Error| Fault::cache(e).in_file(&self.path);
        let mut sink = CacheWriter::create(None, None).map_err(failed)?;
        let mut bounds = ply::BoundsBuilder::new();
        for v in 0..self.vertex_count {
            let p = self.position(v);
            let mut q: [f32; 3] =
                std::array::from_fn(|k| ((f64::from(p[k]) - origin[k]) * scale) as f32);
            // A vertex outside the bounds is one no triangle uses: anywhere finite will do.
            let used = (0..3).all(|k| (self.bounds.min[k]..=self.bounds.max[k]).contains(&p[k]));
            if !used {
                q = q.map(|c| c.clamp(-f32::MAX, f32::MAX));
            }
            if !q.iter().all(|c| c.is_finite()) {
                return Err(MeshError::whole(
                    &self.path,
                    MeshErrorKind::OutOfRange,
                    format!(
                        "vertex {v} at {p:?} leaves the bake's frame (centre {origin:?}, scale {scale:e})"
                    ),
                ));
            }
            bounds.add(q);
            sink.vertex(q).map_err(failed)?;
        }
        for t in 0..self.triangle_count {
            sink.triangle(self.triangle(t)).map_err(failed)?;
        }
        let file = sink.finish(bounds.finish()).map_err(failed)?;
        let len = file.metadata().map_err(failed)?.len();
        let map = FileBytes::open(&file, len, Backing::CacheOf(&self.path)).map_err(failed)?;
        let mesh =
            Mesh::from_cache(&self.path, map, None, MeshSource::Converted).ok_or_else(|| {
                failed(std::io::Error::other(
                    "the transformed mesh just written does not read back",
                ))
            })?;
        Ok(Mesh {
            warnings: self.warnings.clone(),
            ..mesh
        })
    }

    /// What the reader did that the file did not say, one line each naming the file: a
    /// binary STL whose header counts fewer triangles than it holds is read whole. The bake
    /// reports them through [`Progress::warn`](crate::progress::Progress::warn).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }
}

impl std::fmt::Debug for Mesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Mesh")
            .field("path", &self.path)
            .field("vertex_count", &self.vertex_count)
            .field("triangle_count", &self.triangle_count)
            .field("bounds", &self.bounds)
            .field("source", &self.source)
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
