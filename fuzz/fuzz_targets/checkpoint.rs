//! Fuzz target: the checkpoint reader of `patchvis bake --resume`. Two ways in, picked by the
//! first byte:
//!
//! - raw: the rest is a checkpoint file, read against a bake whose shape (level, patches) and
//!   input hash come from the next bytes. Reading must refuse it or accept it, never panic;
//!   a refusal tells the user what to do, and an accepted file holds whole levels with zero
//!   padding bits.
//! - damaged: a valid checkpoint written from the fuzzed rows, then one bit flipped or the
//!   file cut where the input says. The intact file must read back row for row; every damaged
//!   one must be refused (the CRC-32C catches any single flipped bit and any truncation).
//!
//! Run: `cargo fuzz run checkpoint` (nightly).

#![no_main]

use libfuzzer_sys::fuzz_target;
use patchvis::sampler::{VisibilityMatrix, decode_checkpoint, encode_checkpoint};
use patchvis::sphere::view_count;

/// Levels beyond 3 only make inputs larger; the layout does not change with the level.
const MAX_FUZZ_LEVEL: u8 = 3;
/// Enough patches to cross two 64-bit row words.
const MAX_FUZZ_PATCHES: u32 = 140;

fuzz_target!(|data: &[u8]| {
    let Some((&[mode, level, patches, hash], rest)) = data.split_first_chunk::<4>() else {
        return;
    };
    let level = u32::from(level % (MAX_FUZZ_LEVEL + 1));
    let patches = u32::from(patches) % (MAX_FUZZ_PATCHES + 1);
    let hash = u64::from(hash);
    let mut matrix = VisibilityMatrix::new(view_count(level), patches);
    if mode % 2 == 0 {
        match decode_checkpoint(rest, hash, &mut matrix) {
            Ok(levels) => {
                assert!(levels <= level + 1, "{levels} levels of a level-{level} bake");
                if patches % 64 != 0 && levels > 0 {
                    let padding = !((1u64 << (patches % 64)) - 1);
                    for v in 0..view_count(levels - 1) {
                        assert_eq!(matrix.row(v).last().unwrap() & padding, 0, "row {v}");
                    }
                }
            }
            Err(reason) => assert!(reason.contains("delete it"), "{reason}"),
        }
        return;
    }
    // A valid checkpoint of `levels` levels, its rows' bits from the input.
    let Some((&[levels, damage_at, damage_bit], bits)) = rest.split_first_chunk::<3>() else {
        return;
    };
    let levels = u32::from(levels) % (level + 2);
    let rows = if levels == 0 { 0 } else { view_count(levels - 1) };
    let mut written = VisibilityMatrix::new(view_count(level), patches);
    if patches > 0 {
        for (i, &b) in bits.iter().enumerate() {
            let (view, patch) = ((i as u32 / patches) % rows.max(1), i as u32 % patches);
            if rows > 0 && b & 1 == 1 {
                written.set(view, patch);
            }
        }
    }
    let bytes = encode_checkpoint(hash, levels, rows, &written);
    assert_eq!(decode_checkpoint(&bytes, hash, &mut matrix), Ok(levels));
    for v in 0..rows {
        assert_eq!(matrix.row(v), written.row(v), "row {v}");
    }
    let at = usize::from(damage_at) * bytes.len() / 256;
    let mut flipped = bytes.clone();
    flipped[at] ^= 1 << (damage_bit % 8);
    assert!(decode_checkpoint(&flipped, hash, &mut matrix).is_err(), "bit flipped at {at}");
    assert!(decode_checkpoint(&bytes[..at], hash, &mut matrix).is_err(), "cut at {at}");
});
