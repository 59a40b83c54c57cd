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
    })
}

#[test]
fn views_at_sampling_positions_miss_nothing() {
    let mesh = lattice(0.0);
    let bytes = bake(&mesh, 80, 2);
    let pvis = Pvis::parse(&bytes).unwrap();
    let evaluator = Evaluator::new(&mesh, &pvis).unwrap();
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
    let evaluator = Evaluator::new(&mesh, &pvis).unwrap();
    let params = sampling_params(&pvis, RESOLUTION, 1.3);
    let cameras: Vec<Camera> = random_directions(24, 5)
        .into_iter()
        .map(|d| Camera::sampling(&params, d))
        .collect();
    let strip = |mut m: ViewMetrics| {
        (m.full_seconds, m.culled_seconds) = (0.0, 0.0);
        m
    };
    let a: Vec<ViewMetrics> = evaluator
        .evaluate(&pvis, &cameras, &NoProgress)
        .into_iter()
        .map(strip)
        .collect();
    let b: Vec<ViewMetrics> = evaluator
        .evaluate(&pvis, &cameras, &NoProgress)
        .into_iter()
        .map(strip)
        .collect();
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
        Evaluator::new(&moved, &pvis),
        Err(EvalError::PatchMismatch { .. })
    ));
    let other = Mesh::from_memory(
        "tri",
        vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    )
    .unwrap();
    assert_eq!(
        Evaluator::new(&other, &pvis).err(),
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
        let evaluator = Evaluator::new(&mesh, &pvis).unwrap();
        evaluator
            .evaluate(&pvis, &cameras, &NoProgress)
            .into_iter()
            .map(|mut m| {
                (m.full_seconds, m.culled_seconds) = (0.0, 0.0);
                m
            })
            .collect()
    };
    // Same answers in another numbering: every per-view figure is the same.
    assert_eq!(metrics(&spatial), metrics(&covisible));
}
