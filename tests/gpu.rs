//! The GPU sampling backend (wgpu) against the CPU backend on the bundled bunny, and
//! `patchvis bake --backend` end to end.
//!
//! The two backends rasterize differently (the GPU snaps vertices with its own subpixel
//! precision and transforms in `f32`), so a few patches seen only through edge pixels differ;
//! the comparison allows [`MAX_DIFFERENT_BITS`] of all bits. Without a GPU adapter the tests
//! that need one print that they were skipped and pass, except under `CI=true`, where a
//! missing adapter fails them: CI installs Mesa's lavapipe (`.ci/run`) so that they run.
#![cfg(all(feature = "gpu", feature = "cli"))]

mod common;

use common::{Bake, Baked, NO_VULKAN, patchvis, skip_gpu_test, stderr};
use patchvis::ooc::Mesh;
use patchvis::progress::NoProgress;
use patchvis::sampler::gpu::{GpuError, GpuSampler};
use patchvis::sampler::{SamplingOptions, SamplingParams, VisibilityMatrix, sample_tiled};
use patchvis::tiling::{Tiling, tile};
use std::io::Write;
use std::sync::OnceLock;

/// Largest fraction of differing bits between the backends: a rasterization-rule difference
/// moves single edge pixels, which on the bunny changes well under one bit in a thousand.
const MAX_DIFFERENT_BITS: f64 = 1e-3;

/// The GPU, or `None` after saying on stderr that the test is skipped; panics under
/// `CI=true`, where the GPU tests must run.
fn gpu(test: &str) -> Option<GpuSampler> {
    match GpuSampler::new() {
        Ok(gpu) => Some(gpu),
        Err(e) => {
            skip_gpu_test(test, &e.to_string());
            None
        }
    }
}

/// The bunny and a 200-patch tiling of it, shared by the tests.
fn bunny() -> &'static (Mesh, Tiling) {
    static BUNNY_TILED: OnceLock<(Mesh, Tiling)> = OnceLock::new();
    BUNNY_TILED.get_or_init(|| {
        let mesh = common::bunny();
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
    compare_with(test, level, resolution, &|_| options.clone());
}

/// [`compare`] with the options made from the sampling parameters.
fn compare_with(
    test: &str,
    level: u32,
    resolution: u32,
    options: &dyn Fn(&SamplingParams) -> SamplingOptions,
) {
    let Some(gpu) = gpu(test) else { return };
    let (mesh, tiling) = bunny();
    let params = SamplingParams::for_mesh(mesh, level, resolution, 45.0);
    let options = &options(&params);
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
fn gpu_near_views_match_the_cpu() {
    // A cube map of five cameras per view (1.1 bounding radii) and one camera (2 radii).
    for factor in [1.1, 2.0] {
        compare_with(&format!("near {factor}"), 1, 128, &|params| {
            SamplingOptions {
                shell: Some(params.radius * factor),
                min_pixels: 2,
                ..SamplingOptions::default()
            }
        });
    }
}

#[test]
fn gpu_far_shells_match_the_cpu() {
    // One camera a view, framing the bounding sphere from 256 sampling distances out.
    compare_with("far shell", 1, 128, &|params| SamplingOptions {
        shell: Some(params.distance() * 256.0),
        ..SamplingOptions::default()
    });
}

#[test]
fn gpu_refuses_what_it_does_not_implement() {
    let Some(gpu) = gpu("refusals") else { return };
    let (mesh, tiling) = bunny();
    let params = SamplingParams::for_mesh(mesh, 0, 16, 45.0);
    for options in [
        SamplingOptions {
            conservative_raster: true,
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

/// `patchvis bake` of a small bunny with `extra` flags and `env` set, successful or not.
fn bake(extra: &[&str], env: &[(&str, &str)]) -> Baked {
    let mut bake = Bake::new(&[
        "--patches",
        "50",
        "--level",
        "0",
        "--resolution",
        "64",
        "--quiet",
    ])
    .args(extra);
    for (k, v) in env {
        bake = bake.env(k, v);
    }
    bake.attempt()
}

#[test]
fn backend_gpu_without_an_adapter_fails_in_one_line_and_auto_falls_back() {
    let gpu = bake(&["--backend", "gpu"], &NO_VULKAN);
    let err = stderr(&gpu.output);
    assert_eq!(gpu.output.status.code(), Some(1), "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "stderr: {err}");
    assert!(
        err.starts_with("error: --backend gpu: no GPU adapter found"),
        "stderr: {err}"
    );
    assert!(!gpu.pvis.exists());

    let auto = bake(&["--backend", "auto"], &NO_VULKAN);
    let err = stderr(&auto.output);
    assert!(auto.output.status.success(), "stderr: {err}");
    assert!(
        err.contains("--backend auto: sampling on the CPU"),
        "stderr: {err}"
    );
    assert!(auto.pvis.exists());
}

#[test]
fn backend_gpu_bakes_a_file_that_verifies() {
    if gpu("bake --backend gpu").is_none() {
        return;
    }
    let gpu = bake(&["--backend", "gpu", "--view-supersample", "1"], &[]);
    assert!(
        gpu.output.status.success(),
        "stderr: {}",
        stderr(&gpu.output)
    );
    let verify = patchvis(&["verify", gpu.pvis_arg()]);
    assert!(verify.status.success(), "verify: {}", stderr(&verify));

    let refused = bake(&["--backend", "gpu", "--conservative-raster"], &[]);
    let err = stderr(&refused.output);
    assert_eq!(refused.output.status.code(), Some(2), "stderr: {err}");
    assert!(
        err.contains("--conservative-raster needs the CPU backend"),
        "{err}"
    );
}
