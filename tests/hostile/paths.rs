//! Hostile paths: see tests/hostile.rs. Every file a command reads (the mesh, a tiling file,
//! `--source`, an OBJ's material library and textures) compared with every file it writes,
//! `--stats` included, before any work; and outputs that are symbolic links, written through
//! to the file they point to.
//!
//! Unix only: symbolic links and file identity are Unix notions here.
#![cfg(unix)]

use super::support::{SMALL, assert_refused, run, run_in};
use crate::common::{BUNNY, path_str, stderr};
use std::path::{Path, PathBuf};
use tempfile::TempDir;

/// The textured OBJ of the `--mesh-out` tests, copied into `dir` with its library and image.
fn globe(dir: &Path) -> PathBuf {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/obj");
    for name in ["globe.obj", "globe.mtl", "checker.png"] {
        std::fs::copy(data.join(name), dir.join(name)).unwrap();
    }
    dir.join("globe.obj")
}

/// A tiling file of the bunny in `dir`.
fn tiling_file(dir: &Path) -> PathBuf {
    let path = dir.join("t.ptile");
    let out = run(&[
        "tile",
        BUNNY,
        "-o",
        path_str(&path),
        "--patches",
        "64",
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    path
}

#[test]
fn a_tiling_file_is_never_an_output() {
    let dir = TempDir::new().unwrap();
    let tiling = tiling_file(dir.path());
    let before = std::fs::read(&tiling).unwrap();
    let t = path_str(&tiling);
    let part = dir.path().join("p.ppart");
    let part = path_str(&part);
    let shard = ["--shard", "0/2", "--tiling-file", t, "--patches", "64"];
    let mut stats = vec!["bake", BUNNY, "-o", part];
    stats.extend(shard);
    stats.extend(["--stats", t]);
    stats.extend(SMALL);
    assert_refused(
        &run(&stats),
        2,
        &[t, "--stats", "--tiling-file", "same file"],
    );
    // --mesh-out is not a sharded bake's; without --shard a tiling file is not read.
    let mut mesh_out = vec!["bake", BUNNY, "-o", part, "--tiling-file", t];
    mesh_out.extend(["--mesh-out", t]);
    mesh_out.extend(SMALL);
    let out = run(&mesh_out);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert_eq!(
        std::fs::read(&tiling).unwrap(),
        before,
        "the tiling file changed"
    );
    assert!(!Path::new(part).exists());
}

#[test]
fn tiling_file_without_shard_says_what_it_needs() {
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("b.pvis");
    let mut args = vec![
        "bake",
        BUNNY,
        "-o",
        path_str(&out),
        "--tiling-file",
        "t.ptile",
    ];
    args.extend(SMALL);
    assert_refused(&run(&args), 2, &["--tiling-file", "--shard"]);
}

#[test]
fn gen_never_replaces_its_source_whatever_the_kind() {
    let dir = TempDir::new().unwrap();
    std::fs::copy(BUNNY, dir.path().join("g.ply")).unwrap();
    let before = std::fs::read(dir.path().join("g.ply")).unwrap();
    for kind in ["truss", "engine", "subdivided-bunny"] {
        let args = ["gen", "--kind", kind, "--triangles", "1000", "-q"];
        let mut args = args.to_vec();
        args.extend(["-o", "./g.ply", "--source", "g.ply"]);
        assert_refused(
            &run_in(&args, dir.path()),
            2,
            &["g.ply", "--source", "same file"],
        );
    }
    assert_eq!(std::fs::read(dir.path().join("g.ply")).unwrap(), before);
}

#[test]
fn material_libraries_and_textures_are_inputs() {
    let dir = TempDir::new().unwrap();
    let obj = globe(dir.path());
    let (mtl, png) = (dir.path().join("globe.mtl"), dir.path().join("checker.png"));
    let before = (std::fs::read(&mtl).unwrap(), std::fs::read(&png).unwrap());
    let pvis = dir.path().join("g.pvis");
    let glb = dir.path().join("g.glb");
    // The library and the texture belong to the input whatever the outputs read.
    for (flag, victim) in [("--stats", &mtl), ("--stats", &png), ("-o", &mtl)] {
        let mut args = vec!["bake", path_str(&obj)];
        if flag == "--stats" {
            args.extend(["-o", path_str(&pvis), "--mesh-out", path_str(&glb)]);
        }
        args.extend([flag, path_str(victim)]);
        args.extend(SMALL);
        let name = victim.file_name().unwrap().to_str().unwrap();
        assert_refused(&run(&args), 2, &[name, flag, "same file"]);
    }
    assert_eq!(std::fs::read(&mtl).unwrap(), before.0, "the .mtl changed");
    assert_eq!(
        std::fs::read(&png).unwrap(),
        before.1,
        "the texture changed"
    );
    assert!(!pvis.exists());
}

#[test]
fn a_missing_material_library_fails_only_outputs_that_need_it_and_before_the_bake() {
    let dir = TempDir::new().unwrap();
    let obj = globe(dir.path());
    std::fs::remove_file(dir.path().join("globe.mtl")).unwrap();
    let pvis = dir.path().join("g.pvis");
    // A PLY has no materials: it does not need the library.
    let ply = dir.path().join("g.ply");
    let mut args = vec!["bake", path_str(&obj), "-o", path_str(&pvis)];
    args.extend(["--mesh-out", path_str(&ply)]);
    args.extend(SMALL);
    let out = run(&args);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(pvis.exists() && ply.exists());
    std::fs::remove_file(&pvis).unwrap();
    // A glTF does: refused before the bake, naming the library.
    let glb = dir.path().join("g.glb");
    let mut args = vec!["bake", path_str(&obj), "-o", path_str(&pvis)];
    args.extend(["--mesh-out", path_str(&glb)]);
    args.extend(SMALL);
    assert_refused(&run(&args), 1, &["globe.mtl", "--mesh-out"]);
    assert!(!pvis.exists() && !glb.exists());
}

#[test]
fn outputs_that_are_symbolic_links_are_written_through() {
    let dir = TempDir::new().unwrap();
    let sub = dir.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    // A link to an existing file, and a dangling one, in another directory.
    std::fs::write(sub.join("old.ply"), b"old").unwrap();
    std::os::unix::fs::symlink("sub/old.ply", dir.path().join("link.ply")).unwrap();
    std::os::unix::fs::symlink("sub/new.ply", dir.path().join("dangling.ply")).unwrap();
    for (link, target) in [("link.ply", "old.ply"), ("dangling.ply", "new.ply")] {
        let args = [
            "gen",
            "--kind",
            "truss",
            "--triangles",
            "1000",
            "-q",
            "-o",
            link,
        ];
        let out = run_in(&args, dir.path());
        assert!(out.status.success(), "{}", stderr(&out));
        let meta = std::fs::symlink_metadata(dir.path().join(link)).unwrap();
        assert!(meta.is_symlink(), "{link} was replaced by a regular file");
        let written = std::fs::read(sub.join(target)).unwrap();
        assert!(written.starts_with(b"ply\n"), "{target} was not written");
    }
    // A bake's outputs too, and its --stats.
    std::os::unix::fs::symlink("sub/b.pvis", dir.path().join("b.pvis")).unwrap();
    std::os::unix::fs::symlink("sub/s.json", dir.path().join("s.json")).unwrap();
    let mut args = vec!["bake", BUNNY, "-o", "b.pvis", "--stats", "s.json"];
    args.extend(SMALL);
    let out = run_in(&args, dir.path());
    assert!(out.status.success(), "{}", stderr(&out));
    for name in ["b.pvis", "s.json"] {
        assert!(
            std::fs::symlink_metadata(dir.path().join(name))
                .unwrap()
                .is_symlink()
        );
        assert!(sub.join(name).is_file(), "sub/{name} was not written");
    }
    let mut names: Vec<_> = std::fs::read_dir(&sub)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["b.pvis", "new.ply", "old.ply", "s.json"]);
}
