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

/// A usage error with `message` when `condition` holds.
fn usage(condition: bool, message: impl FnOnce() -> String) -> Result<(), UsageError> {
    if condition {
        Err(UsageError(message()))
    } else {
        Ok(())
    }
}
