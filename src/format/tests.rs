//! Writer tests: writer → reader round trips on generated contents, determinism, atomic write.

use super::*;
use crate::runtime::{PatchInfo, Sampling};
use crate::test_kit::rng::Rng;
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
                // Varied axes, so encoding 2's facing features take every value.
                cone_axis: [
                    [0.0, 0.0, 1.0],
                    [1.0, 0.0, 0.0],
                    [0.0, -1.0, 0.0],
                    [0.6, 0.8, 0.0],
                ][i % 4],
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

/// Encodes with the default encoding, parses and checks every field and row against the inputs.
fn round_trip(level: u32, counts: &[u32], matrix: &VisibilityMatrix) -> Vec<u8> {
    round_trip_with(level, counts, matrix, VisibilityEncoding::Tree)
}

/// Encodes with `encoding` (and its default patch table), parses and checks every field and
/// row against the inputs.
fn round_trip_with(
    level: u32,
    counts: &[u32],
    matrix: &VisibilityMatrix,
    encoding: VisibilityEncoding,
) -> Vec<u8> {
    let layout = match encoding {
        VisibilityEncoding::Tree => PatchTableLayout::Compact,
        _ => PatchTableLayout::Full,
    };
    let bytes = round_trip_as(level, counts, matrix, encoding, layout);
    assert_eq!(
        bytes,
        encode_with(
            &BakeContents {
                sampling: &params(level),
                triangle_count: counts.iter().map(|&c| c as u64).sum(),
                patches: &patches(counts),
                visibility: matrix,
                shells: &[],
                reach: 0.0,
            },
            encoding
        ),
        "the encoding's default table"
    );
    bytes
}

/// Encodes with `encoding` and `layout`, parses and checks every field and row against the
/// inputs.
fn round_trip_as(
    level: u32,
    counts: &[u32],
    matrix: &VisibilityMatrix,
    encoding: VisibilityEncoding,
    layout: PatchTableLayout,
) -> Vec<u8> {
    let params = params(level);
    let patches = patches(counts);
    let triangle_count = counts.iter().map(|&c| c as u64).sum();
    let contents = BakeContents {
        sampling: &params,
        triangle_count,
        patches: &patches,
        visibility: matrix,
        shells: &[],
        reach: 0.0,
    };
    let bytes = encode_as(&contents, encoding, layout);
    if (encoding, layout) == (VisibilityEncoding::Tree, PatchTableLayout::Compact) {
        assert_eq!(
            bytes,
            encode(&contents),
            "encoding 2, compact table is the default"
        );
    }
    assert_eq!(
        pvis_version(&bytes),
        match (layout, encoding) {
            (PatchTableLayout::Compact, _) => 4,
            (_, VisibilityEncoding::Tree) => 3,
            _ => 2,
        }
    );
    let pvis = Pvis::parse(&bytes).expect("the writer's output parses");
    let expected_encoding = match encoding {
        VisibilityEncoding::Raw => ENCODING_RAW,
        VisibilityEncoding::Table => ENCODING_HIERARCHICAL,
        VisibilityEncoding::Tree => ENCODING_TREE,
    };
    assert_eq!(pvis.encoding(), expected_encoding);
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
        check_record(&pvis, p as u32, patch);
    }
    let mut row = vec![0u64; pvis.row_words()];
    for view in 0..matrix.views() {
        pvis.view_row(view, &mut row);
        assert_eq!(row, matrix.row(view), "view {view}");
    }
    check_queries(&pvis, matrix, level as u64 * 31 + counts.len() as u64);
    bytes
}

/// Patch `p` of `pvis` stands for `patch`: exactly in a full table; in a compact one, with the
/// same range, the record the writer's quantiser gives, and bounds that contain the true ones.
fn check_record(pvis: &Pvis<'_>, p: u32, patch: &Patch) {
    let info = pvis.patch(p);
    assert_eq!(info, stored_record(pvis.quantisation(), patch));
    if pvis.quantisation().is_some() {
        assert_eq!(
            (info.first_triangle, info.triangle_count),
            (patch.first, patch.count)
        );
        assert_contains(&info, patch);
    }
}

/// The decoded sphere contains the true one and the decoded cone the true cone (where the true
/// one bounds anything).
fn assert_contains(info: &PatchInfo, patch: &Patch) {
    let d = (0..3)
        .map(|i| (f64::from(info.center[i]) - f64::from(patch.center[i])).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        f64::from(info.radius) >= d + f64::from(patch.radius),
        "sphere {info:?} does not contain {patch:?}"
    );
    if info.cone_cos > -1.0 {
        assert!(
            patch.cone_cos > 0.0,
            "a cone where there was none: {info:?}"
        );
        let a = info.cone_axis.map(f64::from);
        let n = patch.cone_axis.map(f64::from);
        let (la, ln) = (
            (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt(),
            (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt(),
        );
        let cos = ((a[0] * n[0] + a[1] * n[1] + a[2] * n[2]) / (la * ln)).clamp(-1.0, 1.0);
        let needed = cos.acos() + f64::from(patch.cone_cos).acos();
        assert!(
            f64::from(info.cone_cos).acos() >= needed,
            "cone {info:?} does not contain {patch:?}"
        );
    }
}

/// Encodes `patches` (one view level 0, nothing visible) with the default writer.
fn encode_patches(patches: &[Patch]) -> Vec<u8> {
    let matrix = VisibilityMatrix::new(sphere::view_count(0), patches.len() as u32);
    encode(&BakeContents {
        sampling: &params(0),
        triangle_count: patches.iter().map(|p| u64::from(p.count)).sum(),
        patches,
        visibility: &matrix,
        shells: &[],
        reach: 0.0,
    })
}

#[test]
fn patches_beyond_the_compact_grid_get_the_full_table() {
    let mut far = patches(&[1, 2, 3]);
    far[0].center = [-3.0e38, 0.0, 0.0];
    far[2].center = [3.0e38, 0.0, 0.0];
    let bytes = encode_patches(&far);
    let pvis = Pvis::parse(&bytes).unwrap();
    assert_eq!((pvis.version(), pvis.quantisation()), (3, None));
    for (p, patch) in far.iter().enumerate() {
        check_record(&pvis, p as u32, patch);
    }
}

#[test]
fn one_huge_patch_among_small_ones_keeps_radii_within_24_bits() {
    let mut mixed = patches(&[1; 200]);
    for (i, p) in mixed.iter_mut().enumerate() {
        p.radius = 1e-3;
        p.center = [i as f32 * 1e-3, 0.0, 0.0];
    }
    mixed[7].radius = 1e9;
    let bytes = encode_patches(&mixed);
    let pvis = Pvis::parse(&bytes).unwrap();
    let q = pvis.quantisation().expect("compact");
    assert!(q.radius_bits <= 24 && q.center_bits <= 24, "{q:?}");
    for (p, patch) in mixed.iter().enumerate() {
        check_record(&pvis, p as u32, patch);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Compact tables of random patches: every decoded sphere and cone contains the true one,
    /// and the file reads back its ranges.
    #[test]
    fn compact_tables_are_conservative(
        raw in proptest::collection::vec(
            (1u32..5000, [-1e4f32..1e4, -1e4f32..1e4, -1e4f32..1e4], 0f32..500.0,
             [-1f32..1.0, -1f32..1.0, -1f32..1.0], -1f32..1.0),
            1..200,
        ),
        scale in prop_oneof![Just(1e-3f32), Just(1.0f32), Just(1e3f32)],
    ) {
        let mut first = 0;
        let patches: Vec<Patch> = raw
            .iter()
            .map(|&(count, c, r, axis, cos)| {
                let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
                let patch = Patch {
                    first,
                    count,
                    area: 1.0,
                    center: c.map(|v| v * scale),
                    radius: r * scale,
                    cone_axis: if len > 1e-3 { axis.map(|v| v / len) } else { [0.0; 3] },
                    cone_cos: if len > 1e-3 { cos } else { -1.0 },
                };
                first += count;
                patch
            })
            .collect();
        let triangle_count = u64::from(first);
        let matrix = VisibilityMatrix::new(sphere::view_count(0), patches.len() as u32);
        let params = params(0);
        let contents = BakeContents {
            sampling: &params,
            triangle_count,
            patches: &patches,
            visibility: &matrix,
            shells: &[],
            reach: 0.0,
        };
        let bytes = encode(&contents);
        let pvis = Pvis::parse(&bytes).expect("the writer's output parses");
        prop_assert!(pvis.quantisation().is_some());
        for (p, patch) in patches.iter().enumerate() {
            check_record(&pvis, p as u32, patch);
        }
    }
}

/// The three query modes agree with each other and with the OR of the matrix rows of the
/// leaf `sphere::locate` finds, for seeded directions, a far eye, the centre and a NaN eye.
fn check_queries(pvis: &Pvis<'_>, matrix: &VisibilityMatrix, seed: u64) {
    let mut scratch = vec![0u64; pvis.scratch_words()];
    let mut stream_scratch = vec![0u64; pvis.scratch_bound()];
    let mut table = vec![0u64; pvis.expanded_bound()];
    let mut streaming = pvis.streaming(&mut stream_scratch);
    let mut expanded = pvis.expand(&mut table);
    for v in 0..matrix.views() {
        assert_eq!(expanded.row(v), matrix.row(v), "expanded row {v}");
    }
    let s = pvis.sampling();
    let mut rng = Rng::new(seed);
    let mut next = || rng.signed();
    let mut eyes: Vec<[f32; 3]> = (0..40)
        .map(|_| {
            let d = [next(), next(), next()];
            [0, 1, 2].map(|i| s.center[i] + d[i] * 3.0 * s.distance)
        })
        .collect();
    // A slow orbit: mostly stays in a leaf, sometimes moves to a neighbour.
    eyes.extend((0..60).map(|i| {
        let t = i as f32 * 0.01;
        [
            s.center[0] + 4.0 * t.cos(),
            s.center[1] + 0.3,
            s.center[2] + 4.0 * t.sin(),
        ]
    }));
    eyes.extend([s.center, [f32::NAN, 0.0, 0.0], [1.0, 2.0, 3.0]]);
    for eye in eyes {
        let d = [0, 1, 2].map(|i| eye[i] - s.center[i]);
        let stateless = pvis.query(eye, &mut scratch);
        let (bits, leaf) = (stateless.bits().to_vec(), stateless.leaf);
        if d.iter().all(|x| x.is_finite()) {
            let face = sphere::locate(d, s.level);
            assert_eq!(leaf, face.views);
            let expected: Vec<u64> = (0..pvis.row_words())
                .map(|w| {
                    face.views
                        .iter()
                        .map(|&v| matrix.row(v)[w])
                        .fold(0, |a, b| a | b)
                })
                .collect();
            assert_eq!(bits, expected, "eye {eye:?}");
        }
        let a = streaming.query(eye);
        assert_eq!(
            (a.bits(), a.leaf),
            (&bits[..], leaf),
            "streaming, eye {eye:?}"
        );
        let b = expanded.query(eye);
        assert_eq!(
            (b.bits(), b.leaf),
            (&bits[..], leaf),
            "expanded, eye {eye:?}"
        );
    }
}

/// The version field of a file.
fn pvis_version(bytes: &[u8]) -> u32 {
    u32::from_le_bytes(bytes[8..12].try_into().unwrap())
}

#[test]
fn layout_of_a_small_file() {
    let mut matrix = VisibilityMatrix::new(6, 3);
    matrix.set(0, 2);
    matrix.set(5, 0);
    let bytes = round_trip_as(
        0,
        &[2, 1, 4],
        &matrix,
        VisibilityEncoding::Tree,
        PatchTableLayout::Full,
    );
    // Header 32 + table 72 = 104; CAMR 104..148; PTCH 152..288; VISB 288..314; CRC 314..318.
    assert_eq!(bytes.len(), 318);
    assert_eq!(&bytes[..8], b"PVIS\r\n\x1a\n");
    assert_eq!(&bytes[32..36], b"CAMR");
    assert_eq!(bytes[40], 104);
    assert_eq!(&bytes[32 + 24 + 8..32 + 24 + 9], [152]);
    assert_eq!(&bytes[32 + 48 + 8..32 + 48 + 10], 288u16.to_le_bytes());
    assert_eq!(bytes[148..152], [0; 4], "alignment padding");
    assert_eq!(bytes[8], 3, "version 3");
    // VISB: encoding 2, reserved, a one-node tree: a leaf with P(0) = 16/18 (2 of the 18 bits
    // are set) = 3641/4096; one checkpoint; then the records.
    assert_eq!(bytes[288..300], [2, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0]);
    assert_eq!(u16::from_le_bytes([bytes[300], bytes[301]]), 0x8000 | 3641);
    assert_eq!(bytes[302..306], [0; 4], "checkpoint of view 0");
    // Views 1–4 see nothing: zeros code to an empty code. Views 0 and 5 each need one byte;
    // so records are 6 length bytes and 2 code bytes.
    let records = &bytes[306..314];
    assert_eq!(records[0], 1);
    assert_eq!(records[2..6], [0, 0, 0, 0]);
    assert_eq!(records[6], 1);
}

#[test]
fn layout_of_a_small_compact_table() {
    let matrix = VisibilityMatrix::new(6, 3);
    let bytes = round_trip(0, &[2, 1, 4], &matrix);
    assert_eq!(pvis_version(&bytes), 4);
    // PTCH at 152: count, reserved, triangles, origin, step, widths, reserved, one block start.
    assert_eq!(&bytes[32 + 24..32 + 28], b"PTCH");
    let ptch = &bytes[152..];
    assert_eq!(ptch[..16], [3, 0, 0, 0, 0, 0, 0, 0, 7, 0, 0, 0, 0, 0, 0, 0]);
    // Centres (0, 0, 0.5), (1, −1, 0.5), (2, −2, 0.5): the grid starts at their minimum.
    assert_eq!(f32::from_le_bytes(ptch[16..20].try_into().unwrap()), 0.0);
    assert_eq!(f32::from_le_bytes(ptch[20..24].try_into().unwrap()), -2.0);
    assert_eq!(f32::from_le_bytes(ptch[24..28].try_into().unwrap()), 0.5);
    let (count_bits, axis_bits, cos_bits) = (ptch[32], ptch[35], ptch[36]);
    assert_eq!(
        (count_bits, axis_bits, cos_bits),
        (2, 7, 6),
        "counts up to 4: 2 bits"
    );
    assert_eq!(ptch[37..40], [0; 3]);
    assert_eq!(ptch[40..44], [0; 4], "patch 0 starts at triangle 0");
    let record_bits: usize = [ptch[32], 3 * ptch[33], ptch[34], 2 * ptch[35], ptch[36]]
        .iter()
        .map(|&b| b as usize)
        .sum();
    let ptch_len = u64::from_le_bytes(bytes[32 + 24 + 16..32 + 24 + 24].try_into().unwrap());
    assert_eq!(ptch_len as usize, 44 + (3 * record_bits).div_ceil(8));
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
        shells: &[],
        reach: 0.0,
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
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn random_contents_round_trip(
        level in 0u32..=3,
        counts in proptest::sample::select(vec![1usize, 2, 63, 64, 65, 130])
            .prop_flat_map(|n| proptest::collection::vec(1u32..5, n)),
        seed in any::<u64>(),
        encoding in proptest::sample::select(vec![
            VisibilityEncoding::Raw,
            VisibilityEncoding::Table,
            VisibilityEncoding::Tree,
        ]),
    ) {
        let views = sphere::view_count(level);
        let mut matrix = VisibilityMatrix::new(views, counts.len() as u32);
        let mut rng = Rng::new(seed);
        for v in 0..views {
            for p in 0..counts.len() as u32 {
                let state = rng.next_u64();
                // Correlated with the view's parents, like real visibility, so the coder's
                // contexts are exercised in every state.
                let parent_sees = sphere::parents(v).is_some_and(|[a, _]| matrix.get(a, p));
                if state % 7 < if parent_sees { 6 } else { 2 } {
                    matrix.set(v, p);
                }
            }
        }
        round_trip_with(level, &counts, &matrix, encoding);
    }
}

/// A level-1 file with `encoding` and a correlated matrix.
fn coded_file(encoding: VisibilityEncoding) -> Vec<u8> {
    let mut matrix = VisibilityMatrix::new(18, 70);
    for v in 0..18 {
        for p in 0..70 {
            if (p * 7 + v * 3) % 11 < 5 {
                matrix.set(v, p);
            }
        }
    }
    round_trip_with(1, &[1; 70], &matrix, encoding)
}

#[test]
fn every_truncated_prefix_trailing_byte_and_bit_flip_of_a_coded_file_is_refused() {
    for encoding in [VisibilityEncoding::Table, VisibilityEncoding::Tree] {
        every_change_is_refused(coded_file(encoding));
    }
}

fn every_change_is_refused(bytes: Vec<u8>) {
    for len in 0..bytes.len() {
        assert!(Pvis::parse(&bytes[..len]).is_err(), "prefix of {len} bytes");
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(Pvis::parse(&longer).is_err());
    let mut flipped = bytes.clone();
    for i in 0..bytes.len() * 8 {
        flipped[i / 8] ^= 1 << (i % 8);
        assert!(Pvis::parse(&flipped).is_err(), "bit {i} flipped");
        flipped[i / 8] ^= 1 << (i % 8);
    }
}

/// Re-stamps the CRC so a structural mutation reaches the VISB checks.
fn with_crc(mut bytes: Vec<u8>) -> Vec<u8> {
    let n = bytes.len() - 4;
    let crc = crc32c(&bytes[..n]);
    bytes[n..].copy_from_slice(&crc.to_le_bytes());
    bytes
}

#[test]
fn coded_visb_structure_errors() {
    let bytes = coded_file(VisibilityEncoding::Table);
    let visb = u64::from_le_bytes(bytes[32 + 48 + 8..32 + 48 + 16].try_into().unwrap()) as usize;
    // A zero probability would collapse the range.
    let mut zero_prob = bytes.clone();
    zero_prob[visb + 8..visb + 10].copy_from_slice(&0u16.to_le_bytes());
    assert!(matches!(
        Pvis::parse(&with_crc(zero_prob)),
        Err(crate::runtime::Error::Invalid { what, .. }) if what.text().contains("probability")
    ));
    // A wrong checkpoint.
    let checkpoint = visb + 8 + 2 * 64;
    let mut bad_checkpoint = bytes.clone();
    bad_checkpoint[checkpoint] = 1;
    assert!(matches!(
        Pvis::parse(&with_crc(bad_checkpoint)),
        Err(crate::runtime::Error::Invalid { what, .. }) if what.text().contains("checkpoint")
    ));
    // Encoding 1 in a version-1 file.
    let mut v1 = bytes.clone();
    v1[8] = 1;
    assert_eq!(
        Pvis::parse(&with_crc(v1)).unwrap_err(),
        crate::runtime::Error::UnsupportedEncoding {
            tag: *b"VISB",
            found: 1
        }
    );
}

#[test]
fn version_1_files_with_raw_rows_still_parse() {
    let mut matrix = VisibilityMatrix::new(6, 3);
    matrix.set(0, 2);
    let v2 = round_trip_as(
        0,
        &[2, 1, 4],
        &matrix,
        VisibilityEncoding::Tree,
        PatchTableLayout::Full,
    );
    // Swap VISB for encoding 0 by hand: same layout, raw rows, version 1.
    let raw = encode_raw(&matrix);
    let visb = u64::from_le_bytes(v2[32 + 48 + 8..32 + 48 + 16].try_into().unwrap()) as usize;
    let mut v1 = v2[..visb].to_vec();
    v1[8] = 1;
    v1[32 + 48 + 16..32 + 48 + 24].copy_from_slice(&(raw.len() as u64).to_le_bytes());
    v1.extend_from_slice(&raw);
    let len = v1.len() as u64 + 4;
    v1[16..24].copy_from_slice(&len.to_le_bytes());
    v1.extend_from_slice(&[0; 4]);
    let v1 = with_crc(v1);
    let pvis = Pvis::parse(&v1).unwrap();
    assert_eq!((pvis.version(), pvis.encoding()), (1, ENCODING_RAW));
    check_queries(&pvis, &matrix, 7);
}

/// Replaces the VISB section (the last one) of `file` with `body` and fixes the lengths and CRC.
fn with_visb(file: &[u8], body: &[u8]) -> Vec<u8> {
    let visb = u64::from_le_bytes(file[32 + 48 + 8..32 + 48 + 16].try_into().unwrap()) as usize;
    let mut out = file[..visb].to_vec();
    out[32 + 48 + 16..32 + 48 + 24].copy_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(body);
    let len = out.len() as u64 + 4;
    out[16..24].copy_from_slice(&len.to_le_bytes());
    out.extend_from_slice(&[0; 4]);
    with_crc(out)
}

/// An encoding-2 VISB body for 18 views whose tree is a chain `depth` internal nodes deep
/// (node `2i` tests feature `i % 23` and leads to `2i + 1`, a leaf, or `2i + 2`) and whose
/// codes are all empty.
fn chain_tree_visb(depth: u16) -> Vec<u8> {
    let mut body = Vec::new();
    body.extend_from_slice(&ENCODING_TREE.to_le_bytes());
    body.extend_from_slice(&0u32.to_le_bytes());
    body.extend_from_slice(&(2 * depth as u32 + 1).to_le_bytes());
    for i in 0..depth {
        body.extend_from_slice(&((i % 23) << 10 | (2 * i + 1)).to_le_bytes());
        body.extend_from_slice(&(0x8000u16 | 4000).to_le_bytes());
    }
    body.extend_from_slice(&(0x8000u16 | 4000).to_le_bytes());
    body.extend_from_slice(&0u32.to_le_bytes());
    body.extend_from_slice(&[0; 18]);
    body
}

#[test]
fn tree_depth_is_limited_and_deep_trees_decode() {
    use crate::runtime::model::MAX_TREE_DEPTH;
    let file = coded_file(VisibilityEncoding::Tree);
    // Children at 2i + 1 (a leaf) and 2i + 2 (the next internal node).
    let ok = with_visb(&file, &chain_tree_visb(MAX_TREE_DEPTH as u16));
    let pvis = Pvis::parse(&ok).expect("a tree exactly MAX_TREE_DEPTH deep is valid");
    let mut row = vec![!0u64; pvis.row_words()];
    pvis.view_row(17, &mut row);
    assert!(row.iter().all(|&w| w == 0), "empty codes decode to zeros");
    let deep = with_visb(&file, &chain_tree_visb(MAX_TREE_DEPTH as u16 + 1));
    assert!(matches!(
        Pvis::parse(&deep),
        Err(crate::runtime::Error::LimitExceeded { what, .. }) if what.text().contains("depth")
    ));
}

/// Encoding 2 shrinks real-looking rows below encoding 1: views see the patches facing them.
#[test]
fn tree_coding_beats_the_table_on_structured_rows() {
    let level = 3;
    let views = sphere::view_count(level);
    let counts = vec![1u32; 400];
    let patches = patches(&counts);
    let mut matrix = VisibilityMatrix::new(views, 400);
    for v in 0..views {
        let d = sphere::direction(v);
        for p in 0..400u32 {
            let t = p as f32 * 0.7;
            let axis = [
                t.cos() * 0.8,
                t.sin() * 0.8,
                0.6 * if p % 2 == 0 { 1.0 } else { -1.0 },
            ];
            let _ = &patches;
            if axis[0] * d[0] + axis[1] * d[1] + axis[2] * d[2] > -0.1 {
                matrix.set(v, p);
            }
        }
    }
    let table = round_trip_with(level, &counts, &matrix, VisibilityEncoding::Table);
    let tree = round_trip_with(level, &counts, &matrix, VisibilityEncoding::Tree);
    assert!(
        tree.len() < table.len(),
        "tree {} B, table {} B",
        tree.len(),
        table.len()
    );
}

/// Contents with the given shells (distance, matrix) over `patches(counts)` at level 1.
fn encode_shells(
    counts: &[u32],
    matrix: &VisibilityMatrix,
    shells: &[ShellRows],
    encoding: VisibilityEncoding,
) -> Vec<u8> {
    let list = patches(counts);
    let contents = BakeContents {
        sampling: &params(1),
        triangle_count: list.iter().map(|p| u64::from(p.count)).sum(),
        patches: &list,
        visibility: matrix,
        shells,
        reach: 0.0,
    };
    encode_with(&contents, encoding)
}

/// Shells give version 5 with a SHEL section whose records and payloads read back as written,
/// in every encoding, deterministically; no shells give version 4's bytes, without SHEL.
#[test]
fn shells_are_written_to_shel_in_version_5() {
    let mut rng = Rng::new(22);
    let counts = [2u32; 70];
    let random = |views: u32, rng: &mut Rng| {
        let mut m = VisibilityMatrix::new(views, 70);
        for v in 0..views {
            for p in 0..70 {
                if rng.next_u64().is_multiple_of(3) {
                    m.set(v, p);
                }
            }
        }
        m
    };
    let main = random(18, &mut rng);
    let (near, nearer) = (random(66, &mut rng), random(6, &mut rng));
    let distance = params(1).distance();
    let shells = [
        ShellRows {
            distance: distance * 0.8,
            visibility: &near,
        },
        ShellRows {
            distance: 3.6,
            visibility: &nearer,
        },
    ];
    let plain = encode_shells(&counts, &main, &[], VisibilityEncoding::Tree);
    assert_eq!(pvis_version(&plain), 4);
    assert!(!plain.windows(4).any(|w| w == TAG_SHEL));
    for encoding in [
        VisibilityEncoding::Raw,
        VisibilityEncoding::Table,
        VisibilityEncoding::Tree,
    ] {
        let bytes = encode_shells(&counts, &main, &shells, encoding);
        assert_eq!(bytes, encode_shells(&counts, &main, &shells, encoding));
        let pvis = Pvis::parse(&bytes).unwrap();
        assert_eq!((pvis.version(), pvis.shell_count()), (5, 2));
        // Version 5 has the compact table whatever the encoding.
        assert!(pvis.quantisation().is_some());
        let mut row = vec![0u64; pvis.row_words()];
        for (k, (shell, level)) in shells.iter().zip([2, 0]).enumerate() {
            let s = pvis.shell(k as u32 + 1);
            assert_eq!((s.distance, s.level), (shell.distance, level));
            for v in 0..s.views {
                pvis.shell_view_row(k as u32 + 1, v, &mut row);
                assert_eq!(
                    &row[..],
                    shell.visibility.row(v),
                    "{encoding:?} shell {k} view {v}"
                );
            }
        }
        // With the same table and encoding, the file is the version-4 one plus the SHEL
        // section and its table entry (alignment gaps aside).
        if encoding == VisibilityEncoding::Tree {
            assert_eq!(
                pvis.total_bytes() - padding(&bytes),
                plain.len() as u64 - padding(&plain) + 24 + pvis.shells_bytes()
            );
        }
    }
}

/// Zero bytes between the sections of a file (alignment gaps).
fn padding(bytes: &[u8]) -> u64 {
    let count = u32::from_le_bytes(bytes[24..28].try_into().unwrap()) as usize;
    let mut end = 32 + 24 * count as u64;
    let mut gaps = 0;
    for i in 0..count {
        let entry = 32 + 24 * i;
        let offset = u64::from_le_bytes(bytes[entry + 8..entry + 16].try_into().unwrap());
        let length = u64::from_le_bytes(bytes[entry + 16..entry + 24].try_into().unwrap());
        gaps += offset - end;
        end = offset + length;
    }
    gaps
}
