//! The attribute readers on files: PLY normals and texture coordinates, OBJ welding and
//! materials, glTF normals under a node transform, and the refusals.

use std::path::Path;

use super::*;

const WUSON: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/ply/Wuson.ply");

fn open(path: &Path) -> Mesh {
    crate::ooc::Mesh::open_with(
        path,
        &crate::ooc::OpenOptions {
            cache_dir: None,
            ..Default::default()
        },
    )
    .unwrap()
}

#[test]
fn ply_normals_and_texture_coordinates_per_vertex() {
    let mesh = open(Path::new(WUSON));
    let a = Attributes::read(&mesh, true).unwrap();
    assert_eq!(
        a.present(),
        Present {
            normals: true,
            uvs: true,
            colours: false
        }
    );
    assert_eq!(a.vertex_count(), mesh.vertex_count());
    // The first vertex: `0.163313 0.540615 -0.268688 0.241919 -0.961129 0.133063 0.681180
    // 0.275678`; t flipped to glTF's convention.
    assert_eq!(a.source(0), 0);
    assert_eq!(a.normal(0), Some([0.241919, -0.961129, 0.133063]));
    assert_eq!(a.uv(0), Some([0.68118, 1.0 - 0.275678]));
    assert_eq!(a.corners(&mesh, 5), mesh.triangle(5));
    assert_eq!(a.material(5), NO_MATERIAL);
}

/// Writes `files` (name, contents) into a fresh directory.
fn files(list: &[(&str, &[u8])]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in list {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    dir
}

const QUADS: &str = "mtllib m.mtl\n\
    v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n\
    vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.5 0.5\n\
    vn 0 0 2\n\
    usemtl red\n\
    f 1/1/1 2/2/1 3/3/1 4/4/1\n\
    usemtl skin\n\
    f -5/5/-1 5/2/1 6/3/1 -4/3/1\n";

#[test]
fn obj_corners_are_welded_by_position_texture_coordinate_and_normal() {
    let dir = files(&[
        ("quads.obj", QUADS.as_bytes()),
        (
            "m.mtl",
            b"newmtl skin\nKd 0.5 0.25 1\nd 0.5\nnewmtl red\nKd 1 0 0\n",
        ),
    ]);
    let mesh = open(&dir.path().join("quads.obj"));
    let a = Attributes::read(&mesh, true).unwrap();
    assert_eq!(mesh.triangle_count(), 4);
    // Vertex 2 (1-based) appears with vt 2 and vt 5: welded into two output vertices;
    // vertex 3 with vt 3 twice: one.
    assert_eq!(a.vertex_count(), 7);
    let t2 = a.corners(&mesh, 2);
    assert_eq!(a.source(t2[0]), 1);
    assert_eq!(a.uv(t2[0]), Some([0.5, 0.5]));
    // Fan triangles; the second quad's last corner (vertex 3, vt 3) reuses output vertex 2.
    let corners: Vec<[u32; 3]> = (0..4).map(|t| a.corners(&mesh, t)).collect();
    assert_eq!(corners, [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 2]]);
    assert_eq!(a.uv(a.corners(&mesh, 0)[0]), Some([0.0, 1.0]));
    // Normals are the file's (unnormalised; the glTF writer normalises).
    assert_eq!(a.normal(0), Some([0.0, 0.0, 2.0]));
    // Materials in order of first use, with the library's values.
    let names: Vec<&str> = a.materials().iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["red", "skin"]);
    assert_eq!(a.materials()[1].base_colour, [0.5, 0.25, 1.0, 0.5]);
    assert_eq!(a.materials()[1].alpha, AlphaMode::Blend);
    assert_eq!(
        (0..4).map(|t| a.material(t)).collect::<Vec<_>>(),
        [0, 0, 1, 1]
    );
}

#[test]
fn textures_are_read_and_refused_by_name() {
    let png = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/obj/checker.png"
    ))
    .unwrap();
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
    let with = |map: &str, extra: &[(&str, &[u8])]| {
        let mtl = format!("newmtl a\nmap_Kd -s 1 1 1 {map}\n");
        let mut list: Vec<(&str, &[u8])> =
            vec![("t.obj", obj.as_bytes()), ("m.mtl", mtl.as_bytes())];
        list.extend_from_slice(extra);
        let dir = files(&list);
        let mesh = open(&dir.path().join("t.obj"));
        (
            Attributes::read(&mesh, true),
            Attributes::read(&mesh, false),
        )
    };
    let (read, _) = with("c.png", &[("c.png", &png)]);
    let texture = read.unwrap().materials()[0].texture.clone().unwrap();
    assert_eq!((texture.mime, texture.bytes), ("image/png", png.clone()));

    let (read, without) = with("missing.png", &[]);
    let message = read.err().unwrap().to_string();
    assert!(message.contains("map_Kd of material 'a'") && message.contains("missing.png"));
    // A PLY output has no use for the image: not read, no error.
    assert!(without.unwrap().materials()[0].texture.is_none());

    let (read, _) = with("c.tga", &[("c.tga", b"not an image")]);
    assert!(
        read.err()
            .unwrap()
            .to_string()
            .contains("neither PNG nor JPEG")
    );
}

#[test]
fn gltf_normals_follow_the_node_transform() {
    use base64::Engine as _;
    // One triangle in the z = 0 plane, normals +z, under a scale of (1, 1, 4): the normals
    // stay +z (renormalised); positions are scaled by the conversion.
    let mut bin = Vec::new();
    for p in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        bin.extend(p.iter().flat_map(|c| c.to_le_bytes()));
    }
    for _ in 0..3 {
        bin.extend([1.0f32, 0.0, 1.0].iter().flat_map(|c| c.to_le_bytes()));
    }
    let uri = base64::engine::general_purpose::STANDARD.encode(&bin);
    let gltf = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"mesh":0,"scale":[1,1,4]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}}}}]}}],
        "accessors":[
          {{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
          {{"bufferView":0,"byteOffset":36,"componentType":5126,"count":3,"type":"VEC3"}}],
        "bufferViews":[{{"buffer":0,"byteLength":72}}],
        "buffers":[{{"byteLength":72,"uri":"data:application/octet-stream;base64,{uri}"}}]}}"#
    );
    let dir = files(&[("t.gltf", gltf.as_bytes())]);
    let mesh = open(&dir.path().join("t.gltf"));
    let a = Attributes::read(&mesh, true).unwrap();
    assert!(a.present().normals && !a.present().uvs);
    let n = a.normal(0).unwrap();
    // (1, 0, 1) under the inverse transpose of scale (1, 1, 4): (1, 0, 1/4), normalised.
    let expected = [1.0, 0.0, 0.25].map(|c: f32| c / (1.0f32 + 0.0625).sqrt());
    for k in 0..3 {
        assert!((n[k] - expected[k]).abs() < 1e-6, "{n:?} vs {expected:?}");
    }
}
