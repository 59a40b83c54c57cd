//! The rows one sampling run yields, from which the stored matrices of any level up to the
//! sampled one are cut: per sphere of views (the sampling sphere, then each sampling shell),
//! the stored views' own rows, plus (when supersampling) the finer views' rows folded into
//! them.
//!
//! Level `l`'s views are a prefix of level `l + 1`'s (`sphere::ViewIndex`), so one run at the
//! finest level serves every coarser one: the bake takes its own level, and `eval --sweep`
//! takes each level it evaluates from the same run. With a fold threshold the stored views
//! are sampled plainly (every pixel) and the finer ones separately with the threshold; without
//! one, the finer pass holds the stored views' rows as its prefix and is sampled alone; with
//! the split fold of `--conservative` it also keeps its rows before the probe pass, as a
//! second pass. A shell's rows are folded the same way, at the shell's own level
//! (`shells.rs`). The folded rows are then saturated (`sampler::saturate`: every bit no
//! query's answer depends on is set), unless the bake keeps the rows as sampled.

use super::plan::{SphereKind, Supersample};
use crate::sampler::{PassViews, fold_views, saturate, split_fold_views};
use crate::sphere::{MAX_LEVEL, view_count};
use crate::visibility::{SamplingParams, VisibilityMatrix};

/// The sampled rows of one tiling (see the module documentation): one entry per sphere of
/// views, in the plan's order (the sampling sphere first, then each shell).
#[derive(Clone, Debug, PartialEq)]
pub struct SampledRows {
    pub(crate) spheres: Vec<SampledSphere>,
}

/// The rows of one sphere of views.
#[derive(Clone, Debug, PartialEq)]
pub struct SampledSphere {
    /// Which sphere it is.
    pub kind: SphereKind,
    /// A shell's camera distance from the centre, in the frame sampled in; `None`: the
    /// sampling distance.
    pub shell: Option<f32>,
    /// Its rows; `params.level` is the sphere's finest stored level.
    pub(crate) rows: SphereRows,
    /// Seconds its passes took.
    pub seconds: f64,
}

/// The rows of one sphere of views: the sampling sphere or a shell.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SphereRows {
    /// Every pixel counted: at `level`, or at the finer level when there is no threshold and
    /// this pass serves as both.
    pub(crate) plain: VisibilityMatrix,
    /// The second pass, at `min(level + K, MAX_LEVEL)`: the thresholded finer views when there
    /// is a threshold, or, with the split fold, the finer views' rows before the probe pass
    /// (`sampler::sample_tiled_split`).
    pub(crate) fine: Option<VisibilityMatrix>,
    /// Where the cameras of the finest stored level were (the mesh's bounding sphere is
    /// computed once, for every level cut from these rows).
    pub(crate) params: SamplingParams,
    pub(crate) supersample: Supersample,
    /// Whether the stored rows are saturated (`sampler::saturate`; off with
    /// `bake --sampled-rows`).
    pub(crate) saturate: bool,
}

impl SphereRows {
    /// Views rendered to get these rows.
    pub(crate) fn sampled_views(&self) -> u32 {
        let fine = self.fine_views(self.params.level);
        // A pass at the finer level renders the views of its layout, one at the stored level
        // every view.
        let rendered = |m: &VisibilityMatrix| {
            if m.views() == fine.slots() {
                fine.end()
            } else {
                m.views()
            }
        };
        if self.supersample.splits(self.params.level) {
            // The seen rows come from the same renders.
            return rendered(&self.plain);
        }
        rendered(&self.plain) + self.fine.as_ref().map_or(0, rendered)
    }

    /// The views of the pass folded into stored level `level`: the sampled level's finer
    /// views are laid out as the bake asked, those of a coarser level cut from the same rows
    /// (`eval --sweep`) are sphere vertices of the sampled level.
    fn fine_views(&self, level: u32) -> PassViews {
        let fine_level = (level + self.supersample.extra_levels).min(MAX_LEVEL);
        let finer = self.supersample.finer_views(self.params.level, fine_level);
        PassViews::new(level, fine_level, finer)
    }

    /// The matrices of the passes, in sampling order: the plain pass, then the thresholded
    /// finer one if any.
    pub(crate) fn passes(&self) -> impl Iterator<Item = &VisibilityMatrix> {
        std::iter::once(&self.plain).chain(self.fine.as_ref())
    }

    /// The stored matrix at `level` (see [`SampledRows::stored`]).
    pub(crate) fn stored(&self, level: u32) -> VisibilityMatrix {
        let rows = self.folded(level);
        if self.saturate {
            saturate(rows, level)
        } else {
            rows
        }
    }

    /// The level's own rows with the finer views folded in, as sampled.
    fn folded(&self, level: u32) -> VisibilityMatrix {
        assert!(
            level <= self.params.level,
            "level {level} is finer than the sampled level {}",
            self.params.level
        );
        let coarse = self.plain.prefix(view_count(level));
        let views = self.fine_views(level);
        let fine_level = views.fine_level();
        if fine_level == level {
            return coarse;
        }
        if self.supersample.splits(level) {
            let seen = self.fine.as_ref().expect("a split pass has its seen rows");
            return split_fold_views(
                coarse,
                &self.plain.prefix(view_count(fine_level)),
                &seen.prefix(view_count(fine_level)),
                &views,
            );
        }
        let fine = self
            .fine
            .as_ref()
            .unwrap_or(&self.plain)
            .prefix(view_count(fine_level));
        fold_views(coarse, &fine, &views, self.supersample.fold_corners)
    }
}

impl SampledRows {
    /// The sampling sphere's rows.
    fn main(&self) -> &SampledSphere {
        &self.spheres[0]
    }

    /// The finest stored level these rows serve.
    pub fn level(&self) -> u32 {
        self.main().rows.params.level
    }

    /// Where the cameras of stored level `level` are: the sampled ones, at that level.
    pub fn params(&self, level: u32) -> SamplingParams {
        SamplingParams {
            level,
            ..self.main().rows.params
        }
    }

    /// Views rendered to get the sampling sphere's rows, every pass counted (each shell's
    /// are [`SampledSphere::sampled_views`]).
    pub fn sampled_views(&self) -> u32 {
        self.main().sampled_views()
    }

    /// Every sphere, in sampling order.
    pub fn spheres(&self) -> &[SampledSphere] {
        &self.spheres
    }

    /// The shells in the file's order (spec § SHEL, decreasing distance): the far band's,
    /// outermost first, then those inside the sampling sphere, outermost first.
    pub fn shells(&self) -> impl Iterator<Item = &SampledSphere> {
        let of = |far: bool| {
            self.spheres.iter().filter(move |s| match s.kind {
                SphereKind::Sampling => false,
                SphereKind::Shell(_) => !far,
                SphereKind::Far(_) => far,
            })
        };
        of(true).rev().chain(of(false))
    }

    /// The matrix a bake at `level` (at most [`SampledRows::level`]) stores: the level's own
    /// rows, with the finer views of `level + K` (capped at the finest sphere level) folded in,
    /// saturated unless the bake keeps the rows as sampled.
    ///
    /// Panics (caller contract) if `level` is finer than the sampled level.
    pub fn stored(&self, level: u32) -> VisibilityMatrix {
        self.main().rows.stored(level)
    }

    /// Every pass's matrix in sampling order: each sphere's, in the plan's order
    /// (`Plan::pass_levels` has their levels).
    pub(crate) fn passes(&self) -> impl Iterator<Item = &VisibilityMatrix> {
        self.spheres.iter().flat_map(|s| s.rows.passes())
    }
}

impl SampledSphere {
    /// The finest stored level of the sphere's rows.
    pub fn level(&self) -> u32 {
        self.rows.params.level
    }

    /// Views rendered for the sphere, every pass counted.
    pub fn sampled_views(&self) -> u32 {
        self.rows.sampled_views()
    }

    /// The matrix a bake storing the sphere at `level` (at most [`SampledSphere::level`])
    /// stores, folded as [`SampledRows::stored`] folds the sampling sphere's.
    ///
    /// Panics (caller contract) if `level` is finer than the sampled level.
    pub fn stored(&self, level: u32) -> VisibilityMatrix {
        self.rows.stored(level)
    }
}
