//! Raw command-line flags (clap). [`crate::cli::bake::Settings`] turns them into checked,
//! resolved settings; nothing else reads these structs.

use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// Bake precomputed patch visibility for huge triangle meshes, and query it.
#[derive(Debug, Parser)]
#[command(name = "patchvis", version, about, long_about = None)]
pub struct Cli {
    /// The command to run.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Tile a mesh into patches, sample their visibility from a sphere of views, write a .pvis.
    Bake(BakeArgs),
    /// Print what a .pvis file holds.
    Info(InfoArgs),
    /// Which patches (and triangle ranges) a camera at a position sees.
    Query(QueryArgs),
    /// Measure what users see: missed pixels, culling rate, popping, frame cost, pictures.
    Eval(EvalArgs),
}

/// `patchvis bake`.
#[derive(Debug, clap::Args)]
pub struct BakeArgs {
    /// Input mesh (PLY).
    pub input: PathBuf,
    /// Output .pvis file.
    #[arg(short, long, value_name = "OUT.pvis")]
    pub output: PathBuf,
    /// Number of patches to group the triangles into (at most the triangle count).
    #[arg(long, default_value_t = 1000, value_name = "N")]
    pub patches: u32,
    /// Sphere subdivision level: 0..=7 gives 6, 18, 66, 258, 1026, 4098, 16386, 65538 views.
    #[arg(long, default_value_t = 4, value_name = "L")]
    pub level: u32,
    /// ID-buffer width and height in pixels.
    #[arg(long, default_value_t = 512, value_name = "PX")]
    pub resolution: u32,
    /// Field of view of the sampling cameras, degrees.
    #[arg(long, default_value_t = 45.0, value_name = "DEG")]
    pub fov: f32,
    /// Also write the mesh reordered so that each patch is one contiguous triangle range, with
    /// per-face `patch` and `red green blue` properties (binary PLY).
    #[arg(long, value_name = "MESH.ply")]
    pub mesh_out: Option<PathBuf>,
    /// Write timings, peak heap and counts per stage as JSON.
    #[arg(long, value_name = "STATS.json")]
    pub stats: Option<PathBuf>,
    /// Print nothing but errors; no progress bars.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `patchvis info`.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// The .pvis file.
    pub file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `patchvis query`.
#[derive(Debug, clap::Args)]
pub struct QueryArgs {
    /// The .pvis file.
    pub file: PathBuf,
    /// Camera position in model space.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true)]
    pub from: [f32; 3],
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `patchvis eval`.
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// The mesh the file was baked from: the original input, not the --mesh-out PLY (the
    /// triangle → patch map is re-derived by tiling it again, and checked against the file).
    pub mesh: PathBuf,
    /// The .pvis file (not with --sweep, which bakes its own).
    #[arg(required_unless_present = "sweep", value_name = "FILE.pvis")]
    pub file: Option<PathBuf>,
    /// Number of seeded random camera positions.
    #[arg(long, default_value_t = 200, value_name = "N")]
    pub views: u32,
    /// Seed of the random camera positions.
    #[arg(long, default_value_t = 1, value_name = "S")]
    pub seed: u64,
    /// Camera distance over the sampling distance (< 1 nearer, > 1 farther).
    #[arg(long, default_value_t = 1.0, value_name = "K")]
    pub distance_scale: f32,
    /// Render resolution [default: the file's sampling resolution; 512 with --sweep].
    #[arg(long, value_name = "PX")]
    pub resolution: Option<u32>,
    /// Evaluate at the sampling positions of sphere level L (at most the file's level) instead
    /// of random ones.
    #[arg(long, value_name = "L", conflicts_with_all = ["path", "sweep"])]
    pub sampling_level: Option<u32>,
    /// Evaluate frame by frame along a path: `orbit` or `orbit:N` (N frames, default 120), or a
    /// camera path file (one camera per line: `X Y Z` or `X Y Z TX TY TZ`).
    #[arg(long, value_name = "orbit[:N]|FILE", conflicts_with = "sweep")]
    pub path: Option<String>,
    /// Directory for pictures: PNGs of the worst views (full | reconstruction | difference),
    /// and SVG plots of the path or the sweep.
    #[arg(long, value_name = "DIR")]
    pub png: Option<PathBuf>,
    /// How many of the worst views get a PNG.
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub worst: u32,
    /// Bake the mesh for every patch count and level of the lists and evaluate each.
    #[arg(long)]
    pub sweep: bool,
    /// Patch counts of the sweep.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "50,300,1000,2000,4000",
        value_name = "P,P,.."
    )]
    pub sweep_patches: Vec<u32>,
    /// Sphere levels of the sweep.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0,1,2,3,4,5",
        value_name = "L,L,.."
    )]
    pub sweep_levels: Vec<u32>,
    /// Field of view of the sweep's bakes, degrees.
    #[arg(long, default_value_t = 45.0, value_name = "DEG")]
    pub fov: f32,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Print nothing but the report and errors; no progress.
    #[arg(short, long)]
    pub quiet: bool,
}

fn parse_point(s: &str) -> Result<[f32; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!(
            "expected three comma-separated numbers X,Y,Z, found {} values",
            parts.len()
        ));
    };
    let num = |t: &str| -> Result<f32, String> {
        match t.parse::<f32>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!("expected a finite number, found '{t}'")),
        }
    };
    Ok([num(x)?, num(y)?, num(z)?])
}
