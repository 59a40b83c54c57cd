//! What the end-to-end tests through the `patchvis` binary share: the bundled model, running
//! the binary, and reading its output. Each test crate uses a part of it.
#![allow(dead_code)]

use std::process::{Command, Output};

/// The bundled Stanford bunny (99,785 triangles).
pub const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/bunny.ply");

/// Runs the `patchvis` binary with `args`.
pub fn patchvis(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_patchvis"))
        .args(args)
        .output()
        .expect("run patchvis")
}

/// The run's stderr as text.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The run's stdout as JSON; fails the test (with stderr) if the run failed.
pub fn json(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "failed: {}", stderr(out));
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}
