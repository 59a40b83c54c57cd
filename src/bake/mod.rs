//! The bake as one library call: settings in, a `.pvis` out.
//!
//! [`BakeSettings`] holds every option `patchvis bake` has, with [`RowSettings`] for those
//! that decide the rows; [`BakeSettings::check`] validates them and resolves the defaults that
//! depend on each other (and on the [`Preset`]) into a [`Plan`], in a [`Recipe`]; [`Backend`]
//! is where the ID buffers are rendered; [`Recipe::run`] tiles, samples each sphere of the
//! plan (supersampling and folding), numbers the patches by co-visibility and encodes,
//! recording each stage's time and peak heap in [`Stages`]; [`Recipe::write`] writes the
//! outputs so that they appear whole or not at all. The heap budget and its split between the
//! stages is [`MemoryBudget`].
//!
//! ```
//! use patchvis::bake::{Backend, BakeSettings, Outputs, Stages};
//! use patchvis::progress::NoProgress;
//! use patchvis::runtime::Pvis;
//!
//! # let dir = tempfile::tempdir()?;
//! # let mesh_path = dir.path().join("octahedron.obj");
//! # std::fs::write(&mesh_path, "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n\
//! #     f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n")?;
//! # let out = dir.path().join("octahedron.pvis");
//! let mut settings = BakeSettings { patches: 4, ..BakeSettings::default() };
//! settings.rows.resolution = 64; // a small ID buffer for a small model
//! let recipe = settings.check()?;
//! let mesh = recipe.open(&mesh_path)?; // PLY, OBJ, STL or glTF, memory-mapped
//! let mut stages = Stages::new();
//! let baked = recipe.run(&mesh, &Backend::Cpu, &NoProgress, &mut stages)?;
//! let outputs = Outputs { pvis: out.clone(), mesh: None };
//! recipe.write(&baked, &mesh, &outputs, &mut stages)?; // a temporary file, then renamed
//!
//! let bytes = std::fs::read(&out)?;
//! let pvis = Pvis::parse(&bytes)?;
//! assert_eq!(pvis.patch_count(), 4);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! A bake can also be split by view over machines: [`Recipe::tile_framed`] once into a tiling
//! file ([`write_tiling_file`]), [`Recipe::run_shard`] per [`Shard`] into a [`Part`], then
//! [`merge`] writes the single bake's bytes.
//!
//! Files: `settings.rs` (options, defaults, their codec), `plan.rs` (what they resolve to,
//! the spheres of views), `recipe.rs` (the stages), `sample.rs` (each sphere's passes),
//! `rows.rs` (sampled rows and the fold), `encode.rs` (numbering and encoding),
//! `outputs.rs` (writing them), `checks.rs` (what is refused before any work), `shells.rs` (the sampling shells' radii and bands),
//! `backend.rs` (CPU or GPU), `stages.rs` (time and heap),
//! `frame.rs` (the working frame of coordinates `f32` cameras cannot handle). Sharded bakes:
//! `shard.rs` (which views a shard owns, `--shard auto`), `shard_run.rs` (a shard's bake and
//! the shared tiling step), `tiling_file.rs` and `part.rs` (their files), `merge.rs`,
//! `fingerprint.rs` (mesh and tiling hashes), `wire.rs` (the files' fields).

mod backend;
mod checks;
mod encode;
mod fingerprint;
mod frame;
mod merge;
mod outputs;
mod part;
mod plan;
mod recipe;
mod rows;
mod sample;
mod settings;
mod shard;
mod shard_run;
mod shells;
mod stages;
mod tiling_file;
mod wire;

pub use crate::memory::{FixedNeeds, MemoryBudget, SamplingShare, StageBudgets};
pub use backend::{Backend, BackendChoice};
pub use fingerprint::{mesh_hash, tiling_hash};
pub use merge::{LoadedPart, MergeError, Merged, merge, read_part};
pub use outputs::Outputs;
pub use part::{Part, PassRows};
pub use plan::{PassCheckpoints, Plan, Sphere, SphereKind, SphereSampling, Supersample};
pub use recipe::{Baked, BakedShell, Recipe};
pub use rows::{SampledRows, SampledSphere};
pub use settings::{
    BakeSettings, CONSERVATIVE_FOLD_CORNERS, CONSERVATIVE_LEVEL, CONSERVATIVE_PROBE_PIXELS,
    DEFAULT_FOLD_MIN_PIXELS, DEFAULT_LEVEL, DEFAULT_PROBE_PIXELS, DEFAULT_VIEW_SUPERSAMPLE,
    MAX_APERTURE_PIXELS, MAX_PROBE_PIXELS, MIN_RESOLUTION, PROBE_FOLD_CORNERS, PatchOrder, Preset,
    Probe, Research, RowSettings, SettingsError, UNPROBED_FOLD_CORNERS, WARN_RESOLUTION,
};
pub use shard::{SHARD_COUNT_ENV, Shard, ShardError};
pub use shard_run::ShardBaked;
pub use shells::{
    DEFAULT_FAR_SHELLS, DEFAULT_SHELL_MIN, DEFAULT_SHELLS, MAX_FAR_SHELL, MAX_SHELLS, bands,
    far_bands, far_distances, shell_distances,
};
pub use stages::{StageRecord, Stages};
pub use tiling_file::{TilingFile, read_tiling_file, write_tiling_file};

use std::path::PathBuf;

/// Why a bake failed.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// A setting is out of range or does not fit the mesh (a usage error).
    #[error("{0}")]
    Settings(String),
    /// The mesh cannot be read.
    #[error(transparent)]
    Mesh(#[from] crate::ooc::MeshError),
    /// Tiling failed.
    #[error("tiling failed: {0}")]
    Tiling(#[from] crate::tiling::TilingError),
    /// Sampling failed (its checkpoint or temporary mesh file).
    #[error(transparent)]
    Sampling(#[from] crate::sampler::SamplingError),
    /// The sampling backend could not be opened or failed.
    #[error("{0}")]
    Backend(String),
    /// A stage does not fit the memory budget.
    #[error("{0}")]
    Budget(String),
    /// A temporary file (the renumbered tiling) could not be written.
    #[error("cannot write a temporary file for the renumbered tiling: {0}")]
    TempFile(#[source] std::io::Error),
    /// An output could not be written.
    #[error("{}: cannot write: {source}", path.display())]
    Write {
        /// The output.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A finished bake's checkpoint could not be removed.
    #[error("{}: cannot remove: {source}", path.display())]
    Remove {
        /// The checkpoint.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A sharded bake's tiling file or part is of another bake, damaged, or missing (the
    /// message names the file).
    #[error("{0}")]
    Sharded(String),
    /// A bug: the pipeline produced something it should not have.
    #[error("internal error: {0}")]
    Internal(String),
}

impl From<SettingsError> for BakeError {
    fn from(e: SettingsError) -> BakeError {
        BakeError::Settings(e.0)
    }
}
