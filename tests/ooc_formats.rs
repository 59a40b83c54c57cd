//! OBJ, STL and the conversion cache through the public `Mesh` API: each format against the
//! same cube, every malformed case with its error kind and position, welding under a tiny
//! memory budget, and cache hits, misses and invalidation.

mod common;

use common::{patchvis_with_env, path_str, stderr};
use patchvis::ooc::{ErrorPosition, Mesh, MeshErrorKind, MeshSource, OpenOptions};
use std::path::Path;

/// A unit cube: 8 corners, 12 triangles (as 6 quads in OBJ).
const CORNERS: [[f32; 3]; 8] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [1.0, 1.0, 1.0],
    [0.0, 1.0, 1.0],
];
const QUADS: [[u32; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [2, 3, 7, 6],
    [1, 2, 6, 5],
    [0, 4, 7, 3],
];

fn open(
    dir: &Path,
    name: &str,
    bytes: &[u8],
    budget: u64,
) -> Result<Mesh, patchvis::ooc::MeshError> {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    Mesh::open_with(
        &path,
        &OpenOptions {
            cache_dir: Some(dir.join("cache")),
            memory_budget: budget,
        },
    )
}

/// The cube's triangles as corner positions, sorted: equal for any vertex numbering.
fn triangle_positions(mesh: &Mesh) -> Vec<[[u32; 3]; 3]> {
    let mut out: Vec<_> = (0..mesh.triangle_count())
        .map(|t| mesh.triangle(t).map(|v| mesh.position(v).map(f32::to_bits)))
        .collect();
    out.sort();
    out
}

fn expected_cube() -> Vec<[[u32; 3]; 3]> {
    let mut out: Vec<_> = QUADS
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .map(|t| t.map(|v| CORNERS[v as usize].map(f32::to_bits)))
        .collect();
    out.sort();
    out
}

fn cube_stl_binary() -> Vec<u8> {
    let mut out = vec![0u8; 80];
    out.extend_from_slice(&12u32.to_le_bytes());
    for q in QUADS {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            out.extend_from_slice(&[0u8; 12]);
            for v in t {
                for c in CORNERS[v as usize] {
                    out.extend_from_slice(&c.to_le_bytes());
                }
            }
            out.extend_from_slice(&[0, 0]);
        }
    }
    out
}

fn cube_stl_ascii() -> String {
    let mut s = String::from("solid cube\n");
    for q in QUADS {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            s += "  facet normal 0 0 0\n    outer loop\n";
            for v in t {
                let [x, y, z] = CORNERS[v as usize];
                s += &format!("      vertex {x} {y} {z}\n");
            }
            s += "    endloop\n  endfacet\n";
        }
    }
    s + "endsolid cube\n"
}

#[test]
fn obj_forms_relative_indices_and_groups() {
    let dir = tempfile::tempdir().unwrap();
    // Two objects, every corner form, the second object with relative indices.
    let mut obj = String::from("# cube\nmtllib cube.mtl\no first\n");
    for p in &CORNERS[..4] {
        obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    obj += "vt 0 0\nvn 0 0 1\ng bottom\nusemtl steel\ns 1\n";
    obj += "f 1/1/1 4/1/1 3/1/1 2/1/1\r\n";
    obj += "o second\n";
    for p in &CORNERS[4..] {
        obj += &format!("v {} {} {} 1.0\n", p[0], p[1], p[2]);
    }
    obj += "f -4//1 -3//1 -2//1 -1//1\n"; // 5 6 7 8
    obj += "f 1/1 2/1 6/1 5/1\nf 3 4 8 7\nf 2 3 7 6\nf 1 5 8 4\n";
    let mesh = open(dir.path(), "cube.obj", obj.as_bytes(), 1 << 20).unwrap();
    assert_eq!((mesh.vertex_count(), mesh.triangle_count()), (8, 12));
    assert_eq!(triangle_positions(&mesh), expected_cube());
    assert_eq!(mesh.source(), MeshSource::Converted);
    assert_eq!(mesh.bounds().max, [1.0, 1.0, 1.0]);
}

#[test]
fn stl_binary_and_ascii_weld_to_the_same_cube() {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in [
        ("b.stl", cube_stl_binary()),
        ("a.stl", cube_stl_ascii().into_bytes()),
    ] {
        // 8 bytes of budget: one welding partition per corner, the slowest path.
        for budget in [1 << 20, 8] {
            let mesh = open(dir.path(), name, &bytes, budget).unwrap();
            assert_eq!(
                (mesh.vertex_count(), mesh.triangle_count()),
                (8, 12),
                "{name}"
            );
            assert_eq!(triangle_positions(&mesh), expected_cube(), "{name}");
        }
    }
}

#[test]
fn converted_meshes_are_cached_and_invalidated() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.stl");
    std::fs::write(&path, cube_stl_ascii()).unwrap();
    let options = OpenOptions {
        cache_dir: Some(dir.path().join("cache")),
        memory_budget: 1 << 20,
    };
    let first = Mesh::open_with(&path, &options).unwrap();
    assert_eq!(first.source(), MeshSource::Converted);
    let second = Mesh::open_with(&path, &options).unwrap();
    assert_eq!(second.source(), MeshSource::CacheHit);
    assert_eq!(triangle_positions(&second), triangle_positions(&first));
    assert_eq!(
        std::fs::read_dir(dir.path().join("cache")).unwrap().count(),
        1
    );

    // A changed input (size and time) is converted again, never served stale.
    std::thread::sleep(std::time::Duration::from_millis(20));
    std::fs::write(&path, cube_stl_ascii().replace("solid cube", "solid cube2")).unwrap();
    let third = Mesh::open_with(&path, &options).unwrap();
    assert_eq!(third.source(), MeshSource::Converted);

    // A damaged cache is rebuilt, not trusted.
    let cache = std::fs::read_dir(dir.path().join("cache"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let mut bytes = std::fs::read(&cache).unwrap();
    let last = bytes.len() - 4;
    bytes[last..].copy_from_slice(&999u32.to_le_bytes());
    std::fs::write(&cache, bytes).unwrap();
    assert_eq!(
        Mesh::open_with(&path, &options).unwrap().source(),
        MeshSource::Converted
    );
    assert_eq!(
        Mesh::open_with(&path, &options).unwrap().source(),
        MeshSource::CacheHit
    );

    // Without a cache directory nothing is left behind.
    let none = OpenOptions {
        cache_dir: None,
        memory_budget: 1 << 20,
    };
    assert_eq!(
        Mesh::open_with(&path, &none).unwrap().source(),
        MeshSource::Converted
    );
}

fn expect(
    name: &str,
    bytes: &[u8],
    kind: MeshErrorKind,
    position: Option<ErrorPosition>,
    mention: &str,
) {
    let dir = tempfile::tempdir().unwrap();
    let err = open(dir.path(), name, bytes, 1 << 20).unwrap_err();
    let text = err.to_string();
    assert_eq!(err.kind(), kind, "{name}: {text}");
    assert_eq!(err.position(), position, "{name}: {text}");
    assert!(text.contains(name), "{text}");
    assert!(text.contains(mention), "{name}: '{text}' lacks '{mention}'");
}

#[test]
fn malformed_obj_files_name_the_line() {
    use MeshErrorKind::*;
    let l = |n| Some(ErrorPosition::Line(n));
    let v3 = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    expect(
        "e.obj",
        b"",
        Empty,
        Some(ErrorPosition::Byte(0)),
        "expected OBJ statements",
    );
    expect(
        "g.obj",
        b"\x7fELF\x02\x01",
        BadHeader,
        l(1),
        "unknown statement",
    );
    expect(
        "r.obj",
        format!("{v3}f 1 2 4\n").as_bytes(),
        BadIndex,
        l(4),
        "expected at most 3",
    );
    expect(
        "z.obj",
        format!("{v3}f 0 1 2\n").as_bytes(),
        BadIndex,
        l(4),
        "1-based",
    );
    expect(
        "n.obj",
        format!("{v3}f -1 -2 -4\n").as_bytes(),
        BadIndex,
        l(4),
        "only 3 vertices",
    );
    expect(
        "c.obj",
        format!("{v3}f 1 2\n").as_bytes(),
        BadFace,
        l(4),
        "2 vertices, expected at least 3",
    );
    expect("x.obj", b"v 0 nan 0\n", NonFinite, l(1), "y is NaN");
    expect("i.obj", b"v 0 0 1e39\n", NonFinite, l(1), "z is inf");
    expect("s.obj", b"v 0 0\n", BadValue, l(1), "expected z");
    expect(
        "t.obj",
        format!("{v3}f 1 2 x\n").as_bytes(),
        BadValue,
        l(4),
        "found 'x'",
    );
    expect("p.obj", v3.as_bytes(), NoFaces, l(3), "point cloud");
    expect("q.obj", b"# nothing\n", NoVertices, l(1), "no 'v'");
}

#[test]
fn malformed_stl_files_name_the_position() {
    use MeshErrorKind::*;
    let mut cube = cube_stl_binary();
    cube.truncate(cube.len() - 7);
    expect(
        "t.stl",
        &cube,
        Truncated,
        Some(ErrorPosition::Byte(677)),
        "12 triangles (684 bytes)",
    );
    expect(
        "h.stl",
        b"\x01\x02",
        Truncated,
        Some(ErrorPosition::Byte(2)),
        "84-byte",
    );
    let mut nan = cube_stl_binary();
    nan[84 + 50 + 16..84 + 50 + 20].copy_from_slice(&f32::NAN.to_le_bytes());
    expect(
        "n.stl",
        &nan,
        NonFinite,
        Some(ErrorPosition::Byte(84 + 50 + 12)),
        "triangle 1 corner 0",
    );
    let mut empty = vec![0u8; 84];
    empty[0] = b'x';
    expect(
        "z.stl",
        &empty,
        NoFaces,
        Some(ErrorPosition::Byte(84)),
        "no triangles",
    );
    let ascii = cube_stl_ascii();
    expect(
        "k.stl",
        ascii.replace("endloop", "endlop").as_bytes(),
        BadHeader,
        Some(ErrorPosition::Line(7)),
        "unknown keyword 'endlop'",
    );
    let cut = &ascii[..ascii.find("endloop").unwrap()];
    expect(
        "c.stl",
        cut.as_bytes(),
        Truncated,
        Some(ErrorPosition::Line(7)),
        "opened on line 3",
    );
    expect(
        "f.stl",
        ascii.replacen("vertex 0 0 0", "vertex 0 0 q", 1).as_bytes(),
        BadValue,
        Some(ErrorPosition::Line(4)),
        "found 'q'",
    );
    let two = ascii.replacen("      vertex 0 1 0\n", "", 1);
    expect(
        "2.stl",
        two.as_bytes(),
        BadFace,
        Some(ErrorPosition::Line(3)),
        "2 vertices",
    );
}

#[test]
fn cli_refuses_malformed_input_with_exit_1_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("bad.obj");
    std::fs::write(&input, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    let out = dir.path().join("out.pvis");
    let cache = dir.path().join("cache");
    let run = patchvis_with_env(
        &["bake", path_str(&input), "-o", path_str(&out), "-q"],
        &[("XDG_CACHE_HOME", path_str(&cache))],
    );
    assert_eq!(run.status.code(), Some(1));
    let err = stderr(&run);
    assert!(
        err.contains("bad.obj: line 4: face refers to vertex 9"),
        "{err}"
    );
    assert!(!out.exists());
}
