//! `patchvis eval` end to end on the bundled bunny at small settings: the JSON report's fields
//! and ranges, determinism for a seed, zero missed pixels at the sampling positions, pictures,
//! paths, the sweep, and refusal of a file baked from another mesh.

mod common;

use common::{BUNNY, SMALL_QUIET, bake, json, number, patchvis, stderr};

const CUBE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/ply/cube.ply");

/// Per-view entries without their timings, which differ run to run.
fn views_without_timings(report: &serde_json::Value) -> Vec<serde_json::Value> {
    report["per_view"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| {
            let mut v = v.clone();
            let o = v.as_object_mut().unwrap();
            for key in ["full_ms", "culled_ms", "gpu_full_ms", "gpu_culled_ms"] {
                o.remove(key);
            }
            v
        })
        .collect()
}

#[test]
fn random_views_report_consistent_deterministic_json() {
    let baked = bake(&SMALL_QUIET);
    let pvis = baked.pvis_arg();
    let run = || {
        json(&patchvis(&[
            "eval", BUNNY, pvis, "--views", "8", "--seed", "3", "--json",
        ]))
    };
    let a = run();
    assert_eq!(a["views"], 8);
    assert_eq!(a["resolution"], 128);
    assert_eq!(a["patches"], 200);
    for key in [
        "culling_rate_mean",
        "culling_rate_max",
        "ideal_culling_rate_mean",
    ] {
        assert!((0.0..=1.0).contains(&number(&a, key)), "{key}");
    }
    // Patches exist behind the bunny from every side.
    assert!(number(&a, "culling_rate_mean") > 0.1);
    let per_view = a["per_view"].as_array().unwrap();
    assert_eq!(per_view.len(), 8);
    let identical = per_view.iter().filter(|v| v["missed_pixels"] == 0).count();
    assert_eq!(
        number(&a, "identical_views_fraction"),
        identical as f64 / 8.0
    );
    let missed: Vec<f64> = per_view
        .iter()
        .map(|v| number(v, "missed_pixels"))
        .collect();
    assert_eq!(
        number(&a, "missed_pixels_max"),
        missed.iter().copied().fold(0.0, f64::max)
    );
    assert!((number(&a, "missed_pixels_mean") - missed.iter().sum::<f64>() / 8.0).abs() < 1e-9);
    for v in per_view {
        // Infinite PSNR (null) exactly for identical views.
        assert_eq!(v["psnr_db"].is_null(), v["missed_pixels"] == 0, "{v}");
        assert!(number(v, "missed_pixels") <= number(v, "covered_pixels") + 128.0 * 128.0);
    }
    assert!(number(&a["frame_cost"], "speedup") > 0.0);
    assert_eq!(views_without_timings(&a), views_without_timings(&run()));
}

#[test]
fn the_sampling_positions_themselves_miss_nothing() {
    let baked = bake(&SMALL_QUIET);
    let pvis = baked.pvis_arg();
    let report = json(&patchvis(&[
        "eval",
        BUNNY,
        pvis,
        "--sampling-level",
        "2",
        "--json",
    ]));
    assert_eq!(report["views"], 66);
    assert_eq!(number(&report, "missed_pixels_max"), 0.0);
    assert_eq!(number(&report, "missed_patches_max"), 0.0);
    assert_eq!(number(&report, "identical_views_fraction"), 1.0);
    // Without a miss the answer holds the true set: culling is at most the ideal.
    for v in report["per_view"].as_array().unwrap() {
        assert!(number(v, "culling_rate") <= number(v, "ideal_culling_rate") + 1e-12);
    }
    let too_fine = patchvis(&["eval", BUNNY, pvis, "--sampling-level", "3"]);
    assert_eq!(too_fine.status.code(), Some(2));
}

#[test]
fn orbit_writes_frames_and_a_plot() {
    let baked = bake(&SMALL_QUIET);
    let pvis = baked.pvis_arg();
    let pics = baked.file("pics");
    let report = json(&patchvis(&[
        "eval",
        BUNNY,
        pvis,
        "--path",
        "orbit:6",
        "--distance-scale",
        "1.5",
        "--png",
        pics.to_str().unwrap(),
        "--worst",
        "2",
        "--json",
    ]));
    assert_eq!(report["views"], 6);
    let written: Vec<&str> = report["pictures"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap())
        .collect();
    assert_eq!(written.len(), 3, "{written:?}");
    for path in &written[..2] {
        let bytes = std::fs::read(path).unwrap();
        assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "{path}");
        // Three 128-px panels side by side: IHDR width 384, height 128.
        assert_eq!(&bytes[16..24], &[0, 0, 1, 128, 0, 0, 0, 128]);
    }
    let svg = std::fs::read_to_string(pics.join("path.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.matches("<polyline").count() == 4);

    // A path file with one camera (the first orbit eye) evaluates one frame; a bad line is
    // reported with its number.
    let eye = &report["per_view"][0]["eye"];
    let path_file = baked.file("cams.txt");
    std::fs::write(
        &path_file,
        format!("# one camera\n{} {} {}\n", eye[0], eye[1], eye[2]),
    )
    .unwrap();
    let from_file = json(&patchvis(&[
        "eval",
        BUNNY,
        pvis,
        "--path",
        path_file.to_str().unwrap(),
        "--json",
    ]));
    assert_eq!(from_file["views"], 1);
    std::fs::write(&path_file, "1 2\n").unwrap();
    let bad = patchvis(&["eval", BUNNY, pvis, "--path", path_file.to_str().unwrap()]);
    let err = stderr(&bad);
    assert_eq!(bad.status.code(), Some(1));
    assert!(err.contains("cams.txt: line 1"), "{err}");
}

#[test]
fn sweep_bakes_every_combination() {
    let dir = tempfile::tempdir().unwrap();
    let report = json(&patchvis(&[
        "eval",
        BUNNY,
        "--sweep",
        "--sweep-patches",
        "20,60",
        "--sweep-levels",
        "1,0",
        "--views",
        "4",
        "--resolution",
        "64",
        "--png",
        dir.path().to_str().unwrap(),
        "--json",
        "-q",
    ]));
    let points = report["points"].as_array().unwrap();
    let combos: Vec<(u64, u64, u64)> = points
        .iter()
        .map(|p| {
            (
                p["patches"].as_u64().unwrap(),
                p["level"].as_u64().unwrap(),
                p["sampling_views"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(combos, [(20, 0, 6), (20, 1, 18), (60, 0, 6), (60, 1, 18)]);
    for p in points {
        assert_eq!(p["views"], 4);
        assert!((0.0..=1.0).contains(&number(p, "culling_rate_mean")));
    }
    // More views cost more bytes.
    assert!(number(&points[1], "file_bytes") > number(&points[0], "file_bytes"));
    for name in ["sweep-levels.svg", "sweep-patches.svg"] {
        let svg = std::fs::read_to_string(dir.path().join(name)).unwrap();
        // Two panels, each with a metric and a size line per group of two.
        assert_eq!(svg.matches("<polyline").count(), 8, "{name}");
    }
}

#[test]
fn files_from_another_mesh_and_bad_flags_are_refused() {
    let baked = bake(&SMALL_QUIET);
    let pvis = baked.pvis_arg();
    let out = patchvis(&["eval", CUBE, pvis]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        err.contains("was not baked from") && err.trim_end().lines().count() == 1,
        "{err}"
    );
    for args in [
        vec!["eval", BUNNY],
        vec!["eval", BUNNY, pvis, "--views", "0"],
        vec!["eval", BUNNY, pvis, "--distance-scale", "-1"],
        vec!["eval", BUNNY, pvis, "--path", "orbit:0"],
    ] {
        let out = patchvis(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}
