//! `--mesh-out X.ply`: binary little-endian PLY, faces in patch order and coloured by patch,
//! for inspecting a tiling in any mesh viewer and for reordering one's own buffers.
//!
//! Every vertex is written as `float x, y, z`, then `float nx, ny, nz`, `float s, t` and
//! `uchar red, green, blue, alpha` when the input had normals, texture coordinates or colours
//! (texture coordinates in the OBJ/PLY convention, origin at the image's bottom left). Each
//! face is `list uchar uint vertex_indices` (count 3), `uint patch`, `uchar red, green, blue`
//! (the patch's colour) and `uint orig_index`, the face's triangle index in the input (after
//! polygons are fan-triangulated, as the bake counts them). Face records have a fixed size and
//! count 3, so [`Mesh::open`](crate::ooc::Mesh::open) reads the output back zero copy. Colours
//! step the hue by the golden ratio per patch id: consecutive ids, which the greedy tiling
//! tends to place side by side, get far-apart hues. Streaming through a 64 KiB buffer; cost:
//! one pass, `12 × vertices + 24 × triangles` bytes without attributes.

use std::io::{self, BufWriter, Write};

use super::Sequence;
use crate::ooc::Mesh;
use crate::ooc::attributes::Attributes;

/// Output buffer size: large enough that the per-record `write_all` calls stay in memory.
const WRITE_BUFFER_BYTES: usize = 64 * 1024;

/// Writes `mesh` as binary little-endian PLY with the faces in `sequence`'s order, each
/// coloured by its patch, with the input's vertex attributes.
pub(super) fn write(
    out: &mut impl Write,
    mesh: &Mesh,
    attributes: &Attributes,
    sequence: &Sequence,
) -> io::Result<()> {
    let present = attributes.present();
    let mut out = BufWriter::with_capacity(WRITE_BUFFER_BYTES, out);
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\n\
         comment patchvis: faces in patch order, coloured by patch; orig_index is the input \
         triangle\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        attributes.vertex_count()
    );
    if present.normals {
        header += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    if present.uvs {
        header += "property float s\nproperty float t\n";
    }
    if present.colours {
        header += "property uchar red\nproperty uchar green\nproperty uchar blue\n\
                   property uchar alpha\n";
    }
    header += &format!(
        "element face {}\nproperty list uchar uint vertex_indices\n\
         property uint patch\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
         property uint orig_index\nend_header\n",
        sequence.triangle_count()
    );
    out.write_all(header.as_bytes())?;
    let mut record = Vec::with_capacity(40);
    for o in 0..attributes.vertex_count() {
        record.clear();
        let floats = mesh
            .position(attributes.source(o))
            .into_iter()
            .chain(
                present
                    .normals
                    .then(|| attributes.normal(o).unwrap_or([0.0; 3]))
                    .into_iter()
                    .flatten(),
            )
            .chain(
                attributes
                    .uv(o)
                    .map(|[s, t]| [s, 1.0 - t])
                    .into_iter()
                    .flatten(),
            );
        for c in floats {
            record.extend_from_slice(&c.to_le_bytes());
        }
        if let Some(colour) = attributes.colour(o) {
            record.extend_from_slice(&colour);
        }
        out.write_all(&record)?;
    }
    let mut failed = Ok(());
    sequence.for_each(|t| {
        if failed.is_err() {
            return;
        }
        let patch = sequence.patch_of(t);
        let mut record = [0u8; 1 + 12 + 4 + 3 + 4];
        record[0] = 3;
        for (field, i) in record[1..13]
            .chunks_exact_mut(4)
            .zip(attributes.corners(mesh, t))
        {
            field.copy_from_slice(&i.to_le_bytes());
        }
        record[13..17].copy_from_slice(&patch.to_le_bytes());
        record[17..20].copy_from_slice(&patch_colour(patch));
        record[20..24].copy_from_slice(&t.to_le_bytes());
        failed = out.write_all(&record);
    });
    failed?;
    out.flush()
}

/// A deterministic, saturated colour for `patch`: hue stepped by the golden ratio conjugate,
/// value alternating between two levels so that hues that come round again still differ.
pub fn patch_colour(patch: u32) -> [u8; 3] {
    const GOLDEN_RATIO_CONJUGATE: f64 = 0.618_033_988_749_894_9;
    /// Value levels; 0.7 keeps dark patches clearly distinct from black.
    const VALUES: [f64; 2] = [1.0, 0.7];
    let hue = (f64::from(patch) * GOLDEN_RATIO_CONJUGATE).fract() * 6.0;
    let value = VALUES[(patch as usize / 7) % VALUES.len()];
    // HSV → RGB with full saturation.
    let sector = hue as u32; // 0..=5
    let f = hue - f64::from(sector);
    let (r, g, b) = match sector {
        0 => (1.0, f, 0.0),
        1 => (1.0 - f, 1.0, 0.0),
        2 => (0.0, 1.0, f),
        3 => (0.0, 1.0 - f, 1.0),
        4 => (f, 0.0, 1.0),
        _ => (1.0, 0.0, 1.0 - f),
    };
    [r, g, b].map(|c| (c * value * 255.0).round() as u8)
}
