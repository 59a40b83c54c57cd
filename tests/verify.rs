//! `patchvis verify` through the binary, on the conformance vectors: exit 0 and an OK line for
//! every valid vector, exit 1 and exactly `FILE: <the vector's expected error>` for every
//! invalid one.

#![cfg(feature = "cli")]

mod common;

use common::{patchvis, stdout};
use patchvis::runtime::consts::VERSION;
use std::path::{Path, PathBuf};
use std::process::Output;

/// `patchvis verify ARGS`.
fn verify(args: &[&str]) -> Output {
    patchvis(&[&["verify"], args].concat())
}

fn vectors(kind: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/conformance")
        .join(kind);
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "pvis"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no {kind} vectors");
    files
}

#[test]
fn valid_vectors_pass() {
    for path in vectors("valid") {
        let file = path.to_str().unwrap();
        let out = verify(&[file]);
        assert_eq!(out.status.code(), Some(0), "{file}: {}", stdout(&out));
        let text = stdout(&out);
        assert_eq!(text.lines().count(), 1, "{text}");
        // Version-4 to -6 vectors say so in their name; of the others, raw and table-coded
        // ones are version 2 (the oldest that holds them), tree-coded ones version 3.
        let version = if file.contains("-v6-") {
            VERSION
        } else if file.contains("-v5-") {
            5
        } else if file.contains("-v4-") {
            4
        } else if file.contains("-raw") || file.contains("-table") {
            2
        } else {
            3
        };
        assert!(
            text.starts_with(&format!("{file}: OK (version {version}, ")),
            "{text}"
        );
    }
    let seven = vectors("valid")
        .into_iter()
        .find(|p| p.to_str().unwrap().contains("002-"))
        .unwrap();
    let out = verify(&[seven.to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(0));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["ok"], true);
    assert_eq!(report["patches"], 7);
    assert_eq!(report["triangles"], 25);
    assert_eq!(report["views"], 18);
    // The dump of 002 has 51 ones over its 18 rows.
    let dump = std::fs::read_to_string(seven.with_extension("dump")).unwrap();
    let ones: usize = dump
        .lines()
        .filter(|l| l.starts_with("view "))
        .map(|l| l.split(": ").nth(1).unwrap().matches('1').count())
        .sum();
    assert_eq!(report["visible_pairs"], ones as u64);
}

#[test]
fn invalid_vectors_fail_with_their_exact_error() {
    for path in vectors("invalid") {
        let file = path.to_str().unwrap();
        let expected = std::fs::read_to_string(path.with_extension("err")).unwrap();
        let out = verify(&[file]);
        assert_eq!(out.status.code(), Some(1), "{file}");
        assert_eq!(stdout(&out), format!("{file}: {expected}"));
    }
    let bad = &vectors("invalid")[0];
    let out = verify(&["--json", bad.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["ok"], false);
    let expected = std::fs::read_to_string(bad.with_extension("err")).unwrap();
    assert_eq!(report["error"], expected.trim_end());
}

#[test]
fn unreadable_file_is_a_violation() {
    let out = verify(&["/nonexistent/x.pvis"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stdout(&out).starts_with("/nonexistent/x.pvis: cannot read: "),
        "{}",
        stdout(&out)
    );
    let usage = verify(&[]);
    assert_eq!(usage.status.code(), Some(2));
}
