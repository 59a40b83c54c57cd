//! `patchvis bake`: flags → [`BakeSettings`], the library's recipe (`patchvis::bake`), then
//! the summary on stdout and the `--stats` JSON. Every pipeline decision (supersampling,
//! folding, numbering, the memory split) lives in `src/bake`.

use super::UsageError;
use super::args::{
    BackendArg, BakeArgs, EncodingArg, FinerViewsArg, FoldCornersArg, PatchOrderArg, memory_budget,
};
use super::bake_common::{check_paths, report};
use super::out::{StdoutError, outln};
use super::progress::Bars;
use anyhow::{Result, anyhow};
use patchvis::bake::{
    Backend, BackendChoice, BakeSettings, Baked, Outputs, PatchOrder, Preset, Recipe, Research,
    RowSettings, Stages,
};
use patchvis::format::VisibilityEncoding;
use patchvis::ooc::{Mesh, read_regular};
use patchvis::sampler::{FinerViews, FoldCorners, PassViews};
use patchvis::tiling::PatchId;
use serde_json::json;
use std::time::Instant;

/// The library's settings for these flags.
pub(super) fn settings(args: &BakeArgs) -> Result<BakeSettings, UsageError> {
    let rows = RowSettings {
        preset: if args.conservative {
            Preset::Conservative
        } else {
            Preset::Default
        },
        level: args.level,
        resolution: args.resolution,
        fov_deg: args.fov,
        shells: args.shells,
        shell_min: args.shell_min,
        shell_level: args.shell_level,
        shell_resolution: args.shell_resolution,
        far_shells: args.far_shells.0.clone(),
        always_visible: match &args.always_visible {
            Some(spec) => parse_patch_ids(spec)?,
            None => Vec::new(),
        },
        patch_order: match args.patch_order {
            PatchOrderArg::Covisibility => PatchOrder::Covisibility,
            PatchOrderArg::Spatial => PatchOrder::Spatial,
        },
        encoding: match args.encoding {
            EncodingArg::Tree => VisibilityEncoding::Tree,
            EncodingArg::Table => VisibilityEncoding::Table,
            EncodingArg::Raw => VisibilityEncoding::Raw,
        },
        research: Research {
            min_pixels: args.min_pixels,
            dilate: args.dilate,
            probe: args.probe.unwrap_or_default(),
            apertures: args.apertures,
            conservative_raster: args.conservative_raster,
            view_supersample: args.view_supersample,
            fold_min_pixels: args.fold_min_pixels,
            fold_corners: args.fold_corners.map(|c| match c {
                FoldCornersArg::All => FoldCorners::All,
                FoldCornersArg::One => FoldCorners::One,
                FoldCornersArg::Split => FoldCorners::Split,
                FoldCornersArg::Cover => FoldCorners::Cover,
            }),
            finer_views: args.finer_views.map(|f| match f {
                FinerViewsArg::Midpoints => FinerViews::Midpoints,
                FinerViewsArg::Centroids => FinerViews::Centroids,
            }),
            sampled_rows: args.sampled_rows,
        },
    };
    Ok(BakeSettings {
        rows,
        patches: args.patches,
        tiling: args.tiling.into(),
        memory: memory_budget(args.memory),
        checkpoint: Some(args.output.clone()),
        resume: args.resume,
    })
}

/// Runs `patchvis bake`.
pub fn run(args: BakeArgs) -> Result<()> {
    let recipe = settings(&args)?.check().map_err(|e| UsageError(e.0))?;
    if let Some(shard) = &args.shard {
        return super::shard::bake(&args, shard, &recipe);
    }
    if let Some(tiling) = &args.tiling_file {
        return Err(UsageError(format!(
            "--tiling-file {}: only a sharded bake reads a tiling file; add --shard I/N (or \
             --shard auto), or leave --tiling-file out to tile here",
            tiling.display()
        ))
        .into());
    }
    let outputs = Outputs {
        pvis: args.output.clone(),
        mesh: args.mesh_out.clone(),
    };
    // Held until the outputs are written: no other command writes them meanwhile.
    let _lock = check_paths(&args, &recipe, &outputs)?;
    let bars = Bars::new(!args.quiet);
    let start = Instant::now();
    // Before any work, so that a missing GPU fails at once.
    let choice = match args.backend {
        BackendArg::Cpu => BackendChoice::Cpu,
        BackendArg::Gpu => BackendChoice::Gpu,
        BackendArg::Auto => BackendChoice::Auto,
    };
    let (backend, why_cpu) =
        Backend::open(choice, &recipe.settings).map_err(|e| report(&args.input, e))?;
    if let Some(why) = why_cpu {
        eprintln!("--backend auto: sampling on the CPU ({why})");
    }
    let mut stages = Stages::new();
    let mesh = stages
        .run("input", || {
            bars.spin("reading", || recipe.open(&args.input))
        })
        .map_err(|e| report(&args.input, e))?;
    let baked = recipe
        .run(&mesh, &backend, &bars, &mut stages)
        .map_err(|e| report(&args.input, e))?;
    recipe
        .write(&baked, &mesh, &outputs, &mut stages)
        .map_err(|e| report(&args.input, e))?;
    let seconds = start.elapsed().as_secs_f64();
    let summary = Summary {
        args: &args,
        recipe: &recipe,
        mesh: &mesh,
        baked: &baked,
        backend: &backend,
        stages: &stages,
        seconds,
    };
    if let Some(path) = &args.stats {
        let text = serde_json::to_string_pretty(&summary.json())? + "\n";
        patchvis::format::write_atomic(path, text.as_bytes())
            .map_err(|e| anyhow!("{}: cannot write: {e}", path.display()))?;
    }
    if !args.quiet {
        summary.print()?;
    }
    Ok(())
}

/// What a finished bake reports.
struct Summary<'a> {
    args: &'a BakeArgs,
    recipe: &'a Recipe,
    mesh: &'a Mesh,
    baked: &'a Baked,
    backend: &'a Backend,
    stages: &'a Stages,
    seconds: f64,
}

impl Summary<'_> {
    fn algorithm(&self) -> &'static str {
        if self.baked.tiling.stats.out_of_core {
            "out-of-core"
        } else {
            "in-core"
        }
    }

    /// The `--stats` report.
    fn json(&self) -> serde_json::Value {
        let (r, b) = (self.recipe, self.baked);
        let (plan, rows) = (&b.plan, &b.plan.rows);
        let q = b.tiling.quality;
        let split = r.memory().split();
        json!({
            "input": self.args.input.display().to_string(),
            "output": self.args.output.display().to_string(),
            "triangles": self.mesh.triangle_count(),
            "vertices": self.mesh.vertex_count(),
            "mesh_source": format!("{:?}", self.mesh.source()),
            "memory_budget_bytes": r.memory().total(),
            "memory_split_bytes": {
                "input": split.input,
                "tiling": split.tiling,
                "sampling": split.sampling.total,
                "sampling_mesh_on_heap_up_to": split.sampling.mesh_copy,
                "gpu_staging": split.sampling.gpu_staging,
                "patch_graph": split.patch_graph,
                "solids": split.solids,
                "encoding": split.encoding,
            },
            "patches": b.tiling.patches.len(),
            "patch_triangles": {"min": q.triangles_min, "median": q.triangles_median, "max": q.triangles_max},
            "tiling": {
                "algorithm": self.algorithm(),
                "chunks": b.tiling.stats.chunks,
                "components": b.tiling.stats.components,
                "merged_components": b.tiling.stats.merged_components,
                "compactness": {"median": q.compactness_median, "p95": q.compactness_p95},
            },
            "level": plan.level(),
            "views": b.visibility.views(),
            "resolution": rows.resolution,
            "fov_deg": rows.fov_deg,
            "min_pixels": rows.research.min_pixels,
            "dilate": rows.research.dilate,
            "conservative": rows.preset == Preset::Conservative,
            "probe": plan.main.probe,
            "apertures": plan.main.apertures,
            "conservative_raster": rows.research.conservative_raster,
            "far_shells": rows.far_shells,
            "sampled_rows": rows.research.sampled_rows,
            "view_supersample": plan.main.supersample.extra_levels,
            "fold_min_pixels": plan.main.supersample.fold_min_pixels,
            "backend": self.backend.describe(),
            "fold_corners": format!("{:?}", plan.main.supersample.fold_corners).to_lowercase(),
            "finer_views": plan.main.supersample.finer.name(),
            "patch_order": if b.renumbered { "covisibility" } else { "spatial" },
            "encoding": format!("{:?}", self.args.encoding).to_lowercase(),
            "sampled_views": b.sampled_views,
            "shells": self.shells_json(),
            "always_visible": rows.always_visible.len(),
            "visible_fraction_mean": b.visible_fraction(),
            "bytes": {"total": b.bytes.len(), "visibility": b.visibility_bytes},
            "seconds": self.seconds,
            "peak_heap_bytes": self.stages.peak_heap_bytes(),
            "stages": self.stages.records().iter().map(|r| json!({
                "name": r.name, "seconds": r.seconds, "peak_heap_bytes": r.peak_heap_bytes,
            })).collect::<Vec<_>>(),
        })
    }

    /// Each sampling shell's distance (also over the bounding radius), level, views, views
    /// sampled, sampling seconds and the bytes it adds to the file.
    fn shells_json(&self) -> Vec<serde_json::Value> {
        let (r, b) = (self.recipe, self.baked);
        let bytes = r.shell_bytes(b, self.mesh.triangle_count());
        b.shells
            .iter()
            .zip(bytes)
            .map(|(shell, bytes)| {
                json!({
                    "distance": shell.distance,
                    "radii": f64::from(shell.distance) / f64::from(b.params.radius),
                    "level": shell.level,
                    "views": shell.visibility.views(),
                    "sampled_views": shell.sampled_views,
                    "seconds": shell.seconds,
                    "bytes": bytes,
                })
            })
            .collect()
    }

    /// The summary on stdout.
    fn print(&self) -> Result<(), StdoutError> {
        let b = self.baked;
        let (plan, level) = (&b.plan, b.plan.level());
        let secs = |name| self.stages.seconds(name);
        let q = b.tiling.quality;
        let patch_count = b.tiling.patches.len();
        outln!(
            "{}: {} triangles, {} vertices (read in {:.2} s)",
            self.args.input.display(),
            self.mesh.triangle_count(),
            self.mesh.vertex_count(),
            secs("input")
        )?;
        let chunks = if b.tiling.stats.out_of_core {
            format!(", {} chunks", b.tiling.stats.chunks)
        } else {
            String::new()
        };
        outln!(
            "tiling:   {} patches, {}/{}/{} triangles min/median/max, compactness {:.2} median {:.2} p95 ({}{chunks}, {:.2} s)",
            patch_count,
            q.triangles_min,
            q.triangles_median,
            q.triangles_max,
            q.compactness_median,
            q.compactness_p95,
            self.algorithm(),
            secs("tiling")
        )?;
        if b.tiling.stats.merged_components > 0 {
            outln!(
                "          the mesh has {} connected components, more than {} patches: {} nearby components were merged",
                b.tiling.stats.components,
                patch_count,
                b.tiling.stats.merged_components
            )?;
        }
        outln!(
            "sampling: {} views (level {}) at {}x{} px, fov {}°; a query answers {:.1}% of the patches on average ({:.2} s)",
            b.visibility.views(),
            level,
            plan.rows.resolution,
            plan.rows.resolution,
            plan.rows.fov_deg,
            100.0 * b.visible_fraction(),
            secs("sampling")
        )?;
        if !self.backend.is_cpu() {
            outln!("          sampled on the {}", self.backend.describe())?;
        }
        let supersample = plan.main.supersample;
        let k = supersample.extra_levels;
        if k > 0 {
            let views = PassViews::new(level, level + k, supersample.finer);
            let which = match supersample.finer {
                FinerViews::Midpoints => format!("level {}", level + k),
                FinerViews::Centroids => format!("level {level} and its faces' centroids"),
            };
            outln!(
                "          view supersampling: sampled {} views ({which}), folded into level {level}",
                views.end(),
            )?;
            if supersample.fold_min_pixels > 0 {
                outln!(
                    "          folding only patches of at least {} pixels; level {level} sampled plain too",
                    supersample.fold_min_pixels,
                )?;
            }
        }
        // The far band's shells come first in the file, then those inside the sampling sphere.
        let distance = b.params.distance();
        let (far, near): (Vec<_>, Vec<_>) = b.shells.iter().partition(|s| s.distance > distance);
        for (is_far, shells) in [(false, near), (true, far)] {
            let Some(first) = shells.first() else {
                continue;
            };
            let (what, unit, scale) = match is_far {
                false => ("near views", "bounding radii", b.params.radius),
                true => ("far views", "sampling distances", distance),
            };
            let mut at: Vec<String> = shells
                .iter()
                .map(|shell| format!("{:.2}", shell.distance / scale))
                .collect();
            if is_far {
                at.reverse();
            }
            outln!(
                "          {what}: {} shells of {} views (level {}) at {} {unit}, {} views sampled in {:.2} s",
                shells.len(),
                first.visibility.views(),
                first.level,
                at.join(", "),
                shells.iter().map(|s| s.sampled_views).sum::<u32>(),
                shells.iter().map(|s| s.seconds).sum::<f64>()
            )?;
        }
        let shells = match b.shells.len() {
            0 => String::new(),
            k => format!(", {k} sampling shells"),
        };
        outln!(
            "wrote {}: {} bytes, visibility {} bytes{shells} ({:.2} s total)",
            self.args.output.display(),
            b.bytes.len(),
            b.visibility_bytes,
            self.seconds
        )?;
        if let Some(path) = &self.args.mesh_out {
            outln!("wrote {}: triangles reordered by patch", path.display())?;
        }
        Ok(())
    }
}

/// The largest `--always-visible` file read: 64 MiB, several times every id of the largest
/// patch count written out with a comment each.
const IDS_FILE_MAX_BYTES: u64 = 64 << 20;

/// `--always-visible`: comma-separated ids, or else the path of a file of ids separated by
/// whitespace or commas with `#` comments, a regular file of at most
/// [`IDS_FILE_MAX_BYTES`]. Sorted, without duplicates.
fn parse_patch_ids(spec: &str) -> Result<Vec<PatchId>, UsageError> {
    let list = |text: &str, origin: &str| -> Result<Vec<u32>, UsageError> {
        let mut ids = Vec::new();
        for (n, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("");
            for word in line.split(|c: char| c == ',' || c.is_whitespace()) {
                if word.is_empty() {
                    continue;
                }
                let id = word.parse::<u32>().map_err(|_| {
                    UsageError(format!(
                        "--always-visible {origin}, line {}: '{word}' is not a patch id (expected a number from 0 to {})",
                        n + 1,
                        u32::MAX
                    ))
                })?;
                ids.push(id);
            }
        }
        ids.sort_unstable();
        ids.dedup();
        Ok(ids)
    };
    let looks_like_ids = spec
        .chars()
        .all(|c| c.is_ascii_digit() || c == ',' || c.is_whitespace());
    if looks_like_ids {
        return list(spec, "list");
    }
    let cannot = |e: &dyn std::fmt::Display| {
        UsageError(format!(
            "--always-visible {spec}: not a list of ids, and cannot read it as a file: {e}"
        ))
    };
    let bytes = read_regular(
        std::path::Path::new(spec),
        IDS_FILE_MAX_BYTES,
        "a list of patch ids",
    )
    .map_err(|e| cannot(&e))?;
    let text = String::from_utf8(bytes).map_err(|e| cannot(&e))?;
    list(&text, spec)
}
