//! `patchvis bake --view-supersample` end to end on the bundled bunny at small settings: the
//! file keeps the stored level's views, each row contains the plain bake's row of that view,
//! the rows are exactly the fold of a plain bake at the finer level (with `--fold-min-pixels`:
//! of a thresholded one into the plain stored rows), the defaults and `--conservative` are the
//! flag combinations they are documented as, the stats record it, and out-of-range values are
//! usage errors.

mod common;

use common::{BUNNY, patchvis};
use patchvis::runtime::Pvis;
use patchvis::sampler::{
    FoldCorners, VisibilityMatrix, fold_into, fold_into_with, supersample_rows,
};
use patchvis::sphere::view_count;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Bakes the bunny in 100 patches at 64 px (unless `extra` sets `--resolution`) with `extra`
/// flags; returns the output path. Patches keep the tiling's numbering, so that rows of
/// bakes with different options compare patch for patch.
fn bake(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let pvis = dir.join(name);
    let mut args = vec![
        "bake",
        BUNNY,
        "-o",
        pvis.to_str().unwrap(),
        "--patches",
        "100",
        "--patch-order",
        "spatial",
        "-q",
    ];
    if !extra.contains(&"--resolution") {
        args.extend_from_slice(&["--resolution", "64"]);
    }
    args.extend_from_slice(extra);
    let out = patchvis(&args);
    assert!(
        out.status.success(),
        "bake {extra:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    pvis
}

/// All rows of a `.pvis` file as a matrix.
fn rows(path: &Path) -> (u32, VisibilityMatrix) {
    let bytes = std::fs::read(path).unwrap();
    let pvis = Pvis::parse(&bytes).unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
    let level = pvis.sampling().level;
    let mut m = VisibilityMatrix::new(view_count(level), pvis.patch_count());
    let mut row = vec![0u64; pvis.row_words()];
    for v in 0..view_count(level) {
        pvis.view_row(v, &mut row);
        m.row_mut(v).copy_from_slice(&row);
    }
    (level, m)
}

#[test]
fn supersampled_rows_contain_the_plain_rows_and_fold_the_finer_bake() {
    let dir = tempfile::tempdir().unwrap();
    let stats = dir.path().join("stats.json");
    let ss = bake(
        dir.path(),
        "ss.pvis",
        &[
            "--level",
            "1",
            "--view-supersample",
            "1",
            "--fold-min-pixels",
            "0",
            "--fold-corners",
            "all",
            "--stats",
            stats.to_str().unwrap(),
        ],
    );
    let plain = bake(
        dir.path(),
        "plain.pvis",
        &["--level", "1", "--view-supersample", "0"],
    );
    let fine = bake(
        dir.path(),
        "fine.pvis",
        &["--level", "2", "--view-supersample", "0"],
    );

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

    let report: Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(report["view_supersample"], 1);
    assert_eq!(report["sampled_views"], view_count(2));
    assert_eq!(report["views"], view_count(1));
    // The fine pass's checkpoint is removed once the output is complete.
    assert!(!dir.path().join("ss.pvis.vs1.ckpt").exists());
}

#[test]
fn a_fold_threshold_folds_the_thresholded_finer_rows_into_the_plain_stored_rows() {
    let dir = tempfile::tempdir().unwrap();
    let stats = dir.path().join("stats.json");
    let ss = bake(
        dir.path(),
        "ss.pvis",
        &[
            "--level",
            "1",
            "--view-supersample",
            "1",
            "--fold-min-pixels",
            "6",
            "--fold-corners",
            "all",
            "--stats",
            stats.to_str().unwrap(),
        ],
    );
    let plain = bake(
        dir.path(),
        "plain.pvis",
        &["--level", "1", "--view-supersample", "0"],
    );
    let fine = bake(
        dir.path(),
        "fine.pvis",
        &[
            "--level",
            "2",
            "--view-supersample",
            "0",
            "--min-pixels",
            "6",
        ],
    );
    let untouched = bake(
        dir.path(),
        "all.pvis",
        &[
            "--level",
            "1",
            "--view-supersample",
            "1",
            "--fold-min-pixels",
            "0",
            "--fold-corners",
            "all",
        ],
    );
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
    let report: Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert_eq!(report["fold_min_pixels"], 6);
    assert_eq!(report["sampled_views"], view_count(2) + view_count(1));
    // Both passes' checkpoints are removed once the output is complete.
    assert!(!dir.path().join("ss.pvis.vs1.m6.ckpt").exists());
    assert!(!dir.path().join("ss.pvis.ckpt").exists());
}

#[test]
fn one_fold_corner_folds_each_finer_row_into_one_stored_view() {
    let dir = tempfile::tempdir().unwrap();
    let one = bake(
        dir.path(),
        "one.pvis",
        &[
            "--level",
            "1",
            "--view-supersample",
            "1",
            "--fold-min-pixels",
            "0",
        ]
        .into_iter()
        .chain(["--fold-corners", "one"])
        .collect::<Vec<_>>(),
    );
    let fine = bake(
        dir.path(),
        "fine.pvis",
        &["--level", "2", "--view-supersample", "0"],
    );
    let (_, one_rows) = rows(&one);
    let (fine_level, fine_rows) = rows(&fine);
    let mut prefix = VisibilityMatrix::new(view_count(1), fine_rows.patches());
    for v in 0..view_count(1) {
        prefix.row_mut(v).copy_from_slice(fine_rows.row(v));
    }
    let all = fold_into(prefix.clone(), &fine_rows, fine_level, 1);
    assert_eq!(
        fold_into_with(prefix, &fine_rows, fine_level, 1, FoldCorners::One),
        one_rows
    );
    assert_ne!(all, one_rows, "one corner folded as much as all corners");
}

#[test]
fn defaults_and_conservative_are_the_documented_flag_combinations() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = |p: PathBuf| std::fs::read(p).unwrap();
    // Default: one level of view supersampling, a 4-pixel fold threshold, one fold corner.
    let default = bake(dir.path(), "default.pvis", &["--level", "1"]);
    let spelled = bake(
        dir.path(),
        "spelled.pvis",
        &[
            "--level",
            "1",
            "--view-supersample",
            "1",
            "--fold-min-pixels",
            "4",
            "--fold-corners",
            "one",
        ],
    );
    assert_eq!(bytes(default), bytes(spelled));
    // --conservative at 32 px: ID buffers of 64 px, every finer patch folded.
    let conservative = bake(
        dir.path(),
        "conservative.pvis",
        &["--level", "1", "--conservative", "--resolution", "32"],
    );
    let spelled = bake(
        dir.path(),
        "spelled-conservative.pvis",
        &[
            "--level",
            "1",
            "--view-supersample",
            "1",
            "--fold-min-pixels",
            "0",
            "--fold-corners",
            "all",
        ],
    );
    let conservative = bytes(conservative);
    assert_eq!(conservative, bytes(spelled));
    assert_eq!(
        Pvis::parse(&conservative).unwrap().sampling().resolution,
        64
    );
}

#[test]
fn out_of_range_supersampling_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.pvis");
    for (level, k) in [("1", "3"), ("6", "2")] {
        let o = patchvis(&[
            "bake",
            BUNNY,
            "-o",
            out.to_str().unwrap(),
            "--level",
            level,
            "--view-supersample",
            k,
            "-q",
        ]);
        assert!(!o.status.success(), "--level {level} K {k} accepted");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("--view-supersample"), "{err}");
        assert!(!out.exists());
    }
}
