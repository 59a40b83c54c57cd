//! Fuzz target: arbitrary bytes → `Pvis::parse` → if accepted, every accessor, every view's
//! row of every shell and queries from fixed and fuzzed eye positions in all three modes
//! (stateless, streaming, expanded; the latter two must agree with the first), checked against
//! the reader's own promises (spec § Query: the answer is the OR of the leaf rows of the one or
//! two shells of the eye's band; ranges are contiguous; padding bits are zero). Any panic or failed check is a reader bug.
//!
//! Input: the first `EYE_BYTES` bytes are two eye positions (six little-endian `f32`), the
//! rest is the file. Each file is tried twice: as given, and with `file_length` and the CRC
//! repaired, so that mutations get past the checksum to the structural checks.
#![no_main]

use libfuzzer_sys::fuzz_target;
use patchvis::runtime::Pvis;
use patchvis::runtime::consts::TRAILER_LEN;
use patchvis::runtime::crc32c::crc32c;

/// Two fuzzed eye positions precede the file.
const EYE_BYTES: usize = 24;

/// Fixed eyes: far along the axes and a diagonal, at the origin, and non-finite.
const FIXED_EYES: [[f32; 3]; 6] = [
    [1e4, 0.0, 0.0],
    [0.0, -1e4, 0.0],
    [-3.0, 5.0, -7.0],
    [0.0, 0.0, 0.0],
    [f32::NAN, 1.0, 1.0],
    [f32::NEG_INFINITY, 0.0, 0.0],
];

fuzz_target!(|data: &[u8]| {
    let (eye_bytes, file) = data.split_at(data.len().min(EYE_BYTES));
    let mut eyes = FIXED_EYES.to_vec();
    for chunk in eye_bytes.chunks_exact(12) {
        let f = |i: usize| f32::from_le_bytes(chunk[i..i + 4].try_into().unwrap());
        eyes.push([f(0), f(4), f(8)]);
    }
    exercise(file, &eyes);
    if file.len() >= 24 + TRAILER_LEN as usize {
        let mut repaired = file.to_vec();
        let n = repaired.len();
        repaired[16..24].copy_from_slice(&(n as u64).to_le_bytes());
        let crc = crc32c(&repaired[..n - 4]);
        repaired[n - 4..].copy_from_slice(&crc.to_le_bytes());
        exercise(&repaired, &eyes);
    }
});

fn exercise(file: &[u8], eyes: &[[f32; 3]]) {
    let Ok(pvis) = Pvis::parse(file) else {
        return;
    };
    let sampling = pvis.sampling();
    let patches = pvis.patch_count();
    assert!(patches >= 1);
    assert_eq!(pvis.total_bytes(), file.len() as u64);
    let _ = pvis.version();

    // Triangle ranges contiguous from 0, summing to triangle_count (spec § PTCH).
    let mut next = 0u64;
    for p in 0..patches {
        let info = pvis.patch(p);
        assert_eq!(u64::from(info.first_triangle), next);
        assert!(info.triangle_count >= 1);
        next += u64::from(info.triangle_count);
    }
    assert_eq!(next, pvis.triangle_count());

    // Every row decodes with its padding bits zero.
    let words = pvis.row_words();
    let tail_mask = if patches % 64 == 0 {
        0
    } else {
        !0u64 << (patches % 64)
    };
    // Every shell's rows (0..=K by decreasing distance, the sampling sphere among them).
    let shells: Vec<Vec<u64>> = (0..=pvis.shell_count())
        .map(|s| {
            let mut rows = vec![0u64; words * pvis.shell(s).views as usize];
            for (view, row) in rows.chunks_exact_mut(words).enumerate() {
                pvis.shell_view_row(s, view as u32, row);
                assert_eq!(row[words - 1] & tail_mask, 0, "shell {s} view {view}: padding");
            }
            rows
        })
        .collect();

    let mut scratch = vec![0u64; pvis.scratch_words()];
    for &eye in eyes {
        let visible = pvis.query(eye, &mut scratch);
        let finite = (0..3).all(|i| (eye[i] - sampling.center[i]).is_finite());
        for (w, &bits) in visible.bits().iter().enumerate() {
            // The OR of the leaf rows of the one or two answering shells (spec § Query).
            let or = |s: u32, leaf: [u32; 3]| {
                leaf.iter()
                    .fold(0, |acc, &v| acc | shells[s as usize][v as usize * words + w])
            };
            let expected = if finite {
                or(visible.shells[0], visible.leaf) | or(visible.shells[1], visible.inner_leaf)
            } else {
                !0 & !(if w == words - 1 { tail_mask } else { 0 })
            };
            assert_eq!(bits, expected, "eye {eye:?}, word {w}");
        }
        let listed: Vec<u32> = visible.patches().collect();
        assert_eq!(listed.len() as u32, visible.count());
        assert!(listed.windows(2).all(|w| w[0] < w[1]));
        assert!(listed.iter().all(|&p| p < patches && visible.contains(p)));
        let triangles: u64 = listed
            .iter()
            .map(|&p| u64::from(pvis.patch(p).triangle_count))
            .sum();
        let ranged: u64 = pvis.ranges(&visible).map(|(_, c)| u64::from(c)).sum();
        assert_eq!(triangles, ranged);
    }

    // The streaming and expanded modes give the stateless answer for every eye. The table
    // starts as all ones: `expand` must not depend on what it held.
    let mut stream_scratch = vec![0u64; pvis.scratch_bound()];
    let mut table = vec![!0u64; pvis.expanded_bound()];
    let mut streaming = pvis.streaming(&mut stream_scratch);
    let mut expanded = pvis.expand(&mut table);
    for &eye in eyes.iter().chain(eyes) {
        let expected = pvis.query(eye, &mut scratch);
        assert_eq!(streaming.query(eye), expected, "streaming, eye {eye:?}");
        assert_eq!(expanded.query(eye), expected, "expanded, eye {eye:?}");
    }
}
