//! Fuzz target: the part-file reader of a sharded bake (`patchvis merge`). Two ways in,
//! picked by the first byte:
//!
//! - raw: the rest is a part file. Reading must refuse it or accept it, never panic; a
//!   refusal says what to do, and an accepted part writes back to the very same bytes.
//! - damaged: a valid part built from the input (its shard, level, patch count and row
//!   bits), then one bit flipped or the file cut where the input says. The intact file must
//!   read back field for field; every damaged one must be refused (the CRC-32C catches any
//!   single flipped bit and any truncation).
//! - crafted (the same input, continued): every shard's part of that bake, then the input's
//!   byte written into one of them where the input says and its CRC-32C recomputed, as a
//!   hostile user would. Reading must refuse it or accept it; the merge of an accepted one
//!   with the other shards must refuse or merge, never panic, and a merged file must parse.
//!
//! Run: `cargo fuzz run part` (nightly).

#![no_main]

use libfuzzer_sys::fuzz_target;
use patchvis::bake::{LoadedPart, Part, PassRows, Plan, Probe, Research, RowSettings, Shard, merge};
use patchvis::runtime::crc32c::crc32c;
use patchvis::sampler::{FinerViews, FoldCorners, SamplingParams};
use patchvis::tiling::Patch;

/// Levels beyond 3 only make inputs larger; the layout does not change with the level.
const MAX_FUZZ_LEVEL: u8 = 3;
/// Enough patches to cross two 64-bit row words.
const MAX_FUZZ_PATCHES: u8 = 140;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    if mode % 2 == 0 {
        match Part::decode(rest) {
            Ok(part) => assert_eq!(part.encode(), rest, "an accepted part re-encodes"),
            Err(reason) => assert!(
                reason.contains("bake this shard again") || reason.contains("give the files"),
                "{reason}"
            ),
        }
        return;
    }
    let Some((&[level, patches, count, index, threshold, damage_at, damage_bit], bits)) =
        rest.split_first_chunk::<7>()
    else {
        return;
    };
    let level = u32::from(level % (MAX_FUZZ_LEVEL + 1));
    // A part of no patches is refused, as a `.pvis` of none is.
    let patches = u32::from(patches % MAX_FUZZ_PATCHES) + 1;
    let count = u32::from(count % 8) + 1;
    let shard = Shard::new(u32::from(index) % count, count).unwrap();
    let extra_levels = u32::from(threshold >> 1 & 1);
    let settings = RowSettings {
        level: Some(level),
        resolution: 64,
        // No sampling shells: the passes below are the sampling sphere's.
        shells: 0,
        far_shells: Vec::new(),
        research: Research {
            dilate: threshold & 1 == 1,
            probe: if threshold >> 5 & 1 == 1 {
                Probe::Pixels(1)
            } else {
                Probe::Off
            },
            view_supersample: Some(extra_levels),
            fold_min_pixels: Some(u32::from(threshold >> 2 & 7)),
            fold_corners: Some(FoldCorners::All),
            finer_views: Some(if index >> 6 & 1 == 1 && extra_levels == 1 {
                FinerViews::Centroids
            } else {
                FinerViews::Midpoints
            }),
            sampled_rows: index >> 7 & 1 == 1,
            ..Research::default()
        },
        ..RowSettings::default()
    };
    let plan = Plan::new(settings.clone()).expect("the fuzzed settings plan");
    let part = |shard: Shard| shard_part(&settings, &plan, shard, level, patches, bits);
    let bytes = part(shard).encode();
    assert_eq!(Part::decode(&bytes).map(|p| p.encode()).as_ref(), Ok(&bytes));
    let at = usize::from(damage_at) * bytes.len() / 256;
    let mut flipped = bytes.clone();
    flipped[at] ^= 1 << (damage_bit % 8);
    assert!(Part::decode(&flipped).is_err(), "bit flipped at {at}");
    assert!(Part::decode(&bytes[..at]).is_err(), "cut at {at}");

    // Crafted: the byte written and the checksum made to hold again.
    let mut crafted = bytes;
    let body = crafted.len() - 4;
    crafted[at.min(body - 1)] = damage_bit;
    let crc = crc32c(&crafted[..body]);
    crafted[body..].copy_from_slice(&crc.to_le_bytes());
    let Ok(crafted) = Part::decode(&crafted) else {
        return;
    };
    let parts: Vec<LoadedPart> = (0..count)
        .map(|i| LoadedPart {
            path: format!("part-{i}").into(),
            part: if i == shard.index {
                crafted.clone()
            } else {
                part(Shard::new(i, count).unwrap())
            },
        })
        .collect();
    if let Ok(merged) = merge(&parts) {
        assert!(patchvis::runtime::Pvis::parse(&merged.bytes).is_ok());
    }
});

/// Shard `shard`'s part of a bake with `settings` (planned as `plan`) at `level`, of
/// `patches` one-triangle patches, its row bits drawn from `bits`.
fn shard_part(
    settings: &RowSettings,
    plan: &Plan,
    shard: Shard,
    level: u32,
    patches: u32,
    bits: &[u8],
) -> Part {
    let words_per_row = (patches as usize).div_ceil(64);
    let mut next_bit = bits.iter().cycle();
    let passes = plan
        .pass_levels()
        .into_iter()
        .map(|pass_level| {
            let views = shard.views(pass_level);
            let mut words = vec![0u64; views.len() * words_per_row];
            for row in words.chunks_mut(words_per_row.max(1)) {
                for p in 0..patches as usize {
                    if next_bit.next().is_some_and(|b| b & 1 == 1) {
                        row[p / 64] |= 1 << (p % 64);
                    }
                }
            }
            PassRows {
                level: pass_level,
                views,
                words,
            }
        })
        .collect();
    Part {
        mesh_hash: 7,
        tiling_hash: 9,
        shard,
        triangle_count: patches,
        settings: settings.clone(),
        params: SamplingParams {
            level,
            resolution: 64,
            fov_deg: 45.0,
            center: [0.0; 3],
            radius: 1.0,
        },
        patches: (0..patches)
            .map(|i| Patch {
                first: i,
                count: 1,
                area: 1.0,
                center: [0.0; 3],
                radius: 1.0,
                cone_axis: [0.0, 0.0, 1.0],
                cone_cos: -1.0,
            })
            .collect(),
        passes,
    }
}
