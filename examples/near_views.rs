//! Near views (issue 22, sampling shells): what a view on a shell costs against a sampling
//! view, how much of the model its row holds, and whether a finer resolution per camera pays.
//!
//! `cargo run --release --example near_views -- MESH [PATCHES] [LEVEL] [RESOLUTION] [RUNS]
//! [resolution]` (defaults: 1000, 5, 512, 1; level 5 is the bake's sampled level for level 4
//! stored, whose fold views it holds). With `resolution` last, only the second part runs.
//!
//! 1. Cost: the sampling pass and near passes at 1.1, 1.5 and 2 bounding radii, every view
//!    of the level, default options; process CPU time (user + system, `/proc/self/stat`, so a
//!    loaded machine does not hide the work) and wall time, median of `RUNS`; the mean
//!    fraction of the patches a row holds; the same with the probe pass of `--conservative`.
//! 2. Resolution: on 64 views of the level spread over the sphere (`SamplingOptions::views`,
//!    which also renders their ancestors), the sampling and near rows at 1× and 2×
//!    `RESOLUTION` against a 4× reference: the reference's patches a row misses, and the CPU
//!    time of each.

use patchvis::ooc::Mesh;
use patchvis::progress::NoProgress;
use patchvis::sampler::{
    SamplingOptions, SamplingParams, VisibilityMatrix, near_camera_count, sample_tiled,
};
use std::time::Instant;

/// Clock ticks per second of `/proc/self/stat` (`sysconf(_SC_CLK_TCK)` is 100 on Linux).
const TICKS_PER_SECOND: f64 = 100.0;

/// The near passes measured, in bounding radii.
const FACTORS: [f32; 3] = [1.1, 1.5, 2.0];

/// A pass's name: the sampling pass, or a near pass at `factor` bounding radii.
fn pass_name(factor: Option<f32>) -> String {
    factor.map_or("sampling (D)".to_string(), |f| format!("near {f} R"))
}

/// User + system CPU seconds of this process so far, or 0 where `/proc` is missing.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
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

/// Runs `sample_tiled` `runs` times: the rows, and the median CPU and wall seconds.
fn timed(
    mesh: &Mesh,
    tiling: &patchvis::tiling::Tiling,
    params: &SamplingParams,
    options: &SamplingOptions,
    runs: u32,
) -> Result<(VisibilityMatrix, f64, f64), Box<dyn std::error::Error>> {
    let (mut cpu, mut wall, mut rows) = (Vec::new(), Vec::new(), None);
    for _ in 0..runs {
        let (c0, w0) = (cpu_seconds(), Instant::now());
        rows = Some(sample_tiled(mesh, tiling, params, options, &NoProgress)?);
        wall.push(w0.elapsed().as_secs_f64());
        cpu.push(cpu_seconds() - c0);
    }
    Ok((rows.expect("runs > 0"), median(cpu), median(wall)))
}

/// The mean fraction of the patches a row of `views` holds.
fn mean_fraction(m: &VisibilityMatrix, views: &[u32]) -> f64 {
    let set: u64 = views
        .iter()
        .map(|&v| {
            m.row(v)
                .iter()
                .map(|w| u64::from(w.count_ones()))
                .sum::<u64>()
        })
        .sum();
    set as f64 / (views.len() as f64 * f64::from(m.patches()))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .ok_or("usage: near_views MESH [PATCHES] [LEVEL] [RESOLUTION] [RUNS]")?;
    let arg = |i: usize, default: u32| args.get(i).map_or(Ok(default), |s| s.parse::<u32>());
    let (patches, level, resolution, runs) = (arg(1, 1000)?, arg(2, 5)?, arg(3, 512)?, arg(4, 1)?);
    let mesh = Mesh::open(std::path::Path::new(path))?;
    let tiling = patchvis::tiling::tile(&mesh, patches)?;
    let params = SamplingParams::for_mesh(&mesh, level, resolution, 45.0);
    let views = patchvis::sphere::view_count(level);
    let all: Vec<u32> = (0..views).collect();
    println!(
        "{path}: {} triangles, {} patches, level {level} ({views} views) at {resolution}², \
         R = {}, D = {} ({:.2} R), {} threads, load {}",
        mesh.triangle_count(),
        tiling.patches.len(),
        params.radius,
        params.distance(),
        params.distance() / params.radius,
        rayon::current_num_threads(),
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .trim()
    );
    let probe = SamplingOptions {
        probe: Some(2),
        ..SamplingOptions::default()
    };
    let only_resolution = args.get(5).is_some_and(|a| a == "resolution");
    println!("\n1. Cost per view (CPU ms, median of {runs}) and the patches a row holds");
    println!(
        "pass          cameras  CPU ms/view  × sampling  wall s  row holds | probe: CPU ms/view  × sampling  row holds"
    );
    let mut base = (0.0, 0.0);
    for factor in [None].into_iter().chain(FACTORS.map(Some)) {
        if only_resolution {
            break;
        }
        let shell = factor.map(|f| params.radius * f);
        let cameras = shell.map_or(1, |r| near_camera_count(&params, r));
        let plain = SamplingOptions {
            shell,
            ..SamplingOptions::default()
        };
        let (rows, cpu, wall) = timed(&mesh, &tiling, &params, &plain, runs)?;
        let probed = SamplingOptions {
            shell,
            ..probe.clone()
        };
        let (probe_rows, probe_cpu, _) = timed(&mesh, &tiling, &params, &probed, runs)?;
        let (per_view, probe_per_view) = (
            1e3 * cpu / f64::from(views),
            1e3 * probe_cpu / f64::from(views),
        );
        if factor.is_none() {
            base = (per_view, probe_per_view);
        }
        println!(
            "{:<13} {cameras:>7}  {per_view:>11.3}  {:>9.2}×  {wall:>6.2}  {:>8.1} % | {probe_per_view:>18.3}  {:>9.2}×  {:>8.1} %",
            pass_name(factor),
            per_view / base.0,
            100.0 * mean_fraction(&rows, &all),
            probe_per_view / base.1,
            100.0 * mean_fraction(&probe_rows, &all),
        );
    }
    // 64 views of the finest level spread over it.
    let first = if level == 0 {
        0
    } else {
        patchvis::sphere::view_count(level - 1)
    };
    let step = ((views - first) / 64).max(1);
    let some: Vec<u32> = (first..views).step_by(step as usize).take(64).collect();
    println!(
        "\n2. Resolution per camera, {} views of level {level} (and their ancestors), against {}²",
        some.len(),
        4 * resolution
    );
    println!(
        "pass          resolution  CPU s  × 1×  row holds  misses of the reference's patches (per row, mean / max)"
    );
    for factor in [None].into_iter().chain(FACTORS.map(Some)) {
        let options = SamplingOptions {
            shell: factor.map(|f| params.radius * f),
            views: Some(some.clone()),
            ..SamplingOptions::default()
        };
        let at = |scale: u32| SamplingParams {
            resolution: scale * resolution,
            ..params
        };
        let (reference, _, _) = timed(&mesh, &tiling, &at(4), &options, 1)?;
        let mut one = 0.0;
        for scale in [1, 2] {
            let (rows, cpu, _) = timed(&mesh, &tiling, &at(scale), &options, runs)?;
            if scale == 1 {
                one = cpu;
            }
            let misses: Vec<u32> = some
                .iter()
                .map(|&v| {
                    rows.row(v)
                        .iter()
                        .zip(reference.row(v))
                        .map(|(a, r)| (r & !a).count_ones())
                        .sum()
                })
                .collect();
            let mean = f64::from(misses.iter().sum::<u32>()) / misses.len() as f64;
            println!(
                "{:<13} {:>10}  {cpu:>5.2}  {:>3.1}  {:>7.1} %  {mean:.2} / {}",
                pass_name(factor),
                scale * resolution,
                cpu / one,
                100.0 * mean_fraction(&rows, &some),
                misses.iter().max().unwrap_or(&0)
            );
        }
    }
    Ok(())
}
