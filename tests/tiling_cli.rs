//! `patchvis bake --tiling` through the binary (issue 4): both algorithms selectable, the
//! choice and the tiling quality reported in `--stats`, out-of-core bakes byte-identical for
//! any thread count, and `--mesh-out` written from the memory-mapped outputs.

mod common;

use common::{Bake, stdout};

/// Bakes the bunny into 300 patches with `--tiling mode --memory memory` on `threads`
/// threads; returns the `.pvis`, `--mesh-out` and parsed `--stats` files.
fn bake(mode: &str, memory: &str, threads: &str) -> (Vec<u8>, Vec<u8>, serde_json::Value) {
    let baked = Bake::new(&["--patches", "300", "--level", "1", "--resolution", "64"])
        .args(&["--tiling", mode, "--memory", memory])
        .env("RAYON_NUM_THREADS", threads)
        .mesh_out()
        .stats()
        .run();
    let stats = baked.stats();
    // The summary names the algorithm that ran, as the stats do.
    let summary = stdout(&baked.output);
    let algorithm = stats["tiling"]["algorithm"].as_str().expect("algorithm");
    assert!(
        summary.contains(&format!("({algorithm}, ")),
        "summary: {summary}"
    );
    (
        baked.bytes(),
        std::fs::read(baked.mesh_out()).unwrap(),
        stats,
    )
}

#[test]
fn both_tilings_bake_and_report_their_quality() {
    let (in_core, _, a) = bake("in-core", "64MiB", "2");
    assert_eq!(a["tiling"]["algorithm"], "in-core");
    assert_eq!(a["tiling"]["chunks"], 0);
    assert_eq!(a["tiling"]["components"], 1);
    assert_eq!(a["patches"], 300);

    // 8 MiB: chunks of about 15,700 triangles, so the bunny is tiled in 7 chunks.
    let (pvis1, mesh1, b) = bake("out-of-core", "8MiB", "1");
    let (pvis2, mesh2, _) = bake("out-of-core", "8MiB", "2");
    assert_eq!(b["tiling"]["algorithm"], "out-of-core");
    assert_eq!(b["tiling"]["chunks"], 7);
    assert_eq!(b["tiling"]["merged_components"], 0);
    assert!(
        pvis1 == pvis2 && mesh1 == mesh2,
        "thread count changed the bake"
    );
    assert_ne!(pvis1, in_core);

    let median = |s: &serde_json::Value| s["tiling"]["compactness"]["median"].as_f64().unwrap();
    let ratio = median(&b) / median(&a);
    assert!((0.85..1.15).contains(&ratio), "compactness ratio {ratio}");
    let sizes = &b["patch_triangles"];
    assert!(sizes["min"].as_u64() <= sizes["median"].as_u64());
    assert!(sizes["median"].as_u64() <= sizes["max"].as_u64());

    // Auto: the bunny's in-core estimate (16 MB) fits 64 MiB but not 8 MiB.
    let (_, _, c) = bake("auto", "64MiB", "2");
    assert_eq!(c["tiling"]["algorithm"], "in-core");
    let (pvis3, _, d) = bake("auto", "8MiB", "2");
    assert_eq!(d["tiling"]["algorithm"], "out-of-core");
    assert_eq!(pvis3, pvis1);
}
