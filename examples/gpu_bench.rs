//! GPU backend benchmark (issue 7): `GpuSampler::sample` against the CPU backend
//! (`sample_tiled`) on one mesh, in the same run, with the bit agreement of their rows.
//!
//! `cargo run --release --example gpu_bench -- MESH.ply [LEVEL] [RESOLUTION] [PATCHES] [RUNS]`
//! (defaults: 4, 512, 1000, 3). Prints the median wall time of `RUNS` runs of each (the GPU's
//! after opening the device once, which is timed separately) and the differing bits.

use patchvis::ooc::Mesh;
use patchvis::progress::NoProgress;
use patchvis::sampler::gpu::GpuSampler;
use patchvis::sampler::{SamplingOptions, SamplingParams, sample_tiled};
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .ok_or("usage: gpu_bench MESH.ply [LEVEL] [RES] [PATCHES] [RUNS]")?;
    let arg = |i: usize, default: u32| args.get(i).map_or(Ok(default), |s| s.parse::<u32>());
    let (level, resolution, patches, runs) = (arg(1, 4)?, arg(2, 512)?, arg(3, 1000)?, arg(4, 3)?);
    let mesh = Mesh::open(std::path::Path::new(path))?;
    let tiling = patchvis::tiling::tile(&mesh, patches)?;
    let params = SamplingParams::for_mesh(&mesh, level, resolution, 45.0);
    let options = SamplingOptions::default();
    let opened = Instant::now();
    let gpu = GpuSampler::new()?;
    let open_seconds = opened.elapsed().as_secs_f64();
    println!(
        "{path}: {} triangles, {} patches, {} views at {resolution}², {} CPU threads, GPU {} (opened in {open_seconds:.2} s), load {}",
        mesh.triangle_count(),
        tiling.patches.len(),
        patchvis::sphere::view_count(level),
        rayon::current_num_threads(),
        gpu.adapter(),
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .trim()
    );
    let (mut cpu_times, mut gpu_times) = (Vec::new(), Vec::new());
    let (mut cpu_rows, mut gpu_rows) = (None, None);
    for _ in 0..runs {
        let start = Instant::now();
        cpu_rows = Some(sample_tiled(
            &mesh,
            &tiling,
            &params,
            &options,
            &NoProgress,
        )?);
        cpu_times.push(start.elapsed().as_secs_f64());
        let start = Instant::now();
        gpu_rows = Some(gpu.sample(&mesh, &tiling, &params, &options, &NoProgress)?);
        gpu_times.push(start.elapsed().as_secs_f64());
    }
    let (cpu, on_gpu) = (cpu_rows.ok_or("RUNS is 0")?, gpu_rows.ok_or("RUNS is 0")?);
    let (mut only_cpu, mut only_gpu, mut set) = (0u64, 0u64, 0u64);
    for view in 0..cpu.views() {
        for (a, b) in cpu.row(view).iter().zip(on_gpu.row(view)) {
            only_cpu += u64::from((a & !b).count_ones());
            only_gpu += u64::from((b & !a).count_ones());
            set += u64::from(a.count_ones());
        }
    }
    let bits = u64::from(cpu.views()) * u64::from(cpu.patches());
    let views = f64::from(cpu.views());
    let (c, g) = (median(cpu_times), median(gpu_times));
    println!(
        "CPU (sample_tiled): {c:.2} s median ({:.2} ms per view)",
        1e3 * c / views
    );
    println!(
        "GPU (wgpu):         {g:.2} s median ({:.2} ms per view)",
        1e3 * g / views
    );
    println!(
        "bits: {bits} total, {set} set on the CPU; {only_cpu} only on the CPU, {only_gpu} only on the GPU ({:.4}% differ)",
        100.0 * (only_cpu + only_gpu) as f64 / bits as f64
    );
    Ok(())
}
