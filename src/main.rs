//! The `patchvis` command-line tool: thin glue over the library.
//!
//! Exit codes: 0 success, 1 bad input or failed check, 2 usage error. Every error is one
//! line on stderr naming the file, the position and what was expected. A closed stdout pipe
//! ends a command quietly with the code it had reached (`cli::out`).

#![deny(clippy::print_stdout)]

mod cli;

use clap::Parser;
use cli::args::{Cli, Command};
use std::io::Write;
use std::process::ExitCode;

#[global_allocator]
static ALLOC: patchvis::heap::CountingAlloc = patchvis::heap::CountingAlloc;

fn main() -> ExitCode {
    let parsed = match Cli::try_parse() {
        Ok(parsed) => parsed,
        Err(err) => {
            use clap::error::ErrorKind;
            if matches!(
                err.kind(),
                ErrorKind::DisplayHelp | ErrorKind::DisplayVersion
            ) {
                let _ = err.print();
                return ExitCode::SUCCESS;
            }
            // clap's first line names the problem; the rest is a hint to try --help.
            let text = err.to_string();
            eprintln!("{}", text.lines().next().unwrap_or("error: bad arguments"));
            return ExitCode::from(2);
        }
    };
    let result = match parsed.command {
        Command::Bake(args) => cli::bake::run(args).map(|()| ExitCode::SUCCESS),
        Command::Info(args) => cli::inspect::info(&args).map(|()| ExitCode::SUCCESS),
        Command::Query(args) => cli::inspect::query(&args).map(|()| ExitCode::SUCCESS),
        Command::Eval(args) => cli::eval::run(args).map(|()| ExitCode::SUCCESS),
        Command::Gen(args) => cli::generate::run(&args).map(|()| ExitCode::SUCCESS),
        Command::Verify(args) => cli::verify::run(&args),
        Command::Tile(args) => cli::shard::tile(&args).map(|()| ExitCode::SUCCESS),
        Command::Merge(args) => cli::shard::merge(&args).map(|()| ExitCode::SUCCESS),
        Command::Conformance(args) => cli::conformance::run(&args),
    };
    match result {
        Ok(code) => code,
        Err(err) => {
            let stdout = err
                .chain()
                .find_map(|e| e.downcast_ref::<cli::out::StdoutError>());
            if stdout.is_some_and(|e| e.is_closed_pipe()) {
                // The reader has what it wanted; nothing to report. `verify` returns its
                // verdict before this can happen (see `cli::verify::run`).
                return ExitCode::SUCCESS;
            }
            let code = if err.downcast_ref::<cli::UsageError>().is_some() {
                2
            } else {
                1
            };
            // `{:#}` joins the context chain on one line: "FILE: what went wrong". A stderr
            // that cannot be written either leaves nothing to tell.
            let _ = writeln!(std::io::stderr(), "error: {err:#}");
            ExitCode::from(code)
        }
    }
}
