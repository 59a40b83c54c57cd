//! Advisory locks on outputs, so that two commands never write one file at once.
//!
//! Each output is locked through a lock file beside the file it names, `.NAME.patchvis-lock`
//! ([`lock_path`]), which holds the pid of the command writing it. The lock is std's
//! `File::try_lock` (an `flock` on Unix), held from the check of the outputs
//! ([`check_outputs`](super::check_outputs)) until the command ends; the kernel drops it with
//! the process, so a killed command never blocks the next. A second command that names any
//! output of a running one is refused at once, with the holder's pid, before it touches
//! anything: it removes no temporary file and writes no byte. Stale temporary files are
//! removed only by the lock's holder, so only when no live command writes them.
//!
//! The lock file is removed when the lock is let go. A command that opened it just before
//! could then lock a file no longer in the directory, so a lock counts only if the file
//! locked is still the one at the path (same device and inode); otherwise it is taken again.
//! On a file system that has no locks the command goes on unlocked, as before locks existed,
//! rather than refuse every output there. Cost: one small file per output, created and
//! removed once per command.

use super::atomic::{parent_dir, resolve_target};
use super::pending::{Listing, PendingFile};
use std::ffi::OsString;
use std::fs::File;
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The lock file of the output `path` (symbolic links followed, as the write follows them):
/// `.NAME.patchvis-lock` beside the file written. Fails (`InvalidInput`) for a path with no
/// file name.
pub fn lock_path(path: &Path) -> std::io::Result<PathBuf> {
    let target = resolve_target(path)?;
    let name = target.file_name().ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "expected a file path, found no file name",
        )
    })?;
    let mut lock = OsString::from(".");
    lock.push(name);
    lock.push(".patchvis-lock");
    Ok(parent_dir(&target).join(lock))
}

/// Why an output's lock could not be taken.
#[derive(Debug)]
pub(super) enum LockFailure {
    /// Another process holds it; its pid, if it had written it.
    Held(Option<u32>),
    /// The lock file could not be created or written.
    Io(std::io::Error),
}

/// The locks on a command's outputs: held until dropped (at the end of the command), when
/// each lock file is removed and its lock let go.
#[derive(Debug, Default)]
#[must_use = "the outputs are locked only while this is held"]
pub struct OutputLock {
    held: Vec<Held>,
}

impl OutputLock {
    /// The lock files held, in the order taken.
    pub fn paths(&self) -> Vec<&Path> {
        self.held.iter().map(|h| h.pending.path()).collect()
    }

    /// Takes the lock of `lock` (a [`lock_path`]) and adds it to these.
    pub(super) fn take(&mut self, lock: &Path) -> Result<(), LockFailure> {
        self.held.push(Held::take(lock)?);
        Ok(())
    }
}

/// One lock file, locked; removed (then unlocked) on drop.
#[derive(Debug)]
struct Held {
    file: File,
    /// Removed on drop, or by [`remove_pending`](super::remove_pending) on a signal.
    pending: PendingFile,
}

/// How long a refused command waits for the holder to write its pid: the holder writes it
/// right after locking, so this is only ever reached if the holder is stopped there.
const PID_WAIT: Duration = Duration::from_millis(200);

impl Held {
    fn take(path: &Path) -> Result<Held, LockFailure> {
        // Each retry follows a holder that removed the file between our open and our lock;
        // a few are plenty, as each needs a whole command to start and end in between.
        for _ in 0..64 {
            // Held from before the file is made until it is listed (or found not ours).
            let mut listing = Listing::hold();
            let mut file = File::options()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(path)
                .map_err(LockFailure::Io)?;
            match file.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    return Err(LockFailure::Held(holder_pid(&mut file)));
                }
                // A file system without locks (some network ones) still takes the output:
                // the command goes on unlocked rather than refuse every output there.
                Err(std::fs::TryLockError::Error(_)) => {}
            }
            if !same_file(&file, path) {
                continue;
            }
            let pending = listing.list(path.to_path_buf());
            drop(listing);
            file.set_len(0)
                .and_then(|()| writeln!(file, "{}", std::process::id()))
                .map_err(LockFailure::Io)?;
            return Ok(Held { file, pending });
        }
        Err(LockFailure::Io(std::io::Error::other(
            "its lock file kept being replaced",
        )))
    }
}

impl Drop for Held {
    fn drop(&mut self) {
        // Removed while still locked, so that no one locks a file about to vanish unknowingly
        // (see the module documentation); the lock goes with the file handle.
        if same_file(&self.file, self.pending.path()) {
            self.pending.remove();
        } else {
            self.pending.forget();
        }
    }
}

/// Whether `file` is the file at `path` now.
fn same_file(file: &File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (file.metadata(), std::fs::metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        // Elsewhere an open file cannot be removed, so the path still names it.
        let _ = file;
        path.exists()
    }
}

/// The pid a locked lock file holds, waiting briefly for a holder that has just locked it.
fn holder_pid(file: &mut File) -> Option<u32> {
    let deadline = Instant::now() + PID_WAIT;
    loop {
        let mut text = String::new();
        let read = file.rewind().and_then(|()| file.read_to_string(&mut text));
        if read.is_ok()
            && let Ok(pid) = text.trim().parse::<u32>()
        {
            return Some(pid);
        }
        if Instant::now() > deadline {
            return None;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_is_refused_with_the_pid_and_the_file_goes_with_the_first() {
        let dir = tempfile::tempdir().unwrap();
        let lock = lock_path(&dir.path().join("out.pvis")).unwrap();
        assert_eq!(lock, dir.path().join(".out.pvis.patchvis-lock"));
        let mut first = OutputLock::default();
        first.take(&lock).unwrap();
        let mut second = OutputLock::default();
        match second.take(&lock) {
            Err(LockFailure::Held(pid)) => assert_eq!(pid, Some(std::process::id())),
            other => panic!("expected the lock held, got {other:?}"),
        }
        drop(first);
        assert!(!lock.exists(), "the lock file stayed");
        second.take(&lock).unwrap();
        assert!(lock.exists());
        drop(second);
        assert!(!lock.exists());
    }
}
