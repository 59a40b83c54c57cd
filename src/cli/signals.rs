//! Ending a command on a signal without leaving files behind.
//!
//! SIGINT (Ctrl-C), SIGTERM (`kill`) and SIGHUP (a closed terminal) would end the process
//! without running a destructor, leaving the temporary file of an output being written
//! (`.NAME.patchvis-tmp`) and the lock files of its outputs. A thread waits for them instead
//! (signal-hook's safe iterator over a self-pipe; no `unsafe` here), removes every pending
//! file ([`patchvis::output::remove_pending`]) and ends the process with the signal's
//! default action, or else exit code 128 + its number (130 for SIGINT), as a shell reports
//! one killed by it. The sampling checkpoints stay, for `--resume`.

use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
use signal_hook::iterator::Signals;

/// Starts the thread that handles the signals; without it (it could not be set up) they keep
/// their default action.
pub fn install() {
    let Ok(mut signals) = Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    let spawned = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                patchvis::output::remove_pending();
                // The default action now, or the shell's code for it.
                let _ = signal_hook::low_level::emulate_default_handler(signal);
                std::process::exit(128 + signal);
            }
        });
    drop(spawned);
}
