//! `patchvis bake`: checked settings, then tile → sample → encode, with a timing and peak-heap
//! record per stage, and outputs that appear only once everything succeeded.

use super::UsageError;
use super::args::{BackendArg, BakeArgs, EncodingArg, FoldCornersArg, PatchOrderArg, TilingArg};
use super::progress::Bars;
use anyhow::{Context, Result};
use patchvis::format::{self, BakeContents};
use patchvis::heap;
use patchvis::ooc::{Mesh, OpenOptions, default_cache_dir};
use patchvis::sampler::{self, SamplingParams};
use patchvis::sphere::{MAX_LEVEL, view_count};
use patchvis::tiling;
use serde_json::json;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Largest ID-buffer side: one buffer per thread is `resolution² × 8` bytes (512 MiB here).
const MAX_RESOLUTION: u32 = 8192;

/// `--view-supersample` unless given: one level finer, which removes most misses between the
/// stored views for ~4× the sampling time (BENCHMARKS.md, "Quality (issue 6)", "Defaults").
pub const DEFAULT_VIEW_SUPERSAMPLE: u32 = 1;
/// `--fold-min-pixels` unless given (and without `--conservative`): finer views fold only
/// patches of at least this many pixels, which buys back culling for misses of a few pixels;
/// chosen on the bunny measurements of BENCHMARKS.md, "Quality (issue 6)".
pub const DEFAULT_FOLD_MIN_PIXELS: u32 = 4;
/// `--fold-corners` unless given (and without `--conservative`, which folds into all): one
/// stored view per finer view, chosen on the same measurements.
pub const DEFAULT_FOLD_CORNERS: sampler::FoldCorners = sampler::FoldCorners::One;
/// `--conservative` samples ID buffers this many times finer than `--resolution`, so that a
/// renderer at up to this multiple of `--resolution` finds no sub-pixel sliver the sampler
/// skipped (measured, not proven: BENCHMARKS.md, "Quality (issue 6)").
pub const CONSERVATIVE_RESOLUTION_SCALE: u32 = 2;

/// Bake settings after checking: every value here is usable as is.
#[derive(Debug)]
pub struct Settings {
    input: PathBuf,
    output: PathBuf,
    patches: u32,
    level: u32,
    resolution: u32,
    fov_deg: f32,
    mesh_out: Option<PathBuf>,
    stats: Option<PathBuf>,
    options: sampler::SamplingOptions,
    /// Extra sphere levels sampled and folded into `level` (`--view-supersample`).
    view_supersample: u32,
    /// `--conservative` (already applied to `resolution`, `view_supersample` and
    /// `fold_min_pixels`; recorded in the stats).
    conservative: bool,
    /// Pixel threshold of the folded fine views (`--fold-min-pixels`); above 1 (and above
    /// `--min-pixels`) the stored level is sampled separately with every pixel.
    fold_min_pixels: u32,
    /// `--fold-corners`.
    fold_corners: sampler::FoldCorners,
    /// The plain pass's checkpoint when the fold has a threshold (the supersampled pass's is
    /// `options.checkpoint`).
    coarse_checkpoint: Option<PathBuf>,
    quiet: bool,
    tiling: tiling::TilingOptions,
    /// Heap budget in bytes (`--memory`, or [`default_memory_budget`]).
    memory_budget: u64,
    /// `--backend`.
    backend: BackendArg,
    /// `--patch-order`.
    patch_order: PatchOrderArg,
    /// `--encoding`.
    encoding: EncodingArg,
}

/// Smallest default budget: below this the machine is too small to bake anything large
/// anyway, and a tiny budget would only make conversion slow.
const MIN_DEFAULT_BUDGET: u64 = 256 << 20;

/// Half of `MemAvailable` from `/proc/meminfo` (the other half left to the page cache that
/// serves the mapped mesh), at least [`MIN_DEFAULT_BUDGET`]; the library default where the
/// file is missing (not Linux).
pub fn default_memory_budget() -> u64 {
    let available_kib = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find_map(|l| l.strip_prefix("MemAvailable:"))
                .and_then(|rest| {
                    rest.trim()
                        .trim_end_matches("kB")
                        .trim()
                        .parse::<u64>()
                        .ok()
                })
        });
    match available_kib {
        Some(kib) => (kib * 1024 / 2).max(MIN_DEFAULT_BUDGET),
        None => patchvis::ooc::DEFAULT_MEMORY_BUDGET,
    }
}

impl Settings {
    /// Checks the raw flags; a value out of range is a usage error.
    pub fn from_args(args: BakeArgs) -> Result<Settings, UsageError> {
        if args.patches == 0 {
            return Err(UsageError("--patches 0: expected at least 1 patch".into()));
        }
        if args.level > MAX_LEVEL {
            return Err(UsageError(format!(
                "--level {}: expected a sphere level from 0 to {MAX_LEVEL} ({} views at most)",
                args.level,
                view_count(MAX_LEVEL)
            )));
        }
        if args.resolution == 0 || args.resolution > MAX_RESOLUTION {
            return Err(UsageError(format!(
                "--resolution {}: expected 1 to {MAX_RESOLUTION} pixels",
                args.resolution
            )));
        }
        let resolution = if args.conservative {
            let scaled = args.resolution * CONSERVATIVE_RESOLUTION_SCALE;
            if scaled > MAX_RESOLUTION {
                return Err(UsageError(format!(
                    "--resolution {} with --conservative: expected 1 to {} pixels (--conservative samples at {CONSERVATIVE_RESOLUTION_SCALE}× the resolution, at most {MAX_RESOLUTION})",
                    args.resolution,
                    MAX_RESOLUTION / CONSERVATIVE_RESOLUTION_SCALE
                )));
            }
            scaled
        } else {
            args.resolution
        };
        if !(args.fov.is_finite() && args.fov > 0.0 && args.fov < 180.0) {
            return Err(UsageError(format!(
                "--fov {}: expected degrees between 0 and 180, exclusive",
                args.fov
            )));
        }
        for out in [
            Some(&args.output),
            args.mesh_out.as_ref(),
            args.stats.as_ref(),
        ]
        .into_iter()
        .flatten()
        {
            check_output_path(out)?;
        }
        // The level was checked above, so the subtraction cannot underflow.
        let view_supersample = args
            .view_supersample
            .unwrap_or(DEFAULT_VIEW_SUPERSAMPLE.min(MAX_LEVEL - args.level));
        if view_supersample > sampler::MAX_VIEW_SUPERSAMPLE
            || args.level + view_supersample > MAX_LEVEL
        {
            return Err(UsageError(format!(
                "--view-supersample {}: expected 0 to {} with --level + K at most {MAX_LEVEL} (--level is {})",
                view_supersample,
                sampler::MAX_VIEW_SUPERSAMPLE,
                args.level
            )));
        }
        let fold_min_pixels = args.fold_min_pixels.unwrap_or(if args.conservative {
            0
        } else {
            DEFAULT_FOLD_MIN_PIXELS
        });
        if args.backend == BackendArg::Gpu {
            if !cfg!(feature = "gpu") {
                return Err(UsageError(
                    "--backend gpu: this patchvis was built without the `gpu` feature".into(),
                ));
            }
            if let Some(flag) = cpu_only_flag(args.conservative_raster, args.resume) {
                return Err(UsageError(format!(
                    "--backend gpu: {flag} needs the CPU backend (--backend cpu or auto)"
                )));
            }
        }
        let always_visible = match &args.always_visible {
            Some(spec) => parse_patch_ids(spec)?,
            None => Vec::new(),
        };
        let mut checkpoint = args.output.clone().into_os_string();
        // The supersampled bake samples other rows than a plain one: its own checkpoint, so
        // that `--resume` finds the right one and a plain bake's checkpoint stays usable.
        let thresholded = view_supersample > 0 && fold_min_pixels > args.min_pixels.max(1);
        if view_supersample > 0 {
            checkpoint.push(format!(".vs{view_supersample}"));
        }
        if thresholded {
            checkpoint.push(format!(".m{fold_min_pixels}"));
        }
        checkpoint.push(".ckpt");
        let memory_budget = args.memory.unwrap_or_else(default_memory_budget);
        // The plain pass of a thresholded fold samples exactly what a plain bake does: it
        // shares a plain bake's checkpoint.
        let coarse_checkpoint = thresholded.then(|| {
            let mut path = args.output.clone().into_os_string();
            path.push(".ckpt");
            PathBuf::from(path)
        });
        let options = sampler::SamplingOptions {
            min_pixels: args.min_pixels,
            dilate: args.dilate,
            always_visible,
            conservative: args.conservative_raster,
            checkpoint: Some(PathBuf::from(checkpoint)),
            resume: args.resume,
            memory_budget: Some(memory_budget),
        };
        Ok(Settings {
            input: args.input,
            output: args.output,
            patches: args.patches,
            level: args.level,
            resolution,
            fov_deg: args.fov,
            mesh_out: args.mesh_out,
            stats: args.stats,
            options,
            view_supersample,
            conservative: args.conservative,
            fold_min_pixels: if thresholded { fold_min_pixels } else { 0 },
            coarse_checkpoint,
            fold_corners: match args.fold_corners {
                Some(FoldCornersArg::All) => sampler::FoldCorners::All,
                Some(FoldCornersArg::One) => sampler::FoldCorners::One,
                None if args.conservative => sampler::FoldCorners::All,
                None => DEFAULT_FOLD_CORNERS,
            },
            quiet: args.quiet,
            memory_budget,
            backend: args.backend,
            patch_order: args.patch_order,
            encoding: args.encoding,
            tiling: tiling::TilingOptions {
                mode: match args.tiling {
                    TilingArg::Auto => tiling::TilingMode::Auto,
                    TilingArg::InCore => tiling::TilingMode::InCore,
                    TilingArg::OutOfCore => tiling::TilingMode::OutOfCore,
                },
                memory_budget,
            },
        })
    }
}

/// The first flag the GPU backend does not implement, if any.
fn cpu_only_flag(conservative: bool, resume: bool) -> Option<&'static str> {
    if conservative {
        Some("--conservative-raster")
    } else if resume {
        Some("--resume")
    } else {
        None
    }
}

/// The sampler `--backend` chose.
enum Backend {
    Cpu,
    #[cfg(feature = "gpu")]
    Gpu(Box<sampler::gpu::GpuSampler>),
}

impl Backend {
    /// Opens the backend of `--backend`: `gpu` fails without an adapter; `auto` takes a
    /// hardware adapter and otherwise says on stderr why it samples on the CPU (a software
    /// rasterizer such as lavapipe is slower than the CPU backend, BENCHMARKS.md).
    fn open(s: &Settings) -> Result<Backend> {
        match s.backend {
            BackendArg::Cpu => Ok(Backend::Cpu),
            #[cfg(feature = "gpu")]
            BackendArg::Gpu => sampler::gpu::GpuSampler::new()
                .map(|g| Backend::Gpu(Box::new(g)))
                .context("--backend gpu"),
            #[cfg(not(feature = "gpu"))]
            BackendArg::Gpu => unreachable!("refused by Settings::from_args"),
            BackendArg::Auto => {
                let why_cpu =
                    if let Some(flag) = cpu_only_flag(s.options.conservative, s.options.resume) {
                        format!("{flag} needs it")
                    } else {
                        #[cfg(feature = "gpu")]
                        match sampler::gpu::GpuSampler::new() {
                            Ok(g) if !g.is_software() => return Ok(Backend::Gpu(Box::new(g))),
                            Ok(g) => format!("{} is a software rasterizer", g.adapter()),
                            Err(e) => e.to_string(),
                        }
                        #[cfg(not(feature = "gpu"))]
                        "built without the `gpu` feature".to_string()
                    };
                eprintln!("--backend auto: sampling on the CPU ({why_cpu})");
                Ok(Backend::Cpu)
            }
        }
    }

    /// `cpu`, or `gpu: ADAPTER`.
    fn describe(&self) -> String {
        match self {
            Backend::Cpu => "cpu".into(),
            #[cfg(feature = "gpu")]
            Backend::Gpu(g) => format!("gpu: {}", g.adapter()),
        }
    }
}

/// `--always-visible`: comma-separated ids, or else the path of a file of ids separated by
/// whitespace or commas with `#` comments. Sorted, without duplicates.
fn parse_patch_ids(spec: &str) -> Result<Vec<u32>, UsageError> {
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
    let text = std::fs::read_to_string(spec).map_err(|e| {
        UsageError(format!(
            "--always-visible {spec}: not a list of ids, and cannot read it as a file: {e}"
        ))
    })?;
    list(&text, spec)
}

/// An output must be a file in an existing directory; found out before hours of work.
fn check_output_path(path: &Path) -> Result<(), UsageError> {
    if path.is_dir() {
        return Err(UsageError(format!(
            "{}: is a directory, expected an output file path",
            path.display()
        )));
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        return Err(UsageError(format!(
            "{}: directory {} does not exist",
            path.display(),
            parent.display()
        )));
    }
    Ok(())
}

/// Time and peak heap of one stage.
struct StageRecord {
    name: &'static str,
    seconds: f64,
    peak_heap_bytes: usize,
}

fn stage<T>(records: &mut Vec<StageRecord>, name: &'static str, f: impl FnOnce() -> T) -> T {
    heap::reset_peak();
    let start = Instant::now();
    let out = f();
    records.push(StageRecord {
        name,
        seconds: start.elapsed().as_secs_f64(),
        peak_heap_bytes: heap::peak(),
    });
    out
}

/// Runs `patchvis bake`.
pub fn run(args: BakeArgs) -> Result<()> {
    let s = Settings::from_args(args)?;
    let bars = Bars::new(!s.quiet);
    let start = Instant::now();
    // Before any work, so that a missing GPU fails at once.
    let backend = Backend::open(&s)?;
    let mut stages = Vec::new();

    let open = OpenOptions {
        cache_dir: Some(default_cache_dir()),
        memory_budget: s.memory_budget,
    };
    let mesh = stage(&mut stages, "input", || {
        bars.spin("reading", || Mesh::open_with(&s.input, &open))
    })?;
    let tiling = stage(&mut stages, "tiling", || {
        bars.spin("tiling", || tiling::tile_with(&mesh, s.patches, &s.tiling))
    })
    .with_context(|| format!("{}: tiling failed", s.input.display()))?;
    let patch_count = tiling.patches.len() as u32;
    let params = SamplingParams::for_mesh(&mesh, s.level, s.resolution, s.fov_deg);
    if let Some(&bad) = s.options.always_visible.iter().find(|&&p| p >= patch_count) {
        return Err(UsageError(format!(
            "--always-visible {bad}: the bake has patches 0 to {}",
            patch_count - 1
        ))
        .into());
    }
    let visibility = stage(&mut stages, "sampling", || {
        // The fine pass differs from the stored level in `level` only (same centre, radius,
        // camera distance), so its views are the stored ones plus the finer ones.
        let fine = SamplingParams {
            level: s.level + s.view_supersample,
            ..params
        };
        let sample = |p: &SamplingParams, o: &sampler::SamplingOptions| match &backend {
            Backend::Cpu => {
                sampler::sample_tiled(&mesh, &tiling, p, o, &bars).map_err(anyhow::Error::from)
            }
            #[cfg(feature = "gpu")]
            Backend::Gpu(gpu) => gpu
                .sample(&mesh, &tiling, p, o, &bars)
                .context("GPU sampling failed"),
        };
        if s.fold_min_pixels > 0 {
            // The stored views keep every pixel; the finer ones report only patches of at
            // least `fold_min_pixels` pixels (see `sampler::fold_into`).
            let plain = sampler::SamplingOptions {
                checkpoint: s.coarse_checkpoint.clone(),
                ..s.options.clone()
            };
            let coarse = sample(&params, &plain)?;
            let thresholded = sampler::SamplingOptions {
                min_pixels: s.fold_min_pixels,
                ..s.options.clone()
            };
            let rows = sample(&fine, &thresholded)?;
            return Ok(sampler::fold_into_with(
                coarse,
                &rows,
                fine.level,
                s.level,
                s.fold_corners,
            ));
        }
        sample(&fine, &s.options).map(|rows| {
            if s.view_supersample == 0 {
                return rows;
            }
            let mut coarse = sampler::VisibilityMatrix::new(view_count(s.level), rows.patches());
            for v in 0..view_count(s.level) {
                coarse.row_mut(v).copy_from_slice(rows.row(v));
            }
            sampler::fold_into_with(coarse, &rows, fine.level, s.level, s.fold_corners)
        })
    })?;
    // Numbering by co-visibility happens after sampling (it needs the rows) and moves the
    // tiling with it, so the file, `--mesh-out` and the stats all use the final ids.
    let mut renumbered = false;
    let (tiling, visibility) = match s.patch_order {
        PatchOrderArg::Spatial => (tiling, visibility),
        PatchOrderArg::Covisibility => stage(&mut stages, "patch-order", || -> Result<_> {
            match format::covisibility_order(&visibility) {
                Some(order) => {
                    renumbered = true;
                    let tiling = tiling
                        .renumbered(&order)
                        .context("cannot write a temporary file for the renumbered tiling")?;
                    Ok((tiling, visibility.with_patch_order(&order)))
                }
                None => Ok((tiling, visibility)),
            }
        })?,
    };
    let contents = BakeContents {
        sampling: &params,
        triangle_count: u64::from(mesh.triangle_count()),
        patches: &tiling.patches,
        visibility: &visibility,
    };
    let bytes = stage(&mut stages, "encoding", || {
        let encoding = match s.encoding {
            EncodingArg::Tree => format::VisibilityEncoding::Tree,
            EncodingArg::Table => format::VisibilityEncoding::Hierarchical,
            EncodingArg::Raw => format::VisibilityEncoding::Raw,
        };
        bars.spin("encoding", || format::encode_with(&contents, encoding))
    });
    let visibility_bytes = patchvis::runtime::Pvis::parse(&bytes)
        .map(|p| p.visibility_bytes())
        .context("internal error: the written file does not parse")?;

    // Outputs: the mesh goes to a temporary file first, so that a failure anywhere leaves
    // no output behind.
    let mesh_tmp = match &s.mesh_out {
        Some(path) => Some(stage(&mut stages, "mesh-out", || {
            write_mesh_tmp(path, &mesh, &tiling)
        })?),
        None => None,
    };
    format::write_atomic(&s.output, &bytes)
        .with_context(|| format!("{}: cannot write", s.output.display()))?;
    // The output is complete: its checkpoints have served their purpose.
    for checkpoint in [&s.options.checkpoint, &s.coarse_checkpoint]
        .into_iter()
        .flatten()
    {
        match std::fs::remove_file(checkpoint) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(e).with_context(|| format!("{}: cannot remove", checkpoint.display()));
            }
            _ => {}
        }
    }
    if let (Some(tmp), Some(path)) = (mesh_tmp, &s.mesh_out) {
        tmp.persist(path)
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }

    let views = visibility.views();
    let seen: u64 = (0..views)
        .map(|v| {
            visibility
                .row(v)
                .iter()
                .map(|w| u64::from(w.count_ones()))
                .sum::<u64>()
        })
        .sum();
    let visible_fraction = seen as f64 / (f64::from(views) * f64::from(patch_count));
    let q = tiling.quality;
    let algorithm = if tiling.stats.out_of_core {
        "out-of-core"
    } else {
        "in-core"
    };
    let seconds = start.elapsed().as_secs_f64();
    let sampled_views = view_count(s.level + s.view_supersample)
        + if s.fold_min_pixels > 0 {
            view_count(s.level)
        } else {
            0
        };

    if let Some(path) = &s.stats {
        let report = json!({
            "input": s.input.display().to_string(),
            "output": s.output.display().to_string(),
            "triangles": mesh.triangle_count(),
            "vertices": mesh.vertex_count(),
            "mesh_source": format!("{:?}", mesh.source()),
            "memory_budget_bytes": s.memory_budget,
            "patches": patch_count,
            "patch_triangles": {"min": q.triangles_min, "median": q.triangles_median, "max": q.triangles_max},
            "tiling": {
                "algorithm": algorithm,
                "chunks": tiling.stats.chunks,
                "components": tiling.stats.components,
                "merged_components": tiling.stats.merged_components,
                "compactness": {"median": q.compactness_median, "p95": q.compactness_p95},
            },
            "level": s.level,
            "views": views,
            "resolution": s.resolution,
            "fov_deg": s.fov_deg,
            "min_pixels": s.options.min_pixels,
            "dilate": s.options.dilate,
            "conservative": s.conservative,
            "conservative_raster": s.options.conservative,
            "view_supersample": s.view_supersample,
            "fold_min_pixels": s.fold_min_pixels,
            "backend": backend.describe(),
            "fold_corners": format!("{:?}", s.fold_corners).to_lowercase(),
            "patch_order": if renumbered { "covisibility" } else { "spatial" },
            "encoding": format!("{:?}", s.encoding).to_lowercase(),
            "sampled_views": sampled_views,
            "always_visible": s.options.always_visible.len(),
            "visible_fraction_mean": visible_fraction,
            "bytes": {"total": bytes.len(), "visibility": visibility_bytes},
            "seconds": seconds,
            "peak_heap_bytes": stages.iter().map(|r| r.peak_heap_bytes).max().unwrap_or(0),
            "stages": stages.iter().map(|r| json!({
                "name": r.name, "seconds": r.seconds, "peak_heap_bytes": r.peak_heap_bytes,
            })).collect::<Vec<_>>(),
        });
        let text = serde_json::to_string_pretty(&report)? + "\n";
        format::write_atomic(path, text.as_bytes())
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }

    if !s.quiet {
        let secs = |name: &str| {
            stages
                .iter()
                .find(|r| r.name == name)
                .map_or(0.0, |r| r.seconds)
        };
        println!(
            "{}: {} triangles, {} vertices (read in {:.2} s)",
            s.input.display(),
            mesh.triangle_count(),
            mesh.vertex_count(),
            secs("input")
        );
        let chunks = if tiling.stats.out_of_core {
            format!(", {} chunks", tiling.stats.chunks)
        } else {
            String::new()
        };
        println!(
            "tiling:   {} patches, {}/{}/{} triangles min/median/max, compactness {:.2} median {:.2} p95 ({algorithm}{chunks}, {:.2} s)",
            patch_count,
            q.triangles_min,
            q.triangles_median,
            q.triangles_max,
            q.compactness_median,
            q.compactness_p95,
            secs("tiling")
        );
        if tiling.stats.merged_components > 0 {
            println!(
                "          the mesh has {} connected components, more than {} patches: {} nearby components were merged",
                tiling.stats.components, patch_count, tiling.stats.merged_components
            );
        }
        println!(
            "sampling: {} views (level {}) at {}x{} px, fov {}°; a view sees {:.1}% of patches on average ({:.2} s)",
            views,
            s.level,
            s.resolution,
            s.resolution,
            s.fov_deg,
            100.0 * visible_fraction,
            secs("sampling")
        );
        if !matches!(backend, Backend::Cpu) {
            println!("          sampled on the {}", backend.describe());
        }
        if s.view_supersample > 0 {
            println!(
                "          view supersampling: sampled {} views (level {}), folded into level {}",
                view_count(s.level + s.view_supersample),
                s.level + s.view_supersample,
                s.level
            );
            if s.fold_min_pixels > 0 {
                println!(
                    "          folding only patches of at least {} pixels; level {} sampled plain too",
                    s.fold_min_pixels, s.level
                );
            }
        }
        println!(
            "wrote {}: {} bytes, visibility {} bytes ({:.2} s total)",
            s.output.display(),
            bytes.len(),
            visibility_bytes,
            seconds
        );
        if let Some(path) = &s.mesh_out {
            println!("wrote {}: triangles reordered by patch", path.display());
        }
    }
    Ok(())
}

fn write_mesh_tmp(
    path: &Path,
    mesh: &Mesh,
    tiling: &tiling::Tiling,
) -> Result<tempfile::NamedTempFile> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    {
        let mut out = BufWriter::new(tmp.as_file_mut());
        patchvis::ooc::write_ply::write_patch_ply(&mut out, mesh, &tiling.order, &tiling.patch_of)
            .and_then(|()| out.flush())
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }
    Ok(tmp)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::args::{Cli, Command};
    use clap::Parser;

    fn settings(flags: &[&str]) -> Result<Settings, UsageError> {
        let mut argv = vec!["patchvis", "bake", "in.ply", "-o", "out.pvis"];
        argv.extend_from_slice(flags);
        match Cli::try_parse_from(argv).expect("flags parse").command {
            Command::Bake(args) => Settings::from_args(args),
            other => panic!("parsed {other:?}"),
        }
    }

    #[test]
    fn supersampling_defaults_follow_the_level_and_conservative() {
        let s = settings(&[]).unwrap();
        assert_eq!(
            (s.view_supersample, s.fold_min_pixels, s.resolution),
            (DEFAULT_VIEW_SUPERSAMPLE, DEFAULT_FOLD_MIN_PIXELS, 512)
        );
        assert_eq!(s.fold_corners, sampler::FoldCorners::One);
        // The finest level has nothing finer to sample: the default turns itself off there,
        // while asking for it explicitly is a usage error.
        let s = settings(&["--level", "7"]).unwrap();
        assert_eq!((s.view_supersample, s.fold_min_pixels), (0, 0));
        let err = settings(&["--level", "7", "--view-supersample", "1"]).unwrap_err();
        assert!(err.0.contains("--view-supersample 1"), "{}", err.0);
        let s = settings(&["--conservative"]).unwrap();
        assert_eq!(
            (s.view_supersample, s.fold_min_pixels, s.resolution),
            (
                DEFAULT_VIEW_SUPERSAMPLE,
                0,
                512 * CONSERVATIVE_RESOLUTION_SCALE
            )
        );
        assert!(s.conservative && !s.options.conservative);
        assert_eq!(s.fold_corners, sampler::FoldCorners::All);
        let err = settings(&["--conservative", "--resolution", "8000"]).unwrap_err();
        assert!(err.0.contains("--conservative"), "{}", err.0);
        // A threshold at or below --min-pixels changes nothing: no extra plain pass.
        let s = settings(&["--min-pixels", "4"]).unwrap();
        assert_eq!((s.fold_min_pixels, s.coarse_checkpoint), (0, None));
        let s = settings(&["--view-supersample", "0", "--fold-min-pixels", "9"]).unwrap();
        assert_eq!((s.view_supersample, s.fold_min_pixels), (0, 0));
    }
}
