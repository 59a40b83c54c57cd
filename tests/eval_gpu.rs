//! `patchvis eval --frame-backend`: the frame cost timed on a GPU through wgpu, and the sweep's
//! bakes against `patchvis bake`'s.
//!
//! Without a GPU adapter the GPU test prints that it was skipped and passes, except under
//! `CI=true`, where a missing adapter fails it: CI installs Mesa's lavapipe (`.ci/run`), as for
//! tests/gpu.rs.
#![cfg(feature = "cli")]

mod common;

use common::{
    BUNNY, Baked, NO_VULKAN, SMALL_QUIET, bake, json, number, patchvis, patchvis_with_env,
    path_str, skip_gpu_test, stderr,
};
use serde_json::Value;
use std::path::Path;

/// The bunny in 200 patches, sphere level 2, 128 px, with `extra` bake flags.
fn bake_small(extra: &[&str]) -> Baked {
    bake(&[&SMALL_QUIET[..], extra].concat())
}

#[test]
fn gpu_frame_cost_reports_positive_timings() {
    let baked = bake_small(&[]);
    let pvis = baked.pvis_arg();
    let out = patchvis(&[
        "eval",
        BUNNY,
        pvis,
        "--frame-backend",
        "gpu",
        "--views",
        "4",
        "--json",
        "-q",
    ]);
    let err = stderr(&out);
    if !out.status.success()
        && (err.contains("no GPU adapter found") || err.contains("cannot open a device"))
    {
        skip_gpu_test("gpu_frame_cost_reports_positive_timings", &err);
        return;
    }
    let report = json(&out);
    assert_eq!(report["frame_backend"], "gpu");
    assert_eq!(report["frame_backend_reason"], "--frame-backend gpu");
    let gpu = &report["frame_cost_gpu"];
    assert!(!gpu["adapter"].as_str().unwrap().is_empty(), "{gpu}");
    assert!(gpu["software"].is_boolean());
    assert!(
        ["gpu timestamps", "wall clock"].contains(&gpu["clock"].as_str().unwrap()),
        "{gpu}"
    );
    assert_eq!(gpu["warmup_frames"], 3);
    for key in [
        "full_ms_median",
        "culled_ms_median",
        "speedup",
        "wall_full_ms_median",
        "wall_culled_ms_median",
        "wall_speedup",
    ] {
        let value = number(gpu, key);
        assert!(value > 0.0 && value.is_finite(), "{key} = {value}");
    }
    // The culled frame draws at least one run of patches (every view sees some of the bunny).
    assert!(number(gpu, "culled_draws_mean") >= 1.0, "{gpu}");
    // The CPU figure is still there, and every view carries both.
    assert!(number(&report["frame_cost"], "full_ms_median") > 0.0);
    let per_view = report["per_view"].as_array().unwrap();
    assert_eq!(per_view.len(), 4);
    for view in per_view {
        assert!(
            number(view, "gpu_full_ms") > 0.0 && number(view, "gpu_culled_ms") > 0.0,
            "{view}"
        );
        assert!(number(view, "full_ms") > 0.0, "{view}");
    }
}

#[test]
fn cpu_frame_backend_reports_no_gpu_figure_and_gpu_sweeps_are_refused() {
    let baked = bake_small(&[]);
    let pvis = baked.pvis_arg();
    let report = json(&patchvis(&[
        "eval",
        BUNNY,
        pvis,
        "--frame-backend",
        "cpu",
        "--views",
        "2",
        "--json",
        "-q",
    ]));
    assert_eq!(report["frame_backend"], "cpu");
    assert_eq!(report["frame_backend_reason"], "--frame-backend cpu");
    assert!(report.get("frame_cost_gpu").is_none(), "{report}");
    assert!(report["per_view"][0].get("gpu_full_ms").is_none());

    let out = patchvis(&["eval", BUNNY, "--sweep", "--frame-backend", "gpu"]);
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(
        err.contains("--frame-backend") && err.contains("--sweep"),
        "{err}"
    );
}

#[test]
fn frame_backend_gpu_without_an_adapter_fails_in_one_line_and_auto_falls_back() {
    let baked = bake_small(&[]);
    let pvis = baked.pvis_arg();
    let eval = |backend: &str| {
        patchvis_with_env(
            &[
                "eval",
                BUNNY,
                pvis,
                "--frame-backend",
                backend,
                "--views",
                "2",
                "--json",
                "-q",
            ],
            &NO_VULKAN,
        )
    };
    let out = eval("gpu");
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "stderr: {err}");
    assert!(
        err.starts_with("error: --frame-backend gpu: no GPU adapter found"),
        "stderr: {err}"
    );
    let report = json(&eval("auto"));
    assert_eq!(report["frame_backend"], "cpu");
    let why = report["frame_backend_reason"].as_str().unwrap();
    assert!(
        why.starts_with("--frame-backend auto: no GPU adapter found"),
        "{why}"
    );
    assert!(report.get("frame_cost_gpu").is_none());
}

/// The sweep's point for the bunny at 200 patches, level 2, 128 px, 6 views, seed 5, sampled
/// in `mode`.
fn sweep_point(mode: &str) -> Value {
    let report = json(&patchvis(&[
        "eval",
        BUNNY,
        "--sweep",
        "--sweep-patches",
        "200",
        "--sweep-levels",
        "2",
        "--sweep-mode",
        mode,
        "--resolution",
        "128",
        "--views",
        "6",
        "--seed",
        "5",
        "--json",
        "-q",
    ]));
    report["points"][0].clone()
}

/// The evaluation of `pvis` on the views of [`sweep_point`].
fn eval_file(pvis: &Path) -> Value {
    json(&patchvis(&[
        "eval",
        BUNNY,
        path_str(pvis),
        "--frame-backend",
        "cpu",
        "--views",
        "6",
        "--seed",
        "5",
        "--json",
        "-q",
    ]))
}

#[test]
fn sweep_bakes_what_bake_writes_in_each_mode() {
    // The sweep bakes no sampling shells: it evaluates at the sampling distance.
    let none = ["--shells", "0", "--far-shells", "none"];
    let default = eval_file(&bake_small(&none).pvis);
    let plain = eval_file(
        &bake_small(&[&none[..], &["--view-supersample", "0", "--probe", "off"]].concat()).pvis,
    );
    for (mode, file) in [("default", &default), ("plain", &plain)] {
        let point = sweep_point(mode);
        // Same bytes in the file (the rows compress to the same size only when they are the
        // same, as far as this test can tell) and the same answers on every view.
        for key in [
            "file_bytes",
            "culling_rate_mean",
            "missed_pixels_mean",
            "missed_patches_max",
            "identical_views",
        ] {
            assert_eq!(point[key], file[key], "{mode}: {key}");
        }
    }
    // Supersampling folds finer views in: never fewer patches, here strictly more.
    assert!(number(&default, "culling_rate_mean") < number(&plain, "culling_rate_mean"));
}
