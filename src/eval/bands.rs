//! An evaluation at one camera distance or several (`eval --distance-scale K[,K..]`): the
//! same cameras — seeded random directions, the views of a sampling level, an orbit or a
//! camera path — placed at each distance and turned by the same look jitter, so that the
//! distances compare view by view.
//!
//! A distance is a scale of the file's sampling distance ([`sampling_params`]); a path's
//! cameras stay where the path puts them. Cost: one [`Evaluator::evaluate`] per distance.

use super::evaluator::{EvalError, Evaluator, ViewMetrics, sampling_params};
use super::summary::EvalSummary;
use super::views::{self, PathCamera};
use crate::bake::Stages;
use crate::progress::Progress;
use crate::runtime::Pvis;
use crate::sampler::{Camera, SamplingParams};
use crate::sphere::view_count;

/// Which cameras to evaluate.
#[derive(Clone, Debug, PartialEq)]
pub enum ViewSet {
    /// `count` seeded random directions on the sphere ([`views::random_directions`]).
    Random {
        /// Cameras.
        count: u32,
        /// Seed of the directions.
        seed: u64,
    },
    /// The sampling views of sphere level `level`.
    Sampling {
        /// The level.
        level: u32,
    },
    /// An orbit of `frames` frames ([`views::orbit_directions`]).
    Orbit {
        /// Frames.
        frames: u32,
    },
    /// A camera path: each camera's eye and the point it looks at ([`ViewSet::path`]).
    Path(Vec<([f32; 3], [f32; 3])>),
}

impl ViewSet {
    /// The views of a camera path: each camera looks at its target, or else at `center` (the
    /// model's centre). Refuses a camera without a target whose eye is `center`.
    pub fn path(cameras: &[PathCamera], center: [f32; 3]) -> Result<ViewSet, EvalError> {
        cameras
            .iter()
            .enumerate()
            .map(|(i, &PathCamera { eye, target })| {
                let target = target.unwrap_or(center);
                if eye == target {
                    return Err(EvalError::EyeAtCentre { camera: i + 1 });
                }
                Ok((eye, target))
            })
            .collect::<Result<_, _>>()
            .map(ViewSet::Path)
    }

    /// The cameras, in view order, at `params`' distance, resolution and field of view (a
    /// path's at its own eyes).
    fn cameras(&self, params: &SamplingParams) -> Vec<Camera> {
        match self {
            ViewSet::Random { count, seed } => views::random_directions(*count, *seed)
                .into_iter()
                .map(|d| Camera::sampling(params, d))
                .collect(),
            ViewSet::Sampling { level } => (0..view_count(*level))
                .map(|v| Camera::sampling_view(params, v))
                .collect(),
            ViewSet::Orbit { frames } => views::orbit_directions(*frames)
                .into_iter()
                .map(|d| Camera::sampling(params, d))
                .collect(),
            ViewSet::Path(cameras) => cameras
                .iter()
                .map(|&(eye, target)| {
                    Camera::look_at(eye, target, params.fov_deg, params.resolution)
                })
                .collect(),
        }
    }
}

/// `camera` with the field of view that frames the bounding sphere (`center`, `radius`) from
/// its eye, looking at the centre, where that is narrower than `fov_deg` (beyond the sampling
/// distance); else `camera` itself.
fn framed(camera: Camera, center: [f32; 3], radius: f32, fov_deg: f32) -> Camera {
    let eye = camera.eye();
    let distance = (0..3)
        .map(|k| (eye[k] - f64::from(center[k])).powi(2))
        .sum::<f64>()
        .sqrt();
    let fov = 2.0 * (f64::from(radius) / distance).min(1.0).asin().to_degrees();
    if fov >= f64::from(fov_deg) {
        return camera;
    }
    Camera::look_at_f64(eye, center.map(f64::from), fov, camera.resolution())
}

/// The cameras of an evaluation, before they are placed at a distance.
#[derive(Clone, Debug, PartialEq)]
pub struct BandViews {
    /// Which cameras.
    pub views: ViewSet,
    /// Render resolution, pixels a side.
    pub resolution: u32,
    /// Largest turn of a camera's look, degrees (`eval --look-jitter`; 0 keeps the looks).
    pub look_jitter_deg: f32,
    /// Seed of the turns: the same in every band, so the same camera turns alike.
    pub seed: u64,
    /// Beyond the sampling distance, each camera's field of view frames the bounding sphere
    /// from its eye (`eval --fit`) instead of keeping the file's.
    pub fit: bool,
}

/// One distance of an evaluation: its cameras and what they showed.
#[derive(Clone, Debug)]
pub struct Band {
    /// Camera distance over the sampling distance.
    pub scale: f32,
    /// Camera distance from the centre, as the cameras were placed (binary32).
    pub distance: f32,
    /// The cameras, in view order.
    pub cameras: Vec<Camera>,
    /// What each camera showed.
    pub metrics: Vec<ViewMetrics>,
    /// Their aggregate.
    pub summary: EvalSummary,
}

impl Band {
    /// Evaluates `views` at `scale` times the file's sampling distance: the evaluation is
    /// stage `eval` of `stages`.
    pub fn evaluate(
        evaluator: &Evaluator<'_>,
        pvis: &Pvis<'_>,
        views: &BandViews,
        scale: f32,
        progress: &dyn Progress,
        stages: &mut Stages,
    ) -> Band {
        let params = sampling_params(pvis, views.resolution, scale);
        let mut cameras = views.views.cameras(&params);
        if views.fit {
            let sampling = pvis.sampling();
            cameras = cameras
                .into_iter()
                .map(|c| framed(c, sampling.center, sampling.radius, sampling.fov_deg))
                .collect();
        }
        let cameras = views::jitter_looks(&cameras, f64::from(views.look_jitter_deg), views.seed);
        let metrics = stages.run("eval", || evaluator.evaluate(pvis, &cameras, progress));
        let summary = EvalSummary::of(&metrics);
        Band {
            scale,
            distance: params.distance(),
            cameras,
            metrics,
            summary,
        }
    }

    /// The camera distance in bounding radii.
    pub fn radii(&self, pvis: &Pvis<'_>) -> f64 {
        f64::from(self.distance) / f64::from(pvis.sampling().radius)
    }

    /// Indices of the `n` views with the most missed pixels (ties: lower index first).
    pub fn worst(&self, n: u32) -> Vec<usize> {
        let metrics = &self.metrics;
        let mut order: Vec<usize> = (0..metrics.len()).collect();
        order.sort_by_key(|&i| (std::cmp::Reverse(metrics[i].missed_pixels), i));
        order.truncate(n as usize);
        order
    }
}
