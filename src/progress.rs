//! Progress reporting from long-running stages, without tying the library to a terminal.
//!
//! The binary implements [`Progress`] with progress bars; library users and tests pass
//! [`NoProgress`].

/// Receives progress from a stage. Implementations must be cheap: stages call [`Progress::inc`]
/// from worker threads, at most a few thousand times per stage.
pub trait Progress: Sync {
    /// Starts a new step named `what` with `total` units of work.
    fn start(&self, what: &str, total: u64);
    /// Records `n` more units done in the current step.
    fn inc(&self, n: u64);
    /// Ends the current step.
    fn finish(&self);
    /// Reports something the user should know but that does not stop the stage (one line,
    /// e.g. an input read differently from what its header says). Ignored by default; the
    /// binary prints it on stderr, also under `--quiet`.
    fn warn(&self, _message: &str) {}
}

/// A [`Progress`] that ignores everything.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _what: &str, _total: u64) {}
    fn inc(&self, _n: u64) {}
    fn finish(&self) {}
}
