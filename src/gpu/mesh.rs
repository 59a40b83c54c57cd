//! The mesh on the GPU, regrouped by patch (the sampling backend's and the frame cost's): each
//! patch's distinct vertices (position relative to the bounding-sphere centre, `f32 × 3`, and the
//! patch id, `u32`, the id the fragment shader writes) and its triangles as 32-bit indices, patch
//! after patch in the tiling's order.
//!
//! A vertex shared by two patches is stored once per patch, so that every vertex carries one
//! patch id without any GPU feature beyond vertex and index buffers; both copies hold the same
//! position, so the mesh stays watertight. Indexed drawing lets the GPU shade each vertex
//! about once instead of once per triangle corner (on the bunny, 0.6 vertices per triangle
//! instead of 3). Positions are made relative to the centre in `f64` before rounding to
//! `f32`, so that meshes far from the origin (survey coordinates) keep the precision the CPU
//! backend's `f64` camera has.
//! Cost: one pass over the triangles plus a sort of each run's corners; about 22 bytes of GPU
//! memory per triangle (12 of indices, 16 per vertex), in buffers of at most
//! [`MAX_CHUNK_BYTES`] each (and the device's buffer limit), one draw per buffer pair.

use super::GpuError;
use crate::ooc::Mesh;
use crate::tiling::Tiling;

/// Bytes of one vertex: position `f32 × 3`, patch id `u32`.
const VERTEX_BYTES: u64 = 16;

/// Bytes of one triangle's indices.
const INDEX_BYTES: u64 = 12;

/// Largest vertex or index buffer, and so the host memory one chunk is built in: 256 MiB is
/// granted by every driver in one piece, and a mesh of 11 million triangles still needs only
/// one draw per view.
const MAX_CHUNK_BYTES: u64 = 256 << 20;

/// Triangles of one patch deduplicated together: bounds the sort of a huge single patch (and
/// so the worst case of one run against a chunk's size).
const RUN_TRIANGLES: usize = 1 << 16;

/// One draw's worth of the mesh.
#[derive(Debug)]
pub(crate) struct MeshChunk {
    /// Vertices, [`vertex_layout`].
    pub(crate) vertices: wgpu::Buffer,
    /// Triangle corners as `u32` indices into `vertices`.
    pub(crate) indices: wgpu::Buffer,
    /// Number of indices (three per triangle).
    pub(crate) index_count: u32,
    /// Position in the tiling's order (`Tiling::order`) of the chunk's first triangle: the
    /// chunk holds triangles `first_triangle..first_triangle + index_count / 3` of the
    /// reordered mesh, so a patch's triangles are a range of its indices (the evaluator's
    /// frame cost draws patch ranges).
    pub(crate) first_triangle: u32,
}

/// The vertex layout of [`MeshChunk::vertices`]: location 0 the position, location 1 the id.
pub(crate) fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRIBUTES: [wgpu::VertexAttribute; 2] =
        wgpu::vertex_attr_array![0 => Float32x3, 1 => Uint32];
    wgpu::VertexBufferLayout {
        array_stride: VERTEX_BYTES,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRIBUTES,
    }
}

/// A chunk being built on the host.
#[derive(Default)]
struct HostChunk {
    vertices: Vec<u8>,
    indices: Vec<u8>,
}

/// The triangles of a mesh in patch order: patch `p` is positions `starts[p]..starts[p + 1]`
/// of `order` (the mesh's own order when `None`, as in a `--mesh-out` mesh).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PatchOrder<'a> {
    /// `order[i]` is the mesh triangle at position `i`.
    pub(crate) order: Option<&'a [u32]>,
    /// Where each patch starts, and the triangle count after the last.
    pub(crate) starts: &'a [u32],
}

impl<'a> PatchOrder<'a> {
    /// The patch order of `tiling`; `starts` must be [`Tiling::starts`].
    pub(crate) fn of(tiling: &'a Tiling, starts: &'a [u32]) -> PatchOrder<'a> {
        PatchOrder {
            order: Some(&tiling.order),
            starts,
        }
    }
}

/// Uploads `mesh`'s triangles patch by patch (`patches`), each vertex tagged with its patch,
/// positions relative to `center`, staging at most `host_bytes` (at least one run) in host
/// memory at a time.
pub(crate) fn upload_mesh(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mesh: &Mesh,
    patches: PatchOrder<'_>,
    center: [f32; 3],
    limits: &wgpu::Limits,
    host_bytes: u64,
) -> Result<Vec<MeshChunk>, GpuError> {
    // Vertex and index buffers are staged together.
    let max_bytes = limits
        .max_buffer_size
        .min(MAX_CHUNK_BYTES)
        .min((host_bytes / 2).max(RUN_TRIANGLES as u64 * 3 * VERTEX_BYTES));
    // The largest run: every corner a distinct vertex.
    let run_bytes = RUN_TRIANGLES as u64 * 3 * VERTEX_BYTES;
    if run_bytes > max_bytes {
        return Err(GpuError::TooLarge {
            what: "one run of vertices (bytes)",
            needed: run_bytes,
            limit: max_bytes,
        });
    }
    let center = center.map(f64::from);
    let mut chunks = Vec::new();
    let mut host = HostChunk::default();
    let mut corners: Vec<u32> = Vec::new();
    let mut distinct: Vec<u32> = Vec::new();
    // Triangles in the chunks before `host`.
    let mut uploaded = 0u32;
    let mut positions: Vec<u32> = Vec::new();
    for (p, w) in patches.starts.windows(2).enumerate() {
        let patch_id = p as u32;
        let range = w[0] as usize..w[1] as usize;
        let run_source: &[u32] = match patches.order {
            Some(order) => &order[range],
            None => {
                positions.clear();
                positions.extend(w[0]..w[1]);
                &positions
            }
        };
        for run in run_source.chunks(RUN_TRIANGLES) {
            corners.clear();
            corners.extend(run.iter().flat_map(|&t| mesh.triangle(t)));
            distinct.clear();
            distinct.extend_from_slice(&corners);
            distinct.sort_unstable();
            distinct.dedup();
            let vertex_bytes = distinct.len() as u64 * VERTEX_BYTES;
            let index_bytes = run.len() as u64 * INDEX_BYTES;
            if host.vertices.len() as u64 + vertex_bytes > max_bytes
                || host.indices.len() as u64 + index_bytes > max_bytes
            {
                chunks.push(flush(device, queue, &mut host, &mut uploaded));
            }
            let base = (host.vertices.len() as u64 / VERTEX_BYTES) as u32;
            for &v in &distinct {
                let position = mesh.position(v);
                for (axis, &c) in position.iter().enumerate() {
                    let relative = (f64::from(c) - center[axis]) as f32;
                    host.vertices.extend_from_slice(&relative.to_le_bytes());
                }
                host.vertices.extend_from_slice(&patch_id.to_le_bytes());
            }
            for &v in &corners {
                // Present: `distinct` holds every corner.
                let local = distinct.binary_search(&v).unwrap_or(0) as u32;
                host.indices
                    .extend_from_slice(&(base + local).to_le_bytes());
            }
        }
    }
    if !host.indices.is_empty() {
        chunks.push(flush(device, queue, &mut host, &mut uploaded));
    }
    Ok(chunks)
}

/// Uploads `host` as one chunk and empties it; `uploaded` counts the triangles uploaded so far.
fn flush(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    host: &mut HostChunk,
    uploaded: &mut u32,
) -> MeshChunk {
    let buffer = |label, bytes: &[u8], usage| {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.len() as u64,
            usage: usage | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        queue.write_buffer(&buffer, 0, bytes);
        buffer
    };
    let chunk = MeshChunk {
        vertices: buffer("mesh vertices", &host.vertices, wgpu::BufferUsages::VERTEX),
        indices: buffer("mesh indices", &host.indices, wgpu::BufferUsages::INDEX),
        index_count: (host.indices.len() as u64 / 4) as u32,
        first_triangle: *uploaded,
    };
    *uploaded += chunk.index_count / 3;
    // Hand the staged copies to the GPU now, so host memory stays one chunk whatever the mesh.
    queue.submit([]);
    host.vertices.clear();
    host.indices.clear();
    chunk
}
