//! Hostile outputs: see tests/hostile.rs. What `bake` and `gen` write, and where: outputs that
//! are an input or each other (under any spelling), outputs that are device nodes, FIFOs or
//! directories, unwritable directories, the permissions of what is written, damaged and
//! foreign checkpoints, a killed run's temporary files, and sizes past `gen`'s limit.
//!
//! Where a test needs the refusal to come before any work, the input is a file that is not a
//! mesh, so that reading it first would give a mesh error instead of the expected one.
//!
//! Unix only: file identity, modes, FIFOs and device nodes are Unix notions here.
#![cfg(unix)]

use super::support::{DEADLINE, SMALL, assert_refused, run, run_in};
use crate::common::{BUNNY, path_str, stderr};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use tempfile::TempDir;

/// `bake INPUT -o OUT` with the small settings and `more` flags.
fn bake_args<'a>(input: &'a str, out: &'a str, more: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["bake", input, "-o", out];
    args.extend(SMALL);
    args.extend(more);
    args
}

/// A file in `dir` whose content is not a mesh: a bake that read it would fail with a mesh
/// error, so a refusal that names the outputs proves nothing was read.
fn not_a_mesh(dir: &Path) -> PathBuf {
    let path = dir.join("not-a-mesh.ply");
    std::fs::write(&path, b"this is not a PLY file\n").unwrap();
    path
}

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A copy of the bunny in `dir` as `name`.
fn bunny_copy(dir: &Path, name: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::copy(BUNNY, &path).unwrap();
    path
}

/// A small closed mesh (a tetrahedron) as OBJ.
const TETRAHEDRON_OBJ: &str =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

/// Whether the tests run as root, which file mode bits do not stop.
fn is_root() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            let line = s.lines().find(|l| l.starts_with("Uid:"))?.to_owned();
            Some(line.split_whitespace().nth(2)? == "0")
        })
        .unwrap_or(false)
}

/// Says that part of a test is skipped, past the harness's capture.
fn skip(what: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "hostile outputs: {what} skipped");
}

#[test]
fn bake_onto_its_input_is_refused_under_any_spelling() {
    let dir = TempDir::new().unwrap();
    let ply = bunny_copy(dir.path(), "b.ply");
    let obj = dir.path().join("t.obj");
    std::fs::write(&obj, TETRAHEDRON_OBJ).unwrap();
    std::os::unix::fs::symlink(&ply, dir.path().join("link.ply")).unwrap();
    std::fs::hard_link(&ply, dir.path().join("hard.ply")).unwrap();
    let before = (std::fs::read(&ply).unwrap(), std::fs::read(&obj).unwrap());
    let names = listing(dir.path());
    // (input, -o), run in the directory so that relative spellings resolve there.
    let cases = [
        ("b.ply", "b.ply"),
        ("b.ply", "./b.ply"),
        (path_str(&ply), "b.ply"),
        ("b.ply", "link.ply"),
        ("link.ply", "b.ply"),
        ("b.ply", "hard.ply"),
        ("t.obj", "t.obj"),
        ("t.obj", "../$DIR/t.obj"),
    ];
    let dir_name = dir.path().file_name().unwrap().to_str().unwrap();
    for (input, out) in cases {
        let out = out.replace("$DIR", dir_name);
        let args = bake_args(input, &out, &[]);
        let result = run_in(&args, dir.path());
        assert_refused(&result, 2, &[&out, input, "-o", "input mesh", "same file"]);
    }
    assert_eq!(std::fs::read(&ply).unwrap(), before.0, "the PLY changed");
    assert_eq!(std::fs::read(&obj).unwrap(), before.1, "the OBJ changed");
    assert!(
        std::fs::symlink_metadata(dir.path().join("link.ply"))
            .unwrap()
            .is_symlink()
    );
    assert_eq!(listing(dir.path()), names, "files appeared or vanished");
}

#[test]
fn outputs_that_are_one_file_are_refused() {
    let dir = TempDir::new().unwrap();
    let input = not_a_mesh(dir.path());
    let input = path_str(&input);
    let x = dir.path().join("x.out");
    let x = path_str(&x);
    let y = dir.path().join("y.pvis");
    let y = path_str(&y);
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    let x_again = dir.path().join("sub/../x.out");
    let x_again = path_str(&x_again);
    // Each pair, with X absent and then present (its bytes must survive).
    for present in [false, true] {
        if present {
            std::fs::write(x, b"keep me").unwrap();
        }
        let cases: [(Vec<&str>, &[&str]); 5] = [
            (
                bake_args(input, x, &["--mesh-out", x]),
                &["-o", "--mesh-out"],
            ),
            (bake_args(input, x, &["--stats", x]), &["-o", "--stats"]),
            (
                bake_args(input, y, &["--mesh-out", x, "--stats", x]),
                &["--mesh-out", "--stats"],
            ),
            (
                bake_args(input, x, &["--mesh-out", x_again]),
                &["-o", "--mesh-out"],
            ),
            (
                bake_args(input, y, &["--stats", x, "--mesh-out", x_again]),
                &["--mesh-out", "--stats"],
            ),
        ];
        for (args, words) in cases {
            let out = run(&args);
            let mut all = vec!["same file"];
            all.extend(words);
            assert_refused(&out, 2, &all);
        }
        assert_eq!(std::fs::read(x).ok(), present.then(|| b"keep me".to_vec()));
        assert!(!Path::new(y).exists());
    }
}

#[test]
fn the_checkpoint_may_not_be_an_input_or_another_output() {
    let dir = TempDir::new().unwrap();
    // A plain bake's checkpoint is OUT.pvis.ckpt; the default bake's OUT.pvis.vs1.ckpt.
    let input = bunny_copy(dir.path(), "b.pvis.ckpt");
    let before = std::fs::read(&input).unwrap();
    let out = dir.path().join("b.pvis");
    let result = run(&bake_args(path_str(&input), path_str(&out), &[]));
    assert_refused(
        &result,
        2,
        &["checkpoint of -o", "input mesh", "b.pvis.ckpt"],
    );
    let input = bunny_copy(dir.path(), "c.pvis.vs1.ckpt");
    let out_c = dir.path().join("c.pvis");
    let result = run(&["bake", path_str(&input), "-o", path_str(&out_c), "-q"]);
    assert_refused(&result, 2, &["checkpoint of -o", "c.pvis.vs1.ckpt"]);
    // --stats onto the checkpoint: two outputs.
    let stats = dir.path().join("b.pvis.ckpt");
    let result = run(&bake_args(
        BUNNY,
        path_str(&out),
        &["--stats", path_str(&stats)],
    ));
    assert_refused(&result, 2, &["--stats", "checkpoint of -o", "same file"]);
    assert_eq!(
        std::fs::read(dir.path().join("b.pvis.ckpt")).unwrap(),
        before
    );
    assert!(!out.exists() && !out_c.exists());
}

#[test]
fn gen_onto_its_source_is_refused() {
    let dir = TempDir::new().unwrap();
    let source = bunny_copy(dir.path(), "b.ply");
    let before = std::fs::read(&source).unwrap();
    std::os::unix::fs::symlink(&source, dir.path().join("link.ply")).unwrap();
    for (out, kind) in [
        ("b.ply", "subdivided-bunny"),
        ("./b.ply", "bunny-grid"),
        ("link.ply", "subdivided-bunny"),
    ] {
        let args = [
            "gen",
            "--kind",
            kind,
            "--triangles",
            "400000",
            "-o",
            out,
            "--source",
            "b.ply",
            "-q",
        ];
        let result = run_in(&args, dir.path());
        assert_refused(&result, 2, &[out, "source mesh", "same file", "-o"]);
    }
    assert_eq!(std::fs::read(&source).unwrap(), before);
    assert_eq!(listing(dir.path()), ["b.ply", "link.ply"]);
}

#[test]
fn eval_stats_onto_its_inputs_is_refused() {
    let baked = crate::common::bake(&SMALL);
    let before = baked.bytes();
    let out = run(&[
        "eval",
        BUNNY,
        baked.pvis_arg(),
        "--views",
        "2",
        "--stats",
        baked.pvis_arg(),
        "-q",
    ]);
    assert_refused(&out, 2, &["--stats", ".pvis file", "same file"]);
    assert_eq!(baked.bytes(), before);
}

#[test]
fn outputs_that_are_not_regular_files_are_refused() {
    let dir = TempDir::new().unwrap();
    let input = not_a_mesh(dir.path());
    let input = path_str(&input);
    let ok = dir.path().join("ok.pvis");
    let ok = path_str(&ok);
    // A directory.
    let out = run(&bake_args(input, path_str(dir.path()), &[]));
    assert_refused(&out, 2, &["is a directory", "-o"]);
    // /dev/null, as -o, --mesh-out and --stats: it must stay a character device.
    for flag in ["-o", "--mesh-out", "--stats"] {
        let args = if flag == "-o" {
            bake_args(input, "/dev/null", &[])
        } else {
            bake_args(input, ok, &[flag, "/dev/null"])
        };
        let out = run(&args);
        assert_refused(
            &out,
            2,
            &["/dev/null", "character device", "not a regular file"],
        );
        assert_char_device(Path::new("/dev/null"));
    }
    // gen -o /dev/null.
    let out = run(&[
        "gen",
        "--kind",
        "truss",
        "--triangles",
        "2000",
        "-o",
        "/dev/null",
    ]);
    assert_refused(&out, 2, &["/dev/null", "character device"]);
    assert_char_device(Path::new("/dev/null"));
    // A FIFO nobody reads: refused at once, not blocked on, and still a FIFO.
    let fifo = dir.path().join("fifo.pvis");
    match Command::new("mkfifo").arg(&fifo).status() {
        Ok(s) if s.success() => {
            use std::os::unix::fs::FileTypeExt;
            for args in [
                bake_args(input, path_str(&fifo), &[]),
                bake_args(input, ok, &["--stats", path_str(&fifo)]),
            ] {
                let out = run(&args);
                assert_refused(&out, 2, &["fifo.pvis", "FIFO", "not a regular file"]);
            }
            let t = std::fs::symlink_metadata(&fifo).unwrap().file_type();
            assert!(t.is_fifo(), "the FIFO was replaced");
        }
        _ => skip("the FIFO case (no mkfifo)"),
    }
    // A character device node of our own (root only, and only where mknod is allowed).
    let node = dir.path().join("node.pvis");
    match Command::new("mknod")
        .arg(&node)
        .args(["c", "1", "3"])
        .status()
    {
        Ok(s) if s.success() => {
            let out = run(&bake_args(input, path_str(&node), &[]));
            assert_refused(&out, 2, &["node.pvis", "character device"]);
            assert_char_device(&node);
        }
        _ => skip("the mknod case (not root, or mknod not allowed)"),
    }
    assert!(!Path::new(ok).exists());
}

/// Asserts that `path` is (still) a character device.
fn assert_char_device(path: &Path) {
    use std::os::unix::fs::FileTypeExt;
    let t = std::fs::symlink_metadata(path).unwrap().file_type();
    assert!(
        t.is_char_device(),
        "{} is no longer a character device",
        path.display()
    );
}

/// The permission bits of `path`.
fn mode(path: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(path).unwrap().permissions().mode() & 0o7777
}

#[test]
fn outputs_get_the_mode_of_a_plain_create_or_keep_their_own() {
    use std::os::unix::fs::PermissionsExt;
    let dir = TempDir::new().unwrap();
    // What a plain create gives under this process's umask (the children inherit it).
    let reference = dir.path().join("reference");
    std::fs::File::create(&reference).unwrap();
    let expected = mode(&reference);
    let pvis = dir.path().join("b.pvis");
    let mesh = dir.path().join("m.ply");
    let stats = dir.path().join("s.json");
    let generated = dir.path().join("g.ply");
    let bake = bake_args(
        BUNNY,
        path_str(&pvis),
        &["--mesh-out", path_str(&mesh), "--stats", path_str(&stats)],
    );
    let gen_args = [
        "gen",
        "--kind",
        "truss",
        "--triangles",
        "2000",
        "-o",
        path_str(&generated),
        "-q",
    ];
    for args in [&bake[..], &gen_args[..]] {
        let out = run(args);
        assert!(out.status.success(), "{}", stderr(&out));
    }
    for path in [&pvis, &mesh, &stats, &generated] {
        assert_eq!(mode(path), expected, "{}", path.display());
    }
    // Existing outputs keep their mode, even one no plain create gives.
    for path in [&pvis, &mesh, &stats, &generated] {
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o604)).unwrap();
    }
    for args in [&bake[..], &gen_args[..]] {
        let out = run(args);
        assert!(out.status.success(), "{}", stderr(&out));
    }
    for path in [&pvis, &mesh, &stats, &generated] {
        assert_eq!(mode(path), 0o604, "{}", path.display());
    }
}

#[test]
fn unwritable_output_directories_fail_before_any_work() {
    let dir = TempDir::new().unwrap();
    let input = not_a_mesh(dir.path());
    let input = path_str(&input);
    let ok = dir.path().join("ok.pvis");
    let ok = path_str(&ok);
    // sysfs takes no new files, from root either.
    if Path::new("/sys").is_dir() {
        for args in [
            bake_args(input, "/sys/patchvis-test.pvis", &[]),
            bake_args(input, ok, &["--stats", "/sys/patchvis-stats.json"]),
            bake_args(input, ok, &["--mesh-out", "/sys/patchvis-mesh.ply"]),
        ] {
            let out = run(&args);
            assert_refused(&out, 2, &["/sys/patchvis-", "cannot create files in /sys"]);
        }
        let out = run(&[
            "gen",
            "--kind",
            "truss",
            "--triangles",
            "2000",
            "-o",
            "/sys/patchvis-gen.ply",
        ]);
        assert_refused(&out, 2, &["/sys/patchvis-gen.ply", "cannot create files"]);
        // The stats were refused before the .pvis was written, not after.
        assert!(!Path::new(ok).exists());
    } else {
        skip("the /sys case (no /sys)");
    }
    // A directory without write permission: mode bits do not stop root.
    if is_root() {
        skip("the read-only directory case (running as root)");
        return;
    }
    use std::os::unix::fs::PermissionsExt;
    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    let out = run(&bake_args(input, path_str(&locked.join("b.pvis")), &[]));
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).unwrap();
    assert_refused(&out, 2, &["cannot create files in", "locked", "-o"]);
}

/// Bakes the bunny at level 3 into `dir/b.pvis` and kills it once a checkpoint exists:
/// returns the checkpoint's path. Retries at a higher resolution should a bake finish
/// before its checkpoint was seen.
fn interrupted_bake(dir: &Path, resolution: &str) -> Option<PathBuf> {
    let pvis = dir.join("b.pvis");
    let ckpt = dir.join("b.pvis.ckpt");
    let mut child = Command::new(env!("CARGO_BIN_EXE_patchvis"))
        .args(["bake", BUNNY, "-o", path_str(&pvis), "--level", "3"])
        .args(["--resolution", resolution, "--view-supersample", "0", "-q"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + DEADLINE;
    loop {
        let seen = ckpt.exists();
        if seen || child.try_wait().unwrap().is_some() || Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            if seen && !pvis.exists() {
                return Some(ckpt);
            }
            // Finished first: try again, slower.
            let _ = std::fs::remove_file(&pvis);
            let _ = std::fs::remove_file(&ckpt);
            return None;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn damaged_and_foreign_checkpoints_are_refused() {
    let dir = TempDir::new().unwrap();
    let (ckpt, resolution) = ["512", "1024", "2048"]
        .into_iter()
        .find_map(|r| interrupted_bake(dir.path(), r).map(|c| (c, r)))
        .expect("no bake was caught with a checkpoint");
    let good = std::fs::read(&ckpt).unwrap();
    assert!(good.len() > 40, "checkpoint of {} bytes", good.len());
    let pvis = dir.path().join("b.pvis");
    let pvis = path_str(&pvis);
    let args = |more: &[&'static str]| -> Vec<String> {
        let mut a: Vec<String> = ["bake", BUNNY, "-o", pvis, "--level", "3", "--resolution"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        a.extend([resolution, "--view-supersample", "0", "-q"].map(String::from));
        a.extend(more.iter().map(|s| s.to_string()));
        a
    };
    let run_owned = |a: Vec<String>| {
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        run(&a)
    };
    // One flipped bit anywhere (header, rows, checksum): refused, nothing written.
    for at in [13, good.len() / 2, good.len() - 9, good.len() - 1] {
        let mut damaged = good.clone();
        damaged[at] ^= 0x10;
        std::fs::write(&ckpt, &damaged).unwrap();
        let out = run_owned(args(&["--resume"]));
        assert_refused(
            &out,
            1,
            &[
                "b.pvis.ckpt",
                "damaged (checksum mismatch",
                "delete it to bake from the start",
            ],
        );
        assert!(
            !Path::new(pvis).exists(),
            "a .pvis was written from a damaged checkpoint"
        );
    }
    // Truncated: refused.
    for len in [good.len() - 4, good.len() / 2, 20] {
        std::fs::write(&ckpt, &good[..len]).unwrap();
        let out = run_owned(args(&["--resume"]));
        assert_refused(&out, 1, &["b.pvis.ckpt", "delete it"]);
        assert!(!Path::new(pvis).exists());
    }
    // Foreign: written for other settings.
    std::fs::write(&ckpt, &good).unwrap();
    let out = run_owned(args(&["--resume", "--probe", "off"]));
    assert_refused(
        &out,
        1,
        &["stale checkpoint", "delete it or bake without --resume"],
    );
    // The intact checkpoint resumes into the bytes of an uninterrupted bake.
    let out = run_owned(args(&["--resume"]));
    assert!(out.status.success(), "{}", stderr(&out));
    let resumed = std::fs::read(pvis).unwrap();
    assert!(!ckpt.exists(), "the finished bake's checkpoint stayed");
    std::fs::remove_file(pvis).unwrap();
    let out = run_owned(args(&[]));
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(
        std::fs::read(pvis).unwrap(),
        resumed,
        "resumed bake differs"
    );
}

#[test]
fn stale_temporary_files_are_removed_by_the_next_run() {
    let dir = TempDir::new().unwrap();
    let pvis = dir.path().join("b.pvis");
    let mesh = dir.path().join("m.ply");
    let stats = dir.path().join("s.json");
    let generated = dir.path().join("g.ply");
    // What a run killed while writing each output (or a checkpoint) leaves behind.
    let stale = [
        ".b.pvis.patchvis-tmp",
        ".b.pvis.ckpt.patchvis-tmp",
        ".m.ply.patchvis-tmp",
        ".s.json.patchvis-tmp",
        ".g.ply.patchvis-tmp",
    ];
    for name in stale {
        std::fs::write(dir.path().join(name), b"half-written").unwrap();
    }
    let out = run(&bake_args(
        BUNNY,
        path_str(&pvis),
        &["--mesh-out", path_str(&mesh), "--stats", path_str(&stats)],
    ));
    assert!(out.status.success(), "{}", stderr(&out));
    let out = run(&[
        "gen",
        "--kind",
        "truss",
        "--triangles",
        "2000",
        "-o",
        path_str(&generated),
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(listing(dir.path()), ["b.pvis", "g.ply", "m.ply", "s.json"]);
    // The outputs are whole: the .pvis is a plain bake's, the stats parse.
    let plain = crate::common::bake(&SMALL);
    assert_eq!(std::fs::read(&pvis).unwrap(), plain.bytes());
    let _: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    let out = run(&["verify", path_str(&pvis)]);
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn gen_refuses_sizes_past_its_limit() {
    let dir = TempDir::new().unwrap();
    let out_path = dir.path().join("huge.ply");
    for kind in ["engine", "subdivided-bunny", "truss"] {
        let out = run(&[
            "gen",
            "--kind",
            kind,
            "--triangles",
            "1000000000000",
            "-o",
            path_str(&out_path),
            "--source",
            BUNNY,
        ]);
        assert_refused(
            &out,
            2,
            &["--triangles 1000000000000", "at most 1000000000"],
        );
    }
    assert!(listing(dir.path()).is_empty());
}
