//! `patchvis eval --sweep`: flags → the library's sweep settings (`patchvis::eval::sweep`),
//! which bakes the mesh for every patch count and level and evaluates each file; then a
//! table or JSON, and the library's figures under `--png`.

use super::args::{EvalArgs, SweepModeArg, memory_budget};
use super::eval_json::{merge, summary_json};
use super::out::{StdoutError, outln};
use super::progress::Bars;
use super::{UsageError, usage};
use anyhow::{Context, Result};
use patchvis::bake::{
    BakeSettings, DEFAULT_FOLD_MIN_PIXELS, DEFAULT_PROBE_PIXELS, DEFAULT_VIEW_SUPERSAMPLE,
    PROBE_FOLD_CORNERS, Probe, Research, RowSettings,
};
use patchvis::eval::{SweepPoint, SweepSettings, open_mesh, sweep_plots};
use patchvis::format::write_atomic;
use patchvis::memory::DEFAULT_PROBE_MAX_TRIANGLES;
use patchvis::ooc::Mesh;
use patchvis::sampler::FoldCorners;
use patchvis::sphere::MAX_LEVEL;
use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::Instant;

/// Resolution of `--sweep`'s bakes unless `--resolution` says otherwise (the bake default).
const DEFAULT_SWEEP_RESOLUTION: u32 = 512;

/// Runs `eval --sweep` at `distance_scale`: bakes and evaluates every patch count and level
/// (a line on stderr each), then the table or JSON, and the figures under `--png`.
pub(super) fn run(args: &EvalArgs, distance_scale: f32) -> Result<()> {
    let settings = sweep_settings(args, distance_scale)?;
    let mode = sweep_mode_name(args.sweep_mode);
    let mesh = open_mesh(&args.mesh, settings.bake.memory)?;
    let bars = Bars::new(!args.quiet && !args.json);
    let start = Instant::now();
    let verbose = !args.quiet;
    let points = patchvis::eval::sweep(&mesh, &settings, &bars, &mut |p| {
        if verbose {
            eprintln!(
                "sweep: {} patches, level {}: culling {:.1}% (ideal {:.1}%), missed pixels {:.1} mean / {} p95 / {} max, identical {:.1}%, {} views missing a patch, {} bytes ({:.0} s)",
                p.patches,
                p.level,
                100.0 * p.summary.culling_rate.mean,
                100.0 * p.summary.ideal_culling_rate.mean,
                p.summary.missed_pixels.mean,
                p.summary.missed_pixels.p95,
                p.summary.missed_pixels.max,
                100.0 * p.summary.identical_views_fraction(),
                p.summary.views_missing_a_patch,
                p.file_bytes,
                start.elapsed().as_secs_f64()
            );
        }
    })
    .with_context(|| format!("{}: sweep failed", args.mesh.display()))?;
    let mut written = Vec::new();
    if let Some(dir) = &args.png {
        for (name, svg) in sweep_plots(&points) {
            let path = dir.join(name);
            write_atomic(&path, svg.as_bytes())
                .with_context(|| format!("{}: cannot write", path.display()))?;
            written.push(path);
        }
    }
    let report = SweepReport {
        args,
        settings: &settings,
        mesh: &mesh,
        points: &points,
        mode,
        written,
    };
    if args.json {
        let json = report.json(start.elapsed().as_secs_f64());
        outln!("{}", serde_json::to_string_pretty(&json)?)?;
    } else {
        report.print()?;
    }
    Ok(())
}

/// The sweep's settings for the flags: the bakes' resolution, field of view, sampling
/// (`--sweep-mode`), tiling and memory, and the evaluation's views.
fn sweep_settings(args: &EvalArgs, distance_scale: f32) -> Result<SweepSettings> {
    usage(args.views == 0, || "--views 0: expected at least 1".into())?;
    usage(args.sweep_patches.contains(&0), || {
        "--sweep-patches: expected patch counts of at least 1".into()
    })?;
    if let Some(&l) = args.sweep_levels.iter().find(|&&l| l > MAX_LEVEL) {
        return Err(UsageError(format!(
            "--sweep-levels: level {l}, expected 0 to {MAX_LEVEL}"
        ))
        .into());
    }
    usage(
        !(args.fov.is_finite() && args.fov > 0.0 && args.fov < 180.0),
        || {
            format!(
                "--fov {}: expected degrees between 0 and 180, exclusive",
                args.fov
            )
        },
    )?;
    Ok(SweepSettings {
        patches: args.sweep_patches.clone(),
        levels: args.sweep_levels.clone(),
        bake: BakeSettings {
            rows: RowSettings {
                resolution: args.resolution.unwrap_or(DEFAULT_SWEEP_RESOLUTION),
                fov_deg: args.fov,
                // Plain: the stored views' own patches (`bake --view-supersample 0 --probe
                // off`); default: what a default `patchvis bake` writes at every level.
                research: Research {
                    view_supersample: match args.sweep_mode {
                        SweepModeArg::Plain => Some(0),
                        SweepModeArg::Default => None,
                    },
                    probe: match args.sweep_mode {
                        SweepModeArg::Plain => Probe::Off,
                        SweepModeArg::Default => Probe::Default,
                    },
                    ..Research::default()
                },
                ..RowSettings::default()
            },
            tiling: args.tiling.into(),
            memory: memory_budget(args.memory),
            ..BakeSettings::default()
        },
        views: args.views,
        seed: args.seed,
        distance_scale,
    })
}

/// How the reports name a `--sweep-mode`: `plain`, or the default bake's options.
fn sweep_mode_name(mode: SweepModeArg) -> String {
    match mode {
        SweepModeArg::Plain => "plain".to_string(),
        SweepModeArg::Default => format!(
            "as bake's default (--view-supersample {DEFAULT_VIEW_SUPERSAMPLE} --fold-min-pixels {DEFAULT_FOLD_MIN_PIXELS} --probe {DEFAULT_PROBE_PIXELS} --fold-corners {}, the probe off past {DEFAULT_PROBE_MAX_TRIANGLES} triangles)",
            match PROBE_FOLD_CORNERS {
                FoldCorners::All => "all",
                FoldCorners::One => "one",
                FoldCorners::Split => "split",
                FoldCorners::Cover => "cover",
            }
        ),
    }
}

/// A finished sweep, for its reports.
struct SweepReport<'a> {
    args: &'a EvalArgs,
    settings: &'a SweepSettings,
    mesh: &'a Mesh,
    points: &'a [SweepPoint],
    /// [`sweep_mode_name`].
    mode: String,
    /// The figures written.
    written: Vec<PathBuf>,
}

impl SweepReport<'_> {
    /// The `--json` report, with the sweep's wall time `seconds`.
    fn json(&self, seconds: f64) -> Value {
        let settings = self.settings;
        let rows: Vec<Value> = self
            .points
            .iter()
            .map(|p| {
                let mut row = summary_json(&p.summary);
                merge(
                    &mut row,
                    json!({"patches": p.patches, "level": p.level, "sampling_views": p.sampling_views, "file_bytes": p.file_bytes}),
                );
                row
            })
            .collect();
        json!({
            "mesh": self.args.mesh.display().to_string(),
            "triangles": self.mesh.triangle_count(),
            "resolution": settings.bake.rows.resolution,
            "fov_deg": settings.bake.rows.fov_deg,
            "views": settings.views,
            "seed": settings.seed,
            "distance_scale": settings.distance_scale,
            "sweep_mode": self.mode,
            "seconds": seconds,
            "points": rows,
            "pictures": self.written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        })
    }

    /// The text report: the settings, a table row per point and the figures written.
    fn print(&self) -> Result<(), StdoutError> {
        let settings = self.settings;
        outln!(
            "{}: {} triangles; {} random views (seed {}) at {} px; bakes sampled {}",
            self.args.mesh.display(),
            self.mesh.triangle_count(),
            settings.views,
            settings.seed,
            settings.bake.rows.resolution,
            self.mode
        )?;
        outln!(
            "| patches | level | views | file bytes | culling | ideal culling | identical views | views with a miss | missed px mean / p95 / max |"
        )?;
        outln!("|---|---|---|---|---|---|---|---|---|")?;
        for p in self.points {
            let s = &p.summary;
            outln!(
                "| {} | {} | {} | {} | {:.1}% | {:.1}% | {:.1}% | {}/{} | {:.1} / {} / {} |",
                p.patches,
                p.level,
                p.sampling_views,
                p.file_bytes,
                100.0 * s.culling_rate.mean,
                100.0 * s.ideal_culling_rate.mean,
                100.0 * s.identical_views_fraction(),
                s.views - s.identical_views,
                s.views,
                s.missed_pixels.mean,
                s.missed_pixels.p95,
                s.missed_pixels.max
            )?;
        }
        for path in &self.written {
            outln!("wrote {}", path.display())?;
        }
        Ok(())
    }
}
