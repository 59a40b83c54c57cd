//! What `patchvis bake` (`bake.rs`) and its sharded form (`bake --shard`, `shard.rs`) share:
//! the check of every file a bake reads and writes, made before any work, and how a bake
//! error is reported.

use super::UsageError;
use super::args::BakeArgs;
use anyhow::anyhow;
use patchvis::bake::{BakeError, Outputs, Recipe};
use patchvis::meshout::MeshFormat;
use patchvis::ooc::attributes::{SideFile, side_files};
use patchvis::output::{NamedPath, OutputLock};
use std::path::Path;

/// A bake error as the command reports it: settings are usage errors (exit 2), the rest
/// name the input where the library's message does not.
pub(super) fn report(input: &Path, e: BakeError) -> anyhow::Error {
    match e {
        BakeError::Settings(message) => UsageError(message).into(),
        BakeError::Tiling(_) => anyhow!("{}: {e}", input.display()),
        other => other.into(),
    }
}

/// Every file the bake writes, checked against every file it reads (the mesh and the files
/// it names beside itself, the `--always-visible` file, the tiling file), each other and the
/// file system, and locked, before any work: a clash, a device node or an unwritable
/// directory is a usage error, an output another command is writing a failure. Then what
/// `--mesh-out` will read is checked to be there. Hold the lock until the outputs are written.
pub(super) fn check_paths(
    args: &BakeArgs,
    recipe: &Recipe,
    outputs: &Outputs,
) -> anyhow::Result<OutputLock> {
    let mut inputs = vec![NamedPath::new("the input mesh", "INPUT", &args.input)];
    // A mesh that cannot be read names nothing here; the bake reports it.
    let beside = side_files(&args.input).unwrap_or_default();
    for file in &beside {
        inputs.push(NamedPath::new(
            format!("the input mesh's {}", file.what),
            "INPUT",
            &file.path,
        ));
    }
    if let Some(spec) = &args.always_visible {
        inputs.push(NamedPath::new(
            "the --always-visible file",
            "--always-visible",
            spec,
        ));
    }
    if let Some(tiling) = &args.tiling_file {
        inputs.push(NamedPath::new(
            "the tiling file of --tiling-file",
            "--tiling-file",
            tiling,
        ));
    }
    let mut written = outputs.paths(recipe);
    if let Some(stats) = &args.stats {
        written.push(NamedPath::flag("--stats", stats));
    }
    let lock = super::claim_outputs(&inputs, &written)?;
    if let Some(mesh_out) = &outputs.mesh {
        check_mesh_out_inputs(&args.input, mesh_out, &beside)?;
    }
    Ok(lock)
}

/// A glTF `--mesh-out` reads the input's material libraries and textures: each must be there
/// before the bake, not found missing after it. A PLY reads neither.
fn check_mesh_out_inputs(input: &Path, mesh_out: &Path, beside: &[SideFile]) -> anyhow::Result<()> {
    if MeshFormat::of(mesh_out) == MeshFormat::Ply {
        return Ok(());
    }
    match beside.iter().find(|f| f.materials_only && !f.exists()) {
        Some(missing) => Err(anyhow!(
            "{}: {} '{}' is not there (or not a file): --mesh-out {} (glTF) reads the mesh's \
             materials and textures; put it there, or give --mesh-out a .ply name (no materials)",
            input.display(),
            missing.what,
            missing.path.display(),
            mesh_out.display()
        )),
        None => Ok(()),
    }
}
