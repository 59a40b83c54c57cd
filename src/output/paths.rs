//! A command's output paths, checked before any work, so that no output destroys an input,
//! another output, or a device node, an unwritable directory is found in a second rather
//! than after hours of baking, and no other command writes them meanwhile.
//!
//! Paths are compared by file identity, not by spelling: an existing file by device and inode
//! on Unix (so `./b.ply`, a symlink to it and a hard link of it are all `b.ply`), a file that
//! does not exist yet by its canonical directory and name. An output that is a symbolic link
//! is the file it points to (it is written through, `atomic.rs`). Every output is written
//! through a temporary file ([`temp_path`]) that is renamed over it and locked through a lock
//! file ([`lock_path`]), so those paths count as written too, and an existing output must be a
//! regular file: the rename would replace a device node, a FIFO or a directory. Then every
//! output is locked (`lock.rs`): one that another command is writing is refused, naming its
//! pid. Writability is probed last, by creating and removing the output's temporary file,
//! which also clears one that a killed run left behind (never a live one: its writer would
//! hold the lock).

use super::atomic::{create_fresh, parent_dir, resolve_target, temp_path};
use super::lock::{LockFailure, OutputLock, lock_path};
use super::pending::Listing;
use std::path::{Path, PathBuf};

/// A file a command reads or writes, and what the user calls it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NamedPath {
    /// What the file is, in the user's words: `-o`, `the input mesh`, `the checkpoint of -o`.
    pub what: String,
    /// The flag (or argument) that sets the path: what the user changes to resolve a clash.
    pub flag: String,
    /// The path as given.
    pub path: PathBuf,
}

impl NamedPath {
    /// The file `path`, called `what`, set by `flag`.
    pub fn new(what: impl Into<String>, flag: impl Into<String>, path: impl Into<PathBuf>) -> Self {
        NamedPath {
            what: what.into(),
            flag: flag.into(),
            path: path.into(),
        }
    }

    /// A file named by its flag alone (`-o`, `--stats`).
    pub fn flag(flag: &str, path: impl Into<PathBuf>) -> Self {
        NamedPath::new(flag, flag, path)
    }
}

/// Why an output path was refused (before any work).
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// An output is an input, or is written through a temporary file that is one.
    #[error(
        "{}: {} {} the same file as {} {}; writing it would destroy {}: give {} another path",
        output.path.display(),
        output.what,
        if *through_temporary { "is written through a temporary file that is" } else { "is" },
        input.what,
        input.path.display(),
        input.what,
        output.flag
    )]
    IsInput {
        /// The output.
        output: Box<NamedPath>,
        /// The input it would overwrite.
        input: Box<NamedPath>,
        /// Whether the clash is with the output's temporary file rather than the output.
        through_temporary: bool,
    },
    /// Two outputs (or their temporary files) are the same file.
    #[error(
        "{}: {} and {} ({}) are the same file, so one would overwrite the other: give {} another path",
        first.path.display(),
        first.what,
        second.what,
        second.path.display(),
        second.flag
    )]
    SameOutput {
        /// The output named first.
        first: Box<NamedPath>,
        /// The output named second.
        second: Box<NamedPath>,
    },
    /// An output exists and is not a regular file.
    #[error("{}", not_regular(output, kind))]
    NotRegular {
        /// The output.
        output: Box<NamedPath>,
        /// What it is: "a directory", "a character device"…
        kind: &'static str,
    },
    /// An output's directory does not exist.
    #[error(
        "{}: directory {} does not exist: create it, or give {} a path in an existing directory",
        output.path.display(),
        dir.display(),
        output.flag
    )]
    NoDirectory {
        /// The output.
        output: Box<NamedPath>,
        /// Its directory.
        dir: PathBuf,
    },
    /// Another process is writing an output (it holds its lock).
    #[error("{}", busy(output, *pid))]
    Busy {
        /// The output.
        output: Box<NamedPath>,
        /// The process holding it, if it could be read.
        pid: Option<u32>,
    },
    /// An output's directory does not take a new file.
    #[error(
        "{}: cannot create files in {} ({source}): give {} a path in a writable directory",
        output.path.display(),
        dir.display(),
        output.flag
    )]
    NotWritable {
        /// The output.
        output: Box<NamedPath>,
        /// Its directory.
        dir: PathBuf,
        /// What creating the temporary file there gave.
        #[source]
        source: std::io::Error,
    },
}

/// The message of [`OutputError::NotRegular`].
fn not_regular(output: &NamedPath, kind: &str) -> String {
    let (path, what, flag) = (output.path.display(), &output.what, &output.flag);
    if kind == DIRECTORY {
        format!("{path}: {what} is a directory: give {flag} a file path")
    } else {
        format!(
            "{path}: {what} is {kind}, not a regular file; patchvis writes outputs to a temporary \
             file and renames it into place, which would replace it: give {flag} a regular file path"
        )
    }
}

/// The message of [`OutputError::Busy`].
fn busy(output: &NamedPath, pid: Option<u32>) -> String {
    let holder = match pid {
        Some(pid) => format!("another patchvis command (pid {pid})"),
        None => "another patchvis command".to_owned(),
    };
    format!(
        "{}: {} is being written by {holder}; wait for it to end, or give {} another path",
        output.path.display(),
        output.what,
        output.flag
    )
}

/// [`file_kind`] of a directory.
const DIRECTORY: &str = "a directory";

/// Checks `outputs` before a command reads or writes anything, and locks them: each is a
/// regular file or does not exist yet, in an existing directory where its temporary file can
/// be created; no output (nor its temporary or lock file) is one of `inputs`, no two outputs
/// are the same file, and no other command is writing one. Stale temporary files of the
/// outputs are removed on the way. The outputs stay locked while the returned lock is held:
/// keep it until they are written.
pub fn check_outputs(
    inputs: &[NamedPath],
    outputs: &[NamedPath],
) -> Result<OutputLock, OutputError> {
    for output in outputs {
        check_kind(output)?;
    }
    let inputs: Vec<(&NamedPath, FileKey)> = inputs
        .iter()
        .filter_map(|input| Some((input, FileKey::of_existing(&input.path)?)))
        .collect();
    // Each output's file (symbolic links followed), its temporary file and its lock file, as
    // keys.
    let written: Vec<[Option<FileKey>; 3]> = outputs
        .iter()
        .map(|output| {
            [
                resolve_target(&output.path)
                    .ok()
                    .and_then(|t| FileKey::of(&t)),
                temp_path(&output.path).ok().and_then(|t| FileKey::of(&t)),
                lock_path(&output.path).ok().and_then(|t| FileKey::of(&t)),
            ]
        })
        .collect();
    for (output, keys) in outputs.iter().zip(&written) {
        for (input, key) in &inputs {
            if let Some(at) = keys.iter().position(|k| k.as_ref() == Some(key)) {
                return Err(OutputError::IsInput {
                    output: Box::new(output.clone()),
                    input: Box::new((*input).clone()),
                    through_temporary: at > 0,
                });
            }
        }
    }
    for (i, first) in written.iter().enumerate() {
        for (j, second) in written.iter().enumerate().skip(i + 1) {
            let clash = first
                .iter()
                .flatten()
                .any(|a| second.iter().flatten().any(|b| a == b));
            if clash {
                return Err(OutputError::SameOutput {
                    first: Box::new(outputs[i].clone()),
                    second: Box::new(outputs[j].clone()),
                });
            }
        }
    }
    let mut lock = OutputLock::default();
    for output in outputs {
        take_lock(&mut lock, output)?;
    }
    for output in outputs {
        probe(output)?;
    }
    Ok(lock)
}

/// Locks `output` into `lock`: refused if another command holds it.
fn take_lock(lock: &mut OutputLock, output: &NamedPath) -> Result<(), OutputError> {
    let failed = |source| OutputError::NotWritable {
        output: Box::new(output.clone()),
        dir: parent_dir(&output.path).to_path_buf(),
        source,
    };
    let path = lock_path(&output.path).map_err(failed)?;
    lock.take(&path).map_err(|e| match e {
        LockFailure::Held(pid) => OutputError::Busy {
            output: Box::new(output.clone()),
            pid,
        },
        LockFailure::Io(source) => failed(source),
    })
}

/// An existing output must be a regular file, in an existing directory.
fn check_kind(output: &NamedPath) -> Result<(), OutputError> {
    if let Ok(meta) = std::fs::metadata(&output.path) {
        let kind = file_kind(&meta.file_type());
        if let Some(kind) = kind {
            return Err(OutputError::NotRegular {
                output: Box::new(output.clone()),
                kind,
            });
        }
    }
    let target = resolve_target(&output.path).unwrap_or_else(|_| output.path.clone());
    let dir = parent_dir(&target);
    if !dir.is_dir() {
        return Err(OutputError::NoDirectory {
            output: Box::new(output.clone()),
            dir: dir.to_path_buf(),
        });
    }
    Ok(())
}

/// What a file that is not regular is, in words; `None` for a regular file.
fn file_kind(t: &std::fs::FileType) -> Option<&'static str> {
    if t.is_file() {
        return None;
    }
    if t.is_dir() {
        return Some(DIRECTORY);
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return Some("a character device");
        }
        if t.is_block_device() {
            return Some("a block device");
        }
        if t.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    Some("not a plain file")
}

/// Creates and removes the output's temporary file, as the write will.
fn probe(output: &NamedPath) -> Result<(), OutputError> {
    let target = resolve_target(&output.path).unwrap_or_else(|_| output.path.clone());
    let dir = parent_dir(&target).to_path_buf();
    let failed = |source| OutputError::NotWritable {
        output: Box::new(output.clone()),
        dir: dir.clone(),
        source,
    };
    let tmp = temp_path(&output.path).map_err(failed)?;
    // Listed while it exists, so that a signal now does not leave it behind.
    let mut listing = Listing::hold();
    drop(create_fresh(&tmp).map_err(failed)?);
    let mut pending = listing.list(tmp);
    drop(listing);
    pending
        .settle(|tmp| std::fs::remove_file(tmp))
        .map_err(failed)
}

/// Which file a path names: an existing file's identity, or else its canonical directory and
/// name.
#[derive(Clone, Debug, PartialEq, Eq)]
enum FileKey {
    /// An existing file: device and inode on Unix, the canonical path elsewhere.
    #[cfg(unix)]
    Inode(u64, u64),
    /// An existing file elsewhere, or one not created yet.
    Path(PathBuf),
}

impl FileKey {
    /// The identity of an existing file (symlinks followed); `None` if there is none.
    fn of_existing(path: &Path) -> Option<FileKey> {
        let meta = std::fs::metadata(path).ok()?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            Some(FileKey::Inode(meta.dev(), meta.ino()))
        }
        #[cfg(not(unix))]
        {
            let _ = meta;
            path.canonicalize().ok().map(FileKey::Path)
        }
    }

    /// The file `path` names, existing or not; `None` if its directory cannot be resolved.
    fn of(path: &Path) -> Option<FileKey> {
        FileKey::of_existing(path).or_else(|| {
            let dir = parent_dir(path).canonicalize().ok()?;
            Some(FileKey::Path(dir.join(path.file_name()?)))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spellings_of_one_file_clash() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("b.ply");
        std::fs::write(&input, b"ply").unwrap();
        let link = dir.path().join("link.ply");
        std::fs::hard_link(&input, &link).unwrap();
        let dotted = dir.path().join(".").join("b.ply");
        let inputs = [NamedPath::new("the input mesh", "INPUT", &input)];
        let symlink = dir.path().join("sym.ply");
        std::os::unix::fs::symlink("b.ply", &symlink).unwrap();
        for spelling in [&input, &link, &dotted, &symlink] {
            let err = check_outputs(&inputs, &[NamedPath::flag("-o", spelling)]).unwrap_err();
            assert!(matches!(err, OutputError::IsInput { .. }), "{err}");
        }
        // Two outputs not created yet, spelled differently.
        let a = dir.path().join("out.pvis");
        let b = dir.path().join("sub/../out.pvis");
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let err = check_outputs(
            &inputs,
            &[NamedPath::flag("-o", &a), NamedPath::flag("--stats", &b)],
        )
        .unwrap_err();
        assert!(matches!(err, OutputError::SameOutput { .. }), "{err}");
        // Distinct files pass, and the probe and the lock leave nothing behind.
        let lock = check_outputs(
            &inputs,
            &[
                NamedPath::flag("-o", &a),
                NamedPath::flag("--stats", dir.path().join("s.json")),
            ],
        )
        .unwrap();
        assert_eq!(lock.paths().len(), 2);
        // Locked: a second check of an output is refused with this process's pid.
        let err = check_outputs(
            &[],
            &[NamedPath::flag("--stats", dir.path().join("s.json"))],
        )
        .unwrap_err();
        let pid = std::process::id().to_string();
        assert!(matches!(err, OutputError::Busy { .. }) && err.to_string().contains(&pid));
        drop(lock);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 4);
    }
}
