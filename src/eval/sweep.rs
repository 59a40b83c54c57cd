//! The parameter sweep behind the seed paper's Figures 4–5: bake the mesh for every patch count
//! and sphere level asked for (tile → sample → encode, through the library) and evaluate each
//! file on the same random views.
//!
//! Level `l`'s views are a prefix of level `l + 1`'s (`sphere::ViewIndex`), so each patch count
//! is tiled once and sampled once per pass, at the finest level; coarser files take the first
//! rows. Sampling is `bake`'s (`sampler::sample_tiled`).
//!
//! The bakes follow [`SweepMode`]: by default what a default `patchvis bake` writes — view
//! supersampling, every stored view's own patches plus the patches of the finer views around
//! it folded in (`sampler::supersample`), the finer views counting only patches of at least
//! `fold_min_pixels` pixels — so that the sweep's figures are those of the files users get;
//! or plain (`bake --view-supersample 0`), what the stored level and patch count alone buy.
//! A supersampled level `l` folds level `l + K` into level `l`'s plain rows (`K` less where
//! `l + K` would pass `sphere::MAX_LEVEL`, as `bake` does); the plain rows come from one pass
//! at the finest level and the thresholded fine rows from a second at the finest level plus
//! `K` (one pass when there is no threshold).
//! Each file numbers its patches by co-visibility, as `bake` does by default
//! (`format::covisibility_order`), so its size is the bake's.
//! Cost per patch count: one tiling; sampling renders `view_count(finest)` plain, plus
//! `view_count(finest + K)` supersampled (about `1 + 4^K` times plain, 5× at the bake's
//! default `K = 1`); two renders per evaluation view per level.

use super::evaluator::{EvalError, Evaluator, sampling_params};
use super::summary::EvalSummary;
use super::views::random_directions;
use crate::format::{self, BakeContents};
use crate::ooc::Mesh;
use crate::progress::Progress;
use crate::runtime::Pvis;
use crate::sampler::{
    self, Camera, FoldCorners, SamplingError, SamplingOptions, SamplingParams, VisibilityMatrix,
};
use crate::sphere::{MAX_LEVEL, view_count};
use crate::tiling::{self, Tiling};

/// How the sweep samples each bake.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SweepMode {
    /// Every stored view's own patches only (`bake --view-supersample 0`).
    Plain,
    /// View supersampling with a fold, as `bake --view-supersample K --fold-min-pixels T
    /// --fold-corners C`; the CLI passes `bake`'s defaults.
    Supersampled {
        /// Extra sphere levels sampled (`K`, at most `sampler::MAX_VIEW_SUPERSAMPLE`).
        extra_levels: u32,
        /// A finer view's patch is folded in only if it covers at least this many pixels
        /// there (0 or 1: any pixel).
        fold_min_pixels: u32,
        /// Which stored views around a finer view receive its patches.
        fold_corners: FoldCorners,
    },
}

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
    /// How each bake samples.
    pub mode: SweepMode,
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
        let rows = Rows::sample(mesh, &tiling, &base, settings.mode, progress)
            .map_err(|e| EvalError::Sampling(e.to_string()))?;
        for &level in &levels {
            let params = SamplingParams { level, ..base };
            let views = view_count(level);
            // Numbered as `patchvis bake` numbers it by default (co-visibility), so that
            // the file size is the bake's.
            let spatial = rows.level(level);
            let (numbered, visibility) = match format::covisibility_order(&spatial) {
                Some(order) => (
                    tiling
                        .renumbered(&order)
                        .map_err(|e| EvalError::TempFile(e.to_string()))?,
                    spatial.with_patch_order(&order),
                ),
                None => (tiling.clone(), spatial),
            };
            let bytes = format::encode(&BakeContents {
                sampling: &params,
                triangle_count: u64::from(mesh.triangle_count()),
                patches: &numbered.patches,
                visibility: &visibility,
            });
            let evaluator = Evaluator::from_tiling(mesh, numbered);
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

/// The sampled rows of one patch count, from which every level's matrix is cut.
struct Rows {
    /// Every pixel, at the finest level.
    plain: VisibilityMatrix,
    /// The finer views of the supersampled mode, at the finest level plus `K` (capped at
    /// `MAX_LEVEL`): thresholded, or `None` when `plain` was sampled there with no threshold
    /// and serves as both.
    fine: Option<VisibilityMatrix>,
    mode: SweepMode,
}

impl Rows {
    /// Samples `tiling` of `mesh` at `base`'s level (the finest) as `mode` needs.
    fn sample(
        mesh: &Mesh,
        tiling: &Tiling,
        base: &SamplingParams,
        mode: SweepMode,
        progress: &dyn Progress,
    ) -> Result<Rows, SamplingError> {
        let at = |level: u32, min_pixels: u32| {
            let params = SamplingParams { level, ..*base };
            let options = SamplingOptions {
                min_pixels,
                ..SamplingOptions::default()
            };
            sampler::sample_tiled(mesh, tiling, &params, &options, progress)
        };
        let (plain, fine) = match mode {
            SweepMode::Plain => (at(base.level, 0)?, None),
            SweepMode::Supersampled {
                extra_levels,
                fold_min_pixels,
                ..
            } => {
                let fine_level = (base.level + extra_levels).min(MAX_LEVEL);
                if fold_min_pixels > 1 {
                    (at(base.level, 0)?, Some(at(fine_level, fold_min_pixels)?))
                } else {
                    // Level `l`'s plain rows are a prefix of the finer plain pass.
                    (at(fine_level, 0)?, None)
                }
            }
        };
        Ok(Rows { plain, fine, mode })
    }

    /// The matrix a bake at `level` (at most the finest) stores.
    fn level(&self, level: u32) -> VisibilityMatrix {
        let coarse = prefix(&self.plain, view_count(level));
        let SweepMode::Supersampled {
            extra_levels,
            fold_corners,
            ..
        } = self.mode
        else {
            return coarse;
        };
        // `bake`'s default K, capped so that the fine level exists.
        let fine_level = (level + extra_levels).min(MAX_LEVEL);
        if fine_level == level {
            return coarse;
        }
        let fine = prefix(
            self.fine.as_ref().unwrap_or(&self.plain),
            view_count(fine_level),
        );
        sampler::fold_into_with(coarse, &fine, fine_level, level, fold_corners)
    }
}

/// The first `views` rows of `rows`.
fn prefix(rows: &VisibilityMatrix, views: u32) -> VisibilityMatrix {
    let mut out = VisibilityMatrix::new(views, rows.patches());
    for v in 0..views {
        out.row_mut(v).copy_from_slice(rows.row(v));
    }
    out
}
