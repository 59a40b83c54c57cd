//! The far-only reader (the library without feature `shells`; spec § SHEL, far-only readers)
//! against the conformance vectors: every valid file opens with no shells and answers each eye
//! of its dump as the dump's `far-query` line says (a file with shells) or as its `query` line
//! says (a file without); every invalid file is refused with the expected message, except those
//! whose only fault lies inside SHEL's contents, which such a reader skips and so accepts.
//!
//! Runs only in a far-only build, the reader for devices too small for the shells (the
//! WebAssembly module and the Cortex-M4F firmware are full readers):
//!
//! ```text
//! cargo test --no-default-features --test far_only
//! ```
#![cfg(not(feature = "shells"))]

use std::fs;
use std::path::{Path, PathBuf};

use patchvis::runtime::Pvis;

/// Invalid vectors whose only fault is inside SHEL's contents: the names listed in
/// tests/conformance/far-only.txt (179, two SHEL sections, is a fault of the section table,
/// which every reader checks, and is not among them).
fn shel_contents() -> Vec<String> {
    let list = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance/far-only.txt");
    fs::read_to_string(list)
        .unwrap()
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(String::from)
        .collect()
}

fn vectors(kind: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/conformance")
        .join(kind);
    let mut files: Vec<PathBuf> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "pvis"))
        .collect();
    files.sort();
    files
}

fn number(s: &str) -> f32 {
    match s {
        "inf" => f32::INFINITY,
        "-inf" => f32::NEG_INFINITY,
        _ => s.parse().unwrap(),
    }
}

/// A `query` line in the format of a file without shells, as this reader answers `eye`.
fn answer(pvis: &Pvis<'_>, eye_text: &str, scratch: &mut [u64]) -> String {
    let eye: Vec<f32> = eye_text.split(',').map(number).collect();
    let visible = pvis.query([eye[0], eye[1], eye[2]], scratch);
    let list = |v: &mut dyn Iterator<Item = u32>| {
        let v: Vec<String> = v.map(|x| x.to_string()).collect();
        v.join(",")
    };
    format!(
        "query {eye_text} -> inside {} views [{}] patches [{}]",
        visible.inside_sphere,
        list(&mut visible.leaf.into_iter()),
        list(&mut visible.patches()),
    )
}

#[test]
fn valid_vectors_answer_as_far_only_readers() {
    let mut far_lines = 0;
    for path in vectors("valid") {
        let bytes = fs::read(&path).unwrap();
        let pvis = Pvis::parse(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(
            (pvis.shell_count(), pvis.sampling_shell()),
            (0, 0),
            "{}",
            path.display()
        );
        let dump = fs::read_to_string(path.with_extension("dump")).unwrap();
        let far = dump.lines().any(|l| l.starts_with("far-query "));
        let mut scratch = vec![0u64; pvis.scratch_words()];
        let mut stream_scratch = vec![0u64; pvis.scratch_bound()];
        let mut streaming = pvis.streaming(&mut stream_scratch);
        let prefix = if far { "far-query " } else { "query " };
        for line in dump.lines().filter(|l| l.starts_with(prefix)) {
            let expected = line.strip_prefix("far-").unwrap_or(line);
            let eye_text = expected["query ".len()..].split(' ').next().unwrap();
            assert_eq!(
                answer(&pvis, eye_text, &mut scratch),
                expected,
                "{}",
                path.display()
            );
            // The streaming mode (the WebAssembly module's) gives the same set.
            let eye: Vec<f32> = eye_text.split(',').map(number).collect();
            let v = streaming.query([eye[0], eye[1], eye[2]]);
            let stateless = pvis.query([eye[0], eye[1], eye[2]], &mut scratch);
            assert_eq!(v.bits(), stateless.bits(), "{} {eye_text}", path.display());
            assert_eq!(v.inside_sphere, stateless.inside_sphere);
            far_lines += usize::from(far);
        }
    }
    assert!(far_lines > 100, "only {far_lines} far-query lines checked");
}

#[test]
fn invalid_vectors_are_refused_unless_the_fault_is_in_shel_contents() {
    let shel_contents = shel_contents();
    assert_eq!(shel_contents.len(), 26);
    let mut accepted = 0;
    for path in vectors("invalid") {
        let bytes = fs::read(&path).unwrap();
        let name = path.file_name().unwrap().to_str().unwrap();
        let listed = shel_contents
            .iter()
            .any(|s| path.file_stem().unwrap() == s.as_str());
        let expected = fs::read_to_string(path.with_extension("err")).unwrap();
        match Pvis::parse(&bytes) {
            Ok(pvis) => {
                assert!(listed, "{name}: accepted");
                assert!(matches!(pvis.version(), 5 | 6), "{name}");
                assert_eq!(pvis.shell_count(), 0, "{name}");
                accepted += 1;
            }
            Err(e) => {
                assert!(!listed, "{name}: refused: {e}");
                assert_eq!(e.to_string(), expected.trim_end(), "{name}");
            }
        }
    }
    assert_eq!(accepted, shel_contents.len());
}
