//! The files a command has in flight and must not leave behind: the temporary files of
//! outputs being written and the lock files of outputs being locked.
//!
//! Each is a [`PendingFile`] for as long as it exists, and so listed in one process-wide
//! table. Normally its owner removes it (or renames it into place) and it leaves the table.
//! A signal that ends the process (Ctrl-C, `kill`) skips every destructor, so the binary's
//! signal handler calls [`remove_pending`] before it exits: nothing of the command is left
//! in the output directories but the sampling checkpoints, which are kept on purpose for
//! `--resume`.
//!
//! A fault in a mapped file (`SIGBUS`: an input truncated by another program, a full disk)
//! ends the process from a signal handler that may not lock this table or allocate, so each
//! pending file is also listed there as a C string ([`RemovedOnFault`]), and that handler
//! unlinks those.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::mapped::RemovedOnFault;

/// Every pending file of the process, by path.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The table, even if a thread panicked while holding it (its list is still right).
fn table() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

/// A file to be removed should the process be ended by a signal: listed while this lives.
#[derive(Debug)]
pub(super) struct PendingFile {
    path: PathBuf,
    /// Whether it is still in the table.
    listed: bool,
    /// Its listing for the fault handler, while it is in the table.
    on_fault: Option<RemovedOnFault>,
}

/// The table held, to make a file and list it in one step: a signal's clean-up
/// ([`remove_pending`], which then holds the table until the process ends) runs wholly before,
/// and no file is made, or wholly after, and it removes the file. Making the file first and
/// listing it after would leave one made in between.
pub(super) struct Listing(std::sync::MutexGuard<'static, Vec<PathBuf>>);

impl Listing {
    /// Holds the table (waits for it: forever once a signal's clean-up has run).
    pub(super) fn hold() -> Listing {
        Listing(table())
    }

    /// Lists `path`, a file made while this was held, as pending.
    pub(super) fn list(&mut self, path: PathBuf) -> PendingFile {
        self.0.push(path.clone());
        let on_fault = Some(RemovedOnFault::new(&path));
        PendingFile {
            path,
            listed: true,
            on_fault,
        }
    }
}

impl PendingFile {
    /// The file.
    pub(super) fn path(&self) -> &Path {
        &self.path
    }

    /// Runs `f` (which removes or renames the file) with the table held, so that a signal
    /// handler never removes the file halfway through, then unlists it.
    /// Unlisted once this returns, whatever `f` gives.
    pub(super) fn settle<T>(&mut self, f: impl FnOnce(&Path) -> T) -> T {
        let mut table = table();
        let result = f(&self.path);
        if self.listed
            && let Some(at) = table.iter().position(|p| *p == self.path)
        {
            table.swap_remove(at);
        }
        self.listed = false;
        self.on_fault = None;
        result
    }

    /// Removes the file (a missing one is fine) and unlists it; nothing once settled.
    pub(super) fn remove(&mut self) {
        if !self.listed {
            return;
        }
        self.settle(|path| {
            let _ = std::fs::remove_file(path);
        });
    }

    /// Unlists the file without touching it (it is no longer ours).
    pub(super) fn forget(&mut self) {
        self.settle(|_| ());
    }
}

impl Drop for PendingFile {
    /// Unlists the file if its owner did not settle it.
    fn drop(&mut self) {
        if self.listed {
            self.forget();
        }
    }
}

/// Removes every pending file of the process: what a signal handler calls before the process
/// exits. Later calls find nothing to remove; the table stays held, so that no other thread
/// creates or renames a pending file after it (the process is about to end).
pub fn remove_pending() {
    let mut table = table();
    for path in table.drain(..) {
        let _ = std::fs::remove_file(path);
    }
    // Held until the process exits: no rename into place after the clean-up.
    std::mem::forget(table);
}
