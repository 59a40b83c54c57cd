//! Measures the patch table of a `.pvis` file and its compact alternatives (issue 23).
//!
//! Usage: `cargo run --release --example ptch_measure -- FILE.pvis`. Re-encodes the file's
//! contents with the full (version 3) and the compact (version 4) patch table, checks that
//! queries answer the same patch sets from both, and prints: the section sizes, `zstd -19` of
//! the full table, the compact table at several centre-grid steps and cone widths, how much the
//! quantised spheres grow, and how many (patch, eye) pairs the back-facing test culls with the
//! exact and with the quantised records (eyes at the sampling distance and at 1.2× the radius).

use patchvis::eval::views::random_directions;
use patchvis::format::{
    BakeContents, PatchTableLayout, VisibilityEncoding, choose_quantisation_with, encode_as,
    quantise,
};
use patchvis::runtime::{Pvis, Quantisation};
use patchvis::sampler::VisibilityMatrix;
use patchvis::tiling::Patch;
use patchvis::visibility::SamplingParams;

/// `n` eyes at `distance` from `center`, directions uniform on the sphere (eval's seeded
/// directions).
fn eyes(center: [f32; 3], distance: f32, n: usize) -> Vec<[f32; 3]> {
    random_directions(n as u32, 7)
        .into_iter()
        .map(|d| [0, 1, 2].map(|i| center[i] + d[i] * distance))
        .collect()
}

/// Fraction of (patch, eye) pairs `pvis` reports back-facing.
fn backfacing_rate(pvis: &Pvis<'_>, eyes: &[[f32; 3]]) -> f64 {
    let mut culled = 0u64;
    for &eye in eyes {
        culled += (0..pvis.patch_count())
            .filter(|&p| pvis.backfacing(p, eye))
            .count() as u64;
    }
    culled as f64 / (eyes.len() as f64 * f64::from(pvis.patch_count()))
}

/// Compact table bytes under `q`.
fn compact_bytes(q: &Quantisation, patches: usize) -> usize {
    40 + 4 * patches.div_ceil(64) + (patches * q.record_bits() as usize).div_ceil(8)
}

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: ptch_measure FILE.pvis");
    let bytes = std::fs::read(&path).expect("read");
    let pvis = Pvis::parse(&bytes).expect("parse");
    let s = pvis.sampling();
    let count = pvis.patch_count();
    let patches: Vec<Patch> = (0..count)
        .map(|p| {
            let i = pvis.patch(p);
            Patch {
                first: i.first_triangle,
                count: i.triangle_count,
                area: 0.0,
                center: i.center,
                radius: i.radius,
                cone_axis: i.cone_axis,
                cone_cos: i.cone_cos,
            }
        })
        .collect();
    let mut matrix = VisibilityMatrix::new(s.views, count);
    for v in 0..s.views {
        pvis.view_row(v, matrix.row_mut(v));
    }
    let params = SamplingParams {
        level: s.level,
        resolution: s.resolution,
        fov_deg: s.fov_deg,
        center: s.center,
        radius: s.radius,
    };
    let contents = BakeContents {
        sampling: &params,
        triangle_count: pvis.triangle_count(),
        patches: &patches,
        visibility: &matrix,
        shells: &[],
        reach: 0.0,
    };
    let full = encode_as(&contents, VisibilityEncoding::Tree, PatchTableLayout::Full);
    let compact = encode_as(
        &contents,
        VisibilityEncoding::Tree,
        PatchTableLayout::Compact,
    );
    let (full_pvis, compact_pvis) = (
        Pvis::parse(&full).expect("full"),
        Pvis::parse(&compact).expect("compact"),
    );
    println!("{path}: {count} patches, {} views", s.views);
    println!(
        "  version 3 (full table):    {:>8} B, patch table {:>7} B, visibility {:>7} B",
        full.len(),
        full_pvis.patch_table_bytes(),
        full_pvis.visibility_bytes()
    );
    println!(
        "  version 4 (compact table): {:>8} B, patch table {:>7} B, visibility {:>7} B",
        compact.len(),
        compact_pvis.patch_table_bytes(),
        compact_pvis.visibility_bytes()
    );
    let table: Vec<u8> = (0..count)
        .flat_map(|p| {
            let i = full_pvis.patch(p);
            let mut r = Vec::with_capacity(40);
            r.extend(i.first_triangle.to_le_bytes());
            r.extend(i.triangle_count.to_le_bytes());
            i.center.iter().for_each(|v| r.extend(v.to_le_bytes()));
            r.extend(i.radius.to_le_bytes());
            i.cone_axis.iter().for_each(|v| r.extend(v.to_le_bytes()));
            r.extend(i.cone_cos.to_le_bytes());
            r
        })
        .collect();
    let zstd = zstd::bulk::compress(&table, 19).expect("zstd").len();
    println!("  zstd -19 of the full table: {zstd} B");

    // Same answers.
    let (mut a, mut b) = (
        vec![0u64; full_pvis.scratch_words()],
        vec![0u64; compact_pvis.scratch_words()],
    );
    let checked = eyes(s.center, s.distance * 1.5, 2000);
    for &eye in &checked {
        let (x, y) = (
            full_pvis.query(eye, &mut a),
            compact_pvis.query(eye, &mut b),
        );
        assert!(x.patches().eq(y.patches()), "answers differ at {eye:?}");
    }
    println!("  queries at 2000 eyes: identical patch sets");

    println!("  compact table by centre step (fraction of the median radius) and cone bits:");
    println!(
        "  {:>6} {:>5} {:>5} {:>8} {:>9} {:>9} {:>12} {:>12}",
        "step", "axis", "cos", "bits/rec", "table B", "file B", "radius +med", "radius +p95"
    );
    for (fraction, axis_bits, cos_bits) in [
        (0.125, 7, 6),
        (0.25, 7, 6),
        (0.5, 7, 6),
        (1.0, 7, 6),
        (0.25, 6, 5),
        (0.25, 8, 7),
        (0.25, 10, 8),
    ] {
        let q = choose_quantisation_with(&patches, fraction, axis_bits, cos_bits);
        let mut growth: Vec<f64> = patches
            .iter()
            .filter(|p| p.radius > 0.0)
            .map(|p| {
                let r = q.decode(&quantise(&q, p), 0).radius;
                f64::from(r) / f64::from(p.radius) - 1.0
            })
            .collect();
        growth.sort_by(f64::total_cmp);
        let at = |f: f64| growth[((growth.len() - 1) as f64 * f) as usize];
        let table = compact_bytes(&q, patches.len());
        println!(
            "  {fraction:>6} {axis_bits:>5} {cos_bits:>5} {:>8} {table:>9} {:>9} {:>11.1}% {:>11.1}%",
            q.record_bits(),
            compact.len() - compact_pvis.patch_table_bytes() as usize + table,
            100.0 * at(0.5),
            100.0 * at(0.95)
        );
    }
    for (name, distance) in [
        ("sampling distance", s.distance),
        ("1.2x radius", s.radius * 1.2),
    ] {
        let e = eyes(s.center, distance, 200);
        println!(
            "  back-facing patches, eyes at {name}: {:.1}% exact records, {:.1}% compact",
            100.0 * backfacing_rate(&full_pvis, &e),
            100.0 * backfacing_rate(&compact_pvis, &e)
        );
    }
}
