//! `patchvis eval`: flags → the library's evaluation (`patchvis::eval`) of random views,
//! sampling views or a path, at one distance or a band per distance (`eval::Band`), or a
//! sweep of bakes (`eval::sweep`); then a text or JSON report, PNGs of the worst views and
//! the library's SVG figures. The binary checks flags, reads and writes files and prints.

use super::args::{EvalArgs, memory_budget};
use super::eval_bands::{BandReport, parse_distance_scales, print_bands};
use super::eval_frame::{FrameBackend, frame_json, gpu_json, print_frame};
use super::eval_json::{merge, per_view_json, stats_culling_json, summary_json};
use super::out::{StdoutError, outln};
use super::progress::Bars;
use super::{UsageError, usage};
use anyhow::{Context, Result, anyhow};
use patchvis::bake::{MemoryBudget, Stages};
use patchvis::eval::shade::RgbImage;
use patchvis::eval::views::{self, MAX_VIEWS, PathCamera};
use patchvis::eval::{
    Band, BandViews, EvalOptions, EvalSummary, Evaluator, ViewSet, metrics::Summary, open_mesh,
    path_plot,
};
use patchvis::format::{PvisFile, write_atomic};
use patchvis::ooc::{Mesh, read_regular};
use patchvis::output::NamedPath;
use patchvis::runtime::Pvis;
use patchvis::sampler::MAX_RESOLUTION;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Frames of `--path orbit` without a count.
const DEFAULT_ORBIT_FRAMES: u32 = 120;

/// Which cameras the flags ask for; a path file is read once the `.pvis` is open
/// ([`Views::view_set`]).
#[derive(Debug)]
enum Views {
    /// Seeded random positions on the (scaled) sampling sphere.
    Random { count: u32, seed: u64 },
    /// The sampling positions of a sphere level.
    Sampling { level: u32 },
    /// An orbit of `frames` frames.
    Orbit { frames: u32 },
    /// Cameras from a file.
    PathFile(PathBuf),
}

impl Views {
    /// The views of `--path`, `--sampling-level` or else `--views` and `--seed`.
    fn of(args: &EvalArgs) -> Result<Views, UsageError> {
        Ok(match (&args.path, args.sampling_level) {
            (Some(spec), _) => parse_path(spec)?,
            (None, Some(level)) => Views::Sampling { level },
            (None, None) => Views::Random {
                count: args.views,
                seed: args.seed,
            },
        })
    }

    /// The library's view set; a path file's cameras look at `center` unless they name a
    /// target.
    fn view_set(&self, center: [f32; 3]) -> Result<ViewSet> {
        Ok(match self {
            Views::Random { count, seed } => ViewSet::Random {
                count: *count,
                seed: *seed,
            },
            Views::Sampling { level } => ViewSet::Sampling { level: *level },
            Views::Orbit { frames } => ViewSet::Orbit { frames: *frames },
            Views::PathFile(path) => ViewSet::path(&read_camera_path(path)?, center)
                .map_err(|e| anyhow!("{}: {e}", path.display()))?,
        })
    }

    /// Whether the views are frames of a path.
    fn is_path(&self) -> bool {
        matches!(self, Views::Orbit { .. } | Views::PathFile(_))
    }

    /// How the report names them.
    fn name(&self) -> String {
        match self {
            Views::Random { .. } => "random".to_string(),
            Views::Sampling { level } => format!("sampling level {level}"),
            Views::Orbit { frames } => format!("orbit of {frames} frames"),
            Views::PathFile(p) => format!("path {}", p.display()),
        }
    }
}

/// `--path orbit`, `orbit:N` or a camera path file.
fn parse_path(spec: &str) -> Result<Views, UsageError> {
    let Some(rest) = spec.strip_prefix("orbit") else {
        return Ok(Views::PathFile(PathBuf::from(spec)));
    };
    let frames = match rest.strip_prefix(':') {
        None if rest.is_empty() => DEFAULT_ORBIT_FRAMES,
        Some(n) => match n.parse::<u32>() {
            Ok(n) if (1..=MAX_VIEWS).contains(&n) => n,
            _ => {
                return Err(UsageError(format!(
                    "--path {spec}: expected orbit:N with N a frame count from 1 to {MAX_VIEWS}"
                )));
            }
        },
        // "orbitfoo" is a file name.
        None => return Ok(Views::PathFile(PathBuf::from(spec))),
    };
    Ok(Views::Orbit { frames })
}

/// Runs `patchvis eval`.
pub fn run(args: EvalArgs) -> Result<()> {
    let scales = check_flags(&args)?;
    if args.sweep {
        return super::eval_sweep::run(&args, scales[0]);
    }
    let views = Views::of(&args)?;
    let file = args
        .file
        .clone()
        .ok_or_else(|| UsageError("expected FILE.pvis (or --sweep)".into()))?;
    // Held until --stats is written.
    let _lock = match &args.stats {
        Some(stats) => {
            let inputs = [
                NamedPath::new("the mesh", "MESH", &args.mesh),
                NamedPath::new("the .pvis file", "FILE", &file),
            ];
            Some(super::claim_outputs(
                &inputs,
                &[NamedPath::flag("--stats", stats)],
            )?)
        }
        None => None,
    };
    let bars = Bars::new(!args.quiet && !args.json);
    let start = Instant::now();
    let options = EvalOptions {
        memory: memory_budget(args.memory),
        tiling: args.tiling.into(),
    };
    let mut stages = Stages::new();
    // The file first: refusing it costs nothing, converting the mesh may cost minutes.
    let bytes = PvisFile::open(&file).map_err(|e| anyhow!("{}: {e}", file.display()))?;
    let pvis = Pvis::parse(&bytes).map_err(|e| anyhow!("{}: {e}", file.display()))?;
    let mesh = stages.run("input", || open_mesh(&args.mesh, options.memory))?;
    let evaluator = stages
        .run("patches", || Evaluator::new(&mesh, &pvis, &options))
        .map_err(|e| {
            anyhow!(
                "{} was not baked from {} with these settings: {e}",
                file.display(),
                args.mesh.display()
            )
        })?;
    // After the inputs are checked, so that their errors come first and alone (probing for
    // an adapter can make the driver write to stderr), before the long evaluation, so that a
    // missing GPU fails soon.
    let frame_backend = FrameBackend::open(args.frame_backend)?;
    let sampling = pvis.sampling();
    if let Views::Sampling { level } = views {
        usage(level > sampling.level, || {
            format!(
                "--sampling-level {level}: expected at most the file's level {}",
                sampling.level
            )
        })?;
    }
    let band_views = BandViews {
        views: views.view_set(sampling.center)?,
        resolution: args.resolution.unwrap_or(sampling.resolution),
        look_jitter_deg: args.look_jitter,
        seed: args.seed,
        fit: args.fit,
    };
    let mut bands = Vec::with_capacity(scales.len());
    for &scale in &scales {
        let band = Band::evaluate(&evaluator, &pvis, &band_views, scale, &bars, &mut stages);
        // After the CPU evaluation, never beside it: a software GPU shares its cores.
        let gpu = frame_backend.measure(&evaluator, &pvis, &band.cameras, &bars)?;
        bands.push(BandReport {
            band,
            gpu,
            pictures: Vec::new(),
        });
    }
    let report = Report {
        args: &args,
        file: &file,
        pvis: &pvis,
        mesh: &mesh,
        evaluator: &evaluator,
        frame_backend: &frame_backend,
        views: &views,
        scales: &scales,
        resolution: band_views.resolution,
        memory: options.memory,
        seconds: start.elapsed().as_secs_f64(),
    };
    if let Some(path) = &args.stats {
        let text = serde_json::to_string_pretty(&report.stats_json(&bands, &stages))? + "\n";
        write_atomic(path, text.as_bytes())
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }
    let written = match &args.png {
        Some(dir) => report.write_pictures(dir, &mut bands)?,
        None => Vec::new(),
    };
    if args.json {
        let json = report.json(&bands, &written);
        outln!("{}", serde_json::to_string_pretty(&json)?)?;
        return Ok(());
    }
    report.print(&bands, &written)?;
    Ok(())
}

/// Checks the flags that need no file: returns the distances of `--distance-scale`, and
/// creates the `--png` directory.
fn check_flags(args: &EvalArgs) -> Result<Vec<f32>> {
    let scales = parse_distance_scales(&args.distance_scale)?;
    if let Some(r) = args.resolution {
        usage(r == 0 || r > MAX_RESOLUTION, || {
            format!("--resolution {r}: expected 1 to {MAX_RESOLUTION} pixels")
        })?;
    }
    usage(
        !(args.look_jitter >= 0.0 && args.look_jitter <= 180.0),
        || {
            format!(
                "--look-jitter {}: expected degrees from 0 to 180",
                args.look_jitter
            )
        },
    )?;
    let listed = |mode: &str| {
        usage(scales.len() > 1, || {
            format!(
                "--distance-scale {}: a list of distances is not supported with {mode}; give one distance",
                args.distance_scale
            )
        })
    };
    if args.sweep {
        listed("--sweep")?;
    }
    if args.path.is_some() {
        listed("--path")?;
    }
    if let Some(dir) = &args.png {
        check_output_dir(dir)?;
    }
    Ok(scales)
}

/// A finished evaluation, for its reports.
struct Report<'a> {
    args: &'a EvalArgs,
    file: &'a Path,
    pvis: &'a Pvis<'a>,
    mesh: &'a Mesh,
    evaluator: &'a Evaluator<'a>,
    frame_backend: &'a FrameBackend,
    views: &'a Views,
    scales: &'a [f32],
    /// Render resolution.
    resolution: u32,
    memory: MemoryBudget,
    /// Wall time of the evaluation, inputs included.
    seconds: f64,
}

impl Report<'_> {
    /// The `--stats` report: inputs, time and heap per stage, and the culling figures (per
    /// band with a list of distances).
    fn stats_json(&self, bands: &[BandReport], stages: &Stages) -> Value {
        let mut report = json!({
            "mesh": self.args.mesh.display().to_string(),
            "file": self.file.display().to_string(),
            "triangles": self.mesh.triangle_count(),
            "patches_from": if self.evaluator.order().is_some() { "tiling" } else { "mesh order" },
            "memory_budget_bytes": self.memory.total(),
            "workers": self.evaluator.workers(&bands[0].band.cameras[0]),
            "seconds": self.seconds,
            "peak_heap_bytes": stages.peak_heap_bytes(),
            "look_jitter_deg": self.args.look_jitter,
        });
        if bands.len() > 1 {
            let rows = bands
                .iter()
                .map(|b| {
                    let mut row = json!({"distance_scale": b.band.scale});
                    merge(&mut row, stats_culling_json(&b.band.summary));
                    row
                })
                .collect::<Vec<_>>();
            merge(&mut report, json!({ "bands": rows }));
        } else {
            merge(&mut report, stats_culling_json(&bands[0].band.summary));
        }
        merge(
            &mut report,
            json!({
                "stages": stages.records().iter().map(|r| json!({
                    "name": r.name, "seconds": r.seconds, "peak_heap_bytes": r.peak_heap_bytes,
                })).collect::<Vec<_>>(),
            }),
        );
        report
    }

    /// Writes into `dir` the pictures of each band's `--worst` views and, for a path, its
    /// figure; returns their paths.
    fn write_pictures(&self, dir: &Path, bands: &mut [BandReport]) -> Result<Vec<PathBuf>> {
        let banded = bands.len() > 1;
        let is_path = self.views.is_path();
        let prefix = if is_path { "frame" } else { "view" };
        let mut written = Vec::new();
        for report in bands.iter_mut() {
            let band = &report.band;
            for index in band.worst(self.args.worst) {
                let pictures = self.evaluator.pictures(self.pvis, &band.cameras[index]);
                let image = RgbImage::side_by_side(&[
                    &pictures.full,
                    &pictures.reconstruction,
                    &pictures.difference,
                ]);
                let name = if banded {
                    format!("{prefix}-x{}-{index:04}.png", band.scale)
                } else {
                    format!("{prefix}-{index:04}.png")
                };
                let path = dir.join(name);
                write_png(&path, &image)?;
                report.pictures.push(path.clone());
                written.push(path);
            }
        }
        if is_path {
            let path = dir.join("path.svg");
            write_atomic(&path, path_plot(&bands[0].band.metrics).as_bytes())
                .with_context(|| format!("{}: cannot write", path.display()))?;
            written.push(path);
        }
        Ok(written)
    }

    /// The `--json` report: the figures (per band with a list of distances), per view, and
    /// the frame backend's.
    fn json(&self, bands: &[BandReport], written: &[PathBuf]) -> Value {
        let (pvis, sampling) = (self.pvis, self.pvis.sampling());
        let banded = bands.len() > 1;
        let first = &bands[0];
        let mut report = if banded {
            json!({})
        } else {
            summary_json(&first.band.summary)
        };
        let extra = json!({
            "mesh": self.args.mesh.display().to_string(),
            "file": self.file.display().to_string(),
            "mode": self.views.name(),
            "seed": self.args.seed,
        });
        merge(&mut report, extra);
        if banded {
            merge(
                &mut report,
                json!({"distance_scales": self.scales, "views_per_band": first.band.summary.views}),
            );
        } else {
            merge(
                &mut report,
                json!({
                    "distance_scale": first.band.scale,
                    "distance": first.band.distance,
                    "distance_radii": first.band.radii(pvis),
                }),
            );
        }
        let extra = json!({
            "look_jitter_deg": self.args.look_jitter,
            "resolution": self.resolution,
            "patches": pvis.patch_count(),
            "triangles": self.mesh.triangle_count(),
            "level": sampling.level,
            "sampling_views": sampling.views,
            "file_bytes": pvis.total_bytes(),
            "seconds": self.seconds,
            "pictures": written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        });
        merge(&mut report, extra);
        if banded {
            merge(&mut report, frame_json(self.frame_backend, None));
            let rows = bands.iter().map(|b| self.band_json(b)).collect::<Vec<_>>();
            merge(&mut report, json!({ "bands": rows }));
        } else {
            merge(&mut report, json!({ "per_view": per_view_json(first) }));
            merge(
                &mut report,
                frame_json(self.frame_backend, first.gpu.as_ref()),
            );
        }
        report
    }

    /// One band's row of the `--json` report.
    fn band_json(&self, b: &BandReport) -> Value {
        let mut row = json!({
            "distance_scale": b.band.scale,
            "distance": b.band.distance,
            "distance_radii": b.band.radii(self.pvis),
        });
        merge(&mut row, summary_json(&b.band.summary));
        merge(
            &mut row,
            json!({
                "pictures": b.pictures.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
                "per_view": per_view_json(b),
            }),
        );
        merge(&mut row, gpu_json(b.gpu.as_ref()));
        row
    }

    /// The text report: the inputs, then the figures (a table row per band with a list of
    /// distances), the frame cost and the pictures written.
    fn print(&self, bands: &[BandReport], written: &[PathBuf]) -> Result<(), StdoutError> {
        let (pvis, sampling) = (self.pvis, self.pvis.sampling());
        let (resolution, seconds, mode) = (self.resolution, self.seconds, self.views.name());
        outln!(
            "{} with {}: {} patches over {} triangles, level {} ({} views), {} bytes",
            self.args.mesh.display(),
            self.file.display(),
            pvis.patch_count(),
            self.mesh.triangle_count(),
            sampling.level,
            sampling.views,
            pvis.total_bytes()
        )?;
        if self.evaluator.shared_records() > 0 {
            outln!(
                "patches sharing their stored bounds with another: {} (matched in the order the \
                 bake keeps them in; for a file numbered otherwise, evaluate its --mesh-out mesh)",
                self.evaluator.shared_records()
            )?;
        }
        let seeded = match self.views {
            Views::Random { seed, .. } => format!(", seed {seed}"),
            _ => String::new(),
        };
        if bands.len() > 1 {
            outln!(
                "eval: {} views ({mode}{seeded}) at {resolution}x{resolution} px at each of {} distances ({seconds:.1} s)",
                bands[0].band.summary.views,
                bands.len(),
            )?;
            print_bands(bands, pvis)?;
            for band in bands {
                if band.gpu.is_some() {
                    outln!("distance x{}:", band.band.scale)?;
                }
                print_frame(self.frame_backend, band.gpu.as_ref())?;
                if band.gpu.is_none() {
                    // The same reason for every band.
                    break;
                }
            }
        } else {
            let band = &bands[0];
            outln!(
                "eval: {} views ({mode}{seeded}) at {resolution}x{resolution} px, distance x{} ({seconds:.1} s)",
                band.band.summary.views,
                band.band.scale
            )?;
            print_summary(&band.band.summary, self.views.is_path())?;
            print_frame(self.frame_backend, band.gpu.as_ref())?;
        }
        for path in written {
            outln!("wrote {}", path.display())?;
        }
        Ok(())
    }
}

/// The picture directory: created if missing; anything else there is a usage error.
fn check_output_dir(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(UsageError(format!(
            "--png {}: is a file, expected a directory",
            dir.display()
        ))
        .into());
    }
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))
}

/// The largest camera path file read: [`MAX_VIEWS`] lines of six numbers, with room.
const PATH_FILE_MAX_BYTES: u64 = 128 << 20;

/// A path file's cameras: a regular file of at most [`PATH_FILE_MAX_BYTES`], read whole,
/// then parsed.
fn read_camera_path(path: &Path) -> Result<Vec<PathCamera>> {
    // A FIFO would block the read, a device never end it.
    let bytes = read_regular(path, PATH_FILE_MAX_BYTES, "a camera path file")
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let text =
        String::from_utf8(bytes).map_err(|e| anyhow!("{}: not UTF-8 text: {e}", path.display()))?;
    views::parse_camera_path(&text).map_err(|e| anyhow!("{}: {e}", path.display()))
}

/// Writes `image` as an 8-bit RGB PNG.
fn write_png(path: &Path, image: &RgbImage) -> Result<()> {
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, image.width, image.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header()?;
        writer.write_image_data(&image.pixels)?;
        writer.finish()?;
    }
    write_atomic(path, &bytes).with_context(|| format!("{}: cannot write", path.display()))
}

/// The text report's table of one distance: mean, p95, p99 and max of each figure.
fn print_summary(s: &EvalSummary, is_path: bool) -> Result<(), StdoutError> {
    let unit = if is_path { "frames" } else { "views" };
    outln!(
        "{:<22}{:>12}{:>12}{:>12}{:>12}",
        "",
        "mean",
        "p95",
        "p99",
        "max"
    )?;
    let row = |name: &str, x: &Summary, percent: bool| {
        let f = |v: f64| {
            if percent {
                format!("{:.1}%", 100.0 * v)
            } else {
                format!("{v:.1}")
            }
        };
        outln!(
            "{name:<22}{:>12}{:>12}{:>12}{:>12}",
            f(x.mean),
            f(x.p95),
            f(x.p99),
            f(x.max)
        )
    };
    row("missed pixels", &s.missed_pixels, false)?;
    row("missed patches", &s.missed_patches, false)?;
    row("triangles drawn", &s.triangles_drawn, false)?;
    row("culling rate", &s.culling_rate, true)?;
    row("ideal culling", &s.ideal_culling_rate, true)?;
    row("culling + frustum", &s.frustum_culling_rate, true)?;
    outln!(
        "pixel-identical {unit}: {}/{} ({:.1}%); {unit} missing a visible patch: {}",
        s.identical_views,
        s.views,
        100.0 * s.identical_views_fraction(),
        s.views_missing_a_patch
    )?;
    if s.views_losing_a_patch_to_the_frustum > 0 {
        outln!(
            "{unit} where the frustum dropped a patch the answer draws: {} (a bug: please report)",
            s.views_losing_a_patch_to_the_frustum
        )?;
    }
    if let Some(p) = &s.psnr_db_differing {
        outln!(
            "PSNR of the {unit} that differ: mean {:.1} dB, worst {:.1} dB",
            p.mean,
            p.min
        )?;
    }
    outln!(
        "frame cost (CPU rasterizer, median per view): full {:.2} ms, culled {:.2} ms, speed-up {:.2}x",
        s.frame_cost.full_ms_median,
        s.frame_cost.culled_ms_median,
        s.frame_cost.speedup
    )
}
