//! The parameter sweep behind the seed paper's Figures 4–5: bake the mesh for every patch count
//! and sphere level asked for (tile → sample → encode, through the library) and evaluate each
//! file on the same random views.
//!
//! Level `l`'s views are a prefix of level `l + 1`'s (`sphere::ViewIndex`), so each patch count
//! is tiled once and sampled once, at the finest level; coarser files take the first rows.
//! The bakes are plain (`bake --view-supersample 0`), not `bake`'s supersampled default: the
//! sweep shows what the stored level and patch count alone buy (the supersampled default is
//! measured in BENCHMARKS.md, "Quality (issue 6)").
//! Cost per patch count: one tiling, `view_count(max level)` sampling renders, and two renders
//! per evaluation view per level.

use super::evaluator::{EvalError, Evaluator, sampling_params};
use super::summary::EvalSummary;
use super::views::random_directions;
use crate::format::{self, BakeContents};
use crate::ooc::Mesh;
use crate::progress::Progress;
use crate::runtime::Pvis;
use crate::sampler::{self, Camera, SamplingParams, VisibilityMatrix};
use crate::sphere::view_count;
use crate::tiling;

/// What to sweep and how to evaluate.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepSettings {
    /// Patch counts to bake.
    pub patches: Vec<u32>,
    /// Sphere levels to bake.
    pub levels: Vec<u32>,
    /// ID-buffer resolution of the bakes and of the evaluation.
    pub resolution: u32,
    /// Field of view, degrees.
    pub fov_deg: f32,
    /// Random evaluation views.
    pub views: u32,
    /// Seed of the evaluation views.
    pub seed: u64,
    /// Evaluation cameras' distance over the sampling distance.
    pub distance_scale: f32,
}

/// One baked and evaluated configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepPoint {
    /// Patches in the file (the request, or the triangle count if smaller).
    pub patches: u32,
    /// Sphere level.
    pub level: u32,
    /// Sampling views of that level.
    pub sampling_views: u32,
    /// Size of the `.pvis` file in bytes.
    pub file_bytes: u64,
    /// The evaluation.
    pub summary: EvalSummary,
}

/// Runs the sweep; `on_point` sees each point as soon as it is done (progress reports).
/// Empty lists give an empty result.
pub fn sweep(
    mesh: &Mesh,
    settings: &SweepSettings,
    progress: &dyn Progress,
    on_point: &mut dyn FnMut(&SweepPoint),
) -> Result<Vec<SweepPoint>, EvalError> {
    let mut levels = settings.levels.clone();
    levels.sort_unstable();
    levels.dedup();
    let Some(&finest) = levels.last() else {
        return Ok(Vec::new());
    };
    let base = SamplingParams::for_mesh(mesh, finest, settings.resolution, settings.fov_deg);
    let directions = random_directions(settings.views, settings.seed);
    let mut points = Vec::new();
    for &requested in &settings.patches {
        let tiling = tiling::tile(mesh, requested)?;
        let patch_count = tiling.patches.len() as u32;
        let full = sampler::sample(mesh, &tiling.patch_of, patch_count, &base, progress);
        let evaluator = Evaluator::from_tiling(mesh, &tiling);
        for &level in &levels {
            let params = SamplingParams { level, ..base };
            let views = view_count(level);
            let mut visibility = VisibilityMatrix::new(views, patch_count);
            for v in 0..views {
                visibility.row_mut(v).copy_from_slice(full.row(v));
            }
            let bytes = format::encode(&BakeContents {
                sampling: &params,
                triangle_count: u64::from(mesh.triangle_count()),
                patches: &tiling.patches,
                visibility: &visibility,
            });
            // The encoder's output always parses; a failure here is a bug in the writer.
            let pvis = Pvis::parse(&bytes).expect("the encoder wrote a file the reader rejects");
            let eval_params = sampling_params(&pvis, settings.resolution, settings.distance_scale);
            let cameras: Vec<Camera> = directions
                .iter()
                .map(|&d| Camera::sampling(&eval_params, d))
                .collect();
            let metrics = evaluator.evaluate(&pvis, &cameras, progress);
            let point = SweepPoint {
                patches: patch_count,
                level,
                sampling_views: views,
                file_bytes: bytes.len() as u64,
                summary: EvalSummary::of(&metrics),
            };
            on_point(&point);
            points.push(point);
        }
    }
    Ok(points)
}
