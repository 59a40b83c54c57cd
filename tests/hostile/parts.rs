//! Crafted part files: a part whose checksum was recomputed after its fields were changed is
//! checked as the reader checks a `.pvis` (every patch record, the camera, the triangle
//! count) and against every other part, so `patchvis merge` refuses it in one line naming
//! the part, or merges it, and never panics.

use std::path::{Path, PathBuf};

use patchvis::runtime::crc32c::crc32c;
use tempfile::TempDir;

use super::support::{SMALL, assert_refused, run};
use crate::common::{BUNNY, path_str, stderr};

/// The part file's offsets (`src/bake/part.rs`): the triangle count, then the settings
/// block's length and the block; the camera (level, resolution, fov, centre, radius) and the
/// patch count follow, then 48-byte patch records.
const TRIANGLES_AT: usize = 44;
const BLOCK_LEN_AT: usize = 48;

/// Where the camera of `bytes` starts.
fn camera_at(bytes: &[u8]) -> usize {
    BLOCK_LEN_AT + 4 + u32::from_le_bytes(bytes[BLOCK_LEN_AT..][..4].try_into().unwrap()) as usize
}

/// `bytes` with its CRC-32C trailer recomputed.
fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
    let body = bytes.len() - 4;
    let crc = crc32c(&bytes[..body]);
    bytes[body..].copy_from_slice(&crc.to_le_bytes());
    bytes
}

/// Two shards of a small bunny bake; returns their part files.
fn parts(dir: &Path) -> [PathBuf; 2] {
    let tiling = dir.join("t.ptile");
    let tile = run(&[
        "tile",
        BUNNY,
        "-o",
        path_str(&tiling),
        "--patches",
        "96",
        "-q",
    ]);
    assert!(tile.status.success(), "tile: {}", stderr(&tile));
    [0, 1].map(|i| {
        let part = dir.join(format!("p{i}.ppart"));
        let shard = format!("{i}/2");
        let mut args = vec!["bake", BUNNY, "-o", path_str(&part)];
        args.extend(["--tiling-file", path_str(&tiling), "--shard", &shard]);
        args.extend(["--patches", "96"]);
        args.extend(SMALL);
        let out = run(&args);
        assert!(out.status.success(), "shard {i}: {}", stderr(&out));
        part
    })
}

/// `merge` of `first` (written to `dir/crafted.ppart`) and `second`: never a panic; a
/// refusal is one line naming the crafted part. Returns whether it merged.
fn merge(dir: &Path, first: &[u8], second: &Path, what: &str) -> bool {
    let crafted = dir.join("crafted.ppart");
    std::fs::write(&crafted, first).unwrap();
    let out = dir.join("merged.pvis");
    let _ = std::fs::remove_file(&out);
    let got = run(&[
        "merge",
        "-q",
        "-o",
        path_str(&out),
        path_str(&crafted),
        path_str(second),
    ]);
    let err = stderr(&got);
    assert_ne!(got.status.code(), Some(101), "{what}: panicked: {err}");
    assert!(!err.contains("panicked"), "{what}: {err}");
    if got.status.success() {
        let verify = run(&["verify", path_str(&out)]);
        assert!(verify.status.success(), "{what}: the merge does not verify");
        return true;
    }
    assert_refused(&got, 1, &[]);
    assert!(!out.exists(), "{what}: output on refusal");
    false
}

#[test]
fn crafted_parts_are_refused_without_a_panic() {
    let dir = TempDir::new().unwrap();
    let [p0, p1] = parts(dir.path());
    let good = std::fs::read(&p0).unwrap();
    let camera = camera_at(&good);
    let patches = camera + 28;
    let record = patches + 4;
    let set = |at: usize, value: &[u8]| {
        let mut b = good.clone();
        b[at..at + value.len()].copy_from_slice(value);
        resealed(b)
    };
    let nan = f32::NAN.to_le_bytes();
    let triangles = u32::from_le_bytes(good[TRIANGLES_AT..][..4].try_into().unwrap());
    // Each of these panicked the merge, or merged into a file the reader refuses.
    let cases: Vec<(&str, Vec<u8>)> = vec![
        (
            "triangles + 1",
            set(TRIANGLES_AT, &(triangles + 1).to_le_bytes()),
        ),
        (
            "triangles - 1",
            set(TRIANGLES_AT, &(triangles - 1).to_le_bytes()),
        ),
        ("NaN camera centre", set(camera + 12, &nan)),
        (
            "another camera radius",
            set(camera + 24, &7.5f32.to_le_bytes()),
        ),
        ("another fov", set(camera + 8, &50f32.to_le_bytes())),
        ("a patch's first triangle", set(record, &5u32.to_le_bytes())),
        ("a patch's count", set(record + 4, &0u32.to_le_bytes())),
        ("a NaN patch area", set(record + 8, &f64::NAN.to_le_bytes())),
        (
            "a negative patch radius",
            set(record + 28, &(-1f32).to_le_bytes()),
        ),
        ("a zero cone axis", set(record + 32, &[0; 12])),
        ("a cone cosine of 2", set(record + 44, &2f32.to_le_bytes())),
        ("a NaN centre", set(record + 16, &nan)),
    ];
    for (what, bytes) in &cases {
        assert!(!merge(dir.path(), bytes, &p1, what), "{what}: merged");
    }
    // Seeded mutations of one to four bytes anywhere past the magic and the version.
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for trial in 0..120 {
        let mut bytes = good.clone();
        for _ in 0..1 + next() % 4 {
            let at = 12 + (next() as usize) % (bytes.len() - 16);
            bytes[at] = next() as u8;
        }
        merge(
            dir.path(),
            &resealed(bytes),
            &p1,
            &format!("mutation {trial}"),
        );
    }
}
