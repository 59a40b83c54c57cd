//! `patchvis bake --view-supersample` end to end on the bundled bunny at small settings: the
//! file keeps the stored level's views, each row contains the plain bake's row of that view,
//! the rows are exactly the fold of a plain bake at the finer level (with `--fold-min-pixels`:
//! of a thresholded one into the plain stored rows), the default is the flag combination it is
//! documented as, and so is `--conservative`, whose rows hold more than the plain bake's,
//! the stats record it, and out-of-range values are usage errors. The fold's tests sample
//! plainly (`--probe off`) unless they ask for a probe, and keep the rows as sampled
//! (`--sampled-rows`): the fold is what they check. The default's rows are those saturated.

mod common;

use common::{Bake, Baked, stderr};
use patchvis::runtime::Pvis;
use patchvis::sampler::{
    FoldCorners, VisibilityMatrix, fold_into, fold_into_with, saturate, supersample_rows,
};
use patchvis::sphere::view_count;

/// The bake of the bunny in 100 patches at 64 px (unless `extra` sets `--resolution`) with
/// `extra` flags, and `--probe off` unless `extra` has `--probe` or `--conservative`
/// ([`bake_default`] keeps the default's probe), and the rows as sampled. Patches keep the
/// tiling's numbering, so that rows of bakes with different options compare patch for patch.
fn bake_with(extra: &[&str]) -> Bake {
    let probe = extra.contains(&"--probe") || extra.contains(&"--conservative");
    bake_flags(extra, if probe { &[] } else { &["--probe", "off"] })
}

/// The default bake (its probe pass included) at [`bake_with`]'s settings.
fn bake_default(extra: &[&str]) -> Baked {
    bake_flags(extra, &[]).run()
}

fn bake_flags(extra: &[&str], probe: &[&str]) -> Bake {
    let mut flags = vec![
        "--patches",
        "100",
        "--patch-order",
        "spatial",
        "--sampled-rows",
        "-q",
    ];
    if !extra.contains(&"--resolution") {
        flags.extend_from_slice(&["--resolution", "64"]);
    }
    flags.extend_from_slice(extra);
    flags.extend_from_slice(probe);
    Bake::new(&flags)
}

/// [`bake_with`], run.
fn bake(extra: &[&str]) -> Baked {
    bake_with(extra).run()
}

/// The sphere level and all rows of a bake.
/// The flags of a level-1 bake supersampled one level finer, folding finer patches of at least
/// `min_pixels` pixels into `corners`.
fn folded_level_1<'a>(min_pixels: &'a str, corners: &'a str) -> [&'a str; 8] {
    [
        "--level",
        "1",
        "--view-supersample",
        "1",
        "--fold-min-pixels",
        min_pixels,
        "--fold-corners",
        corners,
    ]
}

fn rows(baked: &Baked) -> (u32, VisibilityMatrix) {
    common::rows(&baked.bytes())
}

#[test]
fn supersampled_rows_contain_the_plain_rows_and_fold_the_finer_bake() {
    let ss = bake_with(&folded_level_1("0", "all")).stats().run();
    let plain = bake(&["--level", "1", "--view-supersample", "0"]);
    let fine = bake(&["--level", "2", "--view-supersample", "0"]);

    let (ss_level, ss_rows) = rows(&ss);
    let (_, plain_rows) = rows(&plain);
    let (fine_level, fine_rows) = rows(&fine);
    assert_eq!(ss_level, 1);
    assert_eq!(ss_rows.views(), view_count(1));
    assert_eq!(ss_rows.patches(), plain_rows.patches());

    let mut grew = 0;
    for v in 0..view_count(1) {
        let (s, p) = (ss_rows.row(v), plain_rows.row(v));
        assert!(
            s.iter().zip(p).all(|(&s, &p)| p & !s == 0),
            "view {v}: the supersampled row lacks patches of the plain row"
        );
        grew += usize::from(s != p);
    }
    // 18 views see the bunny from far apart: the finer views find patches the corners miss.
    assert!(grew > 0, "supersampling added nothing at level 1");
    // The supersampled bake samples exactly the views of a plain level-2 bake.
    assert_eq!(supersample_rows(&fine_rows, fine_level, 1), ss_rows);

    let report = ss.stats();
    assert_eq!(report["view_supersample"], 1);
    assert_eq!(report["sampled_views"], view_count(2));
    assert_eq!(report["views"], view_count(1));
    // The fine pass's checkpoint is removed once the output is complete.
    assert!(!ss.file("bunny.pvis.vs1.ckpt").exists());
}

/// `--finer-views centroids`: the finer views are level 1's 32 face centroids, each folded
/// into its face's corners; the rows hold the plain level-1 rows, differ from the midpoints'
/// fold, and the stats say how many views were sampled.
#[test]
fn centroid_finer_views_fold_the_face_centres_into_the_plain_rows() {
    let mut flags = folded_level_1("0", "all").to_vec();
    flags.extend_from_slice(&["--finer-views", "centroids"]);
    let centroids = bake_with(&flags).stats().run();
    let midpoints = bake(&folded_level_1("0", "all"));
    let plain = bake(&["--level", "1", "--view-supersample", "0"]);
    let (level, rows_c) = rows(&centroids);
    let (_, rows_m) = rows(&midpoints);
    let (_, rows_p) = rows(&plain);
    assert_eq!((level, rows_c.views()), (1, view_count(1)));
    for v in 0..view_count(1) {
        let (c, p) = (rows_c.row(v), rows_p.row(v));
        assert!(
            c.iter().zip(p).all(|(&c, &p)| p & !c == 0),
            "view {v}: the row lacks patches of the plain row"
        );
    }
    assert!(rows_c != rows_p, "the centroids added nothing at level 1");
    assert!(rows_c != rows_m, "the centroids folded as the midpoints");
    let report = centroids.stats();
    assert_eq!(report["finer_views"], "centroids");
    assert_eq!(report["sampled_views"], view_count(1) + 8 * 4);
    assert!(!centroids.file("bunny.pvis.vs1.centroids.ckpt").exists());
    // Centroids lie one level finer only.
    for k in ["0", "2"] {
        let baked =
            Bake::new(&["--view-supersample", k, "--finer-views", "centroids", "-q"]).attempt();
        assert_eq!(
            baked.output.status.code(),
            Some(2),
            "--view-supersample {k}"
        );
        let err = stderr(&baked.output);
        assert!(
            err.contains(&format!(
                "--finer-views centroids with --view-supersample {k}"
            )),
            "{err}"
        );
        assert!(!baked.pvis.exists());
    }
}

/// Without `--sampled-rows` a bake stores its rows saturated: each view's row is its row as
/// sampled plus every patch all the sphere faces around the view already answer, so every
/// query answers the same, and the file is smaller.
#[test]
fn default_rows_are_the_sampled_rows_saturated() {
    let flags = [
        "--patches",
        "100",
        "--patch-order",
        "spatial",
        "--resolution",
        "64",
        "--level",
        "2",
        "-q",
    ];
    let saturated = Bake::new(&flags).stats().run();
    let sampled = Bake::new(&flags).args(&["--sampled-rows"]).stats().run();
    let (level, sampled_rows) = rows(&sampled);
    let (_, saturated_rows) = rows(&saturated);
    assert_eq!(saturate(sampled_rows.clone(), level), saturated_rows);
    assert!(
        saturated_rows.count_ones() > sampled_rows.count_ones(),
        "saturating added nothing"
    );
    assert!(
        saturated.bytes().len() < sampled.bytes().len(),
        "{} bytes saturated, {} as sampled",
        saturated.bytes().len(),
        sampled.bytes().len()
    );
    assert_eq!(saturated.stats()["sampled_rows"], false);
    assert_eq!(sampled.stats()["sampled_rows"], true);
}

#[test]
fn a_fold_threshold_folds_the_thresholded_finer_rows_into_the_plain_stored_rows() {
    let ss = bake_with(&folded_level_1("6", "all")).stats().run();
    let plain = bake(&["--level", "1", "--view-supersample", "0"]);
    let fine = bake(&[
        "--level",
        "2",
        "--view-supersample",
        "0",
        "--min-pixels",
        "6",
    ]);
    let untouched = bake(&folded_level_1("0", "all"));
    let (_, ss_rows) = rows(&ss);
    let (_, plain_rows) = rows(&plain);
    let (fine_level, fine_rows) = rows(&fine);
    assert_eq!(fold_into(plain_rows, &fine_rows, fine_level, 1), ss_rows);
    // The threshold drops patches the unthresholded fold keeps, and never adds one.
    let (_, all_rows) = rows(&untouched);
    let (mut dropped, mut total) = (0u32, 0u32);
    for v in 0..view_count(1) {
        for (&t, &a) in ss_rows.row(v).iter().zip(all_rows.row(v)) {
            assert_eq!(t & !a, 0, "view {v}: the threshold added a patch");
            dropped += (a & !t).count_ones();
            total += a.count_ones();
        }
    }
    assert!(dropped > 0 && dropped < total, "{dropped} of {total}");
    let report = ss.stats();
    assert_eq!(report["fold_min_pixels"], 6);
    assert_eq!(report["sampled_views"], view_count(2) + view_count(1));
    // Both passes' checkpoints are removed once the output is complete.
    assert!(!ss.file("bunny.pvis.vs1.m6.ckpt").exists());
    assert!(!ss.file("bunny.pvis.ckpt").exists());
}

#[test]
fn one_fold_corner_folds_each_finer_row_into_one_stored_view() {
    let one = bake(&folded_level_1("0", "one"));
    let fine = bake(&["--level", "2", "--view-supersample", "0"]);
    let (_, one_rows) = rows(&one);
    let (fine_level, fine_rows) = rows(&fine);
    let prefix = fine_rows.prefix(view_count(1));
    let all = fold_into(prefix.clone(), &fine_rows, fine_level, 1);
    assert_eq!(
        fold_into_with(prefix, &fine_rows, fine_level, 1, FoldCorners::One),
        one_rows
    );
    assert_ne!(all, one_rows, "one corner folded as much as all corners");
}

#[test]
fn defaults_and_conservative_are_the_documented_flag_combinations() {
    // Default: one level of view supersampling, the probe pass at 1 pixel, the cover fold,
    // over the sampling sphere (`--probe 1`'s cells span the bands between spheres of views,
    // the default's lie at each sphere's own distance: no shells, near or far, here).
    let default = bake_default(&["--level", "1", "--shells", "0", "--far-shells", "none"]);
    let flags = [
        &folded_level_1("0", "cover")[..],
        &["--probe", "1", "--shells", "0", "--far-shells", "none"],
    ];
    assert_eq!(default.bytes(), bake_default(&flags.concat()).bytes());
    // Without the probe: every finer patch folded into every corner.
    let default = bake(&["--level", "1"]);
    let spelled = bake(&folded_level_1("0", "all"));
    assert_eq!(default.bytes(), spelled.bytes());
    // --conservative: the probe pass at 1 pixel with the split fold and the stored faces'
    // centroids for finer views, at the same resolution, shells included; its rows hold more
    // than the plain bake's.
    let conservative = bake(&["--level", "1", "--conservative"]);
    assert_eq!(
        Pvis::parse(&conservative.bytes())
            .unwrap()
            .sampling()
            .resolution,
        64
    );
    let ((level, probed), (_, plain)) = (rows(&conservative), rows(&default));
    assert_eq!(level, 1);
    assert!(probed.count_ones() > plain.count_ones());
    let centroids = ["--level", "1", "--finer-views", "centroids", "--probe", "1"];
    let spelled = bake(&[&centroids[..], &["--fold-corners", "split"]].concat());
    assert_eq!(spelled.bytes(), conservative.bytes());
    // --probe alone folds with the cover fold, which keeps fewer bits than the split fold of
    // the same rows.
    let (_, covered) = rows(&bake(&centroids));
    assert!(covered.count_ones() < probed.count_ones());
    // Unless --level is given, --conservative stores level 5, its shells, near and far,
    // level 4.
    let five = bake(&["--conservative", "--shells", "1", "--far-shells", "2"]).bytes();
    let file = Pvis::parse(&five).unwrap();
    assert_eq!(file.sampling().level, 5);
    assert_eq!(file.sampling_shell(), 1);
    let levels = [0, 1, 2].map(|s| file.shell(s).level);
    assert_eq!(levels, [4, 5, 4]);
}

#[test]
fn out_of_range_supersampling_is_a_usage_error() {
    for (level, k) in [("1", "3"), ("6", "2")] {
        let baked = Bake::new(&["--level", level, "--view-supersample", k, "-q"]).attempt();
        let o = &baked.output;
        assert!(!o.status.success(), "--level {level} K {k} accepted");
        let err = stderr(o);
        assert!(err.contains("--view-supersample"), "{err}");
        assert!(!baked.pvis.exists());
    }
}

#[test]
fn apertures_only_add_what_the_fm1_box_shows_through_its_holes() {
    // The sheet-metal box with holes: each view's probe opens the gaps between parts, and
    // the all-corner fold keeps every view's additions, so every row only grows.
    let fm1 = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/fm1_satellite.glb");
    let dir = tempfile::TempDir::new().unwrap();
    let baked = |more: &[&str]| {
        let out = dir.path().join(format!("fm1-{}.pvis", more.len()));
        let mut args = vec!["bake", fm1, "-o", common::path_str(&out), "-q"];
        args.extend([
            "--level",
            "1",
            "--resolution",
            "128",
            "--shells",
            "0",
            "--far-shells",
            "none",
            "--probe",
            "1",
            "--fold-corners",
            "all",
            "--sampled-rows",
            "--patches",
            "300",
            "--patch-order",
            "spatial",
        ]);
        args.extend(more);
        let run = common::patchvis(&args);
        assert!(run.status.success(), "{}", stderr(&run));
        common::rows(&std::fs::read(&out).unwrap()).1
    };
    let (plain, opened) = (baked(&[]), baked(&["--apertures", "2"]));
    let mut grew = 0;
    for v in 0..plain.views() {
        let (p, o) = (plain.row(v), opened.row(v));
        assert!(
            p.iter().zip(o).all(|(p, o)| p & !o == 0),
            "view {v} lost a patch"
        );
        grew += usize::from(p != o);
    }
    assert!(grew > 0, "no view saw anything more through the holes");
}
