//! Reader tests on files assembled here from the spec's numbers (not from `consts` or the
//! writer), so a drift between the spec and either side shows up as a failure.

extern crate std;

use std::vec;
use std::vec::Vec;

use super::*;
use crate::test_kit::rng::Rng;
use proptest::prelude::*;

/// Lays out a file: header, table, each section 8-aligned in the given order, CRC trailer.
fn assemble(sections: &[([u8; 4], Vec<u8>)]) -> Vec<u8> {
    let table_end = 32 + 24 * sections.len();
    let mut offsets = Vec::new();
    let mut end = table_end;
    for (_, body) in sections {
        let offset = end.div_ceil(8) * 8;
        offsets.push(offset);
        end = offset + body.len();
    }
    let mut out = Vec::new();
    out.extend_from_slice(b"PVIS\r\n\x1a\n");
    out.extend_from_slice(&1u32.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&(end as u64 + 4).to_le_bytes());
    out.extend_from_slice(&(sections.len() as u32).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    for ((tag, body), offset) in sections.iter().zip(&offsets) {
        out.extend_from_slice(tag);
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&(*offset as u64).to_le_bytes());
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    }
    for ((_, body), offset) in sections.iter().zip(&offsets) {
        out.resize(*offset, 0);
        out.extend_from_slice(body);
    }
    out.extend_from_slice(&[0; 4]);
    fix_crc(&mut out);
    out
}

/// Recomputes the trailer after a deliberate mutation, so the structural check is reached.
fn fix_crc(file: &mut [u8]) {
    let n = file.len();
    let crc = crc32c::crc32c(&file[..n - 4]);
    file[n - 4..].copy_from_slice(&crc.to_le_bytes());
}

fn le32(v: u32) -> [u8; 4] {
    v.to_le_bytes()
}

/// CAMR for `level` with a unit sphere at (1, 2, 3), fov 60° (distance 2).
fn camr(level: u32) -> Vec<u8> {
    let views = 4 * 4u32.pow(level) + 2;
    let mut out = Vec::new();
    for v in [level, views] {
        out.extend_from_slice(&le32(v));
    }
    for f in [1.0f32, 2.0, 3.0, 1.0, 2.0, 60.0] {
        out.extend_from_slice(&f.to_le_bytes());
    }
    for v in [256, 1, 0] {
        out.extend_from_slice(&le32(v));
    }
    out
}

/// PTCH with one patch per entry of `counts`, ranges contiguous from 0.
fn ptch(counts: &[u32]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&le32(counts.len() as u32));
    out.extend_from_slice(&le32(0));
    out.extend_from_slice(&(counts.iter().map(|&c| c as u64).sum::<u64>()).to_le_bytes());
    let mut first = 0;
    for (i, &count) in counts.iter().enumerate() {
        out.extend_from_slice(&le32(first));
        out.extend_from_slice(&le32(count));
        for f in [i as f32, 0.5, -0.5, 0.25, 0.0, 1.0, 0.0, 0.5] {
            out.extend_from_slice(&f.to_le_bytes());
        }
        first += count;
    }
    out
}

/// VISB with `views` rows over `patches` patches; view v sees patches p with (p + v) % 3 == 0.
fn visb(views: u32, patches: u32) -> Vec<u8> {
    visb_where(views, patches, |v, p| (p + v) % 3 == 0)
}

/// VISB where view v sees patch p iff `sees(v, p)`.
fn visb_where(views: u32, patches: u32, sees: impl Fn(u32, u32) -> bool) -> Vec<u8> {
    let row_bytes = patches.div_ceil(8) as usize;
    let mut out = vec![0u8; 8 + views as usize * row_bytes];
    for v in 0..views {
        for p in 0..patches {
            if sees(v, p) {
                out[8 + v as usize * row_bytes + p as usize / 8] |= 1 << (p % 8);
            }
        }
    }
    out
}

const COUNTS: [u32; 10] = [3, 1, 4, 1, 5, 9, 2, 6, 5, 3];

/// A valid level-1 file (18 views) with 10 patches: rows of 2 bytes, 6 padding bits each.
fn valid() -> Vec<u8> {
    assemble(&[
        (*b"CAMR", camr(1)),
        (*b"PTCH", ptch(&COUNTS)),
        (*b"VISB", visb(18, 10)),
    ])
}

/// Offset of the first byte of section `i`'s body, from the table.
fn section_offset(file: &[u8], i: usize) -> usize {
    let at = 32 + 24 * i + 8;
    u64::from_le_bytes(file[at..at + 8].try_into().unwrap()) as usize
}

#[test]
fn parses_a_valid_file() {
    let file = valid();
    let pvis = Pvis::parse(&file).unwrap();
    assert_eq!(pvis.version(), 1);
    assert_eq!(
        pvis.sampling(),
        Sampling {
            level: 1,
            views: 18,
            center: [1.0, 2.0, 3.0],
            radius: 1.0,
            distance: 2.0,
            fov_deg: 60.0,
            resolution: 256,
        }
    );
    assert_eq!(pvis.patch_count(), 10);
    assert_eq!(pvis.triangle_count(), 39);
    assert_eq!(pvis.total_bytes(), file.len() as u64);
    assert_eq!(pvis.visibility_bytes(), 8 + 18 * 2);
    assert_eq!(pvis.row_words(), 1);
    assert_eq!(
        pvis.patch(2),
        PatchInfo {
            first_triangle: 4,
            triangle_count: 4,
            center: [2.0, 0.5, -0.5],
            radius: 0.25,
            cone_axis: [0.0, 1.0, 0.0],
            cone_cos: 0.5,
        }
    );
    let mut row = [0u64; 1];
    pvis.view_row(1, &mut row);
    assert_eq!(row[0], 0b01_0010_0100, "patches 2, 5, 8");
}

#[test]
fn unknown_sections_are_ignored() {
    let file = assemble(&[
        (*b"XTRA", vec![7; 13]),
        (*b"CAMR", camr(0)),
        (*b"PTCH", ptch(&[1])),
        (*b"zzzz", vec![]),
        (*b"VISB", visb(6, 1)),
    ]);
    let pvis = Pvis::parse(&file).unwrap();
    assert_eq!(pvis.sampling().views, 6);
    assert_eq!(pvis.patch_count(), 1);
}

#[test]
fn every_truncated_prefix_and_a_trailing_byte_are_refused() {
    let file = valid();
    for n in 0..file.len() {
        assert!(Pvis::parse(&file[..n]).is_err(), "prefix of {n} bytes");
    }
    let mut longer = file.clone();
    longer.push(0);
    assert_eq!(
        Pvis::parse(&longer).unwrap_err(),
        Error::LengthMismatch {
            header: file.len() as u64,
            actual: file.len() as u64 + 1
        }
    );
    assert_eq!(
        Pvis::parse(&file[..20]).unwrap_err(),
        Error::Truncated {
            needed: 36,
            have: 20
        }
    );
}

#[test]
fn every_single_byte_flip_is_refused() {
    let file = valid();
    for i in 0..file.len() {
        for bit in 0..8 {
            let mut bad = file.clone();
            bad[i] ^= 1 << bit;
            assert!(Pvis::parse(&bad).is_err(), "byte {i} bit {bit}");
        }
    }
}

/// The error `file` gives after `mutate` and a CRC fix-up.
fn error_after(mutate: impl FnOnce(&mut Vec<u8>)) -> Error {
    let mut file = valid();
    mutate(&mut file);
    fix_crc(&mut file);
    Pvis::parse(&file).unwrap_err()
}

#[test]
fn header_errors() {
    assert_eq!(error_after(|f| f[0] = b'X'), Error::BadMagic);
    assert_eq!(Pvis::parse(b"PVIX").unwrap_err(), Error::BadMagic);
    // The first version past this reader's.
    let next = consts::VERSION + 1;
    assert_eq!(
        error_after(|f| f[8] = next as u8),
        Error::UnsupportedVersion { found: next }
    );
    assert_eq!(
        error_after(|f| f[8] = 0),
        Error::UnsupportedVersion { found: 0 }
    );
    assert_eq!(
        error_after(|f| f[13] = 1),
        Error::UnknownFlags { flags: 0x100 }
    );
    let len = valid().len() as u64;
    assert_eq!(
        error_after(|f| f[16] ^= 8),
        Error::LengthMismatch {
            header: len ^ 8,
            actual: len
        }
    );
    assert_eq!(
        error_after(|f| f[24] = 17),
        Error::LimitExceeded {
            what: Rule::SectionCount,
            value: 17,
            limit: 16
        }
    );
}

#[test]
fn checksum_mismatch() {
    let mut file = valid();
    let n = file.len();
    let computed = crc32c::crc32c(&file[..n - 4]);
    file[n - 1] ^= 0x80;
    assert_eq!(
        Pvis::parse(&file).unwrap_err(),
        Error::ChecksumMismatch {
            stored: computed ^ 0x8000_0000,
            computed
        }
    );
}

#[test]
fn section_table_errors() {
    let missing = assemble(&[(*b"CAMR", camr(1)), (*b"VISB", visb(18, 10))]);
    assert_eq!(
        Pvis::parse(&missing).unwrap_err(),
        Error::MissingSection { tag: *b"PTCH" }
    );
    let duplicate = assemble(&[
        (*b"CAMR", camr(1)),
        (*b"PTCH", ptch(&COUNTS)),
        (*b"CAMR", camr(1)),
        (*b"VISB", visb(18, 10)),
    ]);
    assert_eq!(
        Pvis::parse(&duplicate).unwrap_err(),
        Error::DuplicateSection { tag: *b"CAMR" }
    );
    // PTCH (entry 1) moved back onto CAMR: overlap.
    let camr_at = section_offset(&valid(), 0) as u64;
    let ptch_len = 16 + 40 * 10;
    assert_eq!(
        error_after(|f| f[32 + 24 + 8..32 + 24 + 16].copy_from_slice(&(camr_at + 8).to_le_bytes())),
        Error::SectionOutOfBounds {
            tag: *b"PTCH",
            offset: camr_at + 8,
            length: ptch_len,
            start: camr_at + 44,
            end: valid().len() as u64 - 4,
        }
    );
    assert_eq!(
        error_after(|f| f[32 + 8] += 4),
        Error::SectionMisaligned {
            tag: *b"CAMR",
            offset: camr_at + 4
        }
    );
}

#[test]
fn camr_errors() {
    let at = section_offset(&valid(), 0);
    assert_eq!(
        error_after(|f| f[at..at + 4].copy_from_slice(&le32(8))),
        Error::LimitExceeded {
            what: Rule::SphereLevel,
            value: 8,
            limit: 7
        }
    );
    assert_eq!(
        error_after(|f| f[at + 4..at + 8].copy_from_slice(&le32(66))),
        Error::ViewCountMismatch {
            level: 1,
            found: 66,
            expected: 18
        }
    );
    assert_eq!(
        error_after(|f| f[at + 20..at + 24].copy_from_slice(&f32::NAN.to_le_bytes())),
        Error::InvalidFloat {
            what: Rule::CamrRadius,
            offset: at as u64 + 20,
            bits: f32::NAN.to_bits()
        }
    );
}

#[test]
fn ptch_errors() {
    let at = section_offset(&valid(), 1);
    // Patch 3's first triangle should be 8.
    let record3 = at + 16 + 3 * 40;
    assert_eq!(
        error_after(|f| f[record3..record3 + 4].copy_from_slice(&le32(9))),
        Error::PatchRange {
            patch: 3,
            first: 9,
            count: 1,
            expected_first: 8
        }
    );
    assert_eq!(
        error_after(|f| f[at + 8] = 40),
        Error::TriangleCountMismatch {
            header: 40,
            sum: 39
        }
    );
}

#[test]
fn visb_errors() {
    let at = section_offset(&valid(), 2);
    // Row of view 4 is bytes at+8+8 .. at+8+10; bit 10 is padding.
    let last = at + 8 + 4 * 2 + 1;
    assert_eq!(
        error_after(|f| f[last] |= 1 << 2),
        Error::PaddingBits {
            tag: *b"VISB",
            view: 4,
            offset: last as u64
        }
    );
    assert_eq!(
        error_after(|f| f[at] = 1),
        Error::UnsupportedEncoding {
            tag: *b"VISB",
            found: 1
        }
    );
    let short = assemble(&[
        (*b"CAMR", camr(1)),
        (*b"PTCH", ptch(&COUNTS)),
        (*b"VISB", visb(17, 10)),
    ]);
    assert_eq!(
        Pvis::parse(&short).unwrap_err(),
        Error::SectionLength {
            tag: *b"VISB",
            length: 8 + 17 * 2,
            expected: 8 + 18 * 2
        }
    );
}

#[test]
fn errors_display_one_precise_line() {
    use core::fmt::Write;
    let mut s = std::string::String::new();
    write!(
        s,
        "{}",
        Error::Truncated {
            needed: 1234,
            have: 1000
        }
    )
    .unwrap();
    assert_eq!(s, "truncated: needed 1234 bytes, have 1000");
    s.clear();
    write!(s, "{}", Error::MissingSection { tag: *b"VISB" }).unwrap();
    assert_eq!(s, "missing section VISB");
    s.clear();
    write!(s, "{}", Error::DuplicateSection { tag: [0, 1, 2, 3] }).unwrap();
    assert_eq!(s, "section 0x00010203 appears twice");
}

/// A level-2 file (66 views, 66 patches of one triangle) where view v sees only patch v.
fn diagonal() -> Vec<u8> {
    assemble(&[
        (*b"CAMR", camr(2)),
        (*b"PTCH", ptch(&[1; 66])),
        (*b"VISB", visb_where(66, 66, |v, p| v == p)),
    ])
}

/// `center + dir · scale` for the fixture's centre (1, 2, 3).
fn eye(dir: [f32; 3], scale: f32) -> [f32; 3] {
    [
        1.0 + dir[0] * scale,
        2.0 + dir[1] * scale,
        3.0 + dir[2] * scale,
    ]
}

#[test]
fn query_from_a_sample_position_sees_its_view() {
    let file = diagonal();
    let pvis = Pvis::parse(&file).unwrap();
    let mut scratch = vec![0u64; pvis.scratch_words()];
    let distance = pvis.sampling().distance;
    for v in 0..66 {
        let vis = pvis.query(
            eye(crate::sphere::direction(v), distance * 1.5),
            &mut scratch,
        );
        assert!(!vis.inside_sphere);
        assert!(vis.leaf.contains(&v), "view {v}: leaf {:?}", vis.leaf);
        assert!(vis.contains(v));
        assert_eq!(vis.count(), 3, "the leaf's three corners");
        let mut corners = vis.leaf;
        corners.sort();
        assert!(vis.patches().eq(corners));
    }
    let vis = pvis.query([1.0, 2.0, 3.0], &mut scratch);
    assert!(vis.inside_sphere);
}

#[test]
fn query_is_the_or_of_the_leaf_rows() {
    let file = valid();
    let pvis = Pvis::parse(&file).unwrap();
    let mut scratch = [0u64; 1];
    let mut row = [0u64; 1];
    for dir in [
        [0.3, -0.2, 0.9],
        [-1.0, 0.0, 0.0],
        [0.5, 0.5, -0.1],
        [0.0, 0.0, 0.0],
    ] {
        let vis = pvis.query(eye(dir, 1.0), &mut scratch);
        let leaf = crate::sphere::locate(dir, 1).views;
        assert_eq!(vis.leaf, leaf);
        let mut expected = 0;
        for view in leaf {
            pvis.view_row(view, &mut row);
            expected |= row[0];
        }
        assert_eq!(vis.bits(), [expected]);
    }
}

#[test]
fn ranges_merge_adjacent_patches() {
    let file = valid();
    let pvis = Pvis::parse(&file).unwrap();
    let mut scratch = [0u64; 1];
    // A non-finite eye gets every patch: one range over all 39 triangles.
    let vis = pvis.query([f32::NAN, 0.0, 0.0], &mut scratch);
    assert!(vis.inside_sphere);
    assert_eq!(vis.count(), 10);
    assert!(pvis.ranges(&vis).eq([(0, 39)]));
    // Elsewhere: the merged ranges equal merging the visible patch records by hand.
    let vis = pvis.query(eye([1.0, 0.0, 0.0], 5.0), &mut scratch);
    let patches: Vec<u32> = vis.patches().collect();
    let mut expected = Vec::new();
    for p in patches {
        let info = pvis.patch(p);
        match expected.last_mut() {
            Some((first, count)) if *first + *count == info.first_triangle => {
                *count += info.triangle_count
            }
            _ => expected.push((info.first_triangle, info.triangle_count)),
        }
    }
    assert!(ranges(&pvis, &vis).eq(expected));
}

proptest! {
    #[test]
    fn queries_never_panic(x in any::<f32>(), y in any::<f32>(), z in any::<f32>()) {
        let file = diagonal();
        let pvis = Pvis::parse(&file).unwrap();
        let mut scratch = vec![0u64; pvis.scratch_words()];
        let vis = pvis.query([x, y, z], &mut scratch);
        prop_assert!(vis.count() >= 1);
        prop_assert!(vis.patches().all(|p| p < 66));
        prop_assert_eq!(pvis.ranges(&vis).map(|(_, c)| c).sum::<u32>(), vis.count());
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let _ = Pvis::parse(&bytes);
        let mut with_magic = b"PVIS\r\n\x1a\n".to_vec();
        with_magic.extend_from_slice(&bytes);
        let _ = Pvis::parse(&with_magic);
    }

    #[test]
    fn mutated_valid_files_never_panic(
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        truncate in any::<prop::sample::Index>(),
        cut in any::<bool>(),
    ) {
        let mut file = valid();
        for (at, byte) in edits {
            let i = at.index(file.len() - 4);
            file[i] = byte;
        }
        if cut {
            file.truncate(truncate.index(file.len()));
        } else {
            // Make the structural checks, not the CRC, the ones that must hold.
            fix_crc(&mut file);
        }
        if let Ok(pvis) = Pvis::parse(&file) {
            let mut row = vec![0u64; pvis.row_words()];
            for v in 0..pvis.sampling().views {
                pvis.view_row(v, &mut row);
            }
            for p in 0..pvis.patch_count() {
                let _ = pvis.patch(p);
            }
            let mut scratch = vec![0u64; pvis.scratch_words()];
            let vis = pvis.query([0.5, -7.0, 2.0], &mut scratch);
            let _ = pvis.ranges(&vis).count();
        }
    }
}

/// The expanded point location (face indices only, corners from the leaf table) finds the same
/// leaf as `sphere::locate` for seeded directions at levels 0 to 4, including directions on
/// the octant planes, and does not depend on what the table held before `expand`.
#[test]
fn expanded_leaves_are_sphere_locate() {
    let mut rng = Rng::new(0x9E37_79B9_7F4A_7C15);
    let mut next = || rng.signed();
    for level in 0..=4 {
        let views = 4 * 4u32.pow(level) + 2;
        let file = assemble(&[
            (*b"CAMR", camr(level)),
            (*b"PTCH", ptch(&[1; 7])),
            (*b"VISB", visb(views, 7)),
        ]);
        let pvis = Pvis::parse(&file).unwrap();
        let mut table = vec![!0u64; pvis.expanded_bound()];
        let mut expanded = pvis.expand(&mut table);
        let distance = pvis.sampling().distance;
        for i in 0..4000 {
            let mut dir = [next(), next(), next()];
            // Every 8th direction lies on one or two of the octant planes.
            if i % 8 == 0 {
                dir[i / 8 % 3] = 0.0;
            }
            if i % 16 == 0 {
                dir[(i / 8 + 1) % 3] = 0.0;
            }
            if dir == [0.0; 3] {
                continue;
            }
            let e = eye(dir, 2.0 * distance);
            let d = [e[0] - 1.0, e[1] - 2.0, e[2] - 3.0];
            let vis = expanded.query(e);
            assert_eq!(
                vis.leaf,
                crate::sphere::locate(d, level).views,
                "level {level}, {dir:?}"
            );
            let mut row = vec![0u64; pvis.row_words()];
            let mut expected = vec![0u64; pvis.row_words()];
            for view in vis.leaf {
                pvis.view_row(view, &mut row);
                expected.iter_mut().zip(&row).for_each(|(e, r)| *e |= r);
            }
            assert_eq!(vis.bits(), expected);
        }
    }
}
