//! The `patchvis` command-line tool: thin glue over the library.
//!
//! Exit codes: 0 success, 1 bad input or failed check, 2 usage error. Every error is one
//! line on stderr naming the file, the position and what was expected, each cause said once.
//! A closed stdout pipe ends a command quietly with the code it had reached (`cli::out`); a
//! help text that cannot be written is an error like any report. SIGINT, SIGTERM and SIGHUP
//! end a command after removing its temporary and lock files (`cli::signals`).

#![deny(clippy::print_stdout)]

mod cli;

use clap::Parser;
use cli::args::{Cli, Command};
use std::io::Write;
use std::process::ExitCode;

#[global_allocator]
static ALLOC: patchvis::heap::CountingAlloc = patchvis::heap::CountingAlloc;

fn main() -> ExitCode {
    cli::signals::install();
    let parsed = match Cli::try_parse() {
        Ok(parsed) => parsed,
        Err(err) => {
            use clap::error::ErrorKind;
            if matches!(
                err.kind(),
                ErrorKind::DisplayHelp | ErrorKind::DisplayVersion
            ) {
                // Help goes to stdout: a failed write there is a failure, a closed pipe not.
                let printed = err.print().and_then(|()| std::io::stdout().flush());
                return match printed {
                    Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
                        let _ = writeln!(std::io::stderr(), "error: {}", cli::out::StdoutError(e));
                        ExitCode::from(1)
                    }
                    _ => ExitCode::SUCCESS,
                };
            }
            // clap's first paragraph names the problem (with what it lists, such as the
            // missing arguments, on the lines below it); the rest is usage and a hint.
            let text = err.to_string();
            let problem: Vec<&str> = text
                .lines()
                .map(str::trim)
                .take_while(|line| !line.is_empty())
                .collect();
            match problem.is_empty() {
                true => eprintln!("error: bad arguments"),
                false => eprintln!("{}", problem.join(" ")),
            }
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
            // A stderr that cannot be written either leaves nothing to tell.
            let _ = writeln!(std::io::stderr(), "error: {}", one_line(&err));
            ExitCode::from(code)
        }
    }
}

/// The error's chain of causes on one line, "FILE: what went wrong: why", each cause once: a
/// message that already ends with its cause's text (`thiserror`'s `{source}`) is not followed
/// by it again.
fn one_line(err: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if line.ends_with(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}
