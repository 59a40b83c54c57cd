//! The JSON fields of `patchvis eval`'s reports (`--json`, `--stats`), its sweep's included:
//! an evaluation's aggregate as flat fields, each view's figures, and the culling figures of
//! `--stats`.

use super::eval_bands::BandReport;
use patchvis::eval::{EvalSummary, ViewMetrics, metrics::Summary};
use serde_json::{Value, json};

/// The culling fields of `--stats`.
pub(super) fn stats_culling_json(s: &EvalSummary) -> Value {
    json!({
        "answered_views": s.answered_views,
        "culling_rate_mean": s.culling_rate.mean,
        "frustum_culling_rate_mean": s.frustum_culling_rate.mean,
        "ideal_culling_rate_mean": s.ideal_culling_rate.mean,
        "ideal_culling_rate_all_directions_mean": s.ideal_culling_rate_all_directions.mean,
        "views_losing_a_patch_to_the_frustum": s.views_losing_a_patch_to_the_frustum,
    })
}

/// The `per_view` entries of a band, with the GPU's timings where measured.
pub(super) fn per_view_json(band: &BandReport) -> Vec<Value> {
    band.band
        .metrics
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let mut view = view_json(i, m);
            if let Some(g) = &band.gpu {
                let (full, culled) = g.per_view_ms[i];
                merge(
                    &mut view,
                    json!({"gpu_full_ms": full, "gpu_culled_ms": culled}),
                );
            }
            view
        })
        .collect()
}

/// The `NAME_mean`, `_p95`, `_p99`, `_max` and `_min` fields of a statistic.
fn summary_fields(out: &mut serde_json::Map<String, Value>, name: &str, s: &Summary) {
    out.insert(format!("{name}_mean"), json!(s.mean));
    out.insert(format!("{name}_p95"), json!(s.p95));
    out.insert(format!("{name}_p99"), json!(s.p99));
    out.insert(format!("{name}_max"), json!(s.max));
    out.insert(format!("{name}_min"), json!(s.min));
}

/// The aggregate as flat JSON fields (`missed_pixels_mean`, …).
pub(super) fn summary_json(s: &EvalSummary) -> Value {
    let mut out = serde_json::Map::new();
    out.insert("views".into(), json!(s.views));
    out.insert("answered_views".into(), json!(s.answered_views));
    out.insert("identical_views".into(), json!(s.identical_views));
    out.insert(
        "identical_views_fraction".into(),
        json!(s.identical_views_fraction()),
    );
    out.insert(
        "views_missing_a_patch".into(),
        json!(s.views_missing_a_patch),
    );
    summary_fields(&mut out, "missed_pixels", &s.missed_pixels);
    summary_fields(&mut out, "missed_patches", &s.missed_patches);
    summary_fields(&mut out, "triangles_drawn", &s.triangles_drawn);
    summary_fields(&mut out, "culling_rate", &s.culling_rate);
    summary_fields(&mut out, "ideal_culling_rate", &s.ideal_culling_rate);
    summary_fields(
        &mut out,
        "ideal_culling_rate_all_directions",
        &s.ideal_culling_rate_all_directions,
    );
    summary_fields(&mut out, "frustum_culling_rate", &s.frustum_culling_rate);
    out.insert(
        "views_losing_a_patch_to_the_frustum".into(),
        json!(s.views_losing_a_patch_to_the_frustum),
    );
    if let Some(p) = &s.psnr_db_differing {
        summary_fields(&mut out, "psnr_db_differing", p);
    }
    out.insert(
        "frame_cost".into(),
        json!({
            "full_ms_median": s.frame_cost.full_ms_median,
            "culled_ms_median": s.frame_cost.culled_ms_median,
            "speedup": s.frame_cost.speedup,
        }),
    );
    Value::Object(out)
}

/// One view's entry of `per_view`.
fn view_json(index: usize, m: &ViewMetrics) -> Value {
    json!({
        "index": index,
        "eye": m.eye,
        "inside_sphere": m.inside_sphere,
        "covered_pixels": m.covered_pixels,
        "missed_pixels": m.missed_pixels,
        "tied_pixels": m.tied_pixels,
        "visible_patches": m.visible_patches,
        "answer_patches": m.answer_patches,
        "missed_patches": m.missed_patches,
        "triangles_drawn": m.triangles_drawn,
        "culling_rate": m.culling_rate,
        "ideal_culling_rate": m.ideal_culling_rate,
        "visible_patches_all_directions": m.visible_patches_all_directions,
        "ideal_culling_rate_all_directions": m.ideal_culling_rate_all_directions,
        "frustum_answer_patches": m.frustum_answer_patches,
        "frustum_triangles_drawn": m.frustum_triangles_drawn,
        "frustum_culling_rate": m.frustum_culling_rate,
        "frustum_lost_patches": m.frustum_lost_patches,
        // Infinite (identical pictures) becomes null.
        "psnr_db": m.psnr_db,
        "full_ms": 1e3 * m.full_seconds,
        "culled_ms": 1e3 * m.culled_seconds,
    })
}

/// Adds `from`'s fields to `into` (both JSON objects).
pub(super) fn merge(into: &mut Value, from: Value) {
    if let (Value::Object(a), Value::Object(b)) = (into, from) {
        a.extend(b);
    }
}
