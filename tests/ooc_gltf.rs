//! glTF 2.0 and GLB input through the public `Mesh` API. Every file is built here: JSON by
//! hand with the binary data in a base64 data URI, a GLB with a BIN chunk, and a `.gltf` with
//! an external `.bin`. Covers node transforms (matrix and TRS) composed down the hierarchy,
//! instancing, default and all-scenes selection, u8/u16/u32 indices, interleaved strides,
//! strips and fans, mirrored winding, skipped line primitives, and malformed files with their
//! error kind and the JSON path or byte they name.

use patchvis::ooc::{ErrorPosition, Mesh, MeshError, MeshErrorKind, MeshSource, OpenOptions};
use std::path::Path;

/// Standard base64 with padding (the tests' own encoder, so they do not test the decoder
/// against itself).
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Collects binary data into one buffer and writes the matching bufferViews and accessors.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<String>,
    accessors: Vec<String>,
}

impl Builder {
    /// Appends `bytes` (4-byte aligned) as a new bufferView; returns its index.
    fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let stride = stride.map_or(String::new(), |s| format!(r#","byteStride":{s}"#));
        self.views.push(format!(
            r#"{{"buffer":0,"byteOffset":{},"byteLength":{}{stride}}}"#,
            self.bin.len(),
            bytes.len()
        ));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }
    fn accessor(
        &mut self,
        view: usize,
        offset: usize,
        component: u32,
        count: usize,
        ty: &str,
    ) -> usize {
        self.accessors.push(format!(
            r#"{{"bufferView":{view},"byteOffset":{offset},"componentType":{component},"count":{count},"type":"{ty}"}}"#
        ));
        self.accessors.len() - 1
    }
    fn positions(&mut self, points: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = points
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        let view = self.view(&bytes, None);
        self.accessor(view, 0, 5126, points.len(), "VEC3")
    }
    fn indices_u8(&mut self, indices: &[u8]) -> usize {
        let view = self.view(indices, None);
        self.accessor(view, 0, 5121, indices.len(), "SCALAR")
    }
    fn indices_u16(&mut self, indices: &[u16]) -> usize {
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, None);
        self.accessor(view, 0, 5123, indices.len(), "SCALAR")
    }
    fn indices_u32(&mut self, indices: &[u32]) -> usize {
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, None);
        self.accessor(view, 0, 5125, indices.len(), "SCALAR")
    }
    /// The document: `rest` holds the meshes, nodes, scenes (JSON members, no braces);
    /// `uri` is the buffer's URI (`None`: a data URI; `Some("")`: none, the GLB BIN chunk).
    fn json(&self, rest: &str, uri: Option<&str>) -> String {
        let uri = match uri {
            None => format!(
                r#","uri":"data:application/octet-stream;base64,{}""#,
                base64(&self.bin)
            ),
            Some("") => String::new(),
            Some(u) => format!(r#","uri":"{u}""#),
        };
        format!(
            r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{}{uri}}}],"bufferViews":[{}],"accessors":[{}],{rest}}}"#,
            self.bin.len(),
            self.views.join(","),
            self.accessors.join(",")
        )
    }
    /// A GLB: header, JSON chunk (space-padded), BIN chunk (zero-padded).
    fn glb(&self, rest: &str) -> Vec<u8> {
        let mut json = self.json(rest, Some("")).into_bytes();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let mut bin = self.bin.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::new();
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    }
}

/// The unit square in z = 0, as two triangles over four corners.
const SQUARE: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
];

fn open(dir: &Path, name: &str, bytes: &[u8]) -> Result<Mesh, MeshError> {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    Mesh::open_with(
        &path,
        &OpenOptions {
            cache_dir: Some(dir.join("cache")),
            memory_budget: 1 << 20,
        },
    )
}

/// Every triangle as its three corner positions, in output order.
fn corners(mesh: &Mesh) -> Vec<[[f32; 3]; 3]> {
    (0..mesh.triangle_count())
        .map(|t| mesh.triangle(t).map(|v| mesh.position(v)))
        .collect()
}

fn moved(points: [[f32; 3]; 3], f: impl Fn([f32; 3]) -> [f32; 3]) -> [[f32; 3]; 3] {
    points.map(f)
}

#[test]
fn transforms_compose_and_meshes_are_instanced() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let p = b.positions(&SQUARE);
    let i = b.indices_u16(&[0, 1, 2, 0, 2, 3]);
    // Scene 0 (the default): node 0 (mesh, translated by x + 10) and node 1 (scale 2, matrix)
    // whose child node 2 holds the same mesh rotated 90° about z. Scene 1's node 3 must not
    // appear.
    let rest = format!(
        r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"indices":{i}}}]}}],
        "nodes":[{{"mesh":0,"translation":[10,0,0]}},
                 {{"matrix":[2,0,0,0, 0,2,0,0, 0,0,2,0, 0,0,0,1],"children":[2]}},
                 {{"mesh":0,"rotation":[0,0,0.70710677,0.70710677]}},
                 {{"mesh":0}}],
        "scenes":[{{"nodes":[0,1]}},{{"nodes":[3]}}],"scene":0"#
    );
    let mesh = open(dir.path(), "square.gltf", b.json(&rest, None).as_bytes()).unwrap();
    assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (8, 4));
    assert_eq!(mesh.source(), MeshSource::Converted);
    let got = corners(&mesh);
    let square = [
        [SQUARE[0], SQUARE[1], SQUARE[2]],
        [SQUARE[0], SQUARE[2], SQUARE[3]],
    ];
    let close = |a: [[f32; 3]; 3], b: [[f32; 3]; 3]| {
        a.iter()
            .flatten()
            .zip(b.iter().flatten())
            .all(|(x, y)| (x - y).abs() < 1e-5)
    };
    for (t, tri) in square.iter().enumerate() {
        let shifted = moved(*tri, |[x, y, z]| [x + 10.0, y, z]);
        assert!(close(got[t], shifted), "{t}: {:?}", got[t]);
        // Rotation (x, y) -> (-y, x), then scale 2.
        let turned = moved(*tri, |[x, y, z]| [-2.0 * y, 2.0 * x, 2.0 * z]);
        assert!(close(got[2 + t], turned), "{t}: {:?}", got[2 + t]);
    }
    let bounds = mesh.bounds();
    assert!(close(
        [bounds.min, bounds.max, [0.0; 3]],
        [[-2.0, 0.0, 0.0], [11.0, 2.0, 0.0], [0.0; 3]]
    ));

    // Without "scene", every scene is drawn: node 3 adds a third instance.
    let all = rest.replace(r#","scene":0"#, "");
    let mesh = open(dir.path(), "all.gltf", b.json(&all, None).as_bytes()).unwrap();
    assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (12, 6));
    assert!(close(corners(&mesh)[4], square[0]));

    // A second open of the unchanged file is a cache hit.
    let again = Mesh::open_with(
        &dir.path().join("all.gltf"),
        &OpenOptions {
            cache_dir: Some(dir.path().join("cache")),
            memory_budget: 1 << 20,
        },
    )
    .unwrap();
    assert_eq!(again.source(), MeshSource::CacheHit);
    assert_eq!(corners(&again), corners(&mesh));
}

#[test]
fn strips_fans_u8_indices_and_skipped_lines() {
    let dir = tempfile::tempdir().unwrap();
    let points: Vec<[f32; 3]> = (0..5).map(|k| [k as f32, (k % 2) as f32, 0.0]).collect();
    let mut b = Builder::default();
    let p = b.positions(&points);
    let i = b.indices_u8(&[4, 3, 2, 1, 0]);
    let rest = format!(
        r#""meshes":[{{"primitives":[
            {{"attributes":{{"POSITION":{p}}},"mode":5}},
            {{"attributes":{{"POSITION":{p}}},"indices":{i},"mode":6}},
            {{"attributes":{{"POSITION":{p}}},"mode":1}}]}}],
        "nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0"#
    );
    let mesh = open(dir.path(), "strip.gltf", b.json(&rest, None).as_bytes()).unwrap();
    // Strip: 3 triangles, 5 vertices; fan: 3 triangles, 5 more vertices; lines: none (but
    // the line primitive is skipped before its vertices are written).
    assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (10, 6));
    let triangles: Vec<[u32; 3]> = (0..6).map(|t| mesh.triangle(t)).collect();
    assert_eq!(
        triangles,
        vec![
            [0, 1, 2],
            [1, 3, 2], // glTF § 3.7.2.1: odd triangles are (v_i, v_i+2, v_i+1)
            [2, 3, 4],
            [5 + 3, 5 + 2, 5 + 4], // fan over indices 4 3 2 1 0: (v1, v2, v0)
            [5 + 2, 5 + 1, 5 + 4],
            [5 + 1, 5, 5 + 4],
        ]
    );
}

#[test]
fn glb_with_bin_chunk_interleaved_u32_and_mirroring() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    // Interleaved: position (12 bytes) then a 4-byte colour per vertex, stride 16.
    let mut interleaved = Vec::new();
    for p in SQUARE {
        interleaved.extend(p.iter().flat_map(|c| c.to_le_bytes()));
        interleaved.extend([255, 0, 0, 255]);
    }
    let view = b.view(&interleaved, Some(16));
    let p = b.accessor(view, 0, 5126, 4, "VEC3");
    let i = b.indices_u32(&[0, 1, 2, 0, 2, 3]);
    let rest = format!(
        r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"indices":{i}}}]}}],
        "nodes":[{{"mesh":0}},{{"mesh":0,"scale":[-1,1,1]}}],"scenes":[{{"nodes":[0,1]}}]"#
    );
    let glb = b.glb(&rest);
    let mesh = open(dir.path(), "square.glb", &glb).unwrap();
    assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (8, 4));
    assert_eq!(mesh.position(2), SQUARE[2]);
    assert_eq!(mesh.triangle(1), [0, 2, 3]);
    // The mirrored copy keeps its front faces: winding flipped.
    assert_eq!(mesh.triangle(2), [4, 6, 5]);
    assert_eq!(mesh.position(5), [-1.0, 0.0, 0.0]);

    // Truncated anywhere: a clear error with the byte, never a panic.
    for cut in [4, 11, 12, 19, 30, glb.len() - 20, glb.len() - 1] {
        let err = open(dir.path(), "cut.glb", &glb[..cut]).unwrap_err();
        assert_eq!(err.kind(), MeshErrorKind::Truncated, "cut {cut}: {err}");
        assert!(
            matches!(err.position(), Some(ErrorPosition::Byte(_))),
            "{err}"
        );
        assert!(err.to_string().contains("cut.glb"), "{err}");
    }
}

#[test]
fn external_bin_is_read_relative_and_not_cached() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let p = b.positions(&SQUARE);
    let i = b.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let rest = format!(
        r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"indices":{i}}}]}}],
        "nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0"#
    );
    std::fs::create_dir(dir.path().join("data")).unwrap();
    std::fs::write(dir.path().join("data/square data.bin"), &b.bin).unwrap();
    let json = b.json(&rest, Some("data/square%20data.bin"));
    for _ in 0..2 {
        let mesh = open(dir.path(), "ext.gltf", json.as_bytes()).unwrap();
        assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (4, 2));
        // The .bin could change without the .gltf changing: never a cache hit.
        assert_eq!(mesh.source(), MeshSource::Converted);
    }
    std::fs::remove_file(dir.path().join("data/square data.bin")).unwrap();
    let err = open(dir.path(), "ext.gltf", json.as_bytes()).unwrap_err();
    assert_eq!(err.kind(), MeshErrorKind::Io, "{err}");
    assert!(err.to_string().contains("buffers[0].uri"), "{err}");
}

/// Opens `json` and checks the error's kind and that it mentions `mention`.
fn expect(json: &str, kind: MeshErrorKind, mention: &str) {
    let dir = tempfile::tempdir().unwrap();
    let err = open(dir.path(), "bad.gltf", json.as_bytes()).unwrap_err();
    let text = err.to_string();
    assert_eq!(err.kind(), kind, "{text}");
    assert!(
        text.starts_with(&dir.path().join("bad.gltf").display().to_string()),
        "{text}"
    );
    assert!(text.contains(mention), "'{text}' lacks '{mention}'");
}

#[test]
fn malformed_gltf_files_name_the_path_and_accessor() {
    use MeshErrorKind::*;
    let mut b = Builder::default();
    let p = b.positions(&SQUARE);
    let i = b.indices_u16(&[0, 1, 2, 0, 2, 7]);
    let with = |primitive: &str| {
        format!(
            r#""meshes":[{{"primitives":[{primitive}]}}],"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}]"#
        )
    };
    // Index 7 of 4 vertices.
    let json = b.json(
        &with(&format!(
            r#"{{"attributes":{{"POSITION":{p}}},"indices":{i}}}"#
        )),
        None,
    );
    expect(
        &json,
        BadIndex,
        "meshes[0].primitives[0] (via nodes[0]).indices: accessor 1 element 5 is 7, expected < 4",
    );
    // A missing accessor.
    let json = b.json(
        &with(&format!(
            r#"{{"attributes":{{"POSITION":{p}}},"indices":9}}"#
        )),
        None,
    );
    expect(&json, BadIndex, "meshes[0].primitives[0].indices");
    // A missing POSITION accessor (gltf-json 1.4.1 panicked on this; found by fuzzing).
    let json = b.json(&with(r#"{"attributes":{"POSITION":5}}"#), None);
    expect(
        &json,
        BadIndex,
        "attributes.POSITION: accessor 5 does not exist, expected < 2",
    );
    // No POSITION.
    let json = b.json(&with(r#"{"attributes":{}}"#), None);
    expect(
        &json,
        MissingProperty,
        r#"meshes[0].primitives[0].attributes["POSITION"]: Missing"#,
    );
    // Positions of the wrong type.
    let json = b.json(
        &with(&format!(r#"{{"attributes":{{"POSITION":{i}}}}}"#)),
        None,
    );
    expect(
        &json,
        UnsupportedFormat,
        "accessor 1 is SCALAR of UNSIGNED_SHORT, expected VEC3 of FLOAT",
    );
    // Points only: no triangles.
    let json = b.json(
        &with(&format!(r#"{{"attributes":{{"POSITION":{p}}},"mode":0}}"#)),
        None,
    );
    expect(&json, NoFaces, "1 point or line primitives skipped");
    // Not JSON at all, on line 2.
    expect("{\n  \"asset\": oops }", BadHeader, "does not parse");
    // Draco and friends.
    let json = b
        .json(
            &with(&format!(r#"{{"attributes":{{"POSITION":{p}}}}}"#)),
            None,
        )
        .replacen(
            '{',
            r#"{"extensionsRequired":["KHR_draco_mesh_compression"],"#,
            1,
        );
    expect(&json, UnsupportedFormat, "KHR_draco_mesh_compression");
    // A node with two parents.
    let json = b.json(
        &format!(
            r#""meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}}],
            "nodes":[{{"children":[2]}},{{"children":[2]}},{{"mesh":0}}],"scenes":[{{"nodes":[0,1]}}]"#
        ),
        None,
    );
    expect(
        &json,
        BadHeader,
        "nodes[2] is a child of nodes[0] and nodes[1]",
    );
    // An accessor reaching past its view.
    let json = b
        .json(
            &with(&format!(r#"{{"attributes":{{"POSITION":{p}}}}}"#)),
            None,
        )
        .replace(r#""count":4,"type":"VEC3""#, r#""count":5,"type":"VEC3""#);
    expect(&json, Truncated, "accessor 0 has 5 elements");
    // An empty index accessor whose offset lies past its view: nothing to read, no triangles.
    let empty = b.accessor(0, 52, 5123, 0, "SCALAR");
    let json = b.json(
        &with(&format!(
            r#"{{"attributes":{{"POSITION":{p}}},"indices":{empty}}}"#
        )),
        None,
    );
    expect(&json, NoFaces, "no triangles: the scene has 4 vertices");
    // A non-finite position (a NaN in the data).
    let mut nan = Builder::default();
    let p = nan.positions(&[[0.0, 0.0, 0.0], [1.0, f32::NAN, 0.0], [0.0, 1.0, 0.0]]);
    let json = nan.json(
        &with(&format!(r#"{{"attributes":{{"POSITION":{p}}}}}"#)),
        None,
    );
    expect(&json, NonFinite, "accessor 0 element 1 is (1, NaN, 0)");
    // A huge transform overflows f32.
    let json = b
        .json(&with(r#"{"attributes":{"POSITION":0}}"#), None)
        .replace(
            r#"{"mesh":0}"#,
            r#"{"mesh":0,"matrix":[1e38,0,0,0, 0,1e38,0,0, 0,0,1e38,0, 3e38,0,0,1]}"#,
        );
    expect(&json, NonFinite, "after the node transform");
}
