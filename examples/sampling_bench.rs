//! Sampling benchmark (issue 7): brute-force `sample` against level-by-level `sample_tiled`
//! on one mesh, in the same run, with wall time and process CPU time (user + system, from
//! `/proc/self/stat`, so a loaded machine does not hide the work done), and a check that both
//! give identical rows.
//!
//! `cargo run --release --example sampling_bench -- MESH.ply [LEVEL] [RESOLUTION] [PATCHES] [RUNS] [tiled]`
//! (defaults: 4, 512, 1000, 3). Prints the median of `RUNS` runs of each. With `tiled` last,
//! only the tiled sampler runs (for profilers; nothing is compared then).

use patchvis::ooc::Mesh;
use patchvis::progress::NoProgress;
use patchvis::sampler::{SamplingOptions, SamplingParams, sample, sample_tiled};
use std::time::Instant;

/// Clock ticks per second of `/proc/self/stat` (`sysconf(_SC_CLK_TCK)` is 100 on Linux).
const TICKS_PER_SECOND: f64 = 100.0;

/// User + system CPU seconds of this process so far, or 0 where `/proc` is missing.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = stat.rsplit(')').next().unwrap_or("");
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| {
        fields
            .get(i)
            .and_then(|f| f.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (tick(11) + tick(12)) / TICKS_PER_SECOND
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .ok_or("usage: sampling_bench MESH.ply [LEVEL] [RES] [PATCHES] [RUNS] [tiled]")?;
    let tiled_only = args.get(5).is_some_and(|a| a == "tiled");
    let arg = |i: usize, default: u32| args.get(i).map_or(Ok(default), |s| s.parse::<u32>());
    let (level, resolution, patches, runs) = (arg(1, 4)?, arg(2, 512)?, arg(3, 1000)?, arg(4, 3)?);
    let mesh = Mesh::open(std::path::Path::new(path))?;
    let tiling = patchvis::tiling::tile(&mesh, patches)?;
    let count = tiling.patches.len() as u32;
    let params = SamplingParams::for_mesh(&mesh, level, resolution, 45.0);
    let views = patchvis::sphere::view_count(level) as f64;
    println!(
        "{path}: {} triangles, {count} patches, {} views at {resolution}², {} threads, load {}",
        mesh.triangle_count(),
        views,
        rayon::current_num_threads(),
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .trim()
    );
    let (mut brute, mut tiled) = ((Vec::new(), Vec::new()), (Vec::new(), Vec::new()));
    for _ in 0..runs {
        let reference = (!tiled_only).then(|| {
            let (c0, t0) = (cpu_seconds(), Instant::now());
            let reference = sample(&mesh, &tiling.patch_of, count, &params, &NoProgress);
            brute.0.push(t0.elapsed().as_secs_f64());
            brute.1.push(cpu_seconds() - c0);
            reference
        });
        let (c0, t0) = (cpu_seconds(), Instant::now());
        let fast = sample_tiled(
            &mesh,
            &tiling,
            &params,
            &SamplingOptions::default(),
            &NoProgress,
        )?;
        tiled.0.push(t0.elapsed().as_secs_f64());
        tiled.1.push(cpu_seconds() - c0);
        if let Some(reference) = reference {
            assert!(fast == reference, "tiled sampling differs from brute force");
        }
    }
    for (name, (wall, cpu)) in [("brute force", brute), ("tiled", tiled)] {
        if wall.is_empty() {
            continue;
        }
        let (wall, cpu) = (median(wall), median(cpu));
        println!(
            "{name:>12}: wall {wall:.3} s, CPU {cpu:.3} s = {:.2} ms CPU per view (median of {runs})",
            1000.0 * cpu / views
        );
    }
    if !tiled_only {
        println!("rows identical: yes");
    }
    Ok(())
}
