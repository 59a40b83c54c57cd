//! The evaluation's SVG figures ([`super::plot`]): popping and picture quality along a path,
//! and the sweep's culling rate and missed pixels against the sampling views and the patch
//! count (the seed paper's Figures 4–5). Cost: linear in the points.

use super::evaluator::ViewMetrics;
use super::plot::{self, Axis, Chart, Series};
use super::sweep::SweepPoint;

/// Identical frames have infinite PSNR; the path plot draws them at this height.
pub const PSNR_PLOT_CAP_DB: f64 = 60.0;

/// The path's figure (`path.svg`): missed pixels and missed visible patches per frame, then
/// PSNR (identical frames drawn at [`PSNR_PLOT_CAP_DB`]) and the culling rate.
pub fn path_plot(metrics: &[ViewMetrics]) -> String {
    let frames = |f: &dyn Fn(&ViewMetrics) -> f64| -> Vec<(f64, f64)> {
        metrics
            .iter()
            .enumerate()
            .map(|(i, m)| (i as f64, f(m)))
            .collect()
    };
    let popping = Chart {
        title: "Popping along the path".into(),
        x_label: "frame".into(),
        x_log: false,
        left_label: "missed pixels".into(),
        right_label: "missed patches".into(),
        series: vec![
            Series {
                name: "missed pixels".into(),
                points: frames(&|m| m.missed_pixels as f64),
                axis: Axis::Left,
                colour: 1,
            },
            Series {
                name: "missed visible patches".into(),
                points: frames(&|m| f64::from(m.missed_patches)),
                axis: Axis::Right,
                colour: 0,
            },
        ],
    };
    let quality = Chart {
        title: format!(
            "PSNR, shaded full vs reconstructed (identical frames at {PSNR_PLOT_CAP_DB} dB)"
        ),
        x_label: "frame".into(),
        x_log: false,
        left_label: "PSNR (dB)".into(),
        right_label: "culling rate (%)".into(),
        series: vec![
            Series {
                name: "PSNR".into(),
                points: frames(&|m| m.psnr_db.min(PSNR_PLOT_CAP_DB)),
                axis: Axis::Left,
                colour: 2,
            },
            Series {
                name: "culling rate".into(),
                points: frames(&|m| 100.0 * m.culling_rate),
                axis: Axis::Right,
                colour: 0,
            },
        ],
    };
    plot::svg(&[popping, quality])
}

/// The seed paper's Figures 4–5 for this mesh: culling rate and missed pixels against the
/// number of sampling views (one line per patch count) and against the patch count (one line
/// per level), with the file size on the right axis.
pub fn sweep_plots(points: &[SweepPoint]) -> Vec<(&'static str, String)> {
    let mut patches: Vec<u32> = points.iter().map(|p| p.patches).collect();
    patches.sort_unstable();
    patches.dedup();
    let mut levels: Vec<u32> = points.iter().map(|p| p.level).collect();
    levels.sort_unstable();
    levels.dedup();
    type Metric = fn(&SweepPoint) -> f64;
    let culling: Metric = |p| 100.0 * p.summary.culling_rate.mean;
    let missed: Metric = |p| p.summary.missed_pixels.mean;
    let size: Metric = |p| p.file_bytes as f64 / 1024.0;
    let chart = |by_level: bool, what: &str, metric: Metric, label: &str| {
        let groups: Vec<u32> = if by_level {
            patches.clone()
        } else {
            levels.clone()
        };
        let mut series = Vec::new();
        for (axis, f, suffix) in [(Axis::Left, metric, ""), (Axis::Right, size, " size")] {
            for (c, &g) in groups.iter().enumerate() {
                let pts = points
                    .iter()
                    .filter(|p| {
                        if by_level {
                            p.patches == g
                        } else {
                            p.level == g
                        }
                    })
                    .map(|p| {
                        let x = if by_level {
                            f64::from(p.sampling_views)
                        } else {
                            f64::from(p.patches)
                        };
                        (x, f(p))
                    })
                    .collect();
                let name = if by_level {
                    format!("P={g}{suffix}")
                } else {
                    format!("level {g}{suffix}")
                };
                series.push(Series {
                    name,
                    points: pts,
                    axis,
                    colour: c,
                });
            }
        }
        Chart {
            title: format!(
                "{what} against {}",
                if by_level {
                    "sampling views"
                } else {
                    "patch count"
                }
            ),
            x_label: if by_level {
                "sampling views (sphere levels)".into()
            } else {
                "patches".into()
            },
            x_log: true,
            left_label: label.into(),
            right_label: "file size (KiB), dashed".into(),
            series,
        }
    };
    vec![
        (
            "sweep-levels.svg",
            plot::svg(&[
                chart(true, "Culling rate", culling, "culling rate (%)"),
                chart(
                    true,
                    "Missed pixels",
                    missed,
                    "missed pixels per view (mean)",
                ),
            ]),
        ),
        (
            "sweep-patches.svg",
            plot::svg(&[
                chart(false, "Culling rate", culling, "culling rate (%)"),
                chart(
                    false,
                    "Missed pixels",
                    missed,
                    "missed pixels per view (mean)",
                ),
            ]),
        ),
    ]
}
