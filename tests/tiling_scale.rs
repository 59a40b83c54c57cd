//! Memory and scale of the tiling (issue 4), measured with a counting global allocator.
//!
//! The one test that runs by default checks the out-of-core promise: tiling a 0.4M-triangle
//! mesh under an 8 MiB budget never holds more heap than the budget, and the in-core peak per
//! triangle stays below `IN_CORE_BYTES_PER_TRIANGLE` (the figure `TilingMode::Auto` relies
//! on). The ignored tests are the benchmarks of BENCHMARKS.md, "Tiling (issue 4)"; run them
//! one at a time in release:
//!
//! ```text
//! cargo test --release --test tiling_scale bunny_1_6m -- --ignored --nocapture
//! cargo test --release --test tiling_scale grid_1m -- --ignored --nocapture
//! cargo test --release --test tiling_scale grid_20m -- --ignored --nocapture
//! ```
//!
//! Meshes are written as binary little-endian PLY by `patchvis::generate`, which `Mesh::open`
//! maps in place (no heap): the bundled bunny subdivided by edge midpoints (×4 triangles per
//! level, `SubdividedMesh::without_relief`), and a wavy grid (height field of two sine waves,
//! a `Model` here) for the largest sizes. The heap is measured by the library's counting
//! allocator (`patchvis::heap`). Only one test runs by default, so the allocator counts
//! nothing but that test.

mod common;

use std::io;
use std::path::{Path, PathBuf};
use std::time::Instant;

use patchvis::generate::subdivide::SubdividedMesh;
use patchvis::generate::{Model, write_ply};
use patchvis::heap;
use patchvis::ooc::Mesh;
use patchvis::tiling::{IN_CORE_BYTES_PER_TRIANGLE, Tiling, TilingMode, TilingOptions, tile_with};

#[global_allocator]
static ALLOC: heap::CountingAlloc = heap::CountingAlloc;

/// Runs `f` and returns its result with the heap it added at the peak (bytes above what was
/// live before) and its wall time.
fn measured<T>(f: impl FnOnce() -> T) -> (T, usize, f64) {
    heap::reset_peak();
    let base = heap::current();
    let start = Instant::now();
    let out = f();
    let secs = start.elapsed().as_secs_f64();
    (out, heap::peak() - base, secs)
}

/// Writes `model` as binary little-endian PLY at `path`, streaming.
fn write(path: &Path, model: &dyn Model) {
    let file = std::fs::File::create(path).expect("create PLY");
    write_ply(file, model, "tests/tiling_scale.rs").expect("write PLY");
}

/// The bundled bunny (99,785 triangles) with every triangle split in four `levels` times
/// (midpoint subdivision, no relief).
fn subdivided_bunny(dir: &Path, levels: u32) -> PathBuf {
    let bunny = common::bunny();
    let path = dir.join(format!("bunny-{levels}.ply"));
    write(&path, &SubdividedMesh::without_relief(&bunny, 1 << levels));
    path
}

/// A `side` × `side` grid of quads (two triangles each) over a height field of two sine
/// waves, emitted without holding it.
struct WavyGrid {
    side: u32,
}

impl Model for WavyGrid {
    fn vertex_count(&self) -> u64 {
        u64::from(self.side + 1).pow(2)
    }

    fn triangle_count(&self) -> u64 {
        2 * u64::from(self.side).pow(2)
    }

    fn vertices(&self, emit: &mut dyn FnMut([f32; 3]) -> io::Result<()>) -> io::Result<()> {
        let side = self.side;
        for y in 0..=side {
            for x in 0..=side {
                let (u, v) = (x as f32 / side as f32, y as f32 / side as f32);
                let h = 0.05 * (u * 37.0).sin() * (v * 23.0).cos();
                emit([u, v, h])?;
            }
        }
        Ok(())
    }

    fn triangles(&self, emit: &mut dyn FnMut([u32; 3]) -> io::Result<()>) -> io::Result<()> {
        let row = self.side + 1;
        let v = |x: u32, y: u32| y * row + x;
        for y in 0..self.side {
            for x in 0..self.side {
                emit([v(x, y), v(x + 1, y), v(x + 1, y + 1)])?;
                emit([v(x, y), v(x + 1, y + 1), v(x, y + 1)])?;
            }
        }
        Ok(())
    }
}

/// The [`WavyGrid`] of `side` written to `dir`.
fn wavy_grid(dir: &Path, side: u32) -> PathBuf {
    let path = dir.join(format!("grid-{side}.ply"));
    write(&path, &WavyGrid { side });
    path
}

/// Every triangle in exactly one patch, patches contiguous in `order`, `target` of them.
fn check_partition(mesh: &Mesh, tiling: &Tiling, target: u32) {
    let n = mesh.triangle_count() as usize;
    assert_eq!(tiling.patches.len() as u32, target);
    assert_eq!((tiling.patch_of.len(), tiling.order.len()), (n, n));
    let mut next = 0;
    for (p, patch) in tiling.patches.iter().enumerate() {
        assert_eq!(patch.first, next);
        next += patch.count;
        for &t in &tiling.order[patch.first as usize..next as usize] {
            assert_eq!(tiling.patch_of[t as usize], p as u32);
        }
    }
    assert_eq!(next as usize, n);
}

fn options(mode: TilingMode, memory_budget: u64) -> TilingOptions {
    TilingOptions {
        mode,
        memory_budget,
    }
}

const MIB: u64 = 1 << 20;

#[test]
fn out_of_core_heap_stays_within_the_budget() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let path = subdivided_bunny(dir.path(), 1);
    let mesh = Mesh::open(&path).expect("generated mesh");
    assert!(mesh.is_mapped());
    let n = mesh.triangle_count();
    assert_eq!(n, 99_785 * 4);

    let budget = 8 * MIB;
    let ooc = options(TilingMode::OutOfCore, budget);
    let (tiling, peak, _) = measured(|| tile_with(&mesh, 1000, &ooc).expect("tiling"));
    assert!(tiling.stats.out_of_core && tiling.stats.chunks > 4);
    assert!(tiling.patch_of.is_mapped() && tiling.order.is_mapped());
    assert!(
        peak as u64 <= budget,
        "peak heap {peak} over the {budget}-byte budget"
    );
    check_partition(&mesh, &tiling, 1000);
    drop(tiling);

    let in_core = options(TilingMode::InCore, 0);
    let (tiling, peak, _) = measured(|| tile_with(&mesh, 1000, &in_core).expect("tiling"));
    assert!(!tiling.stats.out_of_core);
    let per_triangle = peak as u64 / u64::from(n);
    assert!(
        per_triangle <= IN_CORE_BYTES_PER_TRIANGLE,
        "in-core peak {per_triangle} bytes per triangle"
    );
}

/// Prints a result line for BENCHMARKS.md.
fn report(name: &str, mesh: &Mesh, opts: &TilingOptions, target: u32) -> Tiling {
    let (tiling, peak, secs) = measured(|| tile_with(mesh, target, opts).expect("tiling"));
    let q = tiling.quality;
    println!(
        "{name}: {} triangles -> {} patches, {:?} budget {} MiB: {secs:.2} s, peak heap {:.1} MiB, \
         {} chunks; triangles/patch {}/{}/{}; compactness median {:.3} p95 {:.3}",
        mesh.triangle_count(),
        q.patches,
        opts.mode,
        opts.memory_budget / MIB,
        peak as f64 / MIB as f64,
        tiling.stats.chunks,
        q.triangles_min,
        q.triangles_median,
        q.triangles_max,
        q.compactness_median,
        q.compactness_p95,
    );
    check_partition(mesh, &tiling, target);
    tiling
}

/// Compactness target: out of core within 15% of in core on the 1.6M-triangle bunny.
#[test]
#[ignore]
fn bunny_1_6m_in_core_against_out_of_core() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let mesh = Mesh::open(&subdivided_bunny(dir.path(), 2)).expect("generated mesh");
    let a = report("bunny", &mesh, &options(TilingMode::InCore, 0), 1000);
    for budget in [256 * MIB, 64 * MIB] {
        let b = report(
            "bunny",
            &mesh,
            &options(TilingMode::OutOfCore, budget),
            1000,
        );
        let ratio = b.quality.compactness_median / a.quality.compactness_median;
        println!("  out-of-core / in-core median compactness: {ratio:.3}");
        assert!(ratio <= 1.15);
    }
}

/// Speed target: 1M triangles into 1000 patches in core in at most 5 s.
#[test]
#[ignore]
fn grid_1m_in_core() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let mesh = Mesh::open(&wavy_grid(dir.path(), 708)).expect("generated mesh");
    report("grid", &mesh, &options(TilingMode::InCore, 0), 1000);
    report(
        "grid",
        &mesh,
        &options(TilingMode::OutOfCore, 256 * MIB),
        1000,
    );
}

/// Scale target: 20M triangles into 2000 patches under 256 MiB in at most 120 s.
#[test]
#[ignore]
fn grid_20m_out_of_core() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let start = Instant::now();
    let mesh = Mesh::open(&wavy_grid(dir.path(), 3163)).expect("generated mesh");
    println!(
        "generated and opened in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    let budget = 256 * MIB;
    let opts = options(TilingMode::Auto, budget);
    let (tiling, peak, _) = measured(|| report("grid", &mesh, &opts, 2000));
    assert!(tiling.stats.out_of_core);
    assert!(peak as u64 <= budget, "peak heap {peak}");
}
