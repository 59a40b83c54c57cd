//! Evaluator tests on a generated scene with heavy occlusion: a 3 × 3 × 3 lattice of spheres.

use super::shade::MISSED;
use super::views::random_directions;
use super::*;
use crate::format::{self, BakeContents};
use crate::ooc::Mesh;
use crate::progress::NoProgress;
use crate::runtime::Pvis;
use crate::sampler::{self, Camera, SamplingParams};
use crate::tiling;

/// UV spheres of radius 0.4 at the points of a 3 × 3 × 3 lattice of spacing 1; `shift` moves
/// the first vertex (to make a mesh that differs from the baked one).
fn lattice(shift: f32) -> Mesh {
    const SEGMENTS: u32 = 16;
    const RINGS: u32 = 8;
    let (mut positions, mut triangles) = (Vec::new(), Vec::new());
    for cell in 0..27u32 {
        let c = [cell % 3, cell / 3 % 3, cell / 9].map(|k| k as f32 - 1.0);
        let base = positions.len() as u32;
        for r in 0..=RINGS {
            let theta = std::f32::consts::PI * r as f32 / RINGS as f32;
            for s in 0..SEGMENTS {
                let phi = std::f32::consts::TAU * s as f32 / SEGMENTS as f32;
                positions.push([
                    c[0] + 0.4 * theta.sin() * phi.cos(),
                    c[1] + 0.4 * theta.cos(),
                    c[2] + 0.4 * theta.sin() * phi.sin(),
                ]);
            }
        }
        let at = |r: u32, s: u32| base + r * SEGMENTS + s % SEGMENTS;
        for r in 0..RINGS {
            for s in 0..SEGMENTS {
                triangles.push([at(r, s), at(r + 1, s), at(r + 1, s + 1)]);
                triangles.push([at(r, s), at(r + 1, s + 1), at(r, s + 1)]);
            }
        }
    }
    positions[0][0] += shift;
    Mesh::from_memory("lattice", positions, triangles).unwrap()
}

const RESOLUTION: u32 = 96;

fn bake(mesh: &Mesh, patches: u32, level: u32) -> Vec<u8> {
    bake_numbered(mesh, patches, level, false)
}

/// [`bake`], with the patches renumbered by co-visibility when `covisibility` is set (as
/// `patchvis bake` does by default).
fn bake_numbered(mesh: &Mesh, patches: u32, level: u32, covisibility: bool) -> Vec<u8> {
    let mut tiling = tiling::tile(mesh, patches).unwrap();
    let params = SamplingParams::for_mesh(mesh, level, RESOLUTION, 45.0);
    let mut visibility = sampler::sample(
        mesh,
        &tiling.patch_of,
        tiling.patches.len() as u32,
        &params,
        &NoProgress,
    );
    if covisibility {
        let order = format::covisibility_order(&visibility).unwrap();
        assert!(order.iter().enumerate().any(|(i, &p)| i as u32 != p));
        tiling = tiling.renumbered(&order).unwrap();
        visibility = visibility.with_patch_order(&order);
    }
    format::encode(&BakeContents {
        sampling: &params,
        triangle_count: u64::from(mesh.triangle_count()),
        patches: &tiling.patches,
        visibility: &visibility,
        shells: &[],
        reach: 0.0,
    })
}

#[test]
fn views_at_sampling_positions_miss_nothing() {
    let mesh = lattice(0.0);
    let bytes = bake(&mesh, 80, 2);
    let pvis = Pvis::parse(&bytes).unwrap();
    let evaluator = Evaluator::new(&mesh, &pvis, &options()).unwrap();
    let params = sampling_params(&pvis, RESOLUTION, 1.0);
    let cameras: Vec<Camera> = (0..pvis.sampling().views)
        .map(|v| Camera::sampling_view(&params, v))
        .collect();
    let views = evaluator.evaluate(&pvis, &cameras, &NoProgress);
    for (v, m) in views.iter().enumerate() {
        assert_eq!((m.missed_pixels, m.missed_patches), (0, 0), "view {v}");
        assert_eq!(m.psnr_db, f64::INFINITY);
        // The answer holds the true visible set, so it culls at most as much as the ideal.
        assert!(m.culling_rate <= m.ideal_culling_rate + 1e-12, "view {v}");
        assert!(m.answer_patches >= m.visible_patches && m.covered_pixels > 0);
    }
    let summary = EvalSummary::of(&views);
    assert_eq!(summary.identical_views_fraction(), 1.0);
    // The lattice hides its inner sphere and parts of the others (measured: ideal 19 %,
    // culled 6 % with 80 patches, about three per sphere).
    assert!(summary.ideal_culling_rate.mean > 0.15, "{summary:?}");
    assert!(summary.culling_rate.mean > 0.03, "{summary:?}");
}

#[test]
fn random_views_are_deterministic_and_consistent() {
    let mesh = lattice(0.0);
    let bytes = bake(&mesh, 80, 1);
    let pvis = Pvis::parse(&bytes).unwrap();
    let evaluator = Evaluator::new(&mesh, &pvis, &options()).unwrap();
    let params = sampling_params(&pvis, RESOLUTION, 1.3);
    let cameras: Vec<Camera> = random_directions(24, 5)
        .into_iter()
        .map(|d| Camera::sampling(&params, d))
        .collect();
    let a = untimed(&evaluator, &pvis, &cameras);
    let b = untimed(&evaluator, &pvis, &cameras);
    assert_eq!(a, b);
    let mut differing = 0;
    for m in &a {
        assert_eq!(m.missed_pixels == 0, m.psnr_db == f64::INFINITY);
        // A missed patch the full render shows costs at least one pixel.
        assert!(m.missed_patches == 0 || m.missed_pixels > 0);
        assert!((0.0..=1.0).contains(&m.culling_rate));
        assert!(m.ideal_culling_rate >= 0.0 && m.ideal_culling_rate <= 1.0);
        assert!(!m.inside_sphere);
        differing += usize::from(m.missed_pixels > 0);
        let image = evaluator.pictures(
            &pvis,
            &Camera::look_at(m.eye, params.center, 45.0, RESOLUTION),
        );
        let red = image
            .difference
            .pixels
            .chunks(3)
            .filter(|p| *p == MISSED)
            .count() as u64;
        assert_eq!(red, m.missed_pixels);
    }
    // A level-1 file (18 views) seen from 24 random places misses something somewhere.
    assert!(differing > 0);
}

#[test]
fn files_from_another_mesh_are_refused() {
    let bytes = bake(&lattice(0.0), 40, 0);
    let pvis = Pvis::parse(&bytes).unwrap();
    let moved = lattice(0.05);
    assert!(matches!(
        Evaluator::new(&moved, &pvis, &options()),
        Err(EvalError::PatchMismatch { .. })
    ));
    let other = Mesh::from_memory(
        "tri",
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    )
    .unwrap();
    assert_eq!(
        Evaluator::new(&other, &pvis, &options()).err(),
        Some(EvalError::TriangleCount {
            file: 27 * 256,
            mesh: 1
        })
    );
}

#[test]
fn renumbered_files_evaluate_like_the_tiling_numbering() {
    let mesh = lattice(0.0);
    let spatial = bake_numbered(&mesh, 80, 1, false);
    let covisible = bake_numbered(&mesh, 80, 1, true);
    assert_ne!(spatial, covisible);
    let cameras: Vec<Camera> = {
        let pvis = Pvis::parse(&spatial).unwrap();
        let params = sampling_params(&pvis, RESOLUTION, 1.3);
        random_directions(16, 9)
            .into_iter()
            .map(|d| Camera::sampling(&params, d))
            .collect()
    };
    let metrics = |bytes: &[u8]| -> Vec<ViewMetrics> {
        let pvis = Pvis::parse(bytes).unwrap();
        let evaluator = Evaluator::new(&mesh, &pvis, &options()).unwrap();
        untimed(&evaluator, &pvis, &cameras)
    };
    // Same answers in another numbering: every per-view figure is the same.
    assert_eq!(metrics(&spatial), metrics(&covisible));
}

/// The metrics of `cameras`, without the timings (which vary from run to run).
fn untimed(evaluator: &Evaluator<'_>, pvis: &Pvis<'_>, cameras: &[Camera]) -> Vec<ViewMetrics> {
    evaluator
        .evaluate(pvis, cameras, &NoProgress)
        .into_iter()
        .map(|mut m| {
            (m.full_seconds, m.culled_seconds) = (0.0, 0.0);
            m
        })
        .collect()
}

fn options() -> EvalOptions {
    EvalOptions {
        memory: crate::memory::MemoryBudget::new(1 << 30),
        tiling: tiling::TilingMode::Auto,
    }
}

#[test]
fn a_mesh_in_the_files_patch_order_evaluates_without_tiling_and_like_the_original() {
    let mesh = lattice(0.0);
    // The file and its patch order, as `bake --mesh-out` writes them (co-visibility order).
    let mut tiling = tiling::tile(&mesh, 80).unwrap();
    let params = SamplingParams::for_mesh(&mesh, 1, RESOLUTION, 45.0);
    let rows = sampler::sample(&mesh, &tiling.patch_of, 80, &params, &NoProgress);
    let order = format::covisibility_order(&rows).unwrap();
    tiling = tiling.renumbered(&order).unwrap();
    let bytes = format::encode(&BakeContents {
        sampling: &params,
        triangle_count: u64::from(mesh.triangle_count()),
        patches: &tiling.patches,
        visibility: &rows.with_patch_order(&order),
        shells: &[],
        reach: 0.0,
    });
    let pvis = Pvis::parse(&bytes).unwrap();
    let positions = (0..mesh.vertex_count()).map(|v| mesh.position(v)).collect();
    let triangles = tiling.order.iter().map(|&t| mesh.triangle(t)).collect();
    let reordered = Mesh::from_memory("mesh-out", positions, triangles).unwrap();

    let cameras: Vec<Camera> = random_directions(12, 3)
        .into_iter()
        .map(|d| Camera::sampling(&sampling_params(&pvis, RESOLUTION, 1.2), d))
        .collect();
    let metrics = |evaluator: &Evaluator<'_>| untimed(evaluator, &pvis, &cameras);
    let from_original = Evaluator::new(&mesh, &pvis, &options()).unwrap();
    assert!(from_original.order().is_some());
    let in_order = Evaluator::new(&reordered, &pvis, &options()).unwrap();
    assert!(
        in_order.order().is_none(),
        "no tiling for a mesh in file order"
    );
    assert_eq!(metrics(&from_original), metrics(&in_order));
    // A budget for one worker at a time changes nothing but the pace.
    let tight = EvalOptions {
        memory: crate::memory::MemoryBudget::new(1),
        ..options()
    };
    let one_at_a_time = Evaluator::new(&reordered, &pvis, &tight).unwrap();
    assert_eq!(one_at_a_time.workers(&cameras[0]), 1);
    assert_eq!(metrics(&one_at_a_time), metrics(&in_order));
}

#[test]
fn visible_runs_merge_consecutive_patches_and_skip_empty_ones() {
    // Patches of 3, 2, 0, 4 and 3 triangles.
    let starts = [0, 3, 5, 5, 9, 12];
    assert_eq!(visible_runs(&[0b10011], &starts), [0..5, 9..12]);
    // Patch 2 is empty, so 1 and 3 are adjacent.
    assert_eq!(visible_runs(&[0b01010], &starts).first(), Some(&(3..9)));
    assert_eq!(visible_runs(&[0b00100], &starts), []);
}

#[test]
fn near_views_are_flagged_and_the_ideal_without_the_frustum_looks_around() {
    let mesh = lattice(0.0);
    let bytes = bake(&mesh, 80, 1);
    let pvis = Pvis::parse(&bytes).unwrap();
    let evaluator = Evaluator::new(&mesh, &pvis, &options()).unwrap();
    let at = |scale: f32| -> Vec<ViewMetrics> {
        let params = sampling_params(&pvis, RESOLUTION, scale);
        let cameras: Vec<Camera> = random_directions(6, 4)
            .into_iter()
            .map(|d| Camera::sampling(&params, d))
            .collect();
        untimed(&evaluator, &pvis, &cameras)
    };
    let far = at(1.2);
    // At 0.45 of the sampling distance the eye is 1.18 bounding radii from the centre: inside
    // the sampling sphere of this version-4 file, so flagged.
    let near = at(0.45);
    for (f, n) in far.iter().zip(&near) {
        // The camera frames the whole lattice: its full render is the reference.
        assert!(!f.inside_sphere);
        assert_eq!(f.ideal_culling_rate_all_directions, f.ideal_culling_rate);
        assert_eq!(f.visible_patches_all_directions, f.visible_patches);
        assert!(n.inside_sphere);
        assert_eq!(n.frustum_lost_patches, 0);
        // The 45° camera sees part of the lattice; around the eye there is more.
        assert!(n.covered_pixels > 0 && n.frustum_culling_rate > n.culling_rate);
        assert!(
            n.visible_patches_all_directions > n.visible_patches,
            "{n:?}"
        );
        assert!(n.ideal_culling_rate_all_directions < n.ideal_culling_rate);
        assert!(n.ideal_culling_rate_all_directions >= 0.0);
    }
    assert_eq!(EvalSummary::of(&near).answered_views, 0);
    assert_eq!(EvalSummary::of(&far).answered_views, 6);
}
