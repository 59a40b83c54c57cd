//! Progress bars on stderr (indicatif), shown only when stderr is a terminal and not `--quiet`.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use patchvis::progress::Progress;
use std::io::IsTerminal;
use std::sync::Mutex;

/// A [`Progress`] drawing one bar per step.
pub struct Bars {
    bar: Mutex<Option<ProgressBar>>,
    visible: bool,
}

impl Bars {
    /// Bars that draw only if `enabled` and stderr is a terminal.
    pub fn new(enabled: bool) -> Bars {
        Bars {
            bar: Mutex::new(None),
            visible: enabled && std::io::stderr().is_terminal(),
        }
    }
}

impl Bars {
    /// Runs `f` under a spinner with elapsed time, for stages that report no progress of their
    /// own (reading, tiling, encoding): on a huge mesh they take long enough to need one.
    pub fn spin<T>(&self, what: &str, f: impl FnOnce() -> T) -> T {
        if !self.visible {
            return f();
        }
        let spinner = ProgressBar::new_spinner();
        let style = ProgressStyle::with_template("{spinner} {msg} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_spinner());
        spinner.set_style(style);
        spinner.set_message(what.to_string());
        spinner.enable_steady_tick(std::time::Duration::from_millis(120));
        let out = f();
        spinner.finish_and_clear();
        out
    }
}

impl Progress for Bars {
    fn start(&self, what: &str, total: u64) {
        if !self.visible {
            return;
        }
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
        let style = ProgressStyle::with_template("{msg:>10} [{bar:40}] {pos}/{len} ({eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> ");
        bar.set_style(style);
        bar.set_message(what.to_string());
        if let Ok(mut slot) = self.bar.lock() {
            *slot = Some(bar);
        }
    }

    fn inc(&self, n: u64) {
        if let Ok(slot) = self.bar.lock()
            && let Some(bar) = slot.as_ref()
        {
            bar.inc(n);
        }
    }

    fn finish(&self) {
        if let Ok(mut slot) = self.bar.lock()
            && let Some(bar) = slot.take()
        {
            bar.finish_and_clear();
        }
    }

    /// One line on stderr, whatever `--quiet` says: a warning is not progress.
    fn warn(&self, message: &str) {
        let line = || eprintln!("warning: {message}");
        match self.bar.lock().ok().as_deref().and_then(Option::as_ref) {
            Some(bar) => bar.suspend(line),
            None => line(),
        }
    }
}
