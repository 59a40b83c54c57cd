//! The sample stage of a bake: each sphere of the plan (`plan.rs`) in turn, its stored level
//! plainly and its finer level thresholded, or the finer level alone, or (with the split
//! fold) the finer level with its seen rows, into a [`SphereRows`] each (`rows.rs`).
//!
//! Every sphere is sampled within the sampling share of the budget; the rows of those before
//! it are counted in the bake's minimum (`Recipe::check_mesh`). A shard samples the views it
//! owns in each pass, each seeded and rendered as in the whole bake.

use super::plan::{Plan, Sphere};
use super::rows::SphereRows;
use super::{Backend, BakeError, BakeSettings, Shard};
use crate::progress::Progress;
use crate::sampler::{FoldCorners, SamplingOptions, Scene};
use crate::visibility::SamplingParams;
use std::path::PathBuf;

/// What every sphere's sampling takes from the bake: the plan, and the checkpoints'
/// resumption and the budget of the settings.
pub(super) struct Run<'a> {
    pub(super) plan: &'a Plan,
    pub(super) settings: &'a BakeSettings,
}

impl Run<'_> {
    /// Samples one sphere of views, the views `shard` owns or every view.
    pub(super) fn sphere(
        &self,
        scene: &Scene,
        backend: &Backend,
        progress: &dyn Progress,
        sphere: &Sphere,
        shard: Option<Shard>,
    ) -> Result<SphereRows, BakeError> {
        let params = sphere.params;
        let supersample = sphere.sampling.supersample;
        let views = |level: u32| shard.map(|s| s.views(level));
        // The finer pass differs from the stored level in `level` only (same centre, radius,
        // camera distance), so its views are the stored ones plus the finer ones.
        let fine = SamplingParams {
            // Capped for `eval --sweep`, whose recipe may sample at the finest level (a checked
            // bake has `level + extra_levels` within it already).
            level: (params.level + supersample.extra_levels).min(crate::sphere::MAX_LEVEL),
            ..params
        };
        let min_pixels = self.plan.rows.research.min_pixels;
        let options = |min_pixels, checkpoint: &Option<PathBuf>, level| {
            self.options(sphere, min_pixels, checkpoint.clone(), views(level))
        };
        // Where the finer pass's views lie (at the finest level it is the stored level).
        let finer = supersample.finer_views(params.level, fine.level);
        let checkpoints = &sphere.checkpoints;
        let (plain, fine) = if supersample.fold_min_pixels > 0 {
            let coarse_options = options(min_pixels, &checkpoints.coarse, params.level);
            let plain = backend.sample(scene, &params, &coarse_options, progress)?;
            let fine_options = SamplingOptions {
                finer,
                ..options(supersample.fold_min_pixels, &checkpoints.fine, fine.level)
            };
            let rows = backend.sample(scene, &fine, &fine_options, progress)?;
            (plain, Some(rows))
        } else {
            let mut options = SamplingOptions {
                finer,
                ..options(min_pixels, &checkpoints.fine, fine.level)
            };
            // These folds drop what a finer view's fold targets (its parents) hold, so its probe
            // need not look for it.
            if fine.level == params.level + 1
                && matches!(
                    supersample.fold_corners,
                    FoldCorners::Split | FoldCorners::Cover
                )
            {
                options.folds_into = Some(params.level);
            }
            if supersample.splits(params.level) {
                let (rows, seen) = backend.sample_split(scene, &fine, &options, progress)?;
                (rows, Some(seen))
            } else {
                (backend.sample(scene, &fine, &options, progress)?, None)
            }
        };
        Ok(SphereRows {
            plain,
            fine,
            params,
            supersample,
            saturate: !self.plan.rows.research.sampled_rows,
        })
    }

    /// Sampling options of one pass of `sphere`: `min_pixels`, `checkpoint` and `views` as given,
    /// where the views are and the probe from the sphere, the rest from the settings.
    fn options(
        &self,
        sphere: &Sphere,
        min_pixels: u32,
        checkpoint: Option<PathBuf>,
        views: Option<Vec<u32>>,
    ) -> SamplingOptions {
        let rows = &self.plan.rows;
        SamplingOptions {
            min_pixels,
            dilate: rows.research.dilate,
            always_visible: rows.always_visible.clone(),
            conservative_raster: rows.research.conservative_raster,
            checkpoint,
            resume: self.settings.resume,
            memory: Some(self.settings.memory.split().sampling),
            views,
            probe: sphere.sampling.probe,
            apertures: sphere.sampling.apertures,
            // `None` for the sampling sphere.
            shell: sphere.shell,
            band: sphere.probe_band,
            folds_into: None,
            finer: crate::sampler::FinerViews::Midpoints,
        }
    }
}
