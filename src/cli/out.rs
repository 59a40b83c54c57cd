//! Standard output for the commands: every report line goes through [`outln!`], so that a
//! failed write is an error the command returns instead of the panic of `println!`.
//!
//! Two failures matter. A full or broken target (`> /dev/full`) gives one line on stderr,
//! `error: cannot write to stdout: <why>`, and exit code 1. A closed pipe (`| head -c 5`) ends
//! the command quietly: Rust ignores `SIGPIPE`, so the write returns `EPIPE`, which `main`
//! turns into the exit code the command had reached (0, or 1 for a failed `verify`), as
//! ripgrep and the coreutils do. No command uses `println!`.

use std::fmt;
use std::io::{self, Write};

/// Standard output could not be written.
#[derive(Debug)]
pub struct StdoutError(pub io::Error);

impl StdoutError {
    /// True when the reader went away (a closed pipe): not worth a message.
    pub fn is_closed_pipe(&self) -> bool {
        self.0.kind() == io::ErrorKind::BrokenPipe
    }
}

impl fmt::Display for StdoutError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot write to stdout: {}", self.0)
    }
}

impl std::error::Error for StdoutError {}

/// Writes `args` and a newline to stdout, flushed (stdout is line-buffered), so that a
/// failure shows at this line.
pub fn line(args: fmt::Arguments<'_>) -> Result<(), StdoutError> {
    let mut out = io::stdout().lock();
    out.write_fmt(args)
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush())
        .map_err(StdoutError)
}

/// `println!` that returns `Result<(), StdoutError>` instead of panicking.
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::cli::out::line(format_args!($($arg)*))
    };
}
pub(crate) use outln;
