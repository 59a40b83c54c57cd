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
    /// Tiling algorithm: the seed algorithm in memory, the chunked out-of-core one, or
    /// whichever the memory budget allows (auto).
    #[arg(long, value_enum, default_value_t = TilingArg::Auto, value_name = "MODE")]
    pub tiling: TilingArg,
    /// Write timings, peak heap and counts per stage as JSON.
    #[arg(long, value_name = "STATS.json")]
    pub stats: Option<PathBuf>,
    /// Print nothing but errors; no progress bars.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `--tiling`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TilingArg {
    /// In core when it fits the memory budget, else out of core.
    Auto,
    /// The seed algorithm on the whole mesh.
    InCore,
    /// Chunked tiling in bounded memory.
    OutOfCore,
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
