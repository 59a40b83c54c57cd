//! Hostile geometry: see tests/hostile.rs. Meshes whose headers undercount their data, extreme
//! but finite coordinates, meshes with nothing to see, and settings too small to work in:
//! each is baked correctly or refused with one line and the documented exit code, and the
//! input is never changed.

use super::support::{self, SMALL};
use crate::common::{BUNNY, path_str, stderr};
use std::path::{Path, PathBuf};
use std::process::Output;
use tempfile::TempDir;

/// What a bake of `input` into `dir/out.pvis` with [`SMALL`] and `extra` gave.
struct Run {
    output: Output,
    pvis: PathBuf,
}

impl Run {
    fn code(&self) -> Option<i32> {
        self.output.status.code()
    }
    fn err(&self) -> String {
        stderr(&self.output)
    }
    /// `visible_fraction_mean` of the `--stats` written beside the `.pvis`.
    fn visible_fraction(&self) -> f64 {
        let stats = self.pvis.with_extension("json");
        let text = std::fs::read(&stats).expect("stats written");
        let v: serde_json::Value = serde_json::from_slice(&text).expect("stats JSON");
        v["visible_fraction_mean"]
            .as_f64()
            .expect("visible_fraction_mean")
    }
    fn stats(&self) -> serde_json::Value {
        let text = std::fs::read(self.pvis.with_extension("json")).expect("stats written");
        serde_json::from_slice(&text).expect("stats JSON")
    }
}

/// Bakes `input` with the small flags and `extra` into `dir`, with `--stats`; checks that the
/// run neither panicked nor changed the input.
fn bake_in(dir: &Path, input: &Path, name: &str, extra: &[&str]) -> Run {
    let before = std::fs::read(input).expect("read the input");
    let pvis = dir.join(format!("{name}.pvis"));
    let stats = pvis.with_extension("json");
    let mut args = vec![
        "bake",
        path_str(input),
        "-o",
        path_str(&pvis),
        "--stats",
        path_str(&stats),
    ];
    // The small flags, less those `extra` gives again.
    for pair in SMALL[..6].chunks(2) {
        if !extra.contains(&pair[0]) {
            args.extend(pair);
        }
    }
    args.push(SMALL[6]);
    args.extend(extra);
    let output = support::run(&args);
    let err = stderr(&output);
    assert_ne!(output.status.code(), Some(101), "panic: {err}");
    assert!(!err.contains("panicked"), "panic: {err}");
    assert_eq!(std::fs::read(input).unwrap(), before, "the input changed");
    Run { output, pvis }
}

/// Checks a refusal ([`support::assert_refused`]) that also names `file` and wrote no
/// `.pvis`.
fn assert_bake_refused(run: &Run, code: i32, file: Option<&Path>, words: &[&str]) {
    support::assert_refused(&run.output, code, words);
    if let Some(file) = file {
        let err = run.err();
        assert!(
            err.contains(path_str(file)),
            "names {}: {err}",
            file.display()
        );
    }
    assert!(!run.pvis.exists(), "no output on refusal");
}

/// A binary little-endian PLY whose header declares `declared` vertices and faces.
fn binary_ply(v: &[[f32; 3]], f: &[[u32; 3]], declared: (usize, usize)) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        declared.0, declared.1
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

/// An ASCII PLY whose header declares `declared` vertices and faces; the header is 9 lines.
fn ascii_ply(v: &[[f32; 3]], f: &[[u32; 3]], declared: (usize, usize)) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        declared.0, declared.1
    );
    for p in v {
        out += &format!("{} {} {}\n", p[0], p[1], p[2]);
    }
    for t in f {
        out += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    out.into_bytes()
}

/// A binary STL of `f`'s triangles with `declared` in its count field.
fn binary_stl(v: &[[f32; 3]], f: &[[u32; 3]], declared: u32) -> Vec<u8> {
    let mut out = vec![b' '; 80];
    out.extend(declared.to_le_bytes());
    for t in f {
        out.extend([0u8; 12]);
        for &i in t {
            v[i as usize]
                .iter()
                .for_each(|c| out.extend(c.to_le_bytes()));
        }
        out.extend([0u8; 2]);
    }
    out
}

/// The closed cube `[-s/2, s/2]³ + offset`, 8 vertices and 12 outward triangles.
fn cube(scale: f32, offset: f32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let v = (0..8)
        .map(|i| std::array::from_fn(|k| ((i >> k & 1) as f32 - 0.5) * scale + offset))
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

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

#[test]
fn a_binary_ply_declaring_fewer_faces_or_vertices_is_refused_with_its_position() {
    let dir = TempDir::new().unwrap();
    let bunny = std::fs::read(BUNNY).unwrap();
    let text = String::from_utf8_lossy(&bunny[..400]).into_owned();
    assert!(text.contains("element face 99785") && text.contains("element vertex 50000"));
    // The header's counts are the same length, so the body stays where it was.
    let fewer_faces = bunny_with(&bunny, "element face 99785", "element face 99784");
    let path = write(dir.path(), "fewer-faces.ply", &fewer_faces);
    let run = bake_in(dir.path(), &path, "fewer-faces", &[]);
    // 13 bytes: the last face record (a count byte and three indices).
    assert_bake_refused(
        &run,
        1,
        Some(&path),
        &[
            "byte ",
            "13 bytes after the last declared face",
            "99784 faces",
            "do not match",
        ],
    );

    let fewer_vertices = bunny_with(&bunny, "element vertex 50000", "element vertex 49999");
    let path = write(dir.path(), "fewer-vertices.ply", &fewer_vertices);
    let run = bake_in(dir.path(), &path, "fewer-vertices", &[]);
    assert_bake_refused(&run, 1, Some(&path), &["byte "]);

    // A small mesh: 11 faces declared, 12 present.
    let (v, f) = cube(1.0, 0.0);
    let mut bytes = binary_ply(&v, &f, (8, 11));
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let path = write(dir.path(), "cube-fewer.ply", &bytes);
    let run = bake_in(dir.path(), &path, "cube-fewer", &[]);
    let at = header_end + 8 * 12 + 11 * 13;
    assert_bake_refused(
        &run,
        1,
        Some(&path),
        &[&format!("byte {at}: 13 bytes after"), "11 faces"],
    );
    // Fewer data than declared stays an error too.
    bytes.truncate(header_end + 8 * 12 + 10 * 13);
    let path = write(dir.path(), "cube-short.ply", &bytes);
    let run = bake_in(dir.path(), &path, "cube-short", &[]);
    assert_bake_refused(&run, 1, Some(&path), &["the file ends"]);
}

/// `bytes` with the first `from` replaced by `to` (of the same length).
fn bunny_with(bytes: &[u8], from: &str, to: &str) -> Vec<u8> {
    assert_eq!(from.len(), to.len());
    let at = bytes
        .windows(from.len())
        .position(|w| w == from.as_bytes())
        .unwrap();
    let mut out = bytes.to_vec();
    out[at..at + to.len()].copy_from_slice(to.as_bytes());
    out
}

#[test]
fn an_ascii_ply_with_lines_past_its_counts_is_refused_with_the_line() {
    let dir = TempDir::new().unwrap();
    let (v, f) = cube(1.0, 0.0);
    let path = write(dir.path(), "fewer-faces.ply", &ascii_ply(&v, &f, (8, 10)));
    let run = bake_in(dir.path(), &path, "fewer-faces", &[]);
    // 9 header lines, 8 vertex lines, 10 faces read: the 11th face is line 28.
    assert_bake_refused(
        &run,
        1,
        Some(&path),
        &[
            "line 28: '3 1 3 5' after the last declared face",
            "10 faces",
            "do not match",
        ],
    );
    let path = write(
        dir.path(),
        "fewer-vertices.ply",
        &ascii_ply(&v, &f, (7, 12)),
    );
    let run = bake_in(dir.path(), &path, "fewer-vertices", &[]);
    assert_bake_refused(&run, 1, Some(&path), &["line "]);
    // Trailing blank lines are not data.
    let mut blank = ascii_ply(&v, &f, (8, 12));
    blank.extend(b"\n  \n\n");
    let path = write(dir.path(), "blank.ply", &blank);
    let run = bake_in(dir.path(), &path, "blank", &[]);
    assert_eq!(run.code(), Some(0), "{}", run.err());
}

#[test]
fn a_binary_stl_counting_fewer_triangles_bakes_them_all_with_a_warning() {
    let dir = TempDir::new().unwrap();
    let (v, f) = cube(1.0, 0.0);
    let honest = write(dir.path(), "honest.stl", &binary_stl(&v, &f, 12));
    let undercounted = write(dir.path(), "under.stl", &binary_stl(&v, &f, 10));
    let reference = bake_in(dir.path(), &honest, "honest", &[]);
    assert_eq!(reference.code(), Some(0), "{}", reference.err());
    assert_eq!(reference.err(), "", "no warning for an honest count");
    // Twice: the second open serves the conversion cache and must warn as well.
    for round in ["first", "cached"] {
        let run = bake_in(dir.path(), &undercounted, round, &[]);
        let err = run.err();
        assert_eq!(run.code(), Some(0), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.starts_with("warning: ")
                && err.contains(path_str(&undercounted))
                && err.contains("declares 10 triangles but the file holds 12"),
            "{round}: {err}"
        );
        assert_eq!(run.stats()["triangles"], 12, "{round}");
        assert_eq!(
            std::fs::read(&run.pvis).unwrap(),
            std::fs::read(&reference.pvis).unwrap(),
            "{round}: every triangle baked"
        );
    }
    // A length that is no whole number of records: an error at the first stray byte.
    let mut ragged = binary_stl(&v, &f, 10);
    ragged.extend([0u8; 7]);
    let path = write(dir.path(), "ragged.stl", &ragged);
    let run = bake_in(dir.path(), &path, "ragged", &[]);
    assert_bake_refused(
        &run,
        1,
        Some(&path),
        &[&format!("byte {}", 84 + 10 * 50), "not 84 + 50 × n"],
    );
    // Fewer records than the count says: still an error.
    let path = write(dir.path(), "over.stl", &binary_stl(&v, &f, 13));
    let run = bake_in(dir.path(), &path, "over", &[]);
    assert_bake_refused(&run, 1, Some(&path), &["the header says 13 triangles"]);
}

#[test]
fn extreme_finite_coordinates_bake_like_a_unit_model_or_are_refused() {
    let dir = TempDir::new().unwrap();
    let bake_cube = |name: &str, scale: f32, offset: f32| {
        let (v, f) = cube(scale, offset);
        let path = write(
            dir.path(),
            &format!("{name}.ply"),
            &binary_ply(&v, &f, (8, 12)),
        );
        bake_in(dir.path(), &path, name, &[])
    };
    let unit = bake_cube("unit", 1.0, 0.0);
    assert_eq!(unit.code(), Some(0), "{}", unit.err());
    let expected = unit.visible_fraction();
    assert!(expected > 0.3, "{expected}");
    // Before the working frame: 13.5 %, 4 % and 0 % visible, or a panic.
    for (name, scale, offset) in [
        ("x1e37", 1e37, 0.0),
        ("x1e38", 1e38, 0.0),
        ("x1e-40", 1e-40, 0.0),
        ("at1e30", 1e25, 1e30),
        ("at1e6", 1.0, 1e6),
    ] {
        let run = bake_cube(name, scale, offset);
        assert_eq!(run.code(), Some(0), "{name}: {}", run.err());
        let got = run.visible_fraction();
        assert!(
            (got - expected).abs() < 1e-9,
            "{name}: {got} against {expected}"
        );
        let verify = support::run(&["verify", path_str(&run.pvis)]);
        assert!(verify.status.success(), "{name}: {}", stderr(&verify));
    }
    // One triangle at x = 1e30 put the eye on the target (a panic before).
    let v = [[1e30, 0.0, 0.0], [1e30, 1.0, 0.0], [1e30, 0.0, 1.0]];
    let path = write(dir.path(), "far.ply", &binary_ply(&v, &[[0, 1, 2]], (3, 1)));
    let run = bake_in(dir.path(), &path, "far", &[]);
    assert_eq!(run.code(), Some(0), "{}", run.err());
    assert!(run.visible_fraction() > 0.5);
    // ±2e38: no binary32 camera distance frames it (a panic before).
    for (name, v) in [
        (
            "pm2e38",
            cube(1.0, 0.0)
                .0
                .iter()
                .map(|p| p.map(|c| (f64::from(c) * 4e38) as f32))
                .collect(),
        ),
        (
            "axis2e38",
            vec![[-2e38, 0.0, 0.0], [2e38, 0.0, 0.0], [0.0, 1e38, 0.0]],
        ),
    ] {
        let f: Vec<[u32; 3]> = if v.len() == 8 {
            cube(1.0, 0.0).1
        } else {
            vec![[0, 1, 2]]
        };
        let path = write(
            dir.path(),
            &format!("{name}.ply"),
            &binary_ply(&v, &f, (v.len(), f.len())),
        );
        let run = bake_in(dir.path(), &path, name, &[]);
        assert_bake_refused(&run, 1, Some(&path), &["binary32", "scale the model"]);
    }
}

#[test]
fn a_mesh_of_degenerate_triangles_is_refused() {
    let dir = TempDir::new().unwrap();
    let v = [
        [0.0, 0.0, 0.0],
        [1.0, 1.0, 1.0],
        [2.0, 2.0, 2.0],
        [5.0, 5.0, 5.0],
    ];
    let f = [[0, 1, 2], [1, 2, 3], [0, 0, 1]];
    let path = write(dir.path(), "flat.ply", &binary_ply(&v, &f, (4, 3)));
    let run = bake_in(dir.path(), &path, "flat", &[]);
    assert_bake_refused(
        &run,
        1,
        Some(&path),
        &["all 3 triangles are degenerate (zero area); nothing to bake"],
    );
}

#[test]
fn a_resolution_below_the_minimum_is_a_usage_error_and_a_coarse_one_warns() {
    let dir = TempDir::new().unwrap();
    // --resolution 1 baked to 0.1 % of the patches visible per view.
    for r in ["1", "15"] {
        let run = bake_in(dir.path(), Path::new(BUNNY), r, &["--resolution", r]);
        assert_bake_refused(
            &run,
            2,
            None,
            &[&format!("--resolution {r}"), "minimum of 16 pixels"],
        );
    }
    let run = bake_in(
        dir.path(),
        Path::new(BUNNY),
        "coarse",
        &["--resolution", "16"],
    );
    let err = run.err();
    assert_eq!(run.code(), Some(0), "{err}");
    assert!(
        err.lines().count() == 1
            && err.starts_with("warning: --resolution 16")
            && err.contains("use 32 px or more"),
        "{err}"
    );
    let run = bake_in(
        dir.path(),
        Path::new(BUNNY),
        "fine",
        &["--resolution", "32"],
    );
    assert_eq!((run.code(), run.err()), (Some(0), String::new()));
}

#[test]
fn a_memory_budget_below_the_minimum_is_refused_and_the_minimum_is_kept() {
    let dir = TempDir::new().unwrap();
    let run = bake_in(dir.path(), Path::new(BUNNY), "tiny", &["--memory", "1KiB"]);
    assert_bake_refused(&run, 2, None, &["--memory 1 KiB", "use at least"]);
    let err = run.err();
    let minimum: u64 = err
        .split("use at least ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no minimum in {err}"));
    assert!((4..=16).contains(&minimum), "{err}");
    // At the minimum and a little above it the bake runs within its budget.
    for mib in [minimum, minimum + 1, minimum + 3] {
        let memory = format!("{mib}MiB");
        let run = bake_in(
            dir.path(),
            Path::new(BUNNY),
            &memory,
            &["--memory", &memory],
        );
        assert_eq!(run.code(), Some(0), "{memory}: {}", run.err());
        let peak = run.stats()["peak_heap_bytes"].as_u64().unwrap();
        assert!(peak <= mib << 20, "{memory}: peak heap {peak}");
    }
    // The second case: `--memory 1MiB` on a 400K-triangle mesh is refused too, with
    // a larger minimum than the bunny's (the mesh batch grows with the mesh).
    let big = dir.path().join("big.ply");
    let out = support::run(&[
        "gen",
        "--kind",
        "subdivided-bunny",
        "--source",
        BUNNY,
        "--triangles",
        "400000",
        "-o",
        path_str(&big),
        "-q",
    ]);
    assert_eq!(out.status.code(), Some(0), "gen: {}", stderr(&out));
    let run = bake_in(dir.path(), &big, "big-1mib", &["--memory", "1MiB"]);
    assert_bake_refused(&run, 2, None, &["--memory 1 MiB", "use at least"]);
    // A size past 64 bits says so.
    let run = bake_in(
        dir.path(),
        Path::new(BUNNY),
        "huge",
        &["--memory", "99999999999TiB"],
    );
    assert_bake_refused(&run, 2, None, &["99999999999TiB", "too large", "16 EiB"]);
}
