//! Work bounded by what a file or a flag can justify: every input a regular file of a size
//! its kind can have, checked before it is read; counts of views, frames and queries within
//! stated limits; `verify` and `info --compare` within a time or memory bound the user sets;
//! a damaged conversion cache refused by its checksum rather than baked.
//!
//! The runs that would have allocated gigabytes run under an address-space limit
//! (`ulimit -v`), so that an unbounded read fails the test instead of filling the machine.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use tempfile::TempDir;

use super::support::{SMALL, assert_refused, run, run_command, run_env};
use crate::common::{BUNNY, path_str, stderr, stdout};

/// Address space a run may reserve, KiB: a debug `patchvis` needs a few hundred MiB, a read
/// of a 3 GiB file whole more than this.
const ADDRESS_SPACE_KIB: u64 = 2 << 20;

/// `patchvis args` under [`ADDRESS_SPACE_KIB`] of address space.
fn run_limited(args: &[&str]) -> Output {
    let mut c = Command::new("sh");
    c.arg("-c")
        .arg(format!(
            "ulimit -v {ADDRESS_SPACE_KIB} && exec \"$0\" \"$@\""
        ))
        .arg(env!("CARGO_BIN_EXE_patchvis"))
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .stdin(std::process::Stdio::null());
    run_command(c, &format!("patchvis {args:?} (limited)"))
}

/// A sparse file of `len` bytes (holes: no disk).
fn sparse(dir: &Path, name: &str, len: u64) -> PathBuf {
    let path = dir.join(name);
    File::create(&path).unwrap().set_len(len).unwrap();
    path
}

/// Bakes the bunny with the small flags into `dir/b.pvis`.
fn bake_bunny(dir: &Path) -> PathBuf {
    let pvis = dir.join("b.pvis");
    let mut args = vec!["bake", BUNNY, "-o", path_str(&pvis)];
    args.extend(SMALL);
    let out = run(&args);
    assert!(out.status.success(), "bake: {}", stderr(&out));
    pvis
}

#[test]
fn always_visible_and_merge_inputs_are_regular_files_of_a_sane_size() {
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("out.pvis");
    let o = path_str(&out);
    let fifo = dir.path().join("ids");
    let have_fifo = Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success());
    let huge = sparse(dir.path(), "huge.txt", 3 << 30);
    let mut cases: Vec<(&Path, &[&str])> = vec![
        (
            Path::new("/dev/zero"),
            &["character device", "not a regular file"],
        ),
        (&huge, &["3221225472 bytes", "at most"]),
    ];
    if have_fifo {
        cases.push((&fifo, &["FIFO", "not a regular file"]));
    }
    for (path, words) in cases {
        let p = path_str(path);
        let mut args = vec!["bake", BUNNY, "-o", o, "--always-visible", p];
        args.extend(SMALL);
        let start = Instant::now();
        let got = run_limited(&args);
        assert_refused(&got, 2, &[&[p][..], words].concat());
        assert!(start.elapsed() < Duration::from_secs(20), "{p}");
    }
    // merge: the magic first, then the rest.
    let got = run_limited(&["merge", "-o", o, path_str(&huge)]);
    assert_refused(&got, 1, &[path_str(&huge), "PVISPART"]);
    assert!(!out.exists());
}

#[test]
fn counts_of_views_frames_and_queries_have_stated_limits() {
    let dir = TempDir::new().unwrap();
    let pvis = bake_bunny(dir.path());
    let p = path_str(&pvis);
    let cases: [(&[&str], &str); 3] = [
        (&["eval", BUNNY, p, "--views", "4294967295"], "--views"),
        (&["eval", BUNNY, p, "--path", "orbit:4294967295"], "orbit"),
        (&["query", p, "--bench", "4294967295"], "--bench"),
    ];
    for (args, flag) in cases {
        let got = run_limited(args);
        assert_refused(&got, 2, &[flag, "4294967295", "1000000"]);
    }
    // The limits are in the help.
    for (command, flag) in [("eval", "--views"), ("query", "--bench")] {
        let help = stdout(&run(&[command, "--help"]));
        let line = help
            .lines()
            .skip_while(|l| !l.contains(flag))
            .take(6)
            .collect::<String>();
        assert!(line.contains("1000000"), "{command} --help: {line}");
    }
}

#[test]
fn verify_and_compare_are_bounded_by_the_user() {
    let dir = TempDir::new().unwrap();
    let pvis = bake_bunny(dir.path());
    let p = path_str(&pvis);
    // A time limit no file verifies within: stopped, and said so.
    let got = run(&["verify", p, "--time-limit", "0.000001"]);
    assert_eq!(got.status.code(), Some(1), "{}", stderr(&got));
    let text = stdout(&got);
    assert!(
        text.starts_with(&format!("{p}: not verified")) && text.contains("--time-limit"),
        "{text}"
    );
    // Within a limit it can meet: verified.
    let got = run(&["verify", p, "--time-limit", "600"]);
    assert!(stdout(&got).contains(": OK"), "{}", stdout(&got));
    // info --compare holds the raw matrix: a budget below it is refused before any work.
    let got = run(&["info", p, "--compare", "--memory", "1KiB"]);
    assert_refused(&got, 1, &[p, "--compare", "--memory"]);
    let got = run(&["info", p, "--compare"]);
    assert!(got.status.success(), "{}", stderr(&got));
}

/// The one `.pvmesh` file under `dir`.
fn cache_file(dir: &Path) -> PathBuf {
    let mut found = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for entry in std::fs::read_dir(d).unwrap().flatten() {
            let path = entry.path();
            if path.is_dir() {
                todo.push(path);
            } else if path.extension().is_some_and(|e| e == "pvmesh") {
                found.push(path);
            }
        }
    }
    assert_eq!(found.len(), 1, "{found:?}");
    found.pop().unwrap()
}

#[test]
fn a_damaged_conversion_cache_is_converted_again() {
    let dir = TempDir::new().unwrap();
    let cache_home = dir.path().join("cache");
    let env = [("XDG_CACHE_HOME", path_str(&cache_home))];
    // The bunny as an ASCII PLY: converted, and cached.
    let mesh = patchvis::ooc::Mesh::open(Path::new(BUNNY)).unwrap();
    let mut text = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.vertex_count(),
        mesh.triangle_count()
    );
    for v in 0..mesh.vertex_count() {
        let p = mesh.position(v);
        text += &format!("{:e} {:e} {:e}\n", p[0], p[1], p[2]);
    }
    for t in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(t);
        text += &format!("3 {a} {b} {c}\n");
    }
    let input = dir.path().join("bunny.ply");
    std::fs::write(&input, text).unwrap();
    let bake = |name: &str| {
        let pvis = dir.path().join(name);
        let mut args = vec!["bake", path_str(&input), "-o", path_str(&pvis)];
        args.extend(SMALL);
        let got = run_env(&args, &env);
        assert!(got.status.success(), "{name}: {}", stderr(&got));
        std::fs::read(pvis).unwrap()
    };
    let first = bake("first.pvis");
    // A flipped exponent bit in the first vertex's x, past the header and the path.
    let cache = cache_file(&cache_home);
    let mut bytes = std::fs::read(&cache).unwrap();
    let path_len = u32::from_le_bytes(bytes[60..64].try_into().unwrap()) as usize;
    let x = 64 + path_len.next_multiple_of(4);
    bytes[x + 3] ^= 0x20;
    std::fs::write(&cache, &bytes).unwrap();
    let second = bake("second.pvis");
    assert!(first == second, "the damaged cache was used");
    // And it was replaced by a good one.
    assert!(std::fs::read(&cache).unwrap() != bytes);
}

#[test]
fn the_encoding_help_says_which_version_is_written() {
    let dir = TempDir::new().unwrap();
    let version = |extra: &[&str], name: &str| {
        let pvis = dir.path().join(name);
        let mut args = vec!["bake", BUNNY, "-o", path_str(&pvis), "--encoding", "table"];
        args.extend(SMALL);
        args.extend(extra);
        let got = run(&args);
        assert!(got.status.success(), "{name}: {}", stderr(&got));
        let info = run(&["info", path_str(&pvis), "--json"]);
        crate::common::json(&info)["version"].as_u64().unwrap()
    };
    // With the default shells: the far band's version, whatever the encoding.
    assert_eq!(version(&[], "shells.pvis"), 6);
    assert_eq!(
        version(&["--shells", "0", "--far-shells", "none"], "plain.pvis"),
        2
    );
    // A research option: in `--help-all`.
    let help: String = stdout(&run(&["bake", "--help-all"]))
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    let encoding = &help[help.find("--encoding").unwrap()..];
    assert!(
        encoding.contains("version 6") && encoding.contains("--shells 0 --far-shells none"),
        "{}",
        &encoding[..encoding.len().min(600)]
    );
}
