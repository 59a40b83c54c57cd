//! Writing a file so that it either appears complete or not at all.
//!
//! The bytes go to a temporary file beside the destination, which is synced and renamed over
//! the destination (the rename is atomic within one file system). On error the temporary file
//! is removed and the destination is untouched.
//!
//! The temporary file has one fixed name per destination ([`temp_path`]: `.NAME.patchvis-tmp`
//! in the same directory) rather than a random one, so that a run killed mid-write (SIGKILL,
//! power loss) leaves at most that one file, and the next run writing the same output removes
//! it: here, or before any work in [`check_outputs`](super::check_outputs).
//!
//! An output that is a symbolic link is written through: the file it points to (followed to
//! the end of a chain, [`resolve_target`]) is replaced, with its temporary file beside it, and
//! the link stays. A new file gets the permissions a plain `File::create` gives (0o666 less
//! the umask); a file that is replaced keeps its mode. While a temporary file exists it is
//! pending (`pending.rs`): a signal that ends the process removes it. Cost: one `fsync` of
//! the file and one of its directory.

use super::pending::{Listing, PendingFile};
use std::ffi::OsString;
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes `bytes` to `path` atomically: readers see the old file or the new one, never a
/// partial one (see the module documentation for the temporary file and the permissions).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut file = AtomicFile::create(path)?;
    file.file().write_all(bytes)?;
    file.commit()
}

/// The temporary file that [`AtomicFile`] writes `path` through: `.NAME.patchvis-tmp` in the
/// directory of the file written (`path`, or the file a symbolic link `path` points to).
/// Fails (`InvalidInput`) for a path with no file name, such as `..`.
pub fn temp_path(path: &Path) -> std::io::Result<PathBuf> {
    let path = &resolve_target(path)?;
    let name = path.file_name().ok_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "expected a file path, found no file name",
        )
    })?;
    let mut tmp = OsString::from(".");
    tmp.push(name);
    tmp.push(".patchvis-tmp");
    Ok(parent_dir(path).join(tmp))
}

/// Most symbolic links followed in a chain, as Linux's `MAXSYMLINKS`.
const MAX_LINKS: usize = 40;

/// The file an output `path` writes: `path` itself, or, if it is a symbolic link, the path it
/// points to, followed to the end of a chain (the target need not exist yet). Links in the
/// directories above are left as they are: the rename goes through them.
pub fn resolve_target(path: &Path) -> std::io::Result<PathBuf> {
    let mut target = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match std::fs::symlink_metadata(&target) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let link = std::fs::read_link(&target)?;
                target = parent_dir(&target).join(link);
            }
            _ => return Ok(target),
        }
    }
    Err(std::io::Error::other(format!(
        "more than {MAX_LINKS} symbolic links in a chain"
    )))
}

/// The directory `path` is in: its parent, or `.` for a bare file name.
pub fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    }
}

/// Creates `tmp` afresh: a stale one (a killed run's) is removed first, and the new one is
/// created exclusively with the default mode 0o666, which the umask narrows as it does for a
/// plain create.
pub(super) fn create_fresh(tmp: &Path) -> std::io::Result<File> {
    match std::fs::remove_file(tmp) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e),
        _ => {}
    }
    File::options().write(true).create_new(true).open(tmp)
}

/// A file being written at a destination, through its [`temp_path`]: [`AtomicFile::commit`]
/// renames it into place; dropping it uncommitted removes it.
#[derive(Debug)]
pub struct AtomicFile {
    file: File,
    /// The temporary file.
    tmp: PendingFile,
    /// The file written: the destination, symbolic links followed.
    dest: PathBuf,
}

impl AtomicFile {
    /// Starts writing `dest` (through a symbolic link to the file it points to): creates its
    /// temporary file (removing a stale one), with the mode of `dest` if that is an existing
    /// regular file. The caller holds the output's lock
    /// ([`check_outputs`](super::check_outputs)), so no other command writes through it.
    pub fn create(dest: &Path) -> std::io::Result<AtomicFile> {
        let dest = resolve_target(dest)?;
        let tmp = temp_path(&dest)?;
        let mut listing = Listing::hold();
        let file = create_fresh(&tmp)?;
        let tmp = listing.list(tmp);
        drop(listing);
        let file = AtomicFile { file, tmp, dest };
        // A replaced file keeps its mode, as it would if written in place.
        #[cfg(unix)]
        if let Ok(meta) = std::fs::metadata(&file.dest)
            && meta.is_file()
        {
            file.file.set_permissions(meta.permissions())?;
        }
        Ok(file)
    }

    /// The temporary file, to write to.
    pub fn file(&mut self) -> &mut File {
        &mut self.file
    }

    /// Syncs the temporary file and renames it over the destination, durably.
    pub fn commit(mut self) -> std::io::Result<()> {
        self.sync()?;
        self.rename()?;
        // Make the rename itself durable. Directories cannot be opened for this on Windows.
        #[cfg(unix)]
        File::open(parent_dir(&self.dest))?.sync_all()?;
        Ok(())
    }

    /// Syncs the temporary file: what [`AtomicFile::commit`] does before its rename, for
    /// callers that commit several files as a set and want every one synced first.
    pub fn sync(&mut self) -> std::io::Result<()> {
        self.file.sync_all()
    }

    /// Renames the temporary file over the destination, with no signal clean-up in between.
    fn rename(&mut self) -> std::io::Result<()> {
        let dest = &self.dest;
        self.tmp.settle(|tmp| {
            let renamed = std::fs::rename(tmp, dest);
            if renamed.is_err() {
                let _ = std::fs::remove_file(tmp);
            }
            renamed
        })
    }
}

impl Drop for AtomicFile {
    /// Removes the temporary file of an uncommitted write (a committed one is gone).
    fn drop(&mut self) {
        self.tmp.remove();
    }
}
