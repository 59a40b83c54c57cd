//! The GPU sampling backend (wgpu) against the CPU backend on the bundled bunny, and
//! `patchvis bake --backend` end to end.
//!
//! The two backends rasterize differently (the GPU snaps vertices with its own subpixel
//! precision and transforms in `f32`), so a few patches seen only through edge pixels differ;
//! the comparison allows [`MAX_DIFFERENT_BITS`] of all bits. Without a GPU adapter the tests
//! that need one print that they were skipped and pass, except under `CI=true`, where a
//! missing adapter fails them: CI installs Mesa's lavapipe (`.ci/run`) so that they run.
#![cfg(all(feature = "gpu", feature = "cli"))]

use patchvis::ooc::Mesh;
use patchvis::progress::NoProgress;
use patchvis::sampler::gpu::{GpuError, GpuSampler};
use patchvis::sampler::{SamplingOptions, SamplingParams, VisibilityMatrix, sample_tiled};
use patchvis::tiling::{Tiling, tile};
use std::io::Write;
use std::process::{Command, Output};
use std::sync::OnceLock;

const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/bunny.ply");

/// Largest fraction of differing bits between the backends: a rasterization-rule difference
/// moves single edge pixels, which on the bunny changes well under one bit in a thousand.
const MAX_DIFFERENT_BITS: f64 = 1e-3;

/// The GPU, or `None` after saying on stderr that the test is skipped; panics under
/// `CI=true`, where the GPU tests must run.
fn gpu(test: &str) -> Option<GpuSampler> {
    match GpuSampler::new() {
        Ok(gpu) => Some(gpu),
        Err(e) if std::env::var("CI").is_ok_and(|v| v == "true") => {
            panic!("{test}: CI=true but {e}; .ci/run installs Mesa's lavapipe for these tests")
        }
        Err(e) => {
            // Straight to the stream, past the test harness's capture of `eprintln!`, so that
            // a plain `cargo test` shows that the GPU tests did not run.
            let _ = writeln!(std::io::stderr(), "GPU test {test} skipped: {e}");
            None
        }
    }
}

/// The bunny and a 200-patch tiling of it, shared by the tests.
fn bunny() -> &'static (Mesh, Tiling) {
    static BUNNY_TILED: OnceLock<(Mesh, Tiling)> = OnceLock::new();
    BUNNY_TILED.get_or_init(|| {
        let mesh = Mesh::open(std::path::Path::new(BUNNY)).expect("bundled bunny");
        let tiling = tile(&mesh, 200).expect("tiling");
        (mesh, tiling)
    })
}

/// Bits set in `a` but not `b`, set in `b` but not `a`, and set in `a`.
fn differences(a: &VisibilityMatrix, b: &VisibilityMatrix) -> (u64, u64, u64) {
    assert_eq!((a.views(), a.patches()), (b.views(), b.patches()));
    let (mut only_a, mut only_b, mut set_a) = (0, 0, 0);
    for view in 0..a.views() {
        for (x, y) in a.row(view).iter().zip(b.row(view)) {
            only_a += u64::from((x & !y).count_ones());
            only_b += u64::from((y & !x).count_ones());
            set_a += u64::from(x.count_ones());
        }
    }
    (only_a, only_b, set_a)
}

/// Samples the bunny on both backends with `options` and checks that they agree.
fn compare(test: &str, level: u32, resolution: u32, options: &SamplingOptions) {
    let Some(gpu) = gpu(test) else { return };
    let (mesh, tiling) = bunny();
    let params = SamplingParams::for_mesh(mesh, level, resolution, 45.0);
    let start = std::time::Instant::now();
    let cpu = sample_tiled(mesh, tiling, &params, options, &NoProgress).expect("CPU sampling");
    let cpu_seconds = start.elapsed().as_secs_f64();
    let start = std::time::Instant::now();
    let on_gpu = gpu
        .sample(mesh, tiling, &params, options, &NoProgress)
        .expect("GPU sampling");
    let gpu_seconds = start.elapsed().as_secs_f64();
    let (only_cpu, only_gpu, set) = differences(&cpu, &on_gpu);
    let bits = u64::from(cpu.views()) * u64::from(cpu.patches());
    let different = (only_cpu + only_gpu) as f64 / bits as f64;
    let _ = writeln!(
        std::io::stderr(),
        "{test} on {}: {} views x {} patches, {set} bits set on the CPU; {only_cpu} only on the CPU, {only_gpu} only on the GPU ({:.4}% of bits); CPU {cpu_seconds:.2} s, GPU {gpu_seconds:.2} s",
        gpu.adapter(),
        cpu.views(),
        cpu.patches(),
        100.0 * different
    );
    // A broken GPU path (nothing drawn, wrong camera) would differ in most set bits.
    assert!(
        set > bits / 10,
        "the CPU sees too little to compare: {set} of {bits}"
    );
    assert!(
        different < MAX_DIFFERENT_BITS,
        "{test}: {only_cpu} bits only on the CPU and {only_gpu} only on the GPU of {bits}"
    );
}

#[test]
fn gpu_rows_match_cpu_rows_on_the_bunny() {
    compare("plain", 2, 256, &SamplingOptions::default());
}

#[test]
fn gpu_min_pixels_dilate_and_always_visible_match_the_cpu() {
    let options = SamplingOptions {
        min_pixels: 8,
        dilate: true,
        always_visible: vec![0, 199],
        ..SamplingOptions::default()
    };
    compare("options", 1, 256, &options);
}

#[test]
fn gpu_refuses_what_it_does_not_implement() {
    let Some(gpu) = gpu("refusals") else { return };
    let (mesh, tiling) = bunny();
    let params = SamplingParams::for_mesh(mesh, 0, 16, 45.0);
    for options in [
        SamplingOptions {
            conservative: true,
            ..SamplingOptions::default()
        },
        SamplingOptions {
            resume: true,
            ..SamplingOptions::default()
        },
    ] {
        let result = gpu.sample(mesh, tiling, &params, &options, &NoProgress);
        assert!(
            matches!(result, Err(GpuError::Unsupported(_))),
            "{options:?}: {result:?}"
        );
    }
}

/// `patchvis bake` of a small bunny with `extra` flags and `env` set.
fn bake(dir: &std::path::Path, extra: &[&str], env: &[(&str, &str)]) -> Output {
    let out = dir.join("bunny.pvis");
    let mut command = Command::new(env!("CARGO_BIN_EXE_patchvis"));
    command.args([
        "bake",
        BUNNY,
        "-o",
        out.to_str().unwrap(),
        "--patches",
        "50",
        "--level",
        "0",
        "--resolution",
        "64",
        "--quiet",
    ]);
    command.args(extra);
    for (k, v) in env {
        command.env(k, v);
    }
    command.output().expect("run patchvis")
}

/// Environment under which the Vulkan loader finds no driver, so wgpu finds no adapter.
const NO_VULKAN: [(&str, &str); 3] = [
    ("WGPU_BACKEND", "vulkan"),
    ("VK_ICD_FILENAMES", "/nonexistent.json"),
    ("VK_DRIVER_FILES", "/nonexistent.json"),
];

#[test]
fn backend_gpu_without_an_adapter_fails_in_one_line_and_auto_falls_back() {
    let dir = tempfile::tempdir().unwrap();
    let out = bake(dir.path(), &["--backend", "gpu"], &NO_VULKAN);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "stderr: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "stderr: {stderr}");
    assert!(
        stderr.starts_with("error: --backend gpu: no GPU adapter found"),
        "stderr: {stderr}"
    );
    assert!(!dir.path().join("bunny.pvis").exists());

    let out = bake(dir.path(), &["--backend", "auto"], &NO_VULKAN);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "stderr: {stderr}");
    assert!(
        stderr.contains("--backend auto: sampling on the CPU"),
        "stderr: {stderr}"
    );
    assert!(dir.path().join("bunny.pvis").exists());
}

#[test]
fn backend_gpu_bakes_a_file_that_verifies() {
    if gpu("bake --backend gpu").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = bake(
        dir.path(),
        &["--backend", "gpu", "--view-supersample", "1"],
        &[],
    );
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let pvis = dir.path().join("bunny.pvis");
    let verify = Command::new(env!("CARGO_BIN_EXE_patchvis"))
        .args(["verify", pvis.to_str().unwrap()])
        .output()
        .expect("run patchvis");
    assert!(
        verify.status.success(),
        "verify: {}",
        String::from_utf8_lossy(&verify.stderr)
    );

    let out = bake(
        dir.path(),
        &["--backend", "gpu", "--conservative-raster"],
        &[],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    assert!(
        stderr.contains("--conservative-raster needs the CPU backend"),
        "{stderr}"
    );
}
