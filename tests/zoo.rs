//! The model zoo through the CLI (issue 20): the bundled thin-part models (`assets/ant.ply`,
//! `assets/airplane.ply`) and the two generated ones (`patchvis gen --kind exposed-engine`,
//! `--kind truss`) bake and evaluate, and on every one of them the default fold (every finer
//! view's patches into every corner around it) misses no pixel that the thresholded
//! one-corner fold, the default before issue 20, shows — view by view, at the sampled
//! resolution and at twice it — for no more than the culling it gives up.
//!
//! Small settings (level 3 stored, level 4 folded in, 128² ID buffers, 200 patches) keep the
//! debug build fast; `cargo run --release --example zoo` measures the zoo at full size.

mod common;

use common::{json, number, patchvis};
use tempfile::TempDir;

const ASSETS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets");
const VIEWS: &str = "40";

/// Bakes `mesh` with the small settings plus `flags` into `dir/name`, and evaluates it at
/// 128² and 256² over the same seeded views; returns the two JSON reports.
fn bake_and_eval(dir: &TempDir, mesh: &str, name: &str, flags: &[&str]) -> [serde_json::Value; 2] {
    let pvis = dir.path().join(name);
    let pvis = pvis.to_str().unwrap();
    let mut args = vec![
        "bake",
        mesh,
        "-o",
        pvis,
        "-q",
        "--level",
        "3",
        "--resolution",
        "128",
        "--patches",
        "200",
    ];
    args.extend_from_slice(flags);
    let out = patchvis(&args);
    assert!(out.status.success(), "{name}: {}", common::stderr(&out));
    ["128", "256"].map(|resolution| {
        json(&patchvis(&[
            "eval",
            mesh,
            pvis,
            "--views",
            VIEWS,
            "--seed",
            "7",
            "--resolution",
            resolution,
            "--json",
        ]))
    })
}

/// Figure `key` of every view of an eval report.
fn per_view(report: &serde_json::Value, key: &str) -> Vec<f64> {
    report["per_view"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| number(v, key))
        .collect()
}

fn missed_per_view(report: &serde_json::Value) -> Vec<f64> {
    per_view(report, "missed_pixels")
}

/// `patchvis gen --kind KIND` at the small settings' size into `dir`; returns its path.
fn generated(dir: &TempDir, kind: &str) -> String {
    let path = dir.path().join(format!("{kind}.ply"));
    let path = path.to_str().unwrap().to_owned();
    let out = patchvis(&[
        "gen",
        "--kind",
        kind,
        "--triangles",
        "6000",
        "-o",
        &path,
        "-q",
    ]);
    assert!(out.status.success(), "{kind}: {}", common::stderr(&out));
    path
}

#[test]
fn every_zoo_model_loses_no_pixel_to_the_all_corner_fold() {
    let dir = TempDir::new().unwrap();
    let mut meshes = vec![
        ("ant", format!("{ASSETS}/ant.ply")),
        ("airplane", format!("{ASSETS}/airplane.ply")),
    ];
    for kind in ["exposed-engine", "truss"] {
        meshes.push((kind, generated(&dir, kind)));
    }
    let (mut missed_default, mut missed_thresholded, mut missed_probed) = (0.0, 0.0, 0.0);
    for (name, mesh) in &meshes {
        // The all-corner fold, without the probe pass.
        let default = bake_and_eval(&dir, mesh, &format!("{name}.pvis"), &["--probe", "off"]);
        let thresholded = bake_and_eval(
            &dir,
            mesh,
            &format!("{name}.t.pvis"),
            &[
                "--fold-min-pixels",
                "4",
                "--fold-corners",
                "one",
                "--probe",
                "off",
            ],
        );
        // Today's default: the probe pass and the cover fold.
        let probed = bake_and_eval(&dir, mesh, &format!("{name}.p.pvis"), &[]);
        for p in &probed {
            missed_probed += missed_per_view(p).iter().sum::<f64>();
            // The acceptance of the default on every model: mean ≤ 0.5, p99 ≤ 10.
            let (mean, p99) = (
                number(p, "missed_pixels_mean"),
                number(p, "missed_pixels_p99"),
            );
            assert!(mean <= 0.5 && p99 <= 10.0, "{name}: mean {mean}, p99 {p99}");
        }
        for (d, t) in default.iter().zip(&thresholded) {
            let resolution = &d["resolution"];
            // The default's rows hold the thresholded fold's (the one corner is one of all,
            // and every pixel holds the threshold's), so each view misses at most as much.
            missed_default += missed_per_view(d).iter().sum::<f64>();
            missed_thresholded += missed_per_view(t).iter().sum::<f64>();
            for (i, (a, b)) in missed_per_view(d)
                .iter()
                .zip(missed_per_view(t))
                .enumerate()
            {
                assert!(a <= &b, "{name} at {resolution}: view {i} misses {a} > {b}");
            }
            let culling = number(d, "culling_rate_mean");
            assert!(culling <= number(t, "culling_rate_mean"), "{name}");
            // A model where the bake finds nothing to cull would test nothing.
            assert!(number(d, "ideal_culling_rate_mean") > 0.0, "{name}");
        }
    }
    // The zoo exists because the thresholded fold misses thin parts: it must show that.
    assert!(
        missed_default < missed_thresholded,
        "the zoo shows no miss the all-corner fold removes ({missed_default} vs {missed_thresholded})"
    );
    // And the probe pass removes most of what the all-corner fold still misses.
    assert!(
        missed_probed < 0.5 * missed_default,
        "the probe pass removes too little ({missed_probed} vs {missed_default})"
    );
}

/// The split fold (`--conservative`'s) of the probe at 2 pixels against the all-corner fold
/// of the same rows and the default bake without its probe pass, view by view: its rows hold that bake's (what the views
/// showed goes to every corner, as there), so no view misses more; and they are held
/// by the all-corner fold's (the probe's additions go to one corner of those), so no view
/// culls less than with `--fold-corners all`.
#[test]
fn the_split_fold_culls_at_least_the_all_corner_fold_and_misses_no_more_than_the_default() {
    let dir = TempDir::new().unwrap();
    let meshes = [
        ("ant", format!("{ASSETS}/ant.ply")),
        ("airplane", format!("{ASSETS}/airplane.ply")),
        ("exposed-engine", generated(&dir, "exposed-engine")),
    ];
    let (mut culling_split, mut culling_all) = (0.0, 0.0);
    for (name, mesh) in &meshes {
        let default = bake_and_eval(&dir, mesh, &format!("{name}.pvis"), &["--probe", "off"]);
        let probe = ["--probe", "2", "--fold-corners"];
        let split = [&probe[..], &["split"]].concat();
        let split = bake_and_eval(&dir, mesh, &format!("{name}.s.pvis"), &split);
        let all = [&probe[..], &["all"]].concat();
        let all = bake_and_eval(&dir, mesh, &format!("{name}.a.pvis"), &all);
        for ((d, s), a) in default.iter().zip(&split).zip(&all) {
            let resolution = &d["resolution"];
            for (i, (s, d)) in missed_per_view(s)
                .iter()
                .zip(missed_per_view(d))
                .enumerate()
            {
                assert!(*s <= d, "{name} at {resolution}: view {i} misses {s} > {d}");
            }
            let culling = |r| per_view(r, "culling_rate");
            for (i, (s, a)) in culling(s).iter().zip(culling(a)).enumerate() {
                assert!(*s >= a, "{name} at {resolution}: view {i} culls {s} < {a}");
            }
            culling_split += number(s, "culling_rate_mean");
            culling_all += number(a, "culling_rate_mean");
        }
    }
    assert!(
        culling_split > culling_all,
        "the split fold culls nothing more ({culling_split} vs {culling_all})"
    );
}

/// The far band: cameras beyond the sampling distance are answered from shells out there
/// too, so at twice that distance no view misses more than a bake without it, and that
/// bake's misses there (rim it never saw) are gone.
#[test]
fn the_far_band_keeps_the_rim_that_cameras_beyond_the_sampling_distance_see() {
    let dir = TempDir::new().unwrap();
    let mesh = format!("{ASSETS}/ant.ply");
    let at_twice = |name: &str, flags: &[&str]| {
        let pvis = dir.path().join(name);
        let pvis = pvis.to_str().unwrap();
        let mut args = vec!["bake", &mesh, "-o", pvis, "-q", "--shells", "0"];
        args.extend(["--level", "3", "--resolution", "128", "--patches", "200"]);
        args.extend_from_slice(flags);
        let out = patchvis(&args);
        assert!(out.status.success(), "{name}: {}", common::stderr(&out));
        json(&patchvis(&[
            "eval",
            &mesh,
            pvis,
            "--views",
            VIEWS,
            "--seed",
            "7",
            "--resolution",
            "128",
            "--distance-scale",
            "2",
            "--json",
        ]))
    };
    let plain = at_twice("plain.pvis", &["--far-shells", "none"]);
    let far = at_twice("far.pvis", &[]);
    let (plain, far) = (missed_per_view(&plain), missed_per_view(&far));
    for (i, (f, p)) in far.iter().zip(&plain).enumerate() {
        assert!(f <= p, "view {i}: {f} > {p}");
    }
    let total = |m: &[f64]| m.iter().sum::<f64>();
    assert!(
        total(&plain) > 0.0,
        "the plain bake misses nothing at twice the distance"
    );
    assert_eq!(total(&far), 0.0, "{far:?}");
}
