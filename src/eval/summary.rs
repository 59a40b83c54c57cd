//! Aggregates over the views of one evaluation: what the quality table reports.
//!
//! Cost: a sort per summarised quantity.

use super::evaluator::ViewMetrics;
use super::metrics::Summary;

/// The aggregate of a set of [`ViewMetrics`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EvalSummary {
    /// Number of views.
    pub views: u32,
    /// Views the query answered: not flagged `inside_sphere` (a renderer may draw the others
    /// whole; their figures are still those of the query's answer).
    pub answered_views: u32,
    /// Views whose reconstruction is pixel-identical to the full render.
    pub identical_views: u32,
    /// Views where the query misses a patch the full render shows.
    pub views_missing_a_patch: u32,
    /// Missed pixels per view.
    pub missed_pixels: Summary,
    /// Missed patches per view.
    pub missed_patches: Summary,
    /// Triangles drawn per view.
    pub triangles_drawn: Summary,
    /// Culling rate per view.
    pub culling_rate: Summary,
    /// Ideal culling rate with the frustum (patches the view's full render does not show)
    /// per view.
    pub ideal_culling_rate: Summary,
    /// Ideal culling rate without the frustum (patches no direction from the eye shows) per
    /// view.
    pub ideal_culling_rate_all_directions: Summary,
    /// Culling rate per view with the answer also culled by the view frustum.
    pub frustum_culling_rate: Summary,
    /// Views where the frustum dropped a patch the answer's render shows (0 unless the
    /// frustum test is wrong).
    pub views_losing_a_patch_to_the_frustum: u32,
    /// PSNR (dB) over the views whose shaded pictures differ (`None` if none do).
    pub psnr_db_differing: Option<Summary>,
    /// Frame cost of the full mesh and the culled set.
    pub frame_cost: FrameCost,
}

/// Time to draw the full model against the culled set over the views (the seed paper's Table 1):
/// in [`EvalSummary`] with the CPU rasterizer standing in for the GPU; the GPU's own figure
/// (`eval --frame-backend gpu`) is made by the same [`FrameCost::of`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameCost {
    /// Median milliseconds per view to render everything.
    pub full_ms_median: f64,
    /// Median milliseconds per view to render the culled set.
    pub culled_ms_median: f64,
    /// Median full time over median culled time. Medians rather than totals, because on a
    /// loaded machine a few preempted renders would dominate the totals.
    pub speedup: f64,
}

impl FrameCost {
    /// The medians of per-view seconds to draw everything (`full`) and the culled set
    /// (`culled`), in milliseconds, and their ratio (infinite when the culled median is 0).
    pub fn of(full: impl Iterator<Item = f64>, culled: impl Iterator<Item = f64>) -> FrameCost {
        let full_ms = 1e3 * median(full);
        let culled_ms = 1e3 * median(culled);
        FrameCost {
            full_ms_median: full_ms,
            culled_ms_median: culled_ms,
            speedup: if culled_ms > 0.0 {
                full_ms / culled_ms
            } else {
                f64::INFINITY
            },
        }
    }
}

impl EvalSummary {
    /// Aggregates `views`.
    pub fn of(views: &[ViewMetrics]) -> EvalSummary {
        let count = |f: fn(&ViewMetrics) -> bool| views.iter().filter(|v| f(v)).count() as u32;
        let summary = |f: fn(&ViewMetrics) -> f64| Summary::of(views.iter().map(f));
        // A view can differ in triangle ids while its shaded pictures are equal (the missed
        // triangle shades like the one drawn instead, e.g. coplanar neighbours): infinite
        // PSNR, left out like identical views.
        let differing: Vec<f64> = views
            .iter()
            .filter(|v| v.missed_pixels > 0 && v.psnr_db.is_finite())
            .map(|v| v.psnr_db)
            .collect();
        EvalSummary {
            views: views.len() as u32,
            answered_views: count(|v| !v.inside_sphere),
            identical_views: count(|v| v.missed_pixels == 0),
            views_missing_a_patch: count(|v| v.missed_patches > 0),
            missed_pixels: summary(|v| v.missed_pixels as f64),
            missed_patches: summary(|v| f64::from(v.missed_patches)),
            triangles_drawn: summary(|v| v.triangles_drawn as f64),
            culling_rate: summary(|v| v.culling_rate),
            ideal_culling_rate: summary(|v| v.ideal_culling_rate),
            ideal_culling_rate_all_directions: summary(|v| v.ideal_culling_rate_all_directions),
            frustum_culling_rate: summary(|v| v.frustum_culling_rate),
            views_losing_a_patch_to_the_frustum: count(|v| v.frustum_lost_patches > 0),
            psnr_db_differing: (!differing.is_empty()).then(|| Summary::of(differing)),
            frame_cost: FrameCost::of(
                views.iter().map(|v| v.full_seconds),
                views.iter().map(|v| v.culled_seconds),
            ),
        }
    }

    /// Fraction of views that are pixel-identical.
    pub fn identical_views_fraction(&self) -> f64 {
        if self.views == 0 {
            return 1.0;
        }
        f64::from(self.identical_views) / f64::from(self.views)
    }
}

fn median(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view(missed_pixels: u64, missed_patches: u32, drawn: u64, full: f64) -> ViewMetrics {
        ViewMetrics {
            eye: [0.0; 3],
            inside_sphere: false,
            covered_pixels: 100,
            missed_pixels,
            tied_pixels: 0,
            visible_patches: 10,
            answer_patches: 12,
            missed_patches,
            triangles_drawn: drawn,
            culling_rate: 1.0 - drawn as f64 / 100.0,
            ideal_culling_rate: 0.5,
            visible_patches_all_directions: 11,
            ideal_culling_rate_all_directions: 0.4,
            frustum_answer_patches: 11,
            frustum_triangles_drawn: drawn - 1,
            frustum_culling_rate: 1.0 - (drawn - 1) as f64 / 100.0,
            frustum_lost_patches: 0,
            psnr_db: if missed_pixels == 0 {
                f64::INFINITY
            } else {
                30.0
            },
            full_seconds: full,
            culled_seconds: full / 2.0,
        }
    }

    #[test]
    fn aggregates_count_identical_views_and_frame_cost() {
        let views = [
            view(0, 0, 40, 0.010),
            view(5, 1, 60, 0.020),
            view(0, 0, 50, 0.030),
        ];
        let s = EvalSummary::of(&views);
        assert_eq!(
            (s.views, s.identical_views, s.views_missing_a_patch),
            (3, 2, 1)
        );
        assert_eq!(s.answered_views, 3);
        assert!((s.ideal_culling_rate_all_directions.mean - 0.4).abs() < 1e-12);
        assert!((s.identical_views_fraction() - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(s.missed_pixels.max, 5.0);
        assert!((s.culling_rate.mean - 0.5).abs() < 1e-12);
        assert!((s.frustum_culling_rate.mean - 0.51).abs() < 1e-12);
        assert_eq!(s.views_losing_a_patch_to_the_frustum, 0);
        assert_eq!(s.psnr_db_differing.map(|p| p.mean), Some(30.0));
        assert!((s.frame_cost.full_ms_median - 20.0).abs() < 1e-9);
        assert!((s.frame_cost.speedup - 2.0).abs() < 1e-12);
        assert_eq!(median([4.0, 1.0, 3.0, 2.0].into_iter()), 2.5);
        assert!(
            EvalSummary::of(&[view(0, 0, 1, 0.1)])
                .psnr_db_differing
                .is_none()
        );
    }

    #[test]
    fn views_that_differ_only_in_ids_leave_psnr_finite() {
        // Regression: eval at 1024² (seed 2) panicked when a view missed pixels whose
        // replacement shaded the same colour (infinite PSNR with missed pixels > 0).
        let same_shade = ViewMetrics {
            psnr_db: f64::INFINITY,
            ..view(3, 1, 60, 0.02)
        };
        let s = EvalSummary::of(&[same_shade, view(5, 1, 60, 0.02)]);
        assert_eq!(s.identical_views, 0);
        assert_eq!(s.psnr_db_differing.map(|p| p.mean), Some(30.0));
        let only = EvalSummary::of(&[same_shade]);
        assert_eq!(only.psnr_db_differing, None);
    }
}
