//! Raw command-line flags (clap). [`crate::cli::bake::Settings`] turns them into checked,
//! resolved settings; nothing else reads these structs.

use clap::{Parser, Subcommand};
use patchvis::bake::{MAX_PROBE_PIXELS, Probe};
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
    /// Write a huge, real-looking test mesh (binary PLY), streaming and deterministic.
    #[command(alias = "generate")]
    Gen(GenArgs),
    /// Check a .pvis file against the format specification; report the first violation.
    Verify(VerifyArgs),
    /// Tile a mesh once for a sharded bake: a tiling file every `bake --shard` can read.
    Tile(TileArgs),
    /// Merge the parts of a sharded bake (`bake --shard`) into the .pvis one bake writes.
    Merge(MergeArgs),
    /// Test another .pvis reader against the conformance vectors, through a line protocol on
    /// its stdin and stdout.
    Conformance(ConformanceArgs),
}

/// The heading of `bake`'s research options: tuning of the sampling, the fold, the probe pass,
/// the shells and the encoding. `bake --help` leaves them out; `bake --help-all` shows them.
const RESEARCH: &str = "Research options";

/// `patchvis bake`. `-h` and `--help` print the everyday options, one line each;
/// `--help-all` prints every option in full, the research options under their own heading.
#[derive(Debug, clap::Args)]
#[command(
    disable_help_flag = true,
    after_help = "Research options (sampling, fold, probe, shells, encoding): \
                  `patchvis bake --help-all`; every option's measured effect: docs/bake.md.",
    after_long_help = "Every option with its measured effect: docs/bake.md."
)]
pub struct BakeArgs {
    /// Input mesh: PLY, OBJ, STL or glTF 2.0 (.gltf / .glb).
    pub input: PathBuf,
    /// Output .pvis file.
    ///
    /// Outputs that are symbolic links are written through (the file they point to is
    /// replaced, the link stays); each output is locked while the bake runs, and another
    /// command naming one is refused with the bake's pid.
    #[arg(short, long, value_name = "OUT.pvis")]
    pub output: PathBuf,
    /// Number of patches to group the triangles into (at most the triangle count).
    #[arg(long, default_value_t = 1000, value_name = "N")]
    pub patches: u32,
    /// Sphere level of the stored views, 0..=7 [default: 4; 5 with --conservative].
    ///
    /// Levels 0 to 7 store 6, 18, 66, 258, 1026, 4098, 16386 and 65538 views.
    #[arg(long, value_name = "L")]
    pub level: Option<u32>,
    /// ID-buffer width and height in pixels.
    #[arg(long, default_value_t = 512, value_name = "PX")]
    pub resolution: u32,
    /// Field of view of the sampling cameras, degrees.
    #[arg(long, default_value_t = 45.0, value_name = "DEG")]
    pub fov: f32,
    /// The never-miss preset: ≥ 99 % of views pixel-identical on the model zoo, for about 3×
    /// the bake time.
    ///
    /// Stored level 5 (unless --level), the stored faces' centroids for the finer views
    /// (unless --finer-views), the probe pass at 1 pixel with the split fold, on any mesh
    /// --memory holds; shells at level 4 at most (unless --shell-level). After each sampled
    /// view (the stored level's and the centroids), every patch the view did not show is
    /// drawn again with conservative rasterization (any part of a pixel, not only its centre)
    /// against the view's depths shrunk by 1 pixel, and added if a fragment lies in front.
    /// Only triangles whose visible side may face a camera of the sphere faces around the
    /// view are drawn: the outside of their solid, or its inside through an opening.
    ///
    /// What it guarantees: every patch that touches a pixel of a sampled view, or lies within
    /// 1 pixel of coming out from behind an occluder's edge there, is in the answer for every
    /// direction of the sphere faces around that view, at the sampling distance (and, with
    /// shells, nearer). What it does not: a part that comes out by more than 1 pixel between
    /// sampled views, and, with --far-shells none, rim that only cameras farther than the
    /// sampling distance see.
    ///
    /// Measured residual (300 random views at the sampling distance, at --resolution and
    /// twice it): ≥ 99 % of views pixel-identical on every model of the zoo, culling within
    /// 10 points of the ideal (7.6–9.8 below); BENCHMARKS.md, "Quality on the model zoo".
    /// Costs 2.3–3.0× the default's bake time without shells and 1.8–2.2× its file on the
    /// zoo; CPU backend only, and about 60 bytes a triangle of heap while sampling.
    #[arg(long)]
    pub conservative: bool,
    /// Spheres of near views inside the sampling distance, for cameras near the model.
    ///
    /// N nested spheres of near views between the sampling
    /// sphere (distance D = R / sin(fov/2), R the bounding radius) and F·R (--shell-min), at
    /// D·(F·R/D)^(s/N) for s = 1..N. Each near view records every patch visible from its eye
    /// in any direction, so a query nearer than D is answered from the two shells around it
    /// instead of drawing everything; inside the innermost shell the answer is flagged
    /// inside_sphere. Cost: each shell is one more sampling pass of the stored level (its
    /// views render several frustums each) and one more visibility matrix in the file. 0: no
    /// near shells (with --far-shells none, a version-4 file).
    #[arg(long, default_value_t = patchvis::bake::DEFAULT_SHELLS, value_name = "N")]
    pub shells: u32,
    /// Spheres of far views at these multiples of the sampling distance, for cameras farther
    /// out (`none`: no far band).
    ///
    /// The far band, for cameras farther than the sampling distance D: shells of views at
    /// these multiples of D (increasing, above 1), each view framing the bounding sphere from
    /// its eye; a camera between two spheres of views is answered from both, and one beyond
    /// the outermost from it alone. `none`: no far band (cameras beyond D get the sampling
    /// sphere's rows, which miss rim they see past).
    #[arg(long, value_name = "LIST|none", value_parser = parse_far_shells,
          default_value = "2,256")]
    pub far_shells: FarShells,
    /// Also write the mesh reordered so that each patch is one contiguous triangle range.
    ///
    /// .glb/.gltf (glTF 2.0, patch ranges in the mesh's extras, with the input's normals,
    /// texture coordinates and materials), or binary PLY for any other name (per-face patch,
    /// colour and orig_index; it reads no material library). Renamed into place just before
    /// the .pvis, the .pvis already there removed first.
    #[arg(long, value_name = "MESH.ply|.glb|.gltf")]
    pub mesh_out: Option<PathBuf>,
    /// Patches never culled: comma-separated ids, or a file of ids.
    ///
    /// A file holds ids separated by whitespace or commas (`#` starts a comment; a regular
    /// file of at most 64 MiB). Ids are the tiling's (spatial) numbering, which a bake with
    /// `--patch-order spatial --mesh-out M.ply` shows.
    #[arg(long, value_name = "IDS|FILE")]
    pub always_visible: Option<String>,
    /// Heap budget, e.g. 512MiB, 2GiB, 1G [default: half the available memory, at least 256 MiB].
    ///
    /// Split between the stages and reported in --stats; the memory-mapped mesh and the page
    /// cache are not counted.
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    pub memory: Option<u64>,
    /// Where to render the ID buffers.
    #[arg(long, value_enum, default_value_t = BackendArg::Cpu, value_name = "BACKEND")]
    pub backend: BackendArg,
    /// Write timings, peak heap and counts per stage as JSON.
    #[arg(long, value_name = "STATS.json")]
    pub stats: Option<PathBuf>,
    /// Continue an interrupted bake from its checkpoints (OUT.pvis.*ckpt).
    ///
    /// A checkpoint is written after every sphere level; one of other inputs or settings is
    /// refused.
    #[arg(long)]
    pub resume: bool,
    /// Bake only shard I of N of the views into a part file, for `patchvis merge`.
    ///
    /// I runs from 0 to N - 1; `auto` takes I and N from a Slurm job array or a Kubernetes
    /// Indexed Job (JOB_COMPLETION_INDEX with PATCHVIS_SHARD_COUNT). Every shard needs the
    /// same input and flags.
    #[arg(long, value_name = "I/N|auto", conflicts_with = "mesh_out")]
    pub shard: Option<String>,
    /// With --shard: read the tiling from this file (`patchvis tile`) instead of tiling again.
    #[arg(long, value_name = "T.ptile")]
    pub tiling_file: Option<PathBuf>,
    /// Print nothing but errors; no progress bars.
    #[arg(short, long)]
    pub quiet: bool,
    /// Print help: the everyday options.
    #[arg(short, long, action = clap::ArgAction::HelpShort)]
    pub help: Option<bool>,
    /// Print help with every option, the research options too.
    #[arg(long, action = clap::ArgAction::HelpLong)]
    pub help_all: Option<bool>,
    /// Tiling algorithm: the seed algorithm in memory, the chunked out-of-core one, or
    /// whichever the memory budget allows (auto).
    #[arg(long, value_enum, default_value_t = TilingArg::Auto, value_name = "MODE",
          hide_short_help = true, help_heading = RESEARCH)]
    pub tiling: TilingArg,
    /// A patch counts as seen from a view only if it covers at least K pixels there
    /// (aggressive mode; 0 or 1: any pixel). Above 1 it needs --probe off: the probe pass adds
    /// back what it drops.
    #[arg(long, default_value_t = 0, value_name = "K",
          hide_short_help = true, help_heading = RESEARCH)]
    pub min_pixels: u32,
    /// Also mark the edge neighbours of every seen patch that may face the view
    /// (hole filling).
    #[arg(long, hide_short_help = true, help_heading = RESEARCH)]
    pub dilate: bool,
    /// The probe pass: after each view, every patch it did not show is drawn again with
    /// conservative rasterization against its occluders shrunk by PX pixels, and added where
    /// a camera near the view may see it; then each patch a finer view holds goes to one stored
    /// view per sphere face holding the view, chosen over the whole sphere (the cover fold).
    /// The default bake runs it at 1 pixel over every view, the sampling sphere's and the
    /// shells', for the cameras at each sphere's own distance, on the CPU backend, for meshes
    /// of up to 2,236,962 triangles (whose solids, about 60 bytes a triangle, fit any default
    /// --memory), and leaves it off past that, where --memory is too small, and on the GPU
    /// backend, saying so. `--probe PX` asks for it on any mesh --memory holds, for every
    /// camera between a sphere of views and the next (0.1–1.7 points less culling on the
    /// bunny); `--probe off` turns it off.
    /// [default: 1, within those bounds]
    #[arg(long, value_name = "PX|off", value_parser = parse_probe, conflicts_with = "conservative",
          hide_short_help = true, help_heading = RESEARCH)]
    pub probe: Option<Probe>,
    /// With the probe pass (the default's, --probe or --conservative): a pixel with a rim of
    /// another part within PX pixels on both sides (a hole in a sheet, a slit between parts)
    /// is an aperture, and every patch a camera near the view may see through it by parallax
    /// is added too. For parts seen through holes: with --conservative at 2, the FM1 box (a
    /// sheet-metal box with holes) keeps 98.7–100 % identical views at every distance
    /// (95.3–99.3 % without) for 8–13 points of culling; assemblies whose parts meet at gaps
    /// everywhere lose more (the cycloidal drive 13–25 points for its last 1 % of views, the
    /// exposed engine 7–10 for none). [default: 0, none]
    #[arg(long, value_name = "PX", hide_short_help = true, help_heading = RESEARCH)]
    pub apertures: Option<u32>,
    /// Conservative rasterization: a triangle marks every pixel square it touches, at its
    /// nearest depth there (one winner per pixel). Measured no better than point sampling.
    #[arg(long, hide_short_help = true, help_heading = RESEARCH)]
    pub conservative_raster: bool,
    /// Store each view's row as sampled (and folded). By default a bake also sets, in each
    /// view's row, every patch that all the sphere faces around the view already answer
    /// through their corners: no query's answer changes and the file is smaller (the default
    /// bake's 4–45 % on the model zoo). Rows as sampled are for tools that read the rows one
    /// by one (`patchvis_view_row`) as what each view saw.
    #[arg(long, hide_short_help = true, help_heading = RESEARCH)]
    pub sampled_rows: bool,
    /// View supersampling: sample K sphere levels finer (about 4^K times the views) and fold
    /// every finer view's patches into the stored views around it, so that queries from inside
    /// a sphere face see what its finer samples saw; the file keeps level L's size (0: off; 1
    /// or 2). Its checkpoint is OUT.pvis.vsK.ckpt. [default: 1; 0 at --level 7]
    #[arg(long, value_name = "K", hide_short_help = true, help_heading = RESEARCH)]
    pub view_supersample: Option<u32>,
    /// With view supersampling: a finer view's patch is folded into the stored views only if
    /// it covers at least T pixels there (the stored views themselves keep every pixel, at the
    /// cost of sampling the stored level once more); trades a few small misses for culling
    /// (0 or 1: every pixel). [default: 0]
    #[arg(long, value_name = "T", hide_short_help = true, help_heading = RESEARCH)]
    pub fold_min_pixels: Option<u32>,
    /// With view supersampling: a finer view's patches go to all the stored views around it
    /// that every sphere face holding it shares (all), or to just one of them (one: still
    /// covers every finer sample of a face, culls more, misses more), or, with
    /// --conservative, what the view showed to all of them and what only the probe pass added
    /// to one (split), or to one per sphere face holding it, chosen over the whole sphere
    /// (cover). [default: cover with the probe pass (the default's, --probe); split with
    /// --conservative; all with --probe off]
    #[arg(long, value_enum, value_name = "WHICH", hide_short_help = true, help_heading = RESEARCH)]
    pub fold_corners: Option<FoldCornersArg>,
    /// With one level of view supersampling: where the finer views lie. midpoints: the finer
    /// sphere level's vertices, the midpoints of the stored edges (12·4^L views at --level
    /// L). centroids: the centroids of the stored faces (8·4^L views, two thirds as many),
    /// each folded into its face's three corners; every point of a face then lies within a
    /// third of an edge of a view, and the probe's cells grow to match. The sampling sphere
    /// only (shells sample their vertices); the CPU sampler only.
    /// [default: midpoints; centroids with --conservative]
    #[arg(long, value_enum, value_name = "WHERE", hide_short_help = true, help_heading = RESEARCH)]
    pub finer_views: Option<FinerViewsArg>,
    /// The innermost shell's radius over the bounding radius: above 1 and below D/R (2.61 at
    /// --fov 45).
    #[arg(long, default_value_t = patchvis::bake::DEFAULT_SHELL_MIN, value_name = "F",
          hide_short_help = true, help_heading = RESEARCH)]
    pub shell_min: f64,
    /// Sphere level of the shells' views (0..=7), supersampled and folded as the stored level
    /// is. [default: --level; with --conservative, --level but at most 4]
    #[arg(long, value_name = "L", hide_short_help = true, help_heading = RESEARCH)]
    pub shell_level: Option<u32>,
    /// ID-buffer side of the shells' views in pixels, at most --resolution: a near eye sees
    /// the model larger, so each patch covers more pixels. [default: --resolution]
    #[arg(long, value_name = "PX", hide_short_help = true, help_heading = RESEARCH)]
    pub shell_resolution: Option<u32>,
    /// How the file numbers its patches: covisibility (patches seen from the same views get
    /// neighbouring ids, which the visibility coder turns into a smaller file) or spatial (the
    /// tiling's Z-order numbering, the same for every bake of a mesh at a patch count; the
    /// numbering --always-visible ids refer to).
    #[arg(long, value_enum, default_value_t = PatchOrderArg::Covisibility, value_name = "ORDER",
          hide_short_help = true, help_heading = RESEARCH)]
    pub patch_order: PatchOrderArg,
    /// How the file stores the visibility rows (spec/FORMAT.md § VISB): tree (encoding 2, the
    /// smallest), table (encoding 1) or raw (encoding 0, one bit per view and patch, no
    /// decoding). It does not choose the version: a file with sampling shells (the default's
    /// near shells and far band) is version 6 (5 without the far band) with the compact patch
    /// table, whatever the encoding. Only with --shells 0 --far-shells none does tree write
    /// version 4 and table or raw version 2, for readers that predate versions 3 to 6.
    #[arg(long, value_enum, default_value_t = EncodingArg::Tree, value_name = "ENCODING",
          hide_short_help = true, help_heading = RESEARCH)]
    pub encoding: EncodingArg,
}

/// `--encoding`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum EncodingArg {
    /// VISB encoding 2: range-coded rows, context-tree probabilities.
    Tree,
    /// VISB encoding 1: range-coded rows, a 32-context table per level.
    Table,
    /// VISB encoding 0: raw rows.
    Raw,
}

/// `--patch-order`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PatchOrderArg {
    /// A greedy tour of the patches' visibility signatures.
    Covisibility,
    /// The tiling's numbering along a Z-order curve.
    Spatial,
}

/// `--backend`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BackendArg {
    /// The CPU rasterizer: bit-exact, deterministic, checkpoints and every option.
    Cpu,
    /// The GPU through wgpu (Vulkan, Metal or DX12); an error if there is none.
    Gpu,
    /// A hardware GPU if one is found, else the CPU (saying why on stderr).
    Auto,
}

/// `--fold-corners`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FoldCornersArg {
    /// Every stored view shared by the faces holding the finer view.
    All,
    /// One of them.
    One,
    /// With --conservative (its default there): what a finer view showed to all of them,
    /// what only the probe pass added to the one whose faces gain the fewest new answers.
    Split,
    /// One stored view per face holding the finer view, chosen for the whole sphere so that
    /// the fewest other faces answer the patch.
    Cover,
}

/// `--finer-views`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FinerViewsArg {
    /// The finer sphere level's vertices.
    Midpoints,
    /// The centroids of the stored level's faces.
    Centroids,
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

impl From<TilingArg> for patchvis::tiling::TilingMode {
    fn from(arg: TilingArg) -> Self {
        match arg {
            TilingArg::Auto => Self::Auto,
            TilingArg::InCore => Self::InCore,
            TilingArg::OutOfCore => Self::OutOfCore,
        }
    }
}

/// The budget of `--memory SIZE`, or half the available memory without it.
pub fn memory_budget(memory: Option<u64>) -> patchvis::bake::MemoryBudget {
    use patchvis::bake::MemoryBudget;
    memory.map_or_else(MemoryBudget::from_available_memory, MemoryBudget::new)
}

/// `patchvis gen`.
#[derive(Debug, clap::Args)]
pub struct GenArgs {
    /// Which model to generate.
    #[arg(long, value_enum)]
    pub kind: GenKind,
    /// About how many triangles (the model's own steps decide the exact count).
    #[arg(long, value_name = "N")]
    pub triangles: u64,
    /// Output mesh (binary little-endian PLY); a symbolic link is written through.
    #[arg(short, long, value_name = "OUT.ply")]
    pub output: PathBuf,
    /// The mesh that `subdivided-bunny` and `bunny-grid` start from (required for those
    /// kinds), such as the Stanford bunny, assets/bunny.ply in the patchvis repository.
    #[arg(long, value_name = "MESH.ply")]
    pub source: Option<PathBuf>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// The models `patchvis gen` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum GenKind {
    /// The source split k×k per triangle and displaced by smooth noise, like a dense scan.
    SubdividedBunny,
    /// Copies of the source on a floor grid.
    BunnyGrid,
    /// A closed casing around nested closed machine parts, never visible from outside.
    Engine,
    /// Machine parts in the open: thin fins, a plate with holes, gears, pipes and narrow gaps,
    /// so visibility changes quickly with the viewing direction.
    ExposedEngine,
    /// A lattice of thin beams with braces and leaf cards, seen through from every direction.
    Truss,
}

impl GenKind {
    /// The flag value, for messages.
    pub fn name(self) -> &'static str {
        match self {
            GenKind::SubdividedBunny => "subdivided-bunny",
            GenKind::BunnyGrid => "bunny-grid",
            GenKind::Engine => "engine",
            GenKind::ExposedEngine => "exposed-engine",
            GenKind::Truss => "truss",
        }
    }
}

/// `patchvis tile`.
#[derive(Debug, clap::Args)]
pub struct TileArgs {
    /// Input mesh: PLY, OBJ, STL or glTF 2.0 (.gltf / .glb).
    pub input: PathBuf,
    /// Output tiling file.
    #[arg(short, long, value_name = "T.ptile")]
    pub output: PathBuf,
    /// Number of patches (the bake's --patches).
    #[arg(long, default_value_t = 1000, value_name = "N")]
    pub patches: u32,
    /// Heap budget (the bake's --memory; out of core, it decides the tiling's chunks).
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    pub memory: Option<u64>,
    /// Tiling algorithm (the bake's --tiling).
    #[arg(long, value_enum, default_value_t = TilingArg::Auto, value_name = "MODE")]
    pub tiling: TilingArg,
    /// Field of view of the sampling cameras, degrees (the bake's --fov).
    #[arg(long, default_value_t = 45.0, value_name = "DEG")]
    pub fov: f32,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `patchvis merge`.
#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The part files of every shard, in any order.
    #[arg(required = true, value_name = "PART")]
    pub parts: Vec<PathBuf>,
    /// Output .pvis file.
    #[arg(short, long, value_name = "OUT.pvis")]
    pub output: PathBuf,
    /// Print nothing but errors.
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
    /// Also print the visibility payload's size next to the raw matrix and the raw matrix
    /// compressed by `zstd -19` and `xz -9` (done in-process; no external tools needed).
    /// It holds the matrix three times (every row decoded, the raw rows, the raw rows
    /// renumbered: views × patches bits each), within --memory.
    #[arg(long)]
    pub compare: bool,
    /// Heap --compare may use for the matrices it holds, e.g. 512MiB or 4GiB [default: half
    /// of the available memory, at least 256 MiB]; a file whose matrices need more is
    /// refused before any work. The compressors' own state (about 700 MiB for xz -9) comes on
    /// top.
    #[arg(long, value_name = "SIZE", value_parser = parse_size, requires = "compare")]
    pub memory: Option<u64>,
}

/// `patchvis verify`.
#[derive(Debug, clap::Args)]
pub struct VerifyArgs {
    /// The .pvis file.
    pub file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Stop after this many seconds (decimals allowed) with the verdict "not verified" (exit
    /// 1). verify decodes every row of every sphere of views: views × patches bits, which a
    /// small file can make large (a 790 KB file of 65,538 views and 2^20 patches holds 2^36
    /// bits: minutes). Past 2^32 bits it says so on stderr and shows its progress on a
    /// terminal.
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds)]
    pub time_limit: Option<f64>,
}

/// A duration in seconds: a finite, non-negative decimal number.
fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("expected a number of seconds, found '{s}'")),
    }
}

/// `patchvis conformance`.
#[derive(Debug, clap::Args)]
pub struct ConformanceArgs {
    /// The reader to test: a shell command whose process answers the line protocol of
    /// tests/conformance/README.md ("Testing another reader") on stdin and stdout.
    #[arg(long, value_name = "CMD", required_unless_present = "serve")]
    pub reader: Option<String>,
    /// The vectors' folder (tests/conformance in the sources): valid/, invalid/ and
    /// far-only.txt.
    #[arg(long, default_value = "tests/conformance", value_name = "DIR")]
    pub vectors: PathBuf,
    /// Seconds to wait for each reply before the vector fails.
    #[arg(long, default_value_t = 10.0, value_name = "S", value_parser = parse_timeout)]
    pub timeout: f64,
    /// Answer the protocol on stdin and stdout as the reference reader does, instead: the
    /// peer that --reader expects.
    #[arg(long, conflicts_with = "reader")]
    pub serve: bool,
}

/// A positive, finite number of seconds, at most a day.
fn parse_timeout(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(t) if t > 0.0 && t <= 86_400.0 => Ok(t),
        _ => Err(format!("{s}: expected seconds in (0, 86400]")),
    }
}

/// `patchvis query`.
#[derive(Debug, clap::Args)]
pub struct QueryArgs {
    /// The .pvis file.
    pub file: PathBuf,
    /// Camera position in model space.
    #[arg(long, visible_alias = "eye", value_name = "X,Y,Z", value_parser = parse_point,
          allow_hyphen_values = true, required_unless_present = "bench")]
    pub from: Option<[f32; 3]>,
    /// Also drop the patches outside the view frustum of a camera at --eye looking at this
    /// point (OpenGL-style look-at and perspective, world up +Y).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true,
          conflicts_with = "view_proj")]
    pub look_at: Option<[f32; 3]>,
    /// Vertical field of view of the --look-at camera, degrees.
    #[arg(long, default_value_t = 45.0, value_name = "DEG", requires = "look_at")]
    pub fov: f32,
    /// Width over height of the --look-at camera's image.
    #[arg(long, default_value_t = 1.0, value_name = "A", requires = "look_at")]
    pub aspect: f32,
    /// Near-plane distance of the --look-at camera [default: 1/1000 of the distance to the
    /// point looked at].
    #[arg(long, value_name = "N", requires = "look_at")]
    pub near: Option<f32>,
    /// Far-plane distance of the --look-at camera [default: none].
    #[arg(long, value_name = "F", requires = "look_at")]
    pub far: Option<f32>,
    /// Also drop the patches outside the frustum of this view-projection matrix (model space
    /// to clip space): 16 comma-separated numbers, column-major (element (row, col) at
    /// 4·col + row, as OpenGL, WebGPU and glam store it).
    #[arg(long, value_name = "M0,..,M15", value_parser = super::view::parse_matrix,
          allow_hyphen_values = true)]
    pub view_proj: Option<[f32; 16]>,
    /// Clip-space depth range of --view-proj: gl (−w ≤ z ≤ w) or zero-to-one (0 ≤ z ≤ w:
    /// Direct3D, Vulkan, Metal, wgpu).
    #[arg(long, value_enum, default_value_t = DepthArg::Gl, value_name = "RANGE",
          requires = "view_proj")]
    pub depth: DepthArg,
    /// Instead of one query, time N queries per mode (expanded; streaming staying in a leaf;
    /// streaming along a smooth orbit, counting leaf changes) from seeded eyes at 1.5 times
    /// the sampling distance, and print median nanoseconds. N is 1 to 1000000.
    #[arg(long, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=i64::from(super::query_bench::MAX_QUERIES)))]
    pub bench: Option<u32>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `query --depth`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum DepthArg {
    /// `−w ≤ z ≤ w` (OpenGL, WebGL).
    Gl,
    /// `0 ≤ z ≤ w` (Direct3D, Vulkan, Metal, wgpu).
    ZeroToOne,
}

/// `patchvis eval`.
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// The mesh the file was baked from: the bake's --mesh-out PLY (in the file's patch
    /// order; every patch's bounds are checked against the file), or the original input
    /// (tiled again with --memory and --tiling, which must be the bake's when it tiled out of
    /// core, and checked against the file).
    pub mesh: PathBuf,
    /// The .pvis file (not with --sweep, which bakes its own).
    #[arg(required_unless_present = "sweep", value_name = "FILE.pvis")]
    pub file: Option<PathBuf>,
    /// Number of seeded random camera positions, 1 to 1000000 (each is a render of the
    /// whole mesh).
    #[arg(long, default_value_t = 200, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=i64::from(patchvis::eval::views::MAX_VIEWS)))]
    pub views: u32,
    /// Seed of the random camera positions.
    #[arg(long, default_value_t = 1, value_name = "S")]
    pub seed: u64,
    /// Camera distance over the sampling distance (< 1 nearer, > 1 farther). A list
    /// (e.g. 0.45,0.6,0.8,1) evaluates the same cameras at each distance and prints one row a
    /// distance; not with --path or --sweep.
    #[arg(
        long,
        default_value = "1",
        value_name = "K[,K..]",
        allow_hyphen_values = true
    )]
    pub distance_scale: String,
    /// Turn each camera's view direction by a seeded random angle of up to DEG degrees (from
    /// the model's centre, or the path's target), so that parts of the model fall outside
    /// the view and the frustum culls; 0 keeps the cameras as they are.
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "DEG",
        conflicts_with = "sweep"
    )]
    pub look_jitter: f32,
    /// Beyond the sampling distance, each camera's field of view just frames the bounding
    /// sphere from its eye (a telephoto camera: the model as large as at the sampling
    /// distance), instead of the file's field of view, under which a far model shrinks to a
    /// few pixels. The ideal is then every patch visible from the eye at the render's pixel
    /// scale, not only those larger than a far camera's pixels.
    #[arg(long, conflicts_with = "sweep")]
    pub fit: bool,
    /// Render resolution [default: the file's sampling resolution; 512 with --sweep].
    #[arg(long, value_name = "PX")]
    pub resolution: Option<u32>,
    /// Evaluate at the sampling positions of sphere level L (at most the file's level) instead
    /// of random ones.
    #[arg(long, value_name = "L", conflicts_with_all = ["path", "sweep"])]
    pub sampling_level: Option<u32>,
    /// Evaluate frame by frame along a path: `orbit` or `orbit:N` (N frames, 1 to 1000000,
    /// default 120), or a camera path file (one camera per line: `X Y Z` or `X Y Z TX TY TZ`;
    /// at most 1000000 cameras and 128 MiB).
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
    /// How the sweep samples its bakes: as a default `bake` does (view supersampling and
    /// fold; about 5× the sampling time of plain), or plain (--view-supersample 0).
    #[arg(long, value_enum, default_value_t = SweepModeArg::Default, value_name = "MODE")]
    pub sweep_mode: SweepModeArg,
    /// Where to time the frame cost (full mesh vs culled set): the CPU rasterizer; the GPU
    /// through wgpu, software adapters (lavapipe) included, an error without one; or auto
    /// (a hardware GPU if there is one, else the CPU, saying why). The CPU figure is always
    /// reported too.
    #[arg(
        long,
        value_enum,
        default_value_t = FrameBackendArg::Auto,
        value_name = "BACKEND",
        conflicts_with = "sweep"
    )]
    pub frame_backend: FrameBackendArg,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Print nothing but the report and errors; no progress.
    #[arg(short, long)]
    pub quiet: bool,
    /// Heap budget, e.g. 256MiB (default: half the available memory, at least 256 MiB): the
    /// re-tiling of an original mesh and the views rendered at once keep within it.
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    pub memory: Option<u64>,
    /// Tiling algorithm when the mesh must be tiled again (the bake's --tiling).
    #[arg(long, value_enum, default_value_t = TilingArg::Auto, value_name = "MODE")]
    pub tiling: TilingArg,
    /// Write timings and peak heap per stage as JSON.
    #[arg(long, value_name = "STATS.json", conflicts_with = "sweep")]
    pub stats: Option<PathBuf>,
}

/// `eval --sweep-mode`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SweepModeArg {
    /// What a default `patchvis bake` writes: view supersampling, the probe pass and their
    /// default fold. Levels below the finest are cut from the finest level's sampling, whose
    /// probe cells are smaller than a bake at that level draws.
    Default,
    /// The stored views' own patches only (`bake --view-supersample 0 --probe off`).
    Plain,
}

/// `eval --frame-backend`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FrameBackendArg {
    /// The CPU rasterizer only.
    Cpu,
    /// The GPU through wgpu, any adapter (software ones too); an error if there is none.
    Gpu,
    /// A hardware GPU if one is found, else the CPU (saying why).
    Auto,
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

/// A byte size: a number with an optional unit, `K`/`M`/`G`/`T` and `KiB`/`MiB`/`GiB`/`TiB`
/// (all binary, as `free` and `top` count), `B`, or none (bytes).
pub fn parse_size(s: &str) -> Result<u64, String> {
    let text = s.trim();
    let split = text
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(text.len());
    let (number, unit) = text.split_at(split);
    let shift = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kb" | "kib" => 10,
        "m" | "mb" | "mib" => 20,
        "g" | "gb" | "gib" => 30,
        "t" | "tb" | "tib" => 40,
        other => {
            return Err(format!(
                "unknown unit '{other}' in '{s}', expected e.g. 512MiB, 2GiB or 1G"
            ));
        }
    };
    let value: f64 = number
        .parse()
        .map_err(|_| format!("expected a size such as 512MiB, found '{s}'"))?;
    let bytes = value * (1u64 << shift) as f64;
    // `u64::MAX as f64` rounds up to 2^64, the first size that does not fit.
    if bytes >= u64::MAX as f64 {
        return Err(format!(
            "'{s}' is too large: at most 16 EiB ({} bytes)",
            u64::MAX
        ));
    }
    if bytes < 1.0 {
        return Err(format!("'{s}': expected a size of at least 1 byte"));
    }
    Ok(bytes as u64)
}

/// `--probe PX|off`.
fn parse_probe(s: &str) -> Result<Probe, String> {
    if s == "off" {
        return Ok(Probe::Off);
    }
    match s.parse::<u32>() {
        Ok(pixels) if pixels <= MAX_PROBE_PIXELS => Ok(Probe::Pixels(pixels)),
        _ => Err(format!(
            "expected `off` or pixels from 0 to {MAX_PROBE_PIXELS}, got `{s}`"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::parse_size;

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("512MiB"), Ok(512 << 20));
        assert_eq!(parse_size("2GiB"), Ok(2 << 30));
        assert_eq!(parse_size("1G"), Ok(1 << 30));
        assert_eq!(parse_size("1.5g"), Ok(3 << 29));
        assert_eq!(parse_size("4096"), Ok(4096));
        assert!(
            parse_size("12 parsecs")
                .unwrap_err()
                .contains("unknown unit")
        );
        assert!(parse_size("MiB").is_err());
        assert!(parse_size("0").is_err());
        // Past what 64 bits hold: said so, not "at least 1 byte".
        let err = parse_size("99999999999TiB").unwrap_err();
        assert!(err.contains("too large") && err.contains("16 EiB"), "{err}");
        assert!(parse_size("16777216TiB").unwrap_err().contains("too large"));
        assert_eq!(parse_size("16777215TiB"), Ok(16_777_215 << 40));
    }
}

/// `--far-shells`' multiples of the sampling distance (empty for `none`).
#[derive(Clone, Debug, PartialEq)]
pub struct FarShells(pub Vec<f64>);

/// Parses `--far-shells`: `none`, or comma-separated numbers (their range is the library's to
/// check).
fn parse_far_shells(s: &str) -> Result<FarShells, String> {
    if s == "none" {
        return Ok(FarShells(Vec::new()));
    }
    s.split(',')
        .map(|f| {
            f.trim()
                .parse::<f64>()
                .map_err(|_| format!("expected `none` or multiples of the sampling distance such as 2,256; `{f}` is not a number"))
        })
        .collect::<Result<_, _>>()
        .map(FarShells)
}
