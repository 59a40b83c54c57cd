//! Vertices no triangle uses: real OBJ and PLY exports carry them. The camera, the working
//! frame and the tiling's bounds come from the vertices the triangles use, so a mesh with a
//! stray vertex bakes byte for byte as the same mesh without it: in core and out of core,
//! from a PLY served in place and from a converted OBJ, near the model and at 1e30.

use super::support::{self, SMALL};
use crate::common::{BUNNY, path_str, stderr};
use std::path::{Path, PathBuf};
use tempfile::TempDir;

/// The closed unit cube, 8 vertices and 12 outward triangles.
fn cube() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let v = (0..8)
        .map(|i| std::array::from_fn(|k| (i >> k & 1) as f32 - 0.5))
        .collect();
    let f = vec![
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    (v, f)
}

/// A binary little-endian PLY (served in place).
fn binary_ply(v: &[[f32; 3]], f: &[[u32; 3]]) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        v.len(),
        f.len()
    )
    .into_bytes();
    for p in v {
        p.iter().for_each(|c| out.extend(c.to_le_bytes()));
    }
    for t in f {
        out.push(3);
        t.iter().for_each(|i| out.extend(i.to_le_bytes()));
    }
    out
}

/// An OBJ (converted through the cache).
fn obj(v: &[[f32; 3]], f: &[[u32; 3]]) -> Vec<u8> {
    let mut out = String::new();
    for p in v {
        out += &format!("v {:e} {:e} {:e}\n", p[0], p[1], p[2]);
    }
    for t in f {
        out += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    out.into_bytes()
}

/// The bunny with one more vertex, at `p`, that no face uses.
fn bunny_with_stray(p: [f32; 3]) -> Vec<u8> {
    let bytes = std::fs::read(BUNNY).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = String::from_utf8(bytes[..end].to_vec()).unwrap();
    let vertices: usize = header
        .lines()
        .find_map(|l| l.strip_prefix("element vertex "))
        .unwrap()
        .parse()
        .unwrap();
    let header = header.replace(
        &format!("element vertex {vertices}\n"),
        &format!("element vertex {}\n", vertices + 1),
    );
    let at = end + vertices * 12;
    let mut out = header.into_bytes();
    out.extend(&bytes[end..at]);
    p.iter().for_each(|c| out.extend(c.to_le_bytes()));
    out.extend(&bytes[at..]);
    out
}

/// Bakes `input` into `dir/NAME.pvis` with the small flags and `extra` (no conversion cache
/// kept); returns the file's bytes, failing the test on a refusal.
fn bake(dir: &Path, input: &Path, name: &str, extra: &[&str]) -> Vec<u8> {
    let pvis = dir.join(format!("{name}.pvis"));
    let mut args = vec!["bake", path_str(input), "-o", path_str(&pvis)];
    args.extend(SMALL);
    args.extend(extra);
    let out = support::run_env(&args, &[("XDG_CACHE_HOME", path_str(dir))]);
    assert!(out.status.success(), "{name}: {}", stderr(&out));
    std::fs::read(pvis).unwrap()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// Out of core: the out-of-core tiling within a budget it must split the mesh for.
const OUT_OF_CORE: [&str; 4] = ["--tiling", "out-of-core", "--memory", "8MiB"];

#[test]
fn an_unused_vertex_changes_no_byte_of_the_bake() {
    let dir = TempDir::new().unwrap();
    let (v, f) = cube();
    for (format, encode) in [
        ("ply", binary_ply as fn(&[[f32; 3]], &[[u32; 3]]) -> Vec<u8>),
        ("obj", obj),
    ] {
        let clean = write(dir.path(), &format!("cube.{format}"), &encode(&v, &f));
        for (tiling, extra) in [("in-core", &[][..]), ("out-of-core", &OUT_OF_CORE[..])] {
            let expected = bake(dir.path(), &clean, &format!("{format}-{tiling}"), extra);
            // Before: 0.0 % of the patches visible at 1e6, refused as degenerate at 1e30.
            for stray in [[1e6, 0.0, 0.0], [1e30, 0.0, 0.0], [-3e38, 2e38, 1e-30]] {
                let mut with = v.clone();
                with.push(stray);
                let name = format!("stray-{}-{format}-{tiling}", stray[0]);
                let input = write(dir.path(), &format!("{name}.{format}"), &encode(&with, &f));
                let got = bake(dir.path(), &input, &name, extra);
                assert!(got == expected, "{name}: the .pvis differs");
            }
        }
    }
}

#[test]
fn the_bunny_with_a_stray_vertex_keeps_its_camera() {
    let dir = TempDir::new().unwrap();
    let expected = bake(dir.path(), Path::new(BUNNY), "bunny", &[]);
    // Before: a camera distance of 130,689 instead of 87.6.
    let input = write(dir.path(), "stray.ply", &bunny_with_stray([1e5, 0.0, 0.0]));
    let got = bake(dir.path(), &input, "stray", &[]);
    assert!(got == expected, "the .pvis differs");
    let mesh_out = dir.path().join("stray-out.ply");
    let pvis = dir.path().join("stray-mesh-out.pvis");
    let mut args = vec![
        "bake",
        path_str(&input),
        "-o",
        path_str(&pvis),
        "--mesh-out",
        path_str(&mesh_out),
    ];
    args.extend(SMALL);
    let out = support::run(&args);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(std::fs::read(&pvis).unwrap() == expected, "--mesh-out bake");
    // A sharded bake of it: `tile`, each shard, `merge`.
    let tiling = dir.path().join("t.ptile");
    let out = support::run(&["tile", path_str(&input), "-o", path_str(&tiling), "-q"]);
    assert!(out.status.success(), "tile: {}", stderr(&out));
    let parts: Vec<PathBuf> = (0..2)
        .map(|i| {
            let part = dir.path().join(format!("p{i}.ppart"));
            let shard = format!("{i}/2");
            let mut args = vec!["bake", path_str(&input), "-o", path_str(&part)];
            args.extend(["--tiling-file", path_str(&tiling), "--shard", &shard]);
            args.extend(SMALL);
            let out = support::run(&args);
            assert!(out.status.success(), "shard {i}: {}", stderr(&out));
            part
        })
        .collect();
    let merged = dir.path().join("merged.pvis");
    let mut args = vec!["merge", "-q", "-o", path_str(&merged)];
    args.extend(parts.iter().map(|p| path_str(p)));
    let out = support::run(&args);
    assert!(out.status.success(), "merge: {}", stderr(&out));
    assert!(
        std::fs::read(&merged).unwrap() == expected,
        "the merge differs"
    );
    // eval of the original and of the --mesh-out mesh match the file's records.
    for mesh in [&input, &mesh_out] {
        let out = support::run(&[
            "eval",
            path_str(mesh),
            path_str(&pvis),
            "--views",
            "4",
            "--resolution",
            "64",
        ]);
        assert!(
            out.status.success(),
            "eval {}: {}",
            mesh.display(),
            stderr(&out)
        );
    }
}
