//! Hostile settings and reports: see tests/hostile.rs. Flags that would do nothing, or whose
//! refusal would blame a flag the user never gave; and what a command says when it cannot
//! write: one cause, said once, and a help text that did not reach its reader is a failure.
//!
//! Unix only: `/dev/full` and `ulimit` are Unix notions here.
#![cfg(unix)]

use super::support::{DEADLINE, SMALL, assert_refused, run, run_command, wait};
use crate::common::{BUNNY, path_str, stderr};
use std::process::{Command, Stdio};
use tempfile::TempDir;

/// `bake BUNNY -o DIR/b.pvis` with the small settings and `more`.
fn bake(dir: &TempDir, more: &[&str]) -> std::process::Output {
    let out = dir.path().join("b.pvis");
    let mut args = vec!["bake", BUNNY, "-o", path_str(&out)];
    args.extend(SMALL);
    args.extend(more);
    run(&args)
}

#[test]
fn min_pixels_under_the_probe_pass_is_refused_not_ignored() {
    let dir = TempDir::new().unwrap();
    // The probe pass draws every patch a view did not show again and adds it back: the
    // threshold would change nothing.
    for probe in [&[][..], &["--probe", "2"], &["--conservative"]] {
        let mut flags = vec!["--min-pixels", "100"];
        flags.extend(probe);
        assert_refused(&bake(&dir, &flags), 2, &["--min-pixels 100", "--probe off"]);
    }
    let out = bake(&dir, &["--min-pixels", "100", "--probe", "off"]);
    assert!(out.status.success(), "{}", stderr(&out));
    // 0 and 1 mean any pixel, so they are no threshold to defeat.
    let out = bake(&dir, &["--min-pixels", "1"]);
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn apertures_without_the_probe_or_too_wide_are_refused() {
    let dir = TempDir::new().unwrap();
    // The probe pass opens the apertures: without it they would do nothing.
    let out = bake(&dir, &["--apertures", "2", "--probe", "off"]);
    assert_refused(&out, 2, &["--apertures 2", "--probe off"]);
    assert_refused(
        &bake(&dir, &["--apertures", "17"]),
        2,
        &["--apertures 17", "16"],
    );
    let out = bake(&dir, &["--apertures", "0", "--probe", "off"]);
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn a_wide_fov_blames_the_fov_not_a_flag_never_given() {
    let dir = TempDir::new().unwrap();
    for fov in ["170", "179"] {
        let out = bake(&dir, &["--fov", fov]);
        assert_refused(&out, 2, &[&format!("--fov {fov}"), "--shells 0"]);
        let err = stderr(&out);
        assert!(
            !err.contains("--shell-min 1.1:"),
            "blames --shell-min: {err}"
        );
        // The range offered is not empty.
        assert!(!err.contains("below 1.000 "), "{err}");
    }
    // Without shells there is nothing for a wide fov to clash with.
    let out = bake(&dir, &["--fov", "170", "--shells", "0"]);
    assert!(out.status.success(), "{}", stderr(&out));
    // A --shell-min given and out of range is still its own error.
    let out = bake(&dir, &["--shell-min", "3"]);
    assert_refused(&out, 2, &["--shell-min 3"]);
}

#[test]
fn tile_needs_only_the_memory_a_tiling_needs() {
    let dir = TempDir::new().unwrap();
    let t = dir.path().join("t.ptile");
    let out = run(&["tile", BUNNY, "-o", path_str(&t), "--memory", "8MiB", "-q"]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(
        !err.contains("ID buffers") && !err.contains("views"),
        "{err}"
    );
}

#[test]
fn help_that_cannot_be_written_is_a_failure() {
    let dir = TempDir::new().unwrap();
    let err_path = dir.path().join("stderr");
    for args in [
        &["--help"][..],
        &["bake", "--help"],
        &["bake", "--help-all"],
        &["--version"],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_patchvis"))
            .args(args)
            .stdin(Stdio::null())
            .stdout(std::fs::File::create("/dev/full").unwrap())
            .stderr(std::fs::File::create(&err_path).unwrap())
            .spawn()
            .unwrap();
        let status = wait(&mut child, DEADLINE, "patchvis --help > /dev/full");
        let err = std::fs::read_to_string(&err_path).unwrap();
        assert_eq!(status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("cannot write to stdout"), "{args:?}: {err}");
    }
}

#[test]
fn a_write_error_is_said_once() {
    // A file size limit stands in for a full disk: the write fails the same way, with
    // EFBIG instead of ENOSPC (SIGXFSZ ignored, so the write returns the error). 512 bytes
    // take the lock file, not a checkpoint or the .pvis.
    let dir = TempDir::new().unwrap();
    let pvis = dir.path().join("b.pvis");
    let mut c = Command::new("sh");
    c.args(["-c", "trap '' XFSZ; ulimit -f 1; exec \"$0\" \"$@\""])
        .arg(env!("CARGO_BIN_EXE_patchvis"))
        .args(["bake", BUNNY, "-o"])
        .arg(&pvis)
        .args(SMALL)
        .stdin(Stdio::null());
    let out = run_command(c, "patchvis bake under ulimit -f");
    assert_refused(&out, 1, &["b.pvis", "(os error 27)"]);
    assert_eq!(
        stderr(&out).matches("os error").count(),
        1,
        "{}",
        stderr(&out)
    );
    assert!(!pvis.exists());
}
