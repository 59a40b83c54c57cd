//! What the hostile-input modules share: the quick bake flags, running `patchvis` under a
//! deadline (a hang fails its test instead of stalling the suite), and the shape of a clean
//! refusal.

use crate::common::stderr;
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::time::{Duration, Instant};
use tempfile::TempDir;

/// The small, fast bake settings of the suite.
pub const SMALL: [&str; 7] = [
    "--level",
    "2",
    "--resolution",
    "128",
    "--view-supersample",
    "0",
    "-q",
];

/// Longest any run here may take (a debug build on a loaded 2-core machine): refusals end in
/// well under a second, the bakes in seconds; a hang ends here and fails the test.
pub const DEADLINE: Duration = Duration::from_secs(300);

/// `patchvis` with `args` and the environment variables `env`, stdin empty, no backtraces;
/// the caller chooses where stdout and stderr go.
pub fn command(args: &[&str], env: &[(&str, &str)]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_patchvis"));
    c.args(args)
        .envs(env.iter().copied())
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null());
    c
}

/// Waits for `child` up to `limit`; past it kills the child and fails the test, naming `what`.
pub fn wait(child: &mut Child, limit: Duration, what: &str) -> ExitStatus {
    let deadline = Instant::now() + limit;
    loop {
        if let Some(status) = child.try_wait().expect("poll patchvis") {
            return status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after {limit:?} (a hang): killed");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Runs `command` under [`DEADLINE`] with stdout and stderr going through files, so that a
/// chatty child cannot block on a full pipe while it is polled.
pub fn run_command(mut command: Command, what: &str) -> Output {
    let logs = TempDir::new().unwrap();
    let (out_path, err_path) = (logs.path().join("stdout"), logs.path().join("stderr"));
    command
        .stdout(std::fs::File::create(&out_path).unwrap())
        .stderr(std::fs::File::create(&err_path).unwrap());
    let mut child = command.spawn().expect("run patchvis");
    let status = wait(&mut child, DEADLINE, what);
    Output {
        status,
        stdout: std::fs::read(out_path).unwrap(),
        stderr: std::fs::read(err_path).unwrap(),
    }
}

/// `patchvis args` under [`DEADLINE`].
pub fn run(args: &[&str]) -> Output {
    run_command(command(args, &[]), &format!("patchvis {args:?}"))
}

/// [`run`] with environment variables.
pub fn run_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    run_command(command(args, env), &format!("patchvis {args:?}"))
}

/// [`run`] in the directory `cwd`.
pub fn run_in(args: &[&str], cwd: &Path) -> Output {
    let mut c = command(args, &[]);
    c.current_dir(cwd);
    run_command(c, &format!("patchvis {args:?} in {}", cwd.display()))
}

/// Asserts a clean refusal: exit `code` (never a panic), one line on stderr starting
/// `error: ` and holding each of `words`.
pub fn assert_refused(out: &Output, code: i32, words: &[&str]) {
    let err = stderr(out);
    assert_ne!(out.status.code(), Some(101), "panicked: {err}");
    assert!(!err.contains("panicked"), "panicked: {err}");
    assert_eq!(out.status.code(), Some(code), "exit status; stderr: {err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "one line expected: {err}"
    );
    assert!(err.starts_with("error: "), "{err}");
    for word in words {
        assert!(err.contains(word), "expected '{word}' in: {err}");
    }
}
