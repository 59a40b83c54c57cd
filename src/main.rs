//! The `patchvis` command-line tool: thin glue over the library.
//!
//! Exit codes: 0 success, 1 bad input or failed check, 2 usage error. Every error is one
//! line on stderr naming the file, the position and what was expected.

mod cli;

use clap::Parser;
use cli::args::{Cli, Command};
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
        Command::Bake(args) => cli::bake::run(args),
        Command::Info(args) => cli::inspect::info(&args),
        Command::Query(args) => cli::inspect::query(&args),
        Command::Eval(args) => cli::eval::run(args),
        Command::Gen(args) => cli::generate::run(&args),
        Command::Verify(args) => return cli::verify::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            let code = if err.downcast_ref::<cli::UsageError>().is_some() {
                2
            } else {
                1
            };
            // `{:#}` joins the context chain on one line: "FILE: what went wrong".
            eprintln!("error: {err:#}");
            ExitCode::from(code)
        }
    }
}
