//! Writer tests: writer → reader round trips on generated contents, determinism, atomic write.

use super::*;
use crate::runtime::{PatchInfo, Sampling};
use proptest::prelude::*;

/// Patches with the given triangle counts, ranges contiguous from 0, bounds derived from `i`.
fn patches(counts: &[u32]) -> Vec<Patch> {
    let mut first = 0;
    counts
        .iter()
        .enumerate()
        .map(|(i, &count)| {
            let patch = Patch {
                first,
                count,
                area: 1.0,
                center: [i as f32, -(i as f32), 0.5],
                radius: 0.125 * i as f32,
                cone_axis: [0.0, 0.0, 1.0],
                cone_cos: if i % 2 == 0 { -1.0 } else { 0.75 },
            };
            first += count;
            patch
        })
        .collect()
}

fn params(level: u32) -> SamplingParams {
    SamplingParams {
        level,
        resolution: 512,
        fov_deg: 50.0,
        center: [0.25, -1.5, 8.0],
        radius: 3.5,
    }
}

/// Encodes, parses and checks every field and row against the inputs.
fn round_trip(level: u32, counts: &[u32], matrix: &VisibilityMatrix) -> Vec<u8> {
    let params = params(level);
    let patches = patches(counts);
    let triangle_count = counts.iter().map(|&c| c as u64).sum();
    let bytes = encode(&BakeContents {
        sampling: &params,
        triangle_count,
        patches: &patches,
        visibility: matrix,
    });
    let pvis = Pvis::parse(&bytes).expect("the writer's output parses");
    assert_eq!(
        pvis.sampling(),
        Sampling {
            level,
            views: sphere::view_count(level),
            center: params.center,
            radius: params.radius,
            distance: params.distance(),
            fov_deg: params.fov_deg,
            resolution: params.resolution,
        }
    );
    assert_eq!(pvis.patch_count() as usize, counts.len());
    assert_eq!(pvis.triangle_count(), triangle_count);
    for (p, patch) in patches.iter().enumerate() {
        assert_eq!(
            pvis.patch(p as u32),
            PatchInfo {
                first_triangle: patch.first,
                triangle_count: patch.count,
                center: patch.center,
                radius: patch.radius,
                cone_axis: patch.cone_axis,
                cone_cos: patch.cone_cos,
            }
        );
    }
    let mut row = vec![0u64; pvis.row_words()];
    for view in 0..matrix.views() {
        pvis.view_row(view, &mut row);
        assert_eq!(row, matrix.row(view), "view {view}");
    }
    bytes
}

#[test]
fn layout_of_a_small_file() {
    let mut matrix = VisibilityMatrix::new(6, 3);
    matrix.set(0, 2);
    matrix.set(5, 0);
    let bytes = round_trip(0, &[2, 1, 4], &matrix);
    // Header 32 + table 72 = 104; CAMR 104..148; PTCH 152..288; VISB 288..302; CRC 302..306.
    assert_eq!(bytes.len(), 306);
    assert_eq!(&bytes[..8], b"PVIS\r\n\x1a\n");
    assert_eq!(&bytes[32..36], b"CAMR");
    assert_eq!(bytes[40], 104);
    assert_eq!(&bytes[32 + 24 + 8..32 + 24 + 9], [152]);
    assert_eq!(&bytes[32 + 48 + 8..32 + 48 + 10], 288u16.to_le_bytes());
    assert_eq!(bytes[148..152], [0; 4], "alignment padding");
    // VISB rows: one byte each; view 0 sees patch 2, view 5 patch 0.
    assert_eq!(bytes[296..302], [0b100, 0, 0, 0, 0, 0b1]);
}

#[test]
fn encoding_is_deterministic() {
    let mut matrix = VisibilityMatrix::new(18, 70);
    for v in 0..18 {
        matrix.set(v, (v * 7) % 70);
    }
    let counts = [1u32; 70];
    assert_eq!(
        round_trip(1, &counts, &matrix),
        round_trip(1, &counts, &matrix)
    );
}

#[test]
#[should_panic(expected = "patch 1 covers triangles 3+1")]
fn encode_refuses_non_contiguous_ranges() {
    let mut patches = patches(&[2, 1]);
    patches[1].first = 3;
    let matrix = VisibilityMatrix::new(6, 2);
    encode(&BakeContents {
        sampling: &params(0),
        triangle_count: 3,
        patches: &patches,
        visibility: &matrix,
    });
}

#[test]
fn write_atomic_replaces_the_file_and_leaves_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.pvis");
    write_atomic(&path, b"first").unwrap();
    write_atomic(&path, b"second").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"second");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    // A destination in a missing directory fails without creating anything.
    let missing = dir.path().join("no/such/dir/out.pvis");
    assert!(write_atomic(&missing, b"x").is_err());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

proptest! {
    #[test]
    fn random_contents_round_trip(
        level in 0u32..=2,
        counts in proptest::collection::vec(1u32..5, 1..150),
        seed in any::<u64>(),
    ) {
        let views = sphere::view_count(level);
        let mut matrix = VisibilityMatrix::new(views, counts.len() as u32);
        let mut state = seed | 1;
        for v in 0..views {
            for p in 0..counts.len() as u32 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                if state % 3 == 0 {
                    matrix.set(v, p);
                }
            }
        }
        round_trip(level, &counts, &matrix);
    }
}
