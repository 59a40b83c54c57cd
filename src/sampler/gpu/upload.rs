//! The mesh on the GPU for the sampling backend: de-indexed triangles in the tiling's order
//! (patch after patch), each vertex holding its position relative to the bounding-sphere
//! centre (`f32 × 3`) and its patch id (`u32`), the id the fragment shader writes.
//!
//! De-indexing costs memory (3 vertices per triangle) but gives every triangle its own patch
//! id without any GPU feature beyond vertex buffers. Positions are made relative to the
//! centre in `f64` before rounding to `f32`, so that meshes far from the origin (survey
//! coordinates) keep the precision the CPU backend's `f64` camera has.
//! Cost: one pass over the triangles; 48 bytes of GPU memory per triangle, split into
//! buffers of at most [`MAX_CHUNK_BYTES`] (and the device's buffer limit), filled through a
//! host buffer of [`UPLOAD_PIECE_TRIANGLES`] triangles.

use super::GpuError;
use crate::ooc::Mesh;
use crate::tiling::Tiling;

/// Bytes of one vertex: position `f32 × 3`, patch id `u32`.
const VERTEX_BYTES: u64 = 16;

/// Bytes of one de-indexed triangle.
const TRIANGLE_BYTES: u64 = 3 * VERTEX_BYTES;

/// Largest vertex buffer: 1 GiB keeps every allocation well inside what drivers grant in one
/// piece, while a mesh of 22 million triangles still needs only one draw per view.
const MAX_CHUNK_BYTES: u64 = 1 << 30;

/// Triangles converted on the host per upload (48 MiB): bounds host memory for any mesh.
const UPLOAD_PIECE_TRIANGLES: usize = 1 << 20;

/// One vertex buffer of the mesh.
#[derive(Debug)]
pub(super) struct MeshChunk {
    /// `vertices` de-indexed vertices.
    pub(super) buffer: wgpu::Buffer,
    /// Vertices in `buffer` (three per triangle).
    pub(super) vertices: u32,
}

/// The vertex layout of [`MeshChunk`] buffers: location 0 the position, location 1 the id.
pub(super) fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRIBUTES: [wgpu::VertexAttribute; 2] =
        wgpu::vertex_attr_array![0 => Float32x3, 1 => Uint32];
    wgpu::VertexBufferLayout {
        array_stride: VERTEX_BYTES,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRIBUTES,
    }
}

/// Uploads `mesh`'s triangles in `tiling.order`, each tagged with its patch, positions
/// relative to `center`.
pub(super) fn upload_mesh(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mesh: &Mesh,
    tiling: &Tiling,
    center: [f32; 3],
    limits: &wgpu::Limits,
) -> Result<Vec<MeshChunk>, GpuError> {
    let max_bytes = limits.max_buffer_size.min(MAX_CHUNK_BYTES);
    // Vertex counts are u32 in draw calls.
    let per_chunk = (max_bytes / TRIANGLE_BYTES).min(u64::from(u32::MAX) / 3) as usize;
    if per_chunk == 0 {
        return Err(GpuError::TooLarge {
            what: "one triangle's vertex data (bytes)",
            needed: TRIANGLE_BYTES,
            limit: max_bytes,
        });
    }
    let center = center.map(f64::from);
    let mut chunks = Vec::new();
    let mut host = Vec::with_capacity(UPLOAD_PIECE_TRIANGLES.min(per_chunk) * 48);
    for triangles in tiling.order.chunks(per_chunk) {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("mesh"),
            size: triangles.len() as u64 * TRIANGLE_BYTES,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut offset = 0;
        for piece in triangles.chunks(UPLOAD_PIECE_TRIANGLES) {
            host.clear();
            for &t in piece {
                let patch = tiling.patch_of[t as usize];
                for v in mesh.triangle(t) {
                    let p = mesh.position(v);
                    for axis in 0..3 {
                        let relative = (f64::from(p[axis]) - center[axis]) as f32;
                        host.extend_from_slice(&relative.to_le_bytes());
                    }
                    host.extend_from_slice(&patch.to_le_bytes());
                }
            }
            queue.write_buffer(&buffer, offset, &host);
            // Flush the staged copy now, so host memory stays one piece whatever the mesh.
            queue.submit([]);
            offset += host.len() as u64;
        }
        chunks.push(MeshChunk {
            buffer,
            vertices: (triangles.len() * 3) as u32,
        });
    }
    Ok(chunks)
}
