//! `patchvis eval` end to end on the bundled bunny at small settings: the JSON report's fields
//! and ranges, determinism for a seed, zero missed pixels at the sampling positions, pictures,
//! paths, the sweep, distance bands (a row each, equal to single runs; near eyes) and refusal
//! of a file baked from another mesh or of bad flags.

mod common;

use common::{BUNNY, SMALL_QUIET, bake, json, number, patchvis, stderr, stdout};

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

/// The figures do not depend on how the bake numbered the patches. The airplane's small
/// patches often share a quantised record (its file stores no triangle ids), and `eval`
/// finds them in the original mesh in tiling order, which the bake keeps them in.
#[test]
fn the_patch_order_does_not_change_the_figures() {
    let airplane = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/airplane.ply");
    let dir = tempfile::tempdir().unwrap();
    let reports = ["spatial", "covisibility"].map(|order| {
        let pvis = dir.path().join(format!("{order}.pvis"));
        let pvis = pvis.to_str().unwrap();
        let out = patchvis(&[
            "bake",
            airplane,
            "-o",
            pvis,
            "-q",
            "--shells",
            "0",
            "--level",
            "2",
            "--resolution",
            "128",
            "--patches",
            "1000",
            "--patch-order",
            order,
            // Without the probe pass, so that some views miss pixels.
            "--probe",
            "off",
        ]);
        assert!(out.status.success(), "{order}: {}", stderr(&out));
        let report = json(&patchvis(&[
            "eval",
            airplane,
            pvis,
            "--views",
            "60",
            "--seed",
            "5",
            "--resolution",
            "128",
            "--json",
        ]));
        views_without_timings(&report)
    });
    let missed: u64 = reports[0]
        .iter()
        .map(|v| v["missed_pixels"].as_u64().unwrap())
        .sum();
    assert!(missed > 0, "no view misses a pixel: the test shows nothing");
    assert_eq!(reports[0], reports[1]);
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

/// A report's figures without what varies from run to run (timings) or names the run
/// (pictures, the distance list).
fn figures(report: &serde_json::Value) -> serde_json::Value {
    let mut v = report.clone();
    let o = v.as_object_mut().unwrap();
    for key in [
        "per_view",
        "frame_cost",
        "seconds",
        "pictures",
        "mesh",
        "file",
        "mode",
        "seed",
        "look_jitter_deg",
        "resolution",
        "patches",
        "triangles",
        "level",
        "sampling_views",
        "file_bytes",
        "frame_backend",
        "frame_backend_reason",
        "frame_cost_gpu",
    ] {
        o.remove(key);
    }
    o.insert(
        "per_view".into(),
        serde_json::Value::Array(views_without_timings(report)),
    );
    v
}

#[test]
fn distance_bands_give_a_row_each_equal_to_single_runs() {
    let baked = bake(&SMALL_QUIET);
    let pvis = baked.pvis_arg();
    let common = [
        "eval",
        BUNNY,
        pvis,
        "--views",
        "5",
        "--seed",
        "3",
        "--look-jitter",
        "25",
        "-q",
    ];
    let run = |extra: &[&str]| patchvis(&[&common[..], extra].concat());
    let scales = ["0.45", "1.5", "0.8"];
    let banded = json(&run(&["--distance-scale", "0.45,1.5,0.8", "--json"]));
    let bands = banded["bands"].as_array().unwrap();
    assert_eq!(bands.len(), 3);
    assert_eq!(banded["views_per_band"], 5);
    let radius = 33.54217529296875f64;
    for (band, scale) in bands.iter().zip(scales) {
        let scale: f64 = scale.parse().unwrap();
        // In the order given, each with its distance in sampling distances and radii.
        assert!((number(band, "distance_scale") - scale).abs() < 1e-6);
        let radii = number(band, "distance") / radius;
        assert!((number(band, "distance_radii") - radii).abs() < 1e-9);
        assert!((radii - scale / (22.5f64).to_radians().sin()).abs() < 1e-4);
        let per_view = band["per_view"].as_array().unwrap();
        assert_eq!(per_view.len(), 5);
        let answered = per_view
            .iter()
            .filter(|v| v["inside_sphere"] == false)
            .count();
        assert_eq!(number(band, "answered_views"), answered as f64);
        // The default bake's sampling shells answer every eye from 1.1 radii out (a
        // version-4 file flagged every eye inside its sampling sphere).
        assert_eq!(answered, 5, "x{scale}");
        for v in per_view {
            assert_eq!(v["frustum_lost_patches"], 0);
            // The ideal in all directions sees at least what the camera's own render shows.
            assert!(
                number(v, "ideal_culling_rate_all_directions")
                    <= number(v, "ideal_culling_rate") + 1e-12
            );
            assert!(number(v, "visible_patches_all_directions") >= number(v, "visible_patches"));
        }
        for key in [
            "identical_views_fraction",
            "missed_pixels_mean",
            "missed_pixels_p99",
            "missed_pixels_max",
            "culling_rate_mean",
            "frustum_culling_rate_mean",
            "ideal_culling_rate_mean",
            "ideal_culling_rate_all_directions_mean",
        ] {
            assert!(band[key].is_number(), "{key}");
        }
        // Each band is the single-distance run at its scale, figure for figure.
        let single = json(&run(&["--distance-scale", &scale.to_string(), "--json"]));
        assert_eq!(figures(band), figures(&single), "x{scale}");
    }
    // At 0.45 the eye is 1.18 radii from the centre: the 45° camera sees part of the bunny,
    // the eye sees much more of it.
    let near = &bands[0];
    assert!(
        number(near, "ideal_culling_rate_all_directions_mean")
            < number(near, "ideal_culling_rate_mean") - 0.1
    );

    // The table: a row per distance, in order, and what the columns compare.
    let text = stdout(&run(&["--distance-scale", "0.45,1.5,0.8"]));
    let rows: Vec<&str> = text.lines().filter(|l| l.starts_with("| x")).collect();
    assert_eq!(rows.len(), 3, "{text}");
    for (row, (scale, answered)) in
        rows.iter()
            .zip([("0.45", "5/5"), ("1.5", "5/5"), ("0.8", "5/5")])
    {
        assert!(row.starts_with(&format!("| x{scale} | ")), "{row}");
        assert!(row.contains(&format!(" | {answered} | ")), "{row}");
    }
    assert!(text.contains("ideal, all directions") && text.contains("ideal in frustum"));
}

#[test]
fn distance_bands_write_their_pictures_and_stats() {
    let baked = bake(&SMALL_QUIET);
    let pvis = baked.pvis_arg();
    let pics = baked.file("bands");
    let stats = baked.file("stats.json");
    let report = json(&patchvis(&[
        "eval",
        BUNNY,
        pvis,
        "--views",
        "3",
        "--distance-scale",
        "0.6,1",
        "--png",
        pics.to_str().unwrap(),
        "--worst",
        "1",
        "--stats",
        stats.to_str().unwrap(),
        "--json",
        "-q",
    ]));
    let bands = report["bands"].as_array().unwrap();
    for (band, scale) in bands.iter().zip(["0.6", "1"]) {
        let pictures = band["pictures"].as_array().unwrap();
        assert_eq!(pictures.len(), 1);
        let name = pictures[0].as_str().unwrap();
        assert!(name.contains(&format!("view-x{scale}-")), "{name}");
        assert!(std::fs::read(name).unwrap().starts_with(b"\x89PNG"));
    }
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    let rows = stats["bands"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    for (row, band) in rows.iter().zip(bands) {
        for key in [
            "distance_scale",
            "answered_views",
            "culling_rate_mean",
            "frustum_culling_rate_mean",
            "ideal_culling_rate_mean",
            "ideal_culling_rate_all_directions_mean",
        ] {
            assert_eq!(row[key], band[key], "{key}");
        }
    }
}

#[test]
fn an_eye_inside_a_patch_bound_evaluates() {
    // The eye at the centre of patch 0's bounding sphere, looking at the model's centre:
    // parts of the mesh are right at the eye, behind it and beside it.
    let baked = bake(&SMALL_QUIET);
    let bytes = baked.bytes();
    let file = patchvis::runtime::Pvis::parse(&bytes).unwrap();
    let [x, y, z] = file.patch(0).center;
    let [cx, cy, cz] = file.sampling().center;
    let cams = baked.file("inside.txt");
    std::fs::write(&cams, format!("{x} {y} {z} {cx} {cy} {cz}\n")).unwrap();
    let report = json(&patchvis(&[
        "eval",
        BUNNY,
        baked.pvis_arg(),
        "--path",
        cams.to_str().unwrap(),
        "--json",
        "-q",
    ]));
    let view = &report["per_view"][0];
    assert_eq!(view["inside_sphere"], true);
    assert_eq!(view["frustum_lost_patches"], 0);
    assert!(number(view, "covered_pixels") > 0.0);
    // Every direction around an eye inside the model's bound shows more than one view does.
    assert!(number(view, "visible_patches_all_directions") > number(view, "visible_patches"));
}

#[test]
fn bad_distance_lists_are_usage_errors() {
    let baked = bake(&SMALL_QUIET);
    let pvis = baked.pvis_arg();
    for (list, says) in [
        ("", "an empty item"),
        ("0.45,", "an empty item"),
        ("0,1", "0 is not a positive number"),
        ("-1", "-1 is not a positive number"),
        ("0.5,NaN", "NaN is not a positive number"),
        ("inf", "inf is not a positive number"),
        ("0.6,x", "x is not a positive number"),
        ("1,0.6,1", "1 is listed twice"),
    ] {
        let out = patchvis(&["eval", BUNNY, pvis, "--distance-scale", list]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{list}: {err}");
        assert!(
            err.contains("--distance-scale") && err.contains(says),
            "{list}: {err}"
        );
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    }
    for mode in [&["--path", "orbit:4"][..], &["--sweep"]] {
        let out = patchvis(&[&["eval", BUNNY, pvis, "--distance-scale", "0.5,1"], mode].concat());
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{mode:?}");
        assert!(err.contains("not supported with"), "{err}");
    }
}
