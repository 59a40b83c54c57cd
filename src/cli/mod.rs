//! The binary's modules: flags, the commands, and the process-wide helpers they need.

pub mod args;
pub mod bake;
mod bake_common;
pub mod conformance;
pub mod eval;
pub mod eval_bands;
pub mod eval_frame;
mod eval_json;
mod eval_sweep;
pub mod generate;
pub mod inspect;
pub mod out;
pub mod progress;
mod query_bench;
pub mod shard;
pub mod signals;
pub mod verify;
pub mod view;

/// An invocation that cannot run as given (exit code 2), e.g. `--patches 0`.
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// Checks a command's `outputs` against its `inputs` and the file system, and locks them
/// ([`check_outputs`](patchvis::output::check_outputs)), before any work: hold the lock until
/// they are written. A clash, a device node or an unwritable directory is a usage error
/// (exit 2); an output that another command is writing is a plain failure (exit 1), naming
/// that command's pid.
fn claim_outputs(
    inputs: &[patchvis::output::NamedPath],
    outputs: &[patchvis::output::NamedPath],
) -> anyhow::Result<patchvis::output::OutputLock> {
    use patchvis::output::OutputError;
    patchvis::output::check_outputs(inputs, outputs).map_err(|e| match e {
        OutputError::Busy { .. } => anyhow::Error::msg(e.to_string()),
        e => UsageError(e.to_string()).into(),
    })
}

/// A usage error with `message` when `condition` holds.
fn usage(condition: bool, message: impl FnOnce() -> String) -> Result<(), UsageError> {
    if condition {
        Err(UsageError(message()))
    } else {
        Ok(())
    }
}
