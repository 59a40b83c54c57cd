//! `patchvis eval` over the model zoo in one command, one table: culling fidelity of a default
//! and a `--conservative` bake of every zoo model, at the bake's resolution and at twice it.
//!
//! `cargo run --release --example zoo -- [--views N] [--seed S] [--modes default,conservative]
//! [--models LIST] [--triangles T] [--shells N] [--json OUT.json] [--keep DIR]`
//!
//! Modes: `default`, `conservative`, `level5` (`--level 5 --probe 1 --fold-corners split`),
//! `centroids` (the same with `--finer-views centroids`, two thirds of its finer views: the
//! files `--conservative` bakes), and baselines measured in the same run: `thresholded` (the
//! default before issue 20), `plain` (`--probe off`), `probe2-split` (`--probe 2
//! --fold-corners split`, `--conservative` before 2026-12-06) and `conservative-all`
//! (`--conservative` with the all-corner fold).
//!
//! The zoo is the bundled `assets/bunny.ply` (a dense scan), `assets/ant.ply` (thin legs and
//! antennae), `assets/airplane.ply` (few large triangles, thin wings) and three CAD models
//! (`assets/README.md`): `cycloidal.ply` (a gear drive of 119 parts with narrow gaps),
//! `omnicopter.stl` (a frame of thin rods and wires) and `fm1_satellite.glb` (a sheet-metal box
//! with the electronics inside, seen through holes and slots), plus two generated models of
//! about `--triangles` triangles: `exposed-engine` and `truss`. Each model is baked
//! once per mode as `patchvis bake MESH -o FILE.pvis --shells 0 [--conservative]` does (the
//! library's recipe, CPU backend, the command's defaults but for the shells) and evaluated as `patchvis eval MESH FILE.pvis
//! --views N --seed S --resolution R` does, at R = the bake's `--resolution` (512) and 2R: the
//! same seeded random views on the sampling sphere for every model and mode.
//!
//! One row per (model, mode, resolution): pixel-identical views, missed pixels per view
//! (mean / p99 / max), the mean culling rate against the mean ideal one (the true visible
//! set's), the bake's wall clock (open + run; not the write) and the file's size. Progress
//! goes to stderr, the Markdown table to stdout, the same rows to `--json` as JSON. The
//! generated meshes and the `.pvis` files go to a temporary directory, or to `--keep DIR`.
//!
//! Cost: per model and mode one bake (level 4 supersampled from level 5: 5,124 ID buffers at
//! 512², and the probe pass over each; `level5` renders 16,386, `conservative` and
//! `centroids` 12,290) and 2 × 2 × N renders (full and culled, at 1× and 2×). On 2 cores the
//! full default run takes about 5 minutes, two thirds of it baking; `--views 30 --models
//! bunny,ant` takes about 2.

use anyhow::{Context, Result, anyhow, bail};
use clap::{Parser, ValueEnum};
use patchvis::bake::{
    Backend, BakeSettings, MemoryBudget, Outputs, Preset, Probe, Research, RowSettings, Stages,
};
use patchvis::eval::views::random_directions;
use patchvis::eval::{EvalOptions, EvalSummary, Evaluator, sampling_params};
use patchvis::generate::exposed::ExposedEngine;
use patchvis::generate::truss::Truss;
use patchvis::generate::{Model, write_ply};
use patchvis::progress::NoProgress;
use patchvis::runtime::Pvis;
use patchvis::sampler::{Camera, FinerViews, FoldCorners};
use patchvis::tiling::TilingMode;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Evaluation resolutions as multiples of the bake's `--resolution`: the renderer at the
/// sampled size, and at the size `--conservative` is meant to hold up to.
const RESOLUTION_SCALES: [u32; 2] = [1, 2];

/// Where a zoo model's mesh comes from.
enum Source {
    /// A mesh under `assets/`.
    Asset(&'static str),
    /// A generated model of about this many triangles.
    Generated(fn(u64) -> Box<dyn Model>),
}

/// The zoo, in table order.
static ZOO: [(&str, Source); 8] = [
    ("bunny", Source::Asset("bunny.ply")),
    ("ant", Source::Asset("ant.ply")),
    ("airplane", Source::Asset("airplane.ply")),
    ("cycloidal", Source::Asset("cycloidal.ply")),
    ("omnicopter", Source::Asset("omnicopter.stl")),
    ("fm1-satellite", Source::Asset("fm1_satellite.glb")),
    (
        "exposed-engine",
        Source::Generated(|t| Box::new(ExposedEngine::new(t))),
    ),
    ("truss", Source::Generated(|t| Box::new(Truss::new(t)))),
];

/// A bake mode: `patchvis bake` with or without `--conservative`, or with the thresholded
/// fold that was the default before issue 20 (the baseline of its table).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Mode {
    /// The default bake.
    Default,
    /// `--conservative` (its split fold).
    Conservative,
    /// `--conservative --fold-corners all`: `--conservative` before the split fold.
    ConservativeAll,
    /// `--fold-min-pixels 4 --fold-corners one --probe off`.
    Thresholded,
    /// `--probe off`: the default before the probe pass was.
    Plain,
    /// `--level 5 --probe 1 --fold-corners split`: a stored level finer, the probe at one
    /// pixel, the split fold.
    Level5,
    /// `level5` with `--finer-views centroids`: the finer views at the level-5 faces'
    /// centroids instead of level 6's vertices: `--conservative`'s files.
    Centroids,
    /// `--probe 2 --fold-corners split`: `--conservative` before it took level 5 and the
    /// centroids (2026-12-06).
    Probe2Split,
}

impl Mode {
    fn name(self) -> &'static str {
        match self {
            Mode::Default => "default",
            Mode::Conservative => "conservative",
            Mode::ConservativeAll => "conservative-all",
            Mode::Thresholded => "thresholded",
            Mode::Plain => "plain",
            Mode::Level5 => "level5",
            Mode::Centroids => "centroids",
            Mode::Probe2Split => "probe2-split",
        }
    }
}

/// `patchvis eval` over the model zoo: one Markdown table.
#[derive(Debug, Parser)]
struct Args {
    /// Seeded random views per evaluation (the same for every model, mode and resolution).
    #[arg(long, default_value_t = 300, value_name = "N")]
    views: u32,
    /// Seed of the random views.
    #[arg(long, default_value_t = 1, value_name = "S")]
    seed: u64,
    /// Bake modes.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "default,conservative"
    )]
    modes: Vec<Mode>,
    /// Models, comma-separated [default: every model].
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    models: Vec<String>,
    /// About how many triangles the generated models have.
    #[arg(long, default_value_t = 40_000, value_name = "T")]
    triangles: u64,
    /// Also write the rows as JSON.
    #[arg(long, value_name = "OUT.json")]
    json: Option<PathBuf>,
    /// Keep the generated meshes and the .pvis files in DIR (created if missing).
    #[arg(long, value_name = "DIR")]
    keep: Option<PathBuf>,
    /// Sampling shells per bake (`bake --shells`). The zoo's cameras are at the sampling
    /// distance, where shells do not answer, so none by default: the bake times and file
    /// sizes are those of the sampling sphere, comparable with baselines that had no shells.
    #[arg(long, default_value_t = 0, value_name = "N")]
    shells: u32,
}

/// One line of the table.
struct Row {
    model: &'static str,
    triangles: u32,
    patches: u32,
    mode: Mode,
    resolution: u32,
    summary: EvalSummary,
    bake_seconds: f64,
    file_bytes: u64,
}

fn main() -> Result<()> {
    let args = Args::parse();
    if args.views == 0 {
        bail!("--views 0: expected at least 1");
    }
    let models = selected(&args.models)?;
    // Found out before minutes of baking, not after.
    if let Some(path) = &args.json {
        let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
        if parent.is_some_and(|p| !p.is_dir()) || path.is_dir() {
            bail!(
                "--json {}: expected a file in an existing directory",
                path.display()
            );
        }
    }
    // Either the kept directory or a temporary one, removed when `_temp` drops.
    let (dir, _temp) = match &args.keep {
        Some(dir) => {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("--keep {}: cannot create", dir.display()))?;
            (dir.clone(), None)
        }
        None => {
            let temp = tempfile::tempdir().context("cannot create a temporary directory")?;
            (temp.path().to_path_buf(), Some(temp))
        }
    };
    let directions = random_directions(args.views, args.seed);
    let memory = MemoryBudget::from_available_memory();
    let start = Instant::now();
    let mut rows = Vec::new();
    for (name, source) in models {
        let path = mesh_path(name, source, args.triangles, &dir)?;
        for &mode in &args.modes {
            rows.extend(bake_and_eval(
                name,
                &path,
                mode,
                &directions,
                memory,
                &dir,
                args.shells,
            )?);
        }
    }
    eprintln!("zoo: done in {:.0} s", start.elapsed().as_secs_f64());

    println!(
        "{} random views (seed {}); generated models of about {} triangles",
        args.views, args.seed, args.triangles
    );
    println!();
    print_table(&rows);
    if let Some(path) = &args.json {
        let report = json!({
            "views": args.views,
            "seed": args.seed,
            "generated_triangles": args.triangles,
            "rows": rows.iter().map(row_json).collect::<Vec<_>>(),
        });
        let text = serde_json::to_string_pretty(&report)? + "\n";
        patchvis::format::write_atomic(path, text.as_bytes())
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }
    Ok(())
}

/// The zoo entries `--models` names, in zoo order; all of them without it.
fn selected(names: &[String]) -> Result<Vec<&'static (&'static str, Source)>> {
    if let Some(unknown) = names.iter().find(|n| ZOO.iter().all(|(z, _)| z != n)) {
        let known: Vec<&str> = ZOO.iter().map(|(z, _)| *z).collect();
        bail!(
            "--models: no model '{unknown}', expected some of {}",
            known.join(",")
        );
    }
    Ok(ZOO
        .iter()
        .filter(|(z, _)| names.is_empty() || names.iter().any(|n| n == z))
        .collect())
}

/// The mesh of a zoo model: the asset, or the generated model written to `dir` once.
fn mesh_path(name: &str, source: &Source, triangles: u64, dir: &Path) -> Result<PathBuf> {
    match source {
        Source::Asset(file) => Ok(Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("assets")
            .join(file)),
        Source::Generated(make) => {
            let path = dir.join(format!("{name}.ply"));
            let started = Instant::now();
            let model = make(triangles);
            let file = std::fs::File::create(&path)
                .with_context(|| format!("{}: cannot create", path.display()))?;
            write_ply(file, model.as_ref(), &format!("patchvis zoo: {name}"))
                .with_context(|| format!("{}: cannot write", path.display()))?;
            eprintln!(
                "{name}: generated {} triangles in {:.1} s",
                model.triangle_count(),
                started.elapsed().as_secs_f64()
            );
            Ok(path)
        }
    }
}

/// Bakes `path` in `mode` as `patchvis bake` does, writes the file to `dir`, and evaluates it
/// as `patchvis eval` does at each of [`RESOLUTION_SCALES`] from `directions`.
fn bake_and_eval(
    name: &'static str,
    path: &Path,
    mode: Mode,
    directions: &[[f32; 3]],
    memory: MemoryBudget,
    dir: &Path,
    shells: u32,
) -> Result<Vec<Row>> {
    let recipe = BakeSettings {
        rows: RowSettings {
            preset: match mode {
                Mode::Conservative | Mode::ConservativeAll => Preset::Conservative,
                _ => Preset::Default,
            },
            level: match mode {
                Mode::Level5 | Mode::Centroids => Some(5),
                _ => None,
            },
            shells,
            research: Research {
                probe: match mode {
                    Mode::Thresholded | Mode::Plain => Probe::Off,
                    Mode::Default | Mode::Conservative | Mode::ConservativeAll => Probe::Default,
                    Mode::Level5 | Mode::Centroids => Probe::Pixels(1),
                    Mode::Probe2Split => Probe::Pixels(2),
                },
                fold_min_pixels: (mode == Mode::Thresholded).then_some(4),
                fold_corners: match mode {
                    Mode::Thresholded => Some(FoldCorners::One),
                    Mode::ConservativeAll => Some(FoldCorners::All),
                    Mode::Level5 | Mode::Centroids | Mode::Probe2Split => Some(FoldCorners::Split),
                    Mode::Default | Mode::Conservative | Mode::Plain => None,
                },
                finer_views: match mode {
                    Mode::Centroids => Some(FinerViews::Centroids),
                    Mode::Level5 => Some(FinerViews::Midpoints),
                    _ => None,
                },
                ..Research::default()
            },
            ..RowSettings::default()
        },
        memory,
        ..BakeSettings::default()
    }
    .check()
    .map_err(|e| anyhow!("{name}: {e}"))?;
    let mut stages = Stages::new();
    let started = Instant::now();
    let mesh = recipe
        .open(path)
        .with_context(|| format!("{}: cannot open", path.display()))?;
    let baked = recipe
        .run(&mesh, &Backend::Cpu, &NoProgress, &mut stages)
        .with_context(|| format!("{}: bake failed", path.display()))?;
    let bake_seconds = started.elapsed().as_secs_f64();
    let outputs = Outputs {
        pvis: dir.join(format!("{name}.{}.pvis", mode.name())),
        mesh: None,
    };
    recipe
        .write(&baked, &mesh, &outputs, &mut stages)
        .with_context(|| format!("{}: cannot write", outputs.pvis.display()))?;
    eprintln!(
        "{name} {}: {} triangles, {} patches, {} views sampled, baked in {bake_seconds:.1} s, {} bytes",
        mode.name(),
        mesh.triangle_count(),
        baked.tiling.patches.len(),
        baked.sampled_views,
        baked.bytes.len()
    );

    // From here on `patchvis eval MESH FILE.pvis`: the file as written, the mesh tiled again.
    let bytes = std::fs::read(&outputs.pvis)
        .with_context(|| format!("{}: cannot read", outputs.pvis.display()))?;
    let pvis = Pvis::parse(&bytes).map_err(|e| anyhow!("{}: {e}", outputs.pvis.display()))?;
    let options = EvalOptions {
        memory,
        tiling: TilingMode::Auto,
    };
    let evaluator = Evaluator::new(&mesh, &pvis, &options)
        .map_err(|e| anyhow!("{}: does not match {name}: {e}", outputs.pvis.display()))?;
    let mut rows = Vec::new();
    for scale in RESOLUTION_SCALES {
        let resolution = recipe.resolution() * scale;
        let params = sampling_params(&pvis, resolution, 1.0);
        let cameras: Vec<Camera> = directions
            .iter()
            .map(|&d| Camera::sampling(&params, d))
            .collect();
        let started = Instant::now();
        let metrics = evaluator.evaluate(&pvis, &cameras, &NoProgress);
        let summary = EvalSummary::of(&metrics);
        eprintln!(
            "{name} {} at {resolution} px: {:.1}% identical, culling {:.1}%, {:.1} s",
            mode.name(),
            100.0 * summary.identical_views_fraction(),
            100.0 * summary.culling_rate.mean,
            started.elapsed().as_secs_f64()
        );
        rows.push(Row {
            model: name,
            triangles: mesh.triangle_count(),
            patches: pvis.patch_count(),
            mode,
            resolution,
            summary,
            bake_seconds,
            file_bytes: bytes.len() as u64,
        });
    }
    Ok(rows)
}

fn print_table(rows: &[Row]) {
    println!(
        "| model | triangles | patches | mode | eval px | identical views | missed px mean / p99 / max | culling | ideal culling | bake s | file bytes |"
    );
    println!("|---|--:|--:|---|--:|--:|--:|--:|--:|--:|--:|");
    for r in rows {
        let s = &r.summary;
        println!(
            "| {} | {} | {} | {} | {} | {:.1}% | {:.1} / {} / {} | {:.1}% | {:.1}% | {:.1} | {} |",
            r.model,
            r.triangles,
            r.patches,
            r.mode.name(),
            r.resolution,
            100.0 * s.identical_views_fraction(),
            s.missed_pixels.mean,
            s.missed_pixels.p99,
            s.missed_pixels.max,
            100.0 * s.culling_rate.mean,
            100.0 * s.ideal_culling_rate.mean,
            r.bake_seconds,
            r.file_bytes
        );
    }
}

fn row_json(r: &Row) -> serde_json::Value {
    let s = &r.summary;
    json!({
        "model": r.model,
        "triangles": r.triangles,
        "patches": r.patches,
        "mode": r.mode.name(),
        "resolution": r.resolution,
        "views": s.views,
        "identical_views": s.identical_views,
        "identical_views_fraction": s.identical_views_fraction(),
        "missed_pixels_mean": s.missed_pixels.mean,
        "missed_pixels_p99": s.missed_pixels.p99,
        "missed_pixels_max": s.missed_pixels.max,
        "culling_rate_mean": s.culling_rate.mean,
        "ideal_culling_rate_mean": s.ideal_culling_rate.mean,
        "bake_seconds": r.bake_seconds,
        "file_bytes": r.file_bytes,
    })
}
