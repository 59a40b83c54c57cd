//! `patchvis bake --mesh-out` as glTF and PLY on a textured OBJ (`tests/data/obj/globe.obj`:
//! a UV sphere with a texture seam, normals and two materials, one with a PNG texture). The
//! outputs are read by their documented layouts, without the library's readers, and compared
//! with the OBJ corner by corner through the original triangle index, and with the `.pvis`
//! file's patch ranges (the reader's and `patchvis query`'s). tests/web/run.sh loads the same
//! glTF in independent loaders (the Khronos validator, glTF-Transform).

mod common;

use std::path::{Path, PathBuf};

use common::{json, patchvis, stderr};
use patchvis::runtime::Pvis;
use serde_json::Value;

const GLOBE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/obj/globe.obj");
const CHECKER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/obj/checker.png");
/// Small and quick: 16 patches, 66 views of 64 px.
const FLAGS: [&str; 7] = [
    "--patches",
    "16",
    "--level",
    "2",
    "--resolution",
    "64",
    "-q",
];

/// The OBJ's triangles as the bake counts them (quads fan-triangulated): per corner its
/// position and texture coordinate (glTF's convention, `1 - v`), and the material's name.
struct Obj {
    corners: Vec<[([f32; 3], [f32; 2]); 3]>,
    material: Vec<String>,
}

fn read_obj() -> Obj {
    let text = std::fs::read_to_string(GLOBE).unwrap();
    let (mut v, mut vt) = (Vec::new(), Vec::new());
    let mut obj = Obj {
        corners: Vec::new(),
        material: Vec::new(),
    };
    let mut material = String::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        let floats =
            |w: std::str::SplitWhitespace| -> Vec<f32> { w.map(|x| x.parse().unwrap()).collect() };
        match words.next() {
            Some("v") => v.push(floats(words)),
            Some("vt") => vt.push(floats(words)),
            Some("usemtl") => material = words.next().unwrap().to_string(),
            Some("f") => {
                let corners: Vec<([f32; 3], [f32; 2])> = words
                    .map(|c| {
                        let i: Vec<usize> = c.split('/').map(|x| x.parse().unwrap()).collect();
                        let p = &v[i[0] - 1];
                        let t = &vt[i[1] - 1];
                        ([p[0], p[1], p[2]], [t[0], 1.0 - t[1]])
                    })
                    .collect();
                for k in 1..corners.len() - 1 {
                    obj.corners.push([corners[0], corners[k], corners[k + 1]]);
                    obj.material.push(material.clone());
                }
            }
            _ => {}
        }
    }
    obj
}

/// Bakes the globe into a fresh directory with `--mesh-out NAME`; returns the directory, the
/// `.pvis` path and the mesh path.
fn bake(name: &str) -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let pvis = dir.path().join("globe.pvis");
    let mesh = dir.path().join(name);
    let mut args = vec![
        "bake",
        GLOBE,
        "-o",
        pvis.to_str().unwrap(),
        "--mesh-out",
        mesh.to_str().unwrap(),
    ];
    args.extend(FLAGS);
    let out = patchvis(&args);
    assert!(out.status.success(), "bake failed: {}", stderr(&out));
    (dir, pvis, mesh)
}

/// The reader's patch ranges: `first[i]..first[i + 1]` for patch `i`, then the count.
fn pvis_firsts(pvis: &Path) -> Vec<u32> {
    let bytes = std::fs::read(pvis).unwrap();
    let file = Pvis::parse(&bytes).unwrap();
    let mut firsts: Vec<u32> = (0..file.patch_count())
        .map(|p| file.patch(p).first_triangle)
        .collect();
    let last = file.patch(file.patch_count() - 1);
    firsts.push(last.first_triangle + last.triangle_count);
    firsts
}

/// A GLB's JSON and binary chunk.
fn read_glb(path: &Path) -> (Value, Vec<u8>) {
    let bytes = std::fs::read(path).unwrap();
    let word = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
    assert_eq!(&bytes[..4], b"glTF");
    assert_eq!(word(4), 2, "GLB version");
    assert_eq!(word(8), bytes.len(), "GLB length");
    let json_length = word(12);
    assert_eq!(&bytes[16..20], b"JSON");
    let json: Value = serde_json::from_slice(&bytes[20..20 + json_length]).unwrap();
    let bin_at = 20 + json_length;
    assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
    let bin = bytes[bin_at + 8..bin_at + 8 + word(bin_at)].to_vec();
    (json, bin)
}

/// Element `i` of accessor `a` as `n` little-endian `f32`s or `u32`s (as `f64`).
fn element(json: &Value, bin: &[u8], a: u64, i: usize, n: usize) -> Vec<f64> {
    let accessor = &json["accessors"][a as usize];
    let view = &json["bufferViews"][accessor["bufferView"].as_u64().unwrap() as usize];
    let at = view["byteOffset"].as_u64().unwrap_or(0) as usize
        + accessor["byteOffset"].as_u64().unwrap_or(0) as usize
        + 4 * n * i;
    (0..n)
        .map(|k| {
            let b: [u8; 4] = bin[at + 4 * k..at + 4 * k + 4].try_into().unwrap();
            match accessor["componentType"].as_u64().unwrap() {
                5126 => f64::from(f32::from_le_bytes(b)),
                5125 => f64::from(u32::from_le_bytes(b)),
                other => panic!("component type {other}"),
            }
        })
        .collect()
}

#[test]
fn glb_from_a_textured_obj_keeps_uvs_and_materials_in_patch_order() {
    let (_dir, pvis, glb) = bake("globe.glb");
    let (json, bin) = read_glb(&glb);
    let obj = read_obj();
    let triangles = obj.corners.len();

    // Materials: the MTL's colour and the PNG, embedded byte for byte.
    let materials = json["materials"].as_array().unwrap();
    let names: Vec<&str> = materials
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["checker", "paint"]);
    let paint = &materials[1]["pbrMetallicRoughness"];
    assert_eq!(paint["baseColorFactor"][2].as_f64().unwrap() as f32, 0.8);
    let texture = &json["textures"]
        [materials[0]["pbrMetallicRoughness"]["baseColorTexture"]["index"]
            .as_u64()
            .unwrap() as usize];
    let image = &json["images"][texture["source"].as_u64().unwrap() as usize];
    assert_eq!(image["mimeType"], "image/png");
    let view = &json["bufferViews"][image["bufferView"].as_u64().unwrap() as usize];
    let at = view["byteOffset"].as_u64().unwrap() as usize;
    let png = std::fs::read(CHECKER).unwrap();
    assert_eq!(
        &bin[at..at + view["byteLength"].as_u64().unwrap() as usize],
        &png[..]
    );

    // The patch ranges are the .pvis file's.
    let extras = &json["meshes"][0]["extras"]["patchvis"];
    let firsts: Vec<u32> = serde_json::from_value(extras["patch_first_triangle"].clone()).unwrap();
    assert_eq!(firsts, pvis_firsts(&pvis));
    assert_eq!(extras["triangle_count"], triangles);

    // The original triangle of every output triangle: a permutation.
    let original_view =
        &json["bufferViews"][extras["original_triangle_buffer_view"].as_u64().unwrap() as usize];
    let at = original_view["byteOffset"].as_u64().unwrap() as usize;
    let original: Vec<usize> = (0..triangles)
        .map(|i| u32::from_le_bytes(bin[at + 4 * i..at + 4 * i + 4].try_into().unwrap()) as usize)
        .collect();
    let mut sorted = original.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, (0..triangles).collect::<Vec<_>>());

    // Primitives cover the triangles in order; each corner has the OBJ's position, texture
    // coordinate and material, and a unit normal.
    let mut next = 0usize;
    for primitive in json["meshes"][0]["primitives"].as_array().unwrap() {
        let range = &primitive["extras"]["patchvis"];
        let first = range["first_triangle"].as_u64().unwrap() as usize;
        let count = range["triangle_count"].as_u64().unwrap() as usize;
        assert_eq!(first, next, "primitives in order, back to back");
        next += count;
        let indices = primitive["indices"].as_u64().unwrap();
        assert_eq!(json["accessors"][indices as usize]["count"], 3 * count);
        let attributes = &primitive["attributes"];
        let material = names[primitive["material"].as_u64().unwrap() as usize];
        for k in 0..count {
            let t = original[first + k];
            assert_eq!(obj.material[t], material, "triangle {}", first + k);
            let corners = element(&json, &bin, indices, k, 3);
            for (c, &vertex) in corners.iter().enumerate() {
                let v = vertex as usize;
                let p = element(&json, &bin, attributes["POSITION"].as_u64().unwrap(), v, 3);
                let uv = element(
                    &json,
                    &bin,
                    attributes["TEXCOORD_0"].as_u64().unwrap(),
                    v,
                    2,
                );
                let n = element(&json, &bin, attributes["NORMAL"].as_u64().unwrap(), v, 3);
                let (ep, euv) = obj.corners[t][c];
                assert_eq!(p, ep.map(f64::from), "position of triangle {t} corner {c}");
                assert_eq!(uv, euv.map(f64::from), "uv of triangle {t} corner {c}");
                let length = n.iter().map(|x| x * x).sum::<f64>().sqrt();
                assert!((length - 1.0).abs() < 1e-5);
            }
        }
    }
    assert_eq!(next, triangles);

    // A query's ranges are unions of the glTF's patch ranges.
    let pvis = pvis.to_str().unwrap();
    for eye in ["3,1,2", "-2.5,0.5,-1", "0,-3,0.2", "0.1,0.1,0.1"] {
        let answer = json_of(&patchvis(&["query", pvis, "--from", eye, "--json"]));
        let mut merged: Vec<[u32; 2]> = Vec::new();
        for p in answer["patches"].as_array().unwrap() {
            let p = p.as_u64().unwrap() as usize;
            let (a, b) = (firsts[p], firsts[p + 1]);
            match merged.last_mut() {
                Some(last) if last[0] + last[1] == a => last[1] += b - a,
                _ => merged.push([a, b - a]),
            }
        }
        let ranges: Vec<[u32; 2]> = serde_json::from_value(answer["ranges"].clone()).unwrap();
        assert_eq!(ranges, merged, "eye {eye}");
    }
}

fn json_of(out: &std::process::Output) -> Value {
    json(out)
}

#[test]
fn ply_carries_the_original_triangle_index_and_the_vertex_attributes() {
    let (_dir, pvis, ply) = bake("globe.ply");
    let bytes = std::fs::read(&ply).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    let vertex_properties = ["x", "y", "z", "nx", "ny", "nz", "s", "t"]
        .map(|p| format!("property float {p}\n"))
        .concat();
    assert!(header.contains(&vertex_properties), "{header}");
    assert!(header.contains(
        "property list uchar uint vertex_indices\nproperty uint patch\nproperty uchar red\n\
         property uchar green\nproperty uchar blue\nproperty uint orig_index\n"
    ));
    let count = |element: &str| -> usize {
        let line = header
            .lines()
            .find(|l| l.starts_with(&format!("element {element} ")))
            .unwrap();
        line.split_whitespace().nth(2).unwrap().parse().unwrap()
    };
    let (vertices, faces) = (count("vertex"), count("face"));
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let faces_at = end + 32 * vertices;
    assert_eq!(faces_at + 24 * faces, bytes.len());

    let obj = read_obj();
    assert_eq!(faces, obj.corners.len());
    let firsts = pvis_firsts(&pvis);
    let mut seen = vec![false; faces];
    for i in 0..faces {
        let o = faces_at + 24 * i;
        let t = u32_at(o + 20) as usize;
        assert!(!seen[t], "orig_index {t} twice");
        seen[t] = true;
        let patch = u32_at(o + 13) as usize;
        assert!((firsts[patch]..firsts[patch + 1]).contains(&(i as u32)));
        for c in 0..3 {
            let v = u32_at(o + 1 + 4 * c) as usize;
            let at = end + 32 * v;
            let p = [f32_at(at), f32_at(at + 4), f32_at(at + 8)];
            // PLY keeps the OBJ's texture convention (origin bottom left).
            let st = [f32_at(at + 24), 1.0 - f32_at(at + 28)];
            let (ep, euv) = obj.corners[t][c];
            assert_eq!(p, ep, "face {i} (input triangle {t}) corner {c}");
            assert!((st[0] - euv[0]).abs() < 1e-6 && (st[1] - euv[1]).abs() < 1e-6);
        }
    }
}

#[test]
fn gltf_is_one_self_contained_file_that_reads_back() {
    let (_dir, _pvis, gltf) = bake("globe.gltf");
    let text = std::fs::read_to_string(&gltf).unwrap();
    let json: Value = serde_json::from_str(&text).unwrap();
    let uri = json["buffers"][0]["uri"].as_str().unwrap();
    assert!(uri.starts_with("data:application/octet-stream;base64,"));
    // The library's own glTF input reads it back: same triangles.
    let mesh = patchvis::ooc::Mesh::open_with(
        &gltf,
        &patchvis::ooc::OpenOptions {
            cache_dir: None,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(mesh.triangle_count() as usize, read_obj().corners.len());
}
