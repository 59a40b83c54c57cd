//! The parameter sweep behind the seed paper's Figures 4–5: bake the mesh for every patch count
//! and sphere level asked for, with the library's bake recipe (`crate::bake`), and evaluate
//! each file on the same random views.
//!
//! Each patch count is tiled once and sampled once, at the finest level
//! ([`Recipe::sample`]); every level's stored matrix is cut from those rows
//! ([`crate::bake::SampledRows::stored`]: level `l`'s views are a prefix of level `l + 1`'s),
//! numbered and encoded as `bake` does, so each file is the one `patchvis bake --level l`
//! writes with the same settings. The supersampling of each level is the settings' (the
//! default: one level finer, capped at the finest sphere level, as `bake` caps it).
//! Cost per patch count: one tiling and one sampling run at the finest level (with the
//! default supersampling about 5× a plain one); two renders per evaluation view per level.

use super::evaluator::{EvalError, Evaluator, sampling_params};
use super::summary::EvalSummary;
use super::views::random_directions;
use crate::bake::{Backend, BakeSettings, Recipe, RowSettings};
use crate::ooc::Mesh;
use crate::progress::Progress;
use crate::runtime::Pvis;
use crate::sampler::Camera;
use crate::sphere::view_count;

/// What to sweep and how to evaluate.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepSettings {
    /// Patch counts to bake.
    pub patches: Vec<u32>,
    /// Sphere levels to bake.
    pub levels: Vec<u32>,
    /// How each file is baked (its patch count and level are the sweep's; checkpoints are
    /// never written).
    pub bake: BakeSettings,
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
/// Empty lists give an empty result. Evaluation renders at the bakes' resolution.
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
    let directions = random_directions(settings.views, settings.seed);
    let mut points = Vec::new();
    for &requested in &settings.patches {
        let recipe = recipe_for(&settings.bake, requested, finest)?;
        let tiling = recipe.tile(mesh).map_err(EvalError::bake)?;
        let patch_count = tiling.patches.len() as u32;
        let rows = recipe
            .sample(mesh, &tiling, &Backend::Cpu, progress)
            .map_err(EvalError::bake)?;
        for &level in &levels {
            let params = rows.params(level);
            let (numbered, visibility, _) = recipe
                .number(tiling.clone(), rows.stored(level))
                .map_err(EvalError::bake)?;
            let bytes = recipe.encode(&params, mesh.triangle_count(), &numbered, &visibility, &[]);
            // The encoder's output always parses; a failure here is a bug in the writer.
            let pvis = Pvis::parse(&bytes).expect("the encoder wrote a file the reader rejects");
            let evaluator = Evaluator::from_tiling(mesh, &numbered, settings.bake.memory);
            let eval_params = sampling_params(&pvis, params.resolution, settings.distance_scale);
            let cameras: Vec<Camera> = directions
                .iter()
                .map(|&d| Camera::sampling(&eval_params, d))
                .collect();
            let metrics = evaluator.evaluate(&pvis, &cameras, progress);
            let point = SweepPoint {
                patches: patch_count,
                level,
                sampling_views: view_count(level),
                file_bytes: bytes.len() as u64,
                summary: EvalSummary::of(&metrics),
            };
            on_point(&point);
            points.push(point);
        }
    }
    Ok(points)
}

/// The recipe of one patch count, sampled at the finest level asked for.
///
/// The settings are checked at level 0, where every supersampling the settings may ask for
/// exists, and then sampled at `finest`: the sampler caps the finer pass at the finest
/// sphere level and [`crate::bake::SampledRows::stored`] caps each level's fold the same way,
/// so every level gets the rows `bake --level l` would store (its default supersampling is
/// capped likewise).
fn recipe_for(template: &BakeSettings, patches: u32, finest: u32) -> Result<Recipe, EvalError> {
    let mut recipe = BakeSettings {
        patches,
        checkpoint: None,
        resume: false,
        rows: RowSettings {
            level: Some(0),
            // The sweep evaluates the sampling sphere's levels at the sampling distance: no
            // shells, near or far.
            shells: 0,
            far_shells: Vec::new(),
            ..template.rows.clone()
        },
        ..template.clone()
    }
    .check()
    .map_err(|e| EvalError::Settings(e.0))?;
    recipe.plan.main.level = finest;
    Ok(recipe)
}
