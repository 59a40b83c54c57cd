//! `patchvis eval --distance-scale K,K,..`: distance bands. Each distance evaluates the same
//! cameras (same seed, same look jitter) moved to that distance (`patchvis::eval::Band`), so
//! that the bands compare row by row; this file parses the list and prints the table, one row
//! per distance in the order given, with what each column compares.

use super::UsageError;
use super::eval_frame::GpuReport;
use super::out::{StdoutError, outln};
use patchvis::eval::Band;
use patchvis::runtime::Pvis;
use std::path::PathBuf;

/// The distances of `--distance-scale K[,K..]`, in the order given: each finite, positive
/// and listed once.
pub fn parse_distance_scales(text: &str) -> Result<Vec<f32>, UsageError> {
    let expected = "expected positive numbers separated by commas, e.g. 0.45,0.6,0.8,1";
    let mut scales = Vec::new();
    for item in text.split(',') {
        let item = item.trim();
        let scale = item
            .parse::<f32>()
            .ok()
            .filter(|k| k.is_finite() && *k > 0.0)
            .ok_or_else(|| {
                UsageError(if item.is_empty() {
                    format!("--distance-scale {text:?}: an empty item; {expected}")
                } else {
                    format!("--distance-scale {text}: {item} is not a positive number; {expected}")
                })
            })?;
        if scales.contains(&scale) {
            return Err(UsageError(format!(
                "--distance-scale {text}: {item} is listed twice; {expected}"
            )));
        }
        scales.push(scale);
    }
    Ok(scales)
}

/// One distance of the evaluation as the reports show it: the library's band, the GPU's
/// frame cost and the pictures written.
pub struct BandReport {
    /// The cameras and what they showed.
    pub band: Band,
    /// The GPU frame cost, where measured.
    pub gpu: Option<GpuReport>,
    /// PNGs written for this band.
    pub pictures: Vec<PathBuf>,
}

/// The distance bands' table: a row per distance, in the order given, and what its columns
/// compare.
pub fn print_bands(bands: &[BandReport], pvis: &Pvis<'_>) -> Result<(), StdoutError> {
    outln!(
        "| distance | eye / R | answered | identical views | missed px mean / p99 / max | culling | ideal, all directions | culling + frustum | ideal in frustum |"
    )?;
    outln!("|---|---|---|---|---|---|---|---|---|")?;
    for BandReport { band: b, .. } in bands {
        let s = &b.summary;
        let flagged = s.views - s.answered_views;
        outln!(
            "| x{} | {:.2} | {}/{}{} | {:.1}% | {:.1} / {} / {} | {:.1}% | {:.1}% | {:.1}% | {:.1}% |",
            b.scale,
            b.radii(pvis),
            s.answered_views,
            s.views,
            if flagged > 0 {
                format!(" ({flagged} flagged)")
            } else {
                String::new()
            },
            100.0 * s.identical_views_fraction(),
            s.missed_pixels.mean,
            s.missed_pixels.p99,
            s.missed_pixels.max,
            100.0 * s.culling_rate.mean,
            100.0 * s.ideal_culling_rate_all_directions.mean,
            100.0 * s.frustum_culling_rate.mean,
            100.0 * s.ideal_culling_rate.mean,
        )?;
    }
    outln!(
        "distance: camera distance over the sampling distance; eye / R: over the bounding radius."
    )?;
    outln!(
        "answered: views the reader did not flag inside_sphere. A renderer may draw a flagged view whole (culling 0 %, nothing missed); its figures here are of the reader's answer. A version-4 file flags every eye nearer than its sampling distance, and one at exactly that distance about half the time (rounding)."
    )?;
    outln!(
        "culling: the answer, against the ideal in all directions (triangles of patches no direction from the eye shows). culling + frustum: the answer culled by the camera's frustum (query_in_frustum), against the ideal in the frustum (triangles of patches the camera's full render does not show)."
    )?;
    for BandReport { band: b, .. } in bands {
        if b.summary.views_losing_a_patch_to_the_frustum > 0 {
            outln!(
                "distance x{}: views where the frustum dropped a patch the answer draws: {} (a bug: please report)",
                b.scale,
                b.summary.views_losing_a_patch_to_the_frustum
            )?;
        }
    }
    Ok(())
}
