//! Hostile outputs, over time: see tests/hostile.rs. Commands that run at once and name the
//! same outputs (one writes, the others are refused naming its pid, and the writer is not
//! disturbed: `concurrent.sh`), and commands ended by a signal in the middle of a write
//! (their temporary and lock files go with them).
//!
//! Unix only: signals, `flock` and the script are Unix notions here.
#![cfg(unix)]

use super::support::{DEADLINE, SMALL, command, wait};
use crate::common::{BUNNY, path_str, stderr};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use tempfile::TempDir;

/// Runs of `concurrent.sh` here; run it by hand for the full hundred (see the script).
const CONCURRENT_RUNS: &str = "3";

#[test]
fn a_second_command_naming_a_running_bakes_outputs_is_refused_and_disturbs_nothing() {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile/concurrent.sh");
    let mut child = Command::new("bash")
        .arg(&script)
        .args([env!("CARGO_BIN_EXE_patchvis"), CONCURRENT_RUNS])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run bash");
    // The script's output is small; its bakes are the suite's small ones.
    let status = wait(&mut child, DEADLINE, "concurrent.sh");
    let out = child.wait_with_output().unwrap();
    assert!(
        status.success(),
        "concurrent.sh failed: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The files in `dir` whose names end in `suffix`.
fn ending_in(dir: &Path, suffix: &str) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(suffix))
        .collect()
}

/// Sends `signal` (`INT`, `TERM`) to the process `pid`.
fn send(signal: &str, pid: u32) {
    let sent = Command::new("kill")
        .args([&format!("-{signal}"), &pid.to_string()])
        .status()
        .unwrap();
    assert!(sent.success(), "kill -{signal} {pid}");
}

/// Waits (up to the suite's deadline) until `path` exists or `child` ends; whether it exists.
fn wait_for(path: &Path, child: &mut std::process::Child) -> bool {
    let deadline = Instant::now() + DEADLINE;
    while Instant::now() < deadline {
        if path.exists() {
            return true;
        }
        if child.try_wait().unwrap().is_some() {
            return path.exists();
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    false
}

#[test]
fn a_signal_in_the_middle_of_a_write_leaves_no_temporary_or_lock_file() {
    let dir = TempDir::new().unwrap();
    // `gen` writes its mesh through a temporary file for most of its run.
    for signal in ["INT", "TERM"] {
        let out = dir.path().join("g.ply");
        let tmp = dir.path().join(".g.ply.patchvis-tmp");
        let args = ["gen", "--kind", "truss", "--triangles", "20000000"];
        let mut c = command(&args, &[]);
        let mut child = c
            .args(["-o", path_str(&out), "-q"])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        assert!(
            wait_for(&tmp, &mut child),
            "gen never wrote its temporary file"
        );
        send(signal, child.id());
        let status = wait(&mut child, DEADLINE, "patchvis gen");
        assert!(
            !status.success(),
            "gen ended with {status} after SIG{signal}"
        );
        assert!(!out.exists(), "SIG{signal}: a half-written g.ply");
        assert_eq!(ending_in(dir.path(), ".patchvis-tmp"), Vec::<String>::new());
        assert_eq!(
            ending_in(dir.path(), ".patchvis-lock"),
            Vec::<String>::new()
        );
    }
    // A bake, interrupted while it holds its outputs' locks: they go too.
    let pvis = dir.path().join("b.pvis");
    let lock = dir.path().join(".b.pvis.patchvis-lock");
    let mut args = vec!["bake", BUNNY, "-o", path_str(&pvis)];
    args.extend(SMALL);
    let mut child = command(&args, &[])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    if wait_for(&lock, &mut child) {
        send("INT", child.id());
    }
    let status = wait(&mut child, DEADLINE, "patchvis bake");
    let err = child.wait_with_output().unwrap();
    assert!(!status.success() || pvis.exists(), "{}", stderr(&err));
    assert_eq!(ending_in(dir.path(), ".patchvis-tmp"), Vec::<String>::new());
    assert_eq!(
        ending_in(dir.path(), ".patchvis-lock"),
        Vec::<String>::new()
    );
}
