//! Huge, real-looking test meshes, generated deterministically and written streaming.
//!
//! Five models, each a [`Model`] that can recount and re-emit its vertices and triangles in a
//! fixed order from a small description, so a mesh of any size is written in two passes
//! (vertices, then faces) with memory bounded by the description, never by the output:
//!
//! - [`subdivide::SubdividedMesh`]: a source mesh (the bundled bunny) with every triangle split
//!   `k × k` (k = 2^L is L levels of midpoint subdivision) and displaced along the normal by
//!   smooth value noise (`noise.rs`), so it looks like a dense scan. Split points on a source edge are numbered
//!   per edge, so neighbouring triangles share them: the output is as watertight as the source.
//! - [`grid::BunnyGrid`]: copies of a source mesh on a floor grid, each turned about the
//!   vertical axis.
//! - [`engine::Engine`]: a closed outer casing around a closed housing around a lattice of
//!   closed machine parts (gears, pistons, bearings, shells with parts inside). From outside
//!   only the casing is visible, which is what visibility culling should discover.
//! - [`exposed::ExposedEngine`]: an engine-like assembly with nothing hidden: thin cooling
//!   fins, a plate with square holes, gears, pipes and cylinders with narrow gaps between them,
//!   so what is visible changes quickly with the viewing direction.
//! - [`truss::Truss`]: a cubic lattice of thin beams with diagonal braces and crossed leaf
//!   cards, seen through from every direction.
//!
//! The last two are hard cases for culling fidelity rather than for scale: they are built from
//! boxes, rods and tubes (`parts.rs`) tessellated as finely as the triangle budget allows.
//!
//! [`write_ply`] writes any model as binary little-endian PLY that
//! [`Mesh::open`](crate::ooc::Mesh::open) serves zero copy. Cost: one pass per section; about
//! 25 bytes written per triangle.

pub mod engine;
pub mod exposed;
pub mod grid;
mod noise;
mod parts;
mod shapes;
pub mod subdivide;
pub mod truss;

use std::io::{self, BufWriter, Write};

/// The most triangles `patchvis gen` makes: about 25 GB of PLY, a quarter of what the bake's
/// `u32` triangle ids allow. A stated limit, so that a mistyped size fails at once rather
/// than running for hours and filling the disk.
pub const MAX_TRIANGLES: u64 = 1_000_000_000;

/// Output buffer: large sequential writes, a fixed 1 MiB whatever the mesh size.
const WRITE_BUFFER_BYTES: usize = 1 << 20;

/// A mesh that emits its vertices and triangles in a fixed, reproducible order.
pub trait Model {
    /// Number of vertices [`Model::vertices`] emits.
    fn vertex_count(&self) -> u64;
    /// Number of triangles [`Model::triangles`] emits.
    fn triangle_count(&self) -> u64;
    /// Emits every vertex position in index order; stops at the first error `emit` returns.
    fn vertices(&self, emit: &mut dyn FnMut([f32; 3]) -> io::Result<()>) -> io::Result<()>;
    /// Emits every triangle (counter-clockwise seen from outside) in order.
    fn triangles(&self, emit: &mut dyn FnMut([u32; 3]) -> io::Result<()>) -> io::Result<()>;
}

/// Writes `model` as binary little-endian PLY (`float x, y, z`; `list uchar uint
/// vertex_indices`), streaming through a fixed buffer.
///
/// Fails with `InvalidInput` when the model has more than `u32::MAX` vertices or triangles,
/// and with `InvalidData` when it emits a different number than it announced (a bug in the
/// model, reported rather than written as a corrupt file).
pub fn write_ply(out: impl Write, model: &dyn Model, comment: &str) -> io::Result<()> {
    let (vertices, triangles) = (model.vertex_count(), model.triangle_count());
    if vertices > u64::from(u32::MAX) || triangles > u64::from(u32::MAX) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "{vertices} vertices and {triangles} triangles, expected at most {} of each \
                 (u32 indices)",
                u32::MAX
            ),
        ));
    }
    let mut out = BufWriter::with_capacity(WRITE_BUFFER_BYTES, out);
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment {comment}\n\
         element vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {triangles}\nproperty list uchar uint vertex_indices\nend_header\n"
    )?;
    let mut written = 0u64;
    model.vertices(&mut |p| {
        let mut record = [0u8; 12];
        for (field, c) in record.chunks_exact_mut(4).zip(p) {
            field.copy_from_slice(&c.to_le_bytes());
        }
        written += 1;
        out.write_all(&record)
    })?;
    check_count("vertices", written, vertices)?;
    written = 0;
    model.triangles(&mut |t| {
        let mut record = [0u8; 13];
        record[0] = 3;
        for (field, i) in record[1..].chunks_exact_mut(4).zip(t) {
            field.copy_from_slice(&i.to_le_bytes());
        }
        written += 1;
        out.write_all(&record)
    })?;
    check_count("triangles", written, triangles)?;
    out.flush()
}

fn check_count(what: &str, emitted: u64, announced: u64) -> io::Result<()> {
    if emitted == announced {
        return Ok(());
    }
    Err(io::Error::new(
        io::ErrorKind::InvalidData,
        format!("internal error: the model emitted {emitted} {what}, announced {announced}"),
    ))
}

#[cfg(test)]
mod tests;
