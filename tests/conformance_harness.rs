//! `patchvis conformance`, the harness for other readers, through the CLI: the reference
//! reader (`--serve`) passes every vector; a reader that gets one query of one vector wrong is
//! reported failing with that vector and query, and the rest still pass; a reader that exits
//! or hangs is a clear error, not a hang of the harness.

mod common;

use common::{patchvis, stderr, stdout};
use std::fs;
use std::path::Path;

const VECTORS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/conformance");

/// The reference reader as a peer: `patchvis conformance --serve`.
fn serve() -> String {
    format!("'{}' conformance --serve", env!("CARGO_BIN_EXE_patchvis"))
}

fn vector_count() -> usize {
    ["valid", "invalid"]
        .iter()
        .map(|kind| {
            fs::read_dir(Path::new(VECTORS).join(kind))
                .unwrap()
                .filter(|e| {
                    e.as_ref()
                        .unwrap()
                        .path()
                        .extension()
                        .is_some_and(|x| x == "pvis")
                })
                .count()
        })
        .sum()
}

#[test]
fn the_reference_reader_passes_every_vector() {
    let out = patchvis(&["conformance", "--vectors", VECTORS, "--reader", &serve()]);
    let text = stdout(&out);
    assert!(out.status.success(), "{text}{}", stderr(&out));
    let lines: Vec<&str> = text.lines().collect();
    let n = vector_count();
    assert_eq!(lines.len(), n + 1, "one line per vector and a summary");
    assert!(lines[..n].iter().all(|l| l.starts_with("pass ")), "{text}");
    assert!(
        lines[n].starts_with(&format!("{n} of {n} vectors pass")),
        "{}",
        lines[n]
    );
    // Every query position of every dump was asked, frustum queries included.
    let queries: usize = fs::read_dir(Path::new(VECTORS).join("valid"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "dump"))
        .map(|p| {
            let dump = fs::read_to_string(p).unwrap();
            dump.lines().filter(|l| l.starts_with("query ")).count()
        })
        .sum();
    assert!(
        lines[n].contains(&format!("({queries} queries, ")),
        "{}",
        lines[n]
    );
    assert!(!lines[n].contains(" 0 frustum queries"), "{}", lines[n]);
}

/// A proxy in front of the reference reader that changes the answer to `query EYE` while
/// `VECTOR` is open: patches `[...]` become `[]`.
const WRONG_READER: &str = r#"
import subprocess, sys
vector, eye, serve = sys.argv[1], sys.argv[2], sys.argv[3]
peer = subprocess.Popen(serve, shell=True, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
current = ""
for line in sys.stdin:
    peer.stdin.write(line); peer.stdin.flush()
    if line.strip() == "quit":
        break
    reply = peer.stdout.readline()
    if line.startswith("open "):
        current = line[5:].strip()
    if current.endswith(vector) and line.strip() == "query " + eye:
        reply = reply[: reply.index("patches ")] + "patches []\n"
    sys.stdout.write(reply); sys.stdout.flush()
"#;

#[test]
fn a_wrong_answer_names_its_vector_and_query() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("wrong.py");
    fs::write(&script, WRONG_READER).unwrap();
    // An eye beyond the sampling distance of a version-6 vector, answered from two far shells.
    let vector = "023-v6-level2-three-far-two-near-mixed-encodings.pvis";
    assert!(Path::new(VECTORS).join("valid").join(vector).exists());
    let eye = "10,10,-10";
    let reader = format!(
        "python3 '{}' '{vector}' '{eye}' \"{}\"",
        script.display(),
        serve()
    );
    let out = patchvis(&["conformance", "--vectors", VECTORS, "--reader", &reader]);
    let text = stdout(&out);
    assert_eq!(out.status.code(), Some(1), "{text}{}", stderr(&out));
    let failed: Vec<&str> = text.lines().filter(|l| l.starts_with("FAIL ")).collect();
    assert_eq!(failed.len(), 1, "{text}");
    assert!(
        failed[0].starts_with(&format!("FAIL valid/{vector}: query {eye}: patches [")),
        "{}",
        failed[0]
    );
    assert!(failed[0].ends_with("expected, got []"), "{}", failed[0]);
    let n = vector_count();
    assert!(
        text.contains(&format!("{} of {n} vectors pass", n - 1)),
        "{text}"
    );
}

#[test]
fn a_reader_that_exits_or_hangs_is_an_error() {
    let out = patchvis(&["conformance", "--vectors", VECTORS, "--reader", "exit 0"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("`hello 1`: the reader exited"),
        "{}",
        stderr(&out)
    );
    let hang = [
        "conformance",
        "--vectors",
        VECTORS,
        "--timeout",
        "0.5",
        "--reader",
        "sleep 30",
    ];
    let out = patchvis(&hang);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("no reply within 0.5 s"),
        "{}",
        stderr(&out)
    );
    // A reader that greets and then answers nonsense fails each vector, not the harness.
    let babble = "while read l; do case $l in hello*) echo hello 1;; *) echo what;; esac; done";
    let out = patchvis(&["conformance", "--vectors", VECTORS, "--reader", babble]);
    assert_eq!(out.status.code(), Some(1));
    let text = stdout(&out);
    assert!(text.lines().all(|l| !l.starts_with("pass ")), "{text}");
    assert!(
        text.contains("expected `ok` or `error …`, got `what`"),
        "{text}"
    );
}

#[test]
fn a_missing_vector_folder_says_what_was_expected() {
    let out = patchvis(&[
        "conformance",
        "--vectors",
        "/nonexistent",
        "--reader",
        "cat",
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("--vectors DIR"), "{}", stderr(&out));
}
