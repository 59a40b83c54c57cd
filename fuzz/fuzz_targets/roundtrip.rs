//! Fuzz target: arbitrary small bake contents → `format::encode` → `Pvis::parse` → every
//! field, patch and row equal to what went in (patch bounds: exactly in a full table, as the
//! writer quantised them and containing the true sphere in a compact one). Contents are first brought inside the writer's
//! contract (finite values, `fov` in (0, 180), …), since `encode` panics on a broken contract
//! by design; any other panic or mismatch is a writer or reader bug.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use patchvis::format::{BakeContents, encode, quantise};
use patchvis::runtime::Pvis;
use patchvis::sampler::{SamplingParams, VisibilityMatrix};
use patchvis::sphere::view_count;
use patchvis::tiling::Patch;

/// Levels beyond 3 only make inputs larger; the layout does not change with the level.
const MAX_FUZZ_LEVEL: u8 = 3;
/// Enough patches to cross two 64-bit row words.
const MAX_FUZZ_PATCHES: usize = 140;

#[derive(Arbitrary, Debug)]
struct Contents {
    level: u8,
    counts: Vec<u8>,
    center: [f32; 3],
    radius: f32,
    fov_deg: f32,
    resolution: u32,
    patch_floats: Vec<[f32; 8]>,
    bits: Vec<u8>,
}

/// A finite value, or `fallback`.
fn finite(x: f32, fallback: f32) -> f32 {
    if x.is_finite() { x } else { fallback }
}

fuzz_target!(|input: Contents| {
    let level = u32::from(input.level % (MAX_FUZZ_LEVEL + 1));
    let mut counts: Vec<u32> = input
        .counts
        .iter()
        .take(MAX_FUZZ_PATCHES)
        .map(|&c| u32::from(c) + 1)
        .collect();
    if counts.is_empty() {
        counts.push(1);
    }
    let params = SamplingParams {
        level,
        resolution: input.resolution.max(1),
        fov_deg: finite(input.fov_deg, 45.0).abs().clamp(1.0, 179.0),
        center: input.center.map(|c| finite(c, 0.0).clamp(-1e30, 1e30)),
        radius: finite(input.radius, 1.0).abs().clamp(1e-6, 1e30),
    };
    let mut first = 0;
    let patches: Vec<Patch> = counts
        .iter()
        .enumerate()
        .map(|(i, &count)| {
            let f = input.patch_floats.get(i).copied().unwrap_or([0.0; 8]);
            let patch = Patch {
                first,
                count,
                area: 1.0,
                center: [finite(f[0], 0.0), finite(f[1], 0.0), finite(f[2], 0.0)],
                radius: finite(f[3], 0.0).abs(),
                cone_axis: [finite(f[4], 0.0), finite(f[5], 0.0), finite(f[6], 0.0)],
                cone_cos: finite(f[7], -1.0).clamp(-1.0, 1.0),
            };
            first += count;
            patch
        })
        .collect();
    let views = view_count(level);
    let mut matrix = VisibilityMatrix::new(views, patches.len() as u32);
    let total_bits = views as usize * patches.len();
    for (i, byte) in input.bits.iter().enumerate() {
        for bit in 0..8 {
            let n = i * 8 + bit;
            if n < total_bits && byte >> bit & 1 == 1 {
                matrix.set((n / patches.len()) as u32, (n % patches.len()) as u32);
            }
        }
    }
    // A camera distance that overflows breaks the writer's contract; skip such contents.
    if !params.distance().is_finite() || params.distance() < params.radius {
        return;
    }
    let bytes = encode(&BakeContents {
        sampling: &params,
        triangle_count: u64::from(first),
        patches: &patches,
        visibility: &matrix,
        shells: &[],
        reach: 0.0,
    });
    let pvis = Pvis::parse(&bytes).expect("the reader accepts the writer's output");
    let s = pvis.sampling();
    assert_eq!(
        (
            s.level,
            s.views,
            s.center,
            s.radius,
            s.fov_deg,
            s.resolution
        ),
        (
            level,
            views,
            params.center,
            params.radius,
            params.fov_deg,
            params.resolution
        )
    );
    assert_eq!(s.distance, params.distance());
    assert_eq!(pvis.patch_count() as usize, patches.len());
    assert_eq!(pvis.triangle_count(), u64::from(first));
    for (p, patch) in patches.iter().enumerate() {
        let info = pvis.patch(p as u32);
        assert_eq!(
            (info.first_triangle, info.triangle_count),
            (patch.first, patch.count)
        );
        let Some(q) = pvis.quantisation() else {
            // The full table (version 3): every value as it went in.
            assert_eq!((info.center, info.radius), (patch.center, patch.radius));
            assert_eq!(
                (info.cone_axis, info.cone_cos),
                (patch.cone_axis, patch.cone_cos)
            );
            continue;
        };
        // The compact table: the writer's quantisation, and a sphere that contains the true
        // one (spec § PTCH: conservative).
        assert_eq!(info, q.decode(&quantise(&q, patch), patch.first));
        let moved: f64 = (0..3)
            .map(|i| (f64::from(info.center[i]) - f64::from(patch.center[i])).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(f64::from(info.radius) >= moved + f64::from(patch.radius));
    }
    let mut row = vec![0u64; pvis.row_words()];
    for view in 0..views {
        pvis.view_row(view, &mut row);
        assert_eq!(row.as_slice(), matrix.row(view), "view {view}");
    }
    // Byte-deterministic: the same contents give the same bytes.
    let again = encode(&BakeContents {
        sampling: &params,
        triangle_count: u64::from(first),
        patches: &patches,
        visibility: &matrix,
        shells: &[],
        reach: 0.0,
    });
    assert_eq!(bytes, again);
});
