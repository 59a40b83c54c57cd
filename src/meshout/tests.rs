//! `--mesh-out` writers on small meshes: the PLY reads back in place, in patch order, with
//! its original indices; the GLB's index ranges follow the patches.

use super::*;
use crate::ooc::attributes::Attributes;
use crate::tiling::tile;

/// A strip of `n` quads (2n triangles) along x.
fn strip(n: u32) -> Mesh {
    let mut positions = Vec::new();
    for i in 0..=n {
        positions.push([i as f32, 0.0, 0.0]);
        positions.push([i as f32, 1.0, 0.0]);
    }
    let mut triangles = Vec::new();
    for i in 0..n {
        let (a, b, c, d) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        triangles.push([a, c, b]);
        triangles.push([b, c, d]);
    }
    Mesh::from_memory("strip", positions, triangles).unwrap()
}

#[test]
fn ply_reads_back_in_patch_order_with_original_indices() {
    let mesh = strip(16);
    let tiling = tile(&mesh, 4).unwrap();
    let attributes = Attributes::read(&mesh, true).unwrap();
    let mut bytes = Vec::new();
    write(&mut bytes, MeshFormat::Ply, &mesh, &attributes, &tiling).unwrap();

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.ply");
    std::fs::write(&path, &bytes).unwrap();
    let back = Mesh::open(&path).unwrap();
    assert!(back.is_mapped());
    assert_eq!(back.vertex_count(), mesh.vertex_count());
    assert_eq!(back.triangle_count(), mesh.triangle_count());
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let faces = header_end + 12 * mesh.vertex_count() as usize;
    assert_eq!(bytes.len(), faces + 24 * mesh.triangle_count() as usize);
    for (i, &t) in tiling.order.iter().enumerate() {
        assert_eq!(back.triangle(i as u32), mesh.triangle(t));
        let record = &bytes[faces + 24 * i..faces + 24 * (i + 1)];
        let patch = tiling.patch_of[t as usize];
        assert_eq!(record[13..17], patch.to_le_bytes());
        assert_eq!(record[17..20], patch_colour(patch));
        assert_eq!(record[20..24], t.to_le_bytes(), "orig_index of face {i}");
    }
}

#[test]
fn glb_ranges_are_the_patch_ranges() {
    let mesh = strip(16);
    let tiling = tile(&mesh, 4).unwrap();
    let attributes = Attributes::read(&mesh, true).unwrap();
    let mut bytes = Vec::new();
    write(&mut bytes, MeshFormat::Glb, &mesh, &attributes, &tiling).unwrap();
    assert_eq!(&bytes[..4], b"glTF");
    assert_eq!(
        u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
        bytes.len()
    );
    let json_length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_length]).unwrap();
    let extras = &json["meshes"][0]["extras"]["patchvis"];
    let firsts: Vec<u32> = serde_json::from_value(extras["patch_first_triangle"].clone()).unwrap();
    let expected: Vec<u32> = tiling
        .patches
        .iter()
        .map(|p| p.first)
        .chain([mesh.triangle_count()])
        .collect();
    assert_eq!(firsts, expected);
    // The index view holds the triangles in patch order.
    let bin = 20 + json_length + 8;
    let view = &json["bufferViews"][extras["index_buffer_view"].as_u64().unwrap() as usize];
    let at = bin + view["byteOffset"].as_u64().unwrap() as usize;
    for (i, &t) in tiling.order.iter().enumerate() {
        let tri: Vec<u32> = (0..3)
            .map(|k| {
                let o = at + 12 * i + 4 * k;
                u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap())
            })
            .collect();
        assert_eq!(tri, mesh.triangle(t));
    }
    // Computed normals: the strip faces +z or -z, unit length.
    let normals = &json["bufferViews"][1];
    let at = bin + normals["byteOffset"].as_u64().unwrap() as usize;
    let z = f32::from_le_bytes(bytes[at + 8..at + 12].try_into().unwrap());
    assert_eq!(z.abs(), 1.0);
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

#[test]
fn formats_by_extension() {
    assert_eq!(MeshFormat::of(Path::new("a.ply")), MeshFormat::Ply);
    assert_eq!(MeshFormat::of(Path::new("a.GLB")), MeshFormat::Glb);
    assert_eq!(MeshFormat::of(Path::new("a.gltf")), MeshFormat::Gltf);
    assert_eq!(MeshFormat::of(Path::new("/dev/null")), MeshFormat::Ply);
    assert_eq!(MeshFormat::of(Path::new("mesh.out")), MeshFormat::Ply);
}
