//! Tests of the sampling loop: known visibility, determinism, and the timing harness.

use super::*;
use crate::progress::NoProgress;
use crate::test_kit::bunny::bunny;
use crate::test_kit::directions::fibonacci_directions;
use crate::test_kit::meshes::{noisy_sphere, push_cube};
use std::sync::atomic::{AtomicU64, Ordering};

fn params(center: [f32; 3], radius: f32, resolution: u32) -> SamplingParams {
    SamplingParams {
        level: 0,
        resolution,
        fov_deg: 60.0,
        center,
        radius,
    }
}

/// A unit cube (faces are patches 0..6 in the order +X, −X, +Y, −Y, +Z, −Z) holding a cube of
/// half its size (patch 6).
fn nested_cubes() -> (Mesh, Vec<PatchId>) {
    let (mut positions, mut triangles) = (Vec::new(), Vec::new());
    push_cube([0.0; 3], 1.0, &mut positions, &mut triangles);
    push_cube([0.1, -0.05, 0.02], 0.5, &mut positions, &mut triangles);
    let patch_of = (0..24).map(|t| (t / 2).min(6)).collect();
    (
        Mesh::from_memory("cubes", positions, triangles).unwrap(),
        patch_of,
    )
}

#[test]
fn inner_cube_is_hidden_and_axis_views_see_their_own_face() {
    let (mesh, patch_of) = nested_cubes();
    let p = params([0.0; 3], 3f32.sqrt(), 64);
    let axes = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let mut directions = axes.to_vec();
    directions.extend(fibonacci_directions(40));
    let matrix = sample_directions(&mesh, &patch_of, 7, &p, &directions, &NoProgress);
    assert_eq!((matrix.views(), matrix.patches()), (46, 7));
    for view in 0..matrix.views() {
        assert!(!matrix.get(view, 6), "view {view} sees the inner cube");
        assert!(matrix.row(view)[0] != 0, "view {view} sees nothing");
    }
    for (face, _) in axes.iter().enumerate() {
        let opposite = face ^ 1;
        assert!(
            matrix.get(face as u32, face as u32),
            "face {face} from its side"
        );
        assert!(
            !matrix.get(face as u32, opposite as u32),
            "face {opposite} from face {face}"
        );
    }
}

#[test]
fn sample_renders_every_sphere_view_in_order() {
    let (mesh, patch_of) = nested_cubes();
    let p = SamplingParams {
        level: 1,
        ..params([0.0; 3], 3f32.sqrt(), 48)
    };
    let matrix = sample(&mesh, &patch_of, 7, &p, &NoProgress);
    assert_eq!(matrix.views(), 18);
    let directions: Vec<_> = (0..18).map(crate::sphere::direction).collect();
    assert_eq!(
        matrix,
        sample_directions(&mesh, &patch_of, 7, &p, &directions, &NoProgress)
    );
    // Level-0 views are the axes +X, −X, +Y, −Y, +Z, −Z, the order of the cube's faces.
    for face in 0..6 {
        assert!(
            matrix.get(face, face) && !matrix.get(face, face ^ 1),
            "face {face}"
        );
    }
    assert!((0..18).all(|view| !matrix.get(view, 6)));
}

struct Counter {
    started: AtomicU64,
    done: AtomicU64,
    finished: AtomicU64,
}

impl Progress for Counter {
    fn start(&self, what: &str, total: u64) {
        assert_eq!(what, "sampling");
        self.started.store(total, Ordering::Relaxed);
    }
    fn inc(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
    }
    fn finish(&self) {
        self.finished.fetch_add(1, Ordering::Relaxed);
    }
}

#[test]
fn output_is_identical_for_one_and_two_threads() {
    let mesh = noisy_sphere(20, 40, 0.3, 5);
    let patch_of: Vec<PatchId> = (0..mesh.triangle_count()).map(|t| t / 13).collect();
    let patch_count = patch_of.last().unwrap() + 1;
    let p = params([0.0; 3], 1.4, 96);
    let directions = fibonacci_directions(66);
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let progress = Counter {
            started: AtomicU64::new(0),
            done: AtomicU64::new(0),
            finished: AtomicU64::new(0),
        };
        let matrix = pool.install(|| {
            sample_directions(&mesh, &patch_of, patch_count, &p, &directions, &progress)
        });
        assert_eq!(progress.started.load(Ordering::Relaxed), 66);
        assert_eq!(progress.done.load(Ordering::Relaxed), 66);
        assert_eq!(progress.finished.load(Ordering::Relaxed), 1);
        matrix
    };
    let one = run(1);
    assert_eq!(one, run(2));
    // A bumpy sphere: every view sees something, no view sees everything.
    for view in 0..one.views() {
        let seen: u32 = one.row(view).iter().map(|w| w.count_ones()).sum();
        assert!(seen > 0 && seen < patch_count, "view {view} sees {seen}");
    }
}

fn median_sample_time(name: &str, mesh: &Mesh) {
    let patch_of: Vec<PatchId> = (0..mesh.triangle_count()).map(|t| t / 100).collect();
    let patch_count = patch_of.last().unwrap() + 1;
    let (center, radius) = bounding_sphere(mesh);
    let p = SamplingParams {
        level: 4,
        ..params(center, radius, 512)
    };
    let mut times = Vec::new();
    let (mut seen, mut views) = (0, 0);
    for _ in 0..3 {
        let start = std::time::Instant::now();
        let matrix = sample(mesh, &patch_of, patch_count, &p, &NoProgress);
        times.push(start.elapsed().as_secs_f64());
        views = matrix.views();
        seen = (0..views)
            .map(|v| {
                matrix
                    .row(v)
                    .iter()
                    .map(|w| w.count_ones() as u64)
                    .sum::<u64>()
            })
            .sum();
    }
    times.sort_by(f64::total_cmp);
    println!(
        "{name}: {} triangles, {views} views at 512²: median {:.3} s of {times:.3?} on {} \
         threads; {:.1} of {patch_count} patches per view",
        mesh.triangle_count(),
        times[1],
        rayon::current_num_threads(),
        seen as f64 / views as f64
    );
}

/// Median time of `sample` at level 4 (1026 views), 512², on the bundled bunny and on a
/// generated ~100K-triangle closed mesh. Run:
/// `RAYON_NUM_THREADS=2 cargo test --release --lib sampler::tests::timing -- --ignored --nocapture`.
#[test]
#[ignore]
fn timing_level_4_at_512() {
    median_sample_time("bunny", &bunny());
    median_sample_time("noisy sphere", &noisy_sphere(159, 317, 0.05, 1));
}
