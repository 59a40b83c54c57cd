//! Sharded bakes through the binary (issue 25): `patchvis tile`, `bake --shard I/N` and
//! `merge` give the single bake's bytes for any thread count and part order, with the
//! default supersampling fold and with a thresholded one (two passes), with the default
//! sampling shells and with others (issue 22); `--shard auto` reads a Slurm array's or a
//! Kubernetes Indexed Job's environment; and merge refuses, in one line with exit code 1, a
//! missing, repeated, foreign, truncated, damaged or older part.

mod common;

use common::{BUNNY, patchvis, patchvis_with_env, stderr};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use tempfile::TempDir;

/// The ant (pyvista's example mesh): "another mesh".
const ANT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/ant.ply");

fn ok(out: Output) -> Output {
    assert!(out.status.success(), "failed: {}", stderr(&out));
    out
}

fn s(path: &Path) -> &str {
    path.to_str().expect("a UTF-8 temporary path")
}

/// A run that must fail with `code` and one line on stderr containing each of `needles`.
fn refused(out: Output, code: i32, needles: &[&str]) {
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(code), "stderr: {err}");
    assert_eq!(err.lines().count(), 1, "one line expected: {err}");
    assert!(err.starts_with("error: "), "{err}");
    for needle in needles {
        assert!(err.contains(needle), "expected {needle:?} in: {err}");
    }
}

/// A sharded bake of `mesh` with `flags` in `dir`: the tiling file, then shard `i` of
/// `count` on `threads(i)` threads; returns the part paths.
fn shards(
    dir: &Path,
    mesh: &str,
    flags: &[&str],
    count: u32,
    threads: impl Fn(u32) -> u32,
) -> Vec<PathBuf> {
    let tiling = dir.join("t.ptile");
    let patches = flags
        .iter()
        .position(|&f| f == "--patches")
        .map(|i| flags[i + 1]);
    let mut tile = vec!["tile", mesh, "-o", s(&tiling), "-q"];
    if let Some(p) = patches {
        tile.extend(["--patches", p]);
    }
    ok(patchvis(&tile));
    (0..count)
        .map(|i| {
            let part = dir.join(format!("part-{i}.ppart"));
            let shard = format!("{i}/{count}");
            let mut args = vec!["bake", mesh, "-o", s(&part), "--tiling-file", s(&tiling)];
            args.extend(["--shard", &shard, "-q"]);
            args.extend(flags);
            let threads = threads(i).to_string();
            ok(patchvis_with_env(&args, &[("RAYON_NUM_THREADS", &threads)]));
            part
        })
        .collect()
}

/// `patchvis merge PARTS -o OUT` (quiet).
fn merge(parts: &[&Path], out: &Path) -> Output {
    let mut args = vec!["merge", "-o", s(out), "-q"];
    args.extend(parts.iter().map(|p| s(p)));
    patchvis(&args)
}

/// `patchvis merge PARTS -o OUT`, with its summary.
fn merge_loud(parts: &[&Path], out: &Path) -> Output {
    let mut args = vec!["merge", "-o", s(out)];
    args.extend(parts.iter().map(|p| s(p)));
    patchvis(&args)
}

/// The single bake of the bunny with `flags` on `threads` threads.
fn single(dir: &Path, flags: &[&str], threads: &str) -> Vec<u8> {
    let out = dir.join("single.pvis");
    let mut args = vec!["bake", BUNNY, "-o", s(&out), "-q"];
    args.extend(flags);
    ok(patchvis_with_env(&args, &[("RAYON_NUM_THREADS", threads)]));
    std::fs::read(out).unwrap()
}

/// The default fold (one finer level, every corner) at a small level and resolution: four
/// shards on one and two threads, merged in two orders, equal the single bake on two threads.
#[test]
fn four_shards_merge_into_the_single_bake_in_any_order() {
    let dir = TempDir::new().unwrap();
    let flags = ["--patches", "300", "--level", "3", "--resolution", "128"];
    let parts = shards(dir.path(), BUNNY, &flags, 4, |i| 1 + i % 2);
    let expected = single(dir.path(), &flags, "2");
    let out = dir.path().join("merged.pvis");
    for order in [[0, 1, 2, 3], [2, 0, 3, 1]] {
        let given: Vec<&Path> = order.iter().map(|&i| parts[i].as_path()).collect();
        ok(merge(&given, &out));
        assert!(
            std::fs::read(&out).unwrap() == expected,
            "merge in order {order:?} differs from the single bake"
        );
    }
    // A shard that tiles for itself writes the same part as one reading the tiling file.
    let own = dir.path().join("own.ppart");
    let mut args = vec!["bake", BUNNY, "-o", s(&own), "--shard", "1/4", "-q"];
    args.extend(flags);
    ok(patchvis(&args));
    assert!(std::fs::read(&own).unwrap() == std::fs::read(&parts[1]).unwrap());
}

/// A fold threshold samples two passes, for the sampling sphere and for each of two shells
/// at a level of their own; `--shard auto` takes the shard from a Slurm array's or a
/// Kubernetes Indexed Job's environment.
#[test]
fn two_passes_and_scheduler_shards_merge_into_the_single_bake() {
    let dir = TempDir::new().unwrap();
    let flags = [
        "--patches",
        "150",
        "--level",
        "2",
        "--resolution",
        "96",
        "--fold-min-pixels",
        "4",
        "--shells",
        "2",
        "--shell-level",
        "1",
    ];
    let tiling = dir.path().join("t.ptile");
    ok(patchvis(&[
        "tile",
        BUNNY,
        "-o",
        s(&tiling),
        "--patches",
        "150",
        "-q",
    ]));
    let environments: [&[(&str, &str)]; 3] = [
        &[
            ("SLURM_ARRAY_TASK_ID", "0"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ],
        &[
            ("SLURM_ARRAY_TASK_ID", "11"),
            ("SLURM_ARRAY_TASK_MIN", "10"),
            ("SLURM_ARRAY_TASK_MAX", "12"),
        ],
        &[("JOB_COMPLETION_INDEX", "2"), ("PATCHVIS_SHARD_COUNT", "3")],
    ];
    let parts: Vec<PathBuf> = environments
        .iter()
        .enumerate()
        .map(|(i, env)| {
            let part = dir.path().join(format!("p{i}.ppart"));
            let mut args = vec!["bake", BUNNY, "-o", s(&part), "--shard", "auto", "-q"];
            args.extend(["--tiling-file", s(&tiling)]);
            args.extend(flags);
            ok(patchvis_with_env(&args, env));
            part
        })
        .collect();
    let out = dir.path().join("merged.pvis");
    let merged = ok(merge_loud(&[&parts[2], &parts[0], &parts[1]], &out));
    let summary = common::stdout(&merged);
    assert!(
        summary.contains("merged 3 shards: 66 views, 150 patches, 4 sampling shells"),
        "{summary}"
    );
    assert!(std::fs::read(&out).unwrap() == single(dir.path(), &flags, "1"));
}

/// Three shards of a bake of the bunny with `flags`, on one and two threads, merge into the
/// single bake; returns its bytes.
fn three_shards_merge_into_the_single_bake(dir: &Path, flags: &[&str]) -> Vec<u8> {
    let parts = shards(dir, BUNNY, flags, 3, |i| 1 + i % 2);
    let out = dir.join("merged.pvis");
    let given: Vec<&Path> = parts.iter().map(|p| p.as_path()).collect();
    ok(merge(&given, &out));
    let single = single(dir, flags, "2");
    assert!(std::fs::read(&out).unwrap() == single);
    single
}

/// `--conservative` at a small level and resolution, with one shell.
const CONSERVATIVE: [&str; 9] = [
    "--patches",
    "120",
    "--level",
    "2",
    "--resolution",
    "64",
    "--conservative",
    "--shells",
    "1",
];

/// `--conservative`'s split fold with the finer level's vertices for finer views: each pass's
/// rows before the probe travel as a second pass, for the sampling sphere and a shell; three
/// shards on one and two threads merge into the single bake.
#[test]
fn conservative_split_passes_merge_into_the_single_bake() {
    let dir = TempDir::new().unwrap();
    let mut flags = CONSERVATIVE.to_vec();
    flags.extend_from_slice(&["--finer-views", "midpoints"]);
    three_shards_merge_into_the_single_bake(dir.path(), &flags);
}

/// `--conservative`'s centroid finer views: the sampling sphere's finer pass renders the
/// stored faces' centroids (its shell the finer vertices); three shards, each rendering its
/// centroids and the corners seeding them, merge into the single bake, which is not the
/// midpoints'.
#[test]
fn centroid_finer_views_merge_into_the_single_bake() {
    let dir = TempDir::new().unwrap();
    let centroids = three_shards_merge_into_the_single_bake(dir.path(), &CONSERVATIVE);
    let mut midpoints = CONSERVATIVE.to_vec();
    midpoints.extend_from_slice(&["--finer-views", "midpoints"]);
    assert!(
        single(dir.path(), &midpoints, "2") != centroids,
        "the finer views changed nothing"
    );
}

/// Every refusal is one line with exit code 1 (2 for a usage error), naming the file at fault.
#[test]
fn merge_refuses_missing_repeated_foreign_and_damaged_parts() {
    let dir = TempDir::new().unwrap();
    let d = dir.path();
    let flags = ["--patches", "100", "--level", "2", "--resolution", "64"];
    let parts = shards(d, BUNNY, &flags, 4, |_| 2);
    let p: Vec<&Path> = parts.iter().map(PathBuf::as_path).collect();
    let out = d.join("out.pvis");
    refused(merge(&p[..3], &out), 1, &["shard 3/4 is missing"]);
    let again = [p[0], p[1], p[2], p[2]];
    refused(
        merge(&again, &out),
        1,
        &[s(p[2]), "shard 2/4 is given twice"],
    );
    // Shard 3 of another mesh, and of other settings.
    let bake3 = |mesh: &str, name: &str, extra: &[&str]| {
        let part = d.join(name);
        let mut args = vec!["bake", mesh, "-o", s(&part), "--shard", "3/4", "-q"];
        args.extend(flags);
        args.extend(extra);
        ok(patchvis(&args));
        part
    };
    let ant = bake3(ANT, "ant-3.ppart", &[]);
    refused(
        merge(&[p[0], p[1], p[2], &ant], &out),
        1,
        &[s(&ant), "from another mesh"],
    );
    let other = bake3(
        BUNNY,
        "other-3.ppart",
        &["--min-pixels", "2", "--probe", "off"],
    );
    refused(
        merge(&[p[0], p[1], p[2], &other], &out),
        1,
        &[s(&other), "other settings"],
    );
    // Other sampling shells are other settings too.
    let shells = bake3(BUNNY, "shells-3.ppart", &["--shells", "1"]);
    refused(
        merge(&[p[0], p[1], p[2], &shells], &out),
        1,
        &[s(&shells), "other settings"],
    );
    // Cut short, and one bit flipped.
    let bytes = std::fs::read(p[3]).unwrap();
    let cut = d.join("cut-3.ppart");
    std::fs::write(&cut, &bytes[..bytes.len() - 100]).unwrap();
    refused(
        merge(&[p[0], p[1], p[2], &cut], &out),
        1,
        &[s(&cut), "damaged or cut short"],
    );
    let mut flipped = bytes.clone();
    flipped[bytes.len() / 2] ^= 0x10;
    let bad = d.join("bad-3.ppart");
    std::fs::write(&bad, &flipped).unwrap();
    refused(
        merge(&[p[0], p[1], p[2], &bad], &out),
        1,
        &[s(&bad), "checksum mismatch"],
    );
    // A part of the layout before sampling shells (version 2).
    let mut old = bytes.clone();
    old[8..12].copy_from_slice(&2u32.to_le_bytes());
    let old_part = d.join("old-3.ppart");
    std::fs::write(&old_part, &old).unwrap();
    refused(
        merge(&[p[0], p[1], p[2], &old_part], &out),
        1,
        &[
            s(&old_part),
            "part file version 2, expected 10",
            "bake this shard again",
        ],
    );
    // An output that is one of the parts is a usage error, before anything is read.
    refused(merge(&p, p[3]), 2, &["-o", s(p[3])]);
    assert!(std::fs::read(p[3]).unwrap() == bytes);
    assert!(!out.exists(), "a refused merge wrote {}", out.display());
    // A tiling file of another mesh, and --shard auto outside a scheduler.
    let ant_tiling = d.join("ant.ptile");
    ok(patchvis(&[
        "tile",
        ANT,
        "-o",
        s(&ant_tiling),
        "--patches",
        "100",
        "-q",
    ]));
    let part = d.join("x.ppart");
    let mut args = vec!["bake", BUNNY, "-o", s(&part), "--shard", "0/4", "-q"];
    args.extend(["--tiling-file", s(&ant_tiling)]);
    args.extend(flags);
    refused(patchvis(&args), 1, &[s(&ant_tiling), "tiles another mesh"]);
    let auto = Command::new(env!("CARGO_BIN_EXE_patchvis"))
        .args(["bake", BUNNY, "-o", s(&part), "--shard", "auto", "-q"])
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .output()
        .unwrap();
    refused(auto, 2, &["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"]);
    refused(
        patchvis(&["bake", BUNNY, "-o", s(&part), "--shard", "4/4"]),
        2,
        &["--shard 4/4"],
    );
    assert!(!part.exists());
}
