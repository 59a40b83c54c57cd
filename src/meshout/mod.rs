//! `--mesh-out`: the baked mesh written back with its triangles in the file's patch order, so
//! that patch `i`'s triangles are the one contiguous range the `.pvis` gives it, with the
//! input's attributes ([`Attributes`]) and the input index of every triangle.
//!
//! Two formats, chosen by the output's extension ([`MeshFormat`]):
//! - `ply.rs`: binary little-endian PLY, faces coloured by patch and carrying their patch and
//!   original triangle index; vertices carry the input's normals, texture coordinates and
//!   colours. It reads back in place with `Mesh::open`, so `patchvis eval` takes it.
//! - `gltf.rs`: glTF 2.0, `.glb` or self-contained `.gltf`, for engines and viewers: positions,
//!   normals (the input's, else computed), texture coordinates, colours and materials, one
//!   index range per patch, the ranges in the mesh's `extras`.
//!
//! Within a patch the triangles are grouped by material (stably), so a glTF primitive is a
//! run of one material; without materials the order is the tiling's own. The patch ranges
//! are the same either way.

mod gltf;
mod ply;
mod sequence;

use std::io::{self, Write};
use std::path::Path;

use crate::ooc::Mesh;
use crate::ooc::attributes::Attributes;
use crate::tiling::Tiling;

pub use ply::patch_colour;
pub use sequence::Sequence;

/// The formats of `--mesh-out`: glTF for `.glb` and `.gltf`, PLY for any other name (as
/// `--mesh-out` wrote before it had glTF: `/dev/null` or `mesh.out` stay PLY).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// Binary little-endian PLY (`.ply`).
    Ply,
    /// Binary glTF (`.glb`).
    Glb,
    /// glTF JSON with its buffer as a `data:` URI (`.gltf`).
    Gltf,
}

impl MeshFormat {
    /// The format for `path`, by its extension (case-insensitive).
    pub fn of(path: &Path) -> MeshFormat {
        let extension = path.extension().map(|e| e.to_string_lossy().to_lowercase());
        match extension.as_deref() {
            Some("glb") => MeshFormat::Glb,
            Some("gltf") => MeshFormat::Gltf,
            _ => MeshFormat::Ply,
        }
    }
}

/// Writes `mesh` in `tiling`'s patch order as `format`, with `attributes` (read from the
/// mesh's source by [`Attributes::read`]).
pub fn write(
    out: &mut impl Write,
    format: MeshFormat,
    mesh: &Mesh,
    attributes: &Attributes,
    tiling: &Tiling,
) -> io::Result<()> {
    let sequence = Sequence::new(tiling, attributes);
    match format {
        MeshFormat::Ply => ply::write(out, mesh, attributes, &sequence),
        MeshFormat::Glb | MeshFormat::Gltf => {
            gltf::write(out, format == MeshFormat::Glb, mesh, attributes, &sequence)
        }
    }
}

#[cfg(test)]
mod tests;
