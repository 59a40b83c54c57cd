//! What `patchvis bake` (`bake.rs`) and its sharded form (`bake --shard`, `shard.rs`) share:
//! the check of every file a bake writes, made before any work, and how a bake error is
//! reported.

use super::UsageError;
use super::args::BakeArgs;
use anyhow::anyhow;
use patchvis::bake::{BakeError, Outputs, Recipe};
use patchvis::output::{NamedPath, check_outputs};
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

/// Every file the bake writes, checked against its inputs, each other and the file system
/// before any work: a clash, a device node or an unwritable directory is a usage error.
pub(super) fn check_paths(
    args: &BakeArgs,
    recipe: &Recipe,
    outputs: &Outputs,
) -> Result<(), UsageError> {
    let mut inputs = vec![NamedPath::new("the input mesh", "INPUT", &args.input)];
    if let Some(spec) = &args.always_visible {
        inputs.push(NamedPath::new(
            "the --always-visible file",
            "--always-visible",
            spec,
        ));
    }
    let mut written = outputs.paths(recipe);
    if let Some(stats) = &args.stats {
        written.push(NamedPath::flag("--stats", stats));
    }
    check_outputs(&inputs, &written).map_err(|e| UsageError(e.to_string()))
}
