//! Query timings with and without sampling shells (spec § SHEL), on synthetic files: the same
//! patches and sampling-sphere rows written once without shells (version 4) and once with
//! three shells (version 5), then the expanded query (random eyes) and the streaming query
//! (a camera staying in its leaf) timed on each, for eyes beyond the sampling sphere and, in
//! the version-5 file, between two shells and inside the innermost one. Also prints the SHEL
//! section's size and its framing. The rows are synthetic (each view sees the patches facing
//! it, plus 1 in 17 flipped), so the sizes say nothing about real bakes; the timings do.
//!
//! ```text
//! cargo run --release --example shells_bench [PATCHES] [LEVEL]   # defaults 2000, 4
//! ```

use std::hint::black_box;
use std::time::Instant;

use patchvis::format::{BakeContents, ShellRows, encode};
use patchvis::runtime::Pvis;
use patchvis::sampler::{SamplingParams, VisibilityMatrix};
use patchvis::sphere::{direction, view_count};
use patchvis::tiling::Patch;

/// Queries per timed batch.
const BATCH: usize = 1000;

fn main() {
    let args: Vec<u32> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("PATCHES and LEVEL are integers"))
        .collect();
    let (patches, level) = (
        args.first().copied().unwrap_or(2000),
        args.get(1).copied().unwrap_or(4),
    );
    // SplitMix64, seeded: the same files every run.
    let mut state = 22u64;
    let mut signed = move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 23) as f32 - 1.0
    };
    let params = SamplingParams {
        level,
        resolution: 512,
        fov_deg: 45.0,
        center: [0.0; 3],
        radius: 1.0,
    };
    let axes: Vec<[f32; 3]> = (0..patches)
        .map(|_| normalized([signed(), signed(), signed()]))
        .collect();
    let list: Vec<Patch> = axes
        .iter()
        .enumerate()
        .map(|(i, &axis)| Patch {
            first: 4 * i as u32,
            count: 4,
            area: 1.0,
            center: axis.map(|x| 0.8 * x),
            radius: 0.05,
            cone_axis: axis,
            cone_cos: 0.7,
        })
        .collect();
    let rows = |near: f32, signed: &mut dyn FnMut() -> f32| {
        let views = view_count(level);
        let mut m = VisibilityMatrix::new(views, patches);
        for v in 0..views {
            let d = direction(v);
            for (p, a) in axes.iter().enumerate() {
                let facing = a[0] * d[0] + a[1] * d[1] + a[2] * d[2] > -0.2 - near;
                if facing != (signed() > 0.88) {
                    m.set(v, p as u32);
                }
            }
        }
        m
    };
    let outer = params.distance();
    let main_rows = rows(0.0, &mut signed);
    // Three shells, geometric from the sampling distance to 1.1 radii (the bake's default).
    let distances: Vec<f32> = (1..=3)
        .map(|s| (f64::from(outer) * (1.1 / f64::from(outer)).powf(s as f64 / 3.0)) as f32)
        .collect();
    let shell_rows: Vec<VisibilityMatrix> = (1..=3)
        .map(|s| rows(0.15 * s as f32, &mut signed))
        .collect();
    let shells: Vec<ShellRows> = distances
        .iter()
        .zip(&shell_rows)
        .map(|(&distance, visibility)| ShellRows {
            distance,
            visibility,
        })
        .collect();
    let file = |shells: &[ShellRows]| {
        encode(&BakeContents {
            sampling: &params,
            triangle_count: 4 * u64::from(patches),
            patches: &list,
            visibility: &main_rows,
            shells,
            reach: 0.0,
        })
    };
    let (v4, v5) = (file(&[]), file(&shells));
    let (a, b) = (Pvis::parse(&v4).unwrap(), Pvis::parse(&v5).unwrap());
    println!(
        "{patches} patches, level {level}, shells at {distances:?} (sampling distance {outer})"
    );
    println!(
        "version 4: {} bytes; version 5: {} bytes, SHEL {} bytes of which framing {} \
         (8 + 16 per shell) and payloads {:?}",
        v4.len(),
        v5.len(),
        b.shells_bytes(),
        8 + 16 * 3,
        (1..=3).map(|s| b.shell(s).bytes).collect::<Vec<_>>()
    );
    let at = |r: f32, signed: &mut dyn FnMut() -> f32| -> Vec<[f32; 3]> {
        (0..BATCH * 20)
            .map(|_| normalized([signed(), signed(), signed()]).map(|x| x * r))
            .collect()
    };
    let far = at(2.0 * outer, &mut signed);
    let between = at(0.5 * (distances[0] + distances[1]), &mut signed);
    let inside = at(1.05, &mut signed);
    for (name, pvis, cases) in [
        ("version 4", &a, vec![("beyond the sampling sphere", &far)]),
        (
            "version 5",
            &b,
            vec![
                ("beyond the sampling sphere", &far),
                ("between shells 1 and 2", &between),
                ("inside the innermost shell", &inside),
            ],
        ),
    ] {
        let mut table = vec![0u64; pvis.expanded_bound()];
        let t = Instant::now();
        let mut expanded = pvis.expand(&mut table);
        let expand_ms = t.elapsed().as_secs_f64() * 1e3;
        println!(
            "{name}: expand {expand_ms:.1} ms, {} KiB table; streaming scratch {} KiB",
            pvis.expanded_bound() * 8 / 1024,
            pvis.scratch_bound() * 8 / 1024
        );
        for (case, eyes) in cases {
            let mut samples: Vec<f64> = eyes
                .chunks(BATCH)
                .map(|batch| {
                    let t = Instant::now();
                    for &eye in batch {
                        black_box(expanded.query(eye).bits()[0]);
                    }
                    t.elapsed().as_nanos() as f64 / BATCH as f64
                })
                .collect();
            let mut scratch = vec![0u64; pvis.scratch_bound()];
            let mut streaming = pvis.streaming(&mut scratch);
            let mut stay: Vec<f64> = eyes
                .chunks(BATCH)
                .map(|batch| {
                    let base = batch[0];
                    streaming.query(base);
                    let jitter: Vec<[f32; 3]> = batch
                        .iter()
                        .map(|e| [0, 1, 2].map(|i| base[i] + 1e-6 * e[i]))
                        .collect();
                    let t = Instant::now();
                    for &eye in &jitter {
                        black_box(streaming.query(eye).bits()[0]);
                    }
                    t.elapsed().as_nanos() as f64 / BATCH as f64
                })
                .collect();
            println!(
                "  {case:<28} expanded {:>6.1} ns   streaming, same leaf {:>6.1} ns   (medians of {} batches of {BATCH})",
                median(&mut samples),
                median(&mut stay),
                samples.len()
            );
        }
    }
}

fn normalized(v: [f32; 3]) -> [f32; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-6);
    v.map(|x| x / n)
}

fn median(samples: &mut [f64]) -> f64 {
    samples.sort_by(f64::total_cmp);
    samples[samples.len() / 2]
}
