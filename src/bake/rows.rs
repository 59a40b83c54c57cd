//! The rows one sampling run yields, from which the stored matrix of any level up to the
//! sampled one is cut: the stored views' own rows, plus (when supersampling) the finer views'
//! rows folded into them.
//!
//! Level `l`'s views are a prefix of level `l + 1`'s (`sphere::ViewIndex`), so one run at the
//! finest level serves every coarser one: the bake takes its own level, and `eval --sweep`
//! takes each level it evaluates from the same run. With a fold threshold the stored views
//! are sampled plainly (every pixel) and the finer ones separately with the threshold; without
//! one, the finer pass holds the stored views' rows as its prefix and is sampled alone.

use super::Supersample;
use crate::sampler::fold_into_with;
use crate::sphere::{MAX_LEVEL, view_count};
use crate::visibility::{SamplingParams, VisibilityMatrix};

/// The sampled rows of one tiling (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct SampledRows {
    /// Every pixel counted: at `level`, or at the finer level when there is no threshold and
    /// this pass serves as both.
    pub(crate) plain: VisibilityMatrix,
    /// The thresholded finer views, at `min(level + K, MAX_LEVEL)`, when there is a threshold.
    pub(crate) fine: Option<VisibilityMatrix>,
    /// Where the cameras of the finest stored level were (the mesh's bounding sphere is
    /// computed once, for every level cut from these rows).
    pub(crate) params: SamplingParams,
    pub(crate) supersample: Supersample,
}

impl SampledRows {
    /// The finest stored level these rows serve.
    pub fn level(&self) -> u32 {
        self.params.level
    }

    /// Where the cameras of stored level `level` are: the sampled ones, at that level.
    pub fn params(&self, level: u32) -> SamplingParams {
        SamplingParams {
            level,
            ..self.params
        }
    }

    /// Views rendered to get these rows.
    pub fn sampled_views(&self) -> u32 {
        self.plain.views() + self.fine.as_ref().map_or(0, VisibilityMatrix::views)
    }

    /// The matrix a bake at `level` (at most [`SampledRows::level`]) stores: the level's own
    /// rows, with the finer views of `level + K` (capped at the finest sphere level) folded in.
    ///
    /// Panics (caller contract) if `level` is finer than the sampled level.
    pub fn stored(&self, level: u32) -> VisibilityMatrix {
        assert!(
            level <= self.level(),
            "level {level} is finer than the sampled level {}",
            self.level()
        );
        let coarse = self.plain.prefix(view_count(level));
        let fine_level = (level + self.supersample.extra_levels).min(MAX_LEVEL);
        if fine_level == level {
            return coarse;
        }
        let fine = self
            .fine
            .as_ref()
            .unwrap_or(&self.plain)
            .prefix(view_count(fine_level));
        fold_into_with(
            coarse,
            &fine,
            fine_level,
            level,
            self.supersample.fold_corners,
        )
    }
}
