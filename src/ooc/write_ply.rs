//! `--mesh-out`: the mesh written back as binary little-endian PLY, faces in patch order and
//! coloured by patch, for inspecting a tiling in any mesh viewer.
//!
//! Every vertex is written as `float x, y, z`; each face as `list uchar uint vertex_indices`
//! (count 3), `uint patch`, `uchar red, green, blue`. Face records have a fixed size and count
//! 3, so [`Mesh::open`](super::Mesh::open) reads the output back zero copy. Colours step the
//! hue by the golden ratio per patch id: consecutive ids, which the greedy tiling tends to
//! place side by side, get far-apart hues. Streaming through a 64 KiB buffer; cost: one pass,
//! `12 × vertices + 18 × triangles` bytes.

use std::io::{self, BufWriter, Write};

use super::Mesh;

/// Output buffer size: large enough that the per-record `write_all` calls stay in memory.
const WRITE_BUFFER_BYTES: usize = 64 * 1024;

/// Writes `mesh` as binary little-endian PLY with the faces in `order` (`order[i]` is the input
/// triangle placed at position `i`), each coloured by its patch, `patch_of[t]` for input
/// triangle `t` (as in `tiling::Tiling`).
///
/// # Panics
///
/// When `patch_of.len() != mesh.triangle_count()`, `order.len()` does not fit in `u32`, or an
/// entry of `order` is not a triangle index: broken caller contracts.
pub fn write_patch_ply(
    out: &mut impl Write,
    mesh: &Mesh,
    order: &[u32],
    patch_of: &[u32],
) -> io::Result<()> {
    assert_eq!(
        patch_of.len(),
        mesh.triangle_count() as usize,
        "patch_of has one entry per input triangle"
    );
    let face_count = u32::try_from(order.len()).expect("at most u32::MAX faces");
    assert!(
        order.iter().all(|&t| t < mesh.triangle_count()),
        "order holds input triangle indices"
    );

    let mut out = BufWriter::with_capacity(WRITE_BUFFER_BYTES, out);
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\n\
         comment patchvis: faces in patch order, coloured by patch\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {face_count}\nproperty list uchar uint vertex_indices\n\
         property uint patch\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
         end_header\n",
        mesh.vertex_count()
    )?;
    for v in 0..mesh.vertex_count() {
        let mut record = [0u8; 12];
        for (field, c) in record.chunks_exact_mut(4).zip(mesh.position(v)) {
            field.copy_from_slice(&c.to_le_bytes());
        }
        out.write_all(&record)?;
    }
    for &t in order {
        let patch = patch_of[t as usize];
        let mut record = [0u8; 1 + 12 + 4 + 3];
        record[0] = 3;
        for (field, i) in record[1..13].chunks_exact_mut(4).zip(mesh.triangle(t)) {
            field.copy_from_slice(&i.to_le_bytes());
        }
        record[13..17].copy_from_slice(&patch.to_le_bytes());
        record[17..20].copy_from_slice(&patch_colour(patch));
        out.write_all(&record)?;
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_mesh_reads_back_reordered_and_in_place() {
        let positions = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 2.5],
        ];
        let triangles = vec![[0, 1, 2], [1, 3, 2], [0, 3, 1]];
        let mesh = Mesh::from_memory("mem", positions.clone(), triangles.clone()).unwrap();
        let order = [2, 0, 1];
        let patch_of = [7, 7, 8];
        let mut bytes = Vec::new();
        write_patch_ply(&mut bytes, &mesh, &order, &patch_of).unwrap();

        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.ply");
        std::fs::write(&path, &bytes).unwrap();
        let back = Mesh::open(&path).unwrap();
        assert!(back.is_mapped());
        assert_eq!(back.vertex_count(), 4);
        assert_eq!(back.triangle_count(), 3);
        for v in 0..4 {
            assert_eq!(back.position(v), positions[v as usize]);
        }
        for (i, &t) in order.iter().enumerate() {
            assert_eq!(back.triangle(i as u32), triangles[t as usize]);
        }
        // The patch id and colour sit right after the indices of the first face record.
        let header_end = bytes
            .windows(11)
            .position(|w| w == b"end_header\n")
            .unwrap()
            + 11;
        let first_face = header_end + 4 * 12;
        assert_eq!(
            &bytes[first_face + 13..first_face + 17],
            &8u32.to_le_bytes()
        );
        assert_eq!(&bytes[first_face + 17..first_face + 20], &patch_colour(8));
        assert_eq!(bytes.len(), header_end + 4 * 12 + 3 * 20);
    }

    #[test]
    fn neighbouring_patches_get_distinct_colours() {
        for p in 0..1000u32 {
            let (a, b) = (patch_colour(p), patch_colour(p + 1));
            let distance: i32 = a
                .iter()
                .zip(b)
                .map(|(&x, y)| (i32::from(x) - i32::from(y)).abs())
                .sum();
            assert!(
                distance > 60,
                "patches {p} and {} look alike: {a:?} {b:?}",
                p + 1
            );
        }
        assert_eq!(patch_colour(5), patch_colour(5));
    }
}
