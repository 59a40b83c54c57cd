//! Opening an input file for reading: regular files only.
//!
//! A path can name a FIFO, a device or a socket as easily as a file. Opening a FIFO with no
//! writer blocks forever, and `/dev/zero` or `/dev/urandom` never end, so every input is
//! checked with `stat` before it is opened, and again with `fstat` on the open handle (the
//! path may have been replaced in between; a FIFO put there in that window can still block
//! the `open`, a race no user makes by accident). Cost: two system calls.
//!
//! A file read whole ([`read_regular`]: lists of ids, camera paths, material libraries,
//! textures, checkpoints) has, besides, a size limit its kind states: a 3 GiB file given where
//! a list of ids belongs is refused before a byte of it is read.

use std::fs::{self, File, Metadata};
use std::io::{self, Read};
use std::path::Path;

/// Opens `path` for reading if it is a regular file (after following symbolic links);
/// returns the file and its metadata. A directory gives `ErrorKind::IsADirectory`; a FIFO,
/// a device or a socket gives `ErrorKind::InvalidInput` with a message naming what it is,
/// e.g. "a FIFO (named pipe), not a regular file".
pub fn open_regular(path: &Path) -> io::Result<(File, Metadata)> {
    check(&fs::metadata(path)?)?;
    let file = File::open(path)?;
    let metadata = file.metadata()?;
    check(&metadata)?;
    Ok((file, metadata))
}

/// Reads the file at `path` whole, after [`open_regular`]'s checks, if it holds at most
/// `limit` bytes; `what` names its kind in the error for a larger one ("3221225472 bytes,
/// expected at most 67108864 for a list of patch ids"), which comes before any read. A file
/// that grows past the limit while it is read is refused too.
pub fn read_regular(path: &Path, limit: u64, what: &str) -> io::Result<Vec<u8>> {
    let (file, metadata) = open_regular(path)?;
    let too_large = |len: u64| {
        io::Error::new(
            io::ErrorKind::FileTooLarge,
            format!("{len} bytes, expected at most {limit} for {what}"),
        )
    };
    if metadata.len() > limit {
        return Err(too_large(metadata.len()));
    }
    let mut bytes = Vec::with_capacity(metadata.len() as usize);
    file.take(limit.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

fn check(metadata: &Metadata) -> io::Result<()> {
    if metadata.is_file() {
        return Ok(());
    }
    if metadata.is_dir() {
        return Err(io::Error::from(io::ErrorKind::IsADirectory));
    }
    Err(io::Error::new(
        io::ErrorKind::InvalidInput,
        format!("{}, not a regular file", kind(metadata)),
    ))
}

/// What a non-regular, non-directory file is, in words.
fn kind(metadata: &Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = metadata.file_type();
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    let _ = metadata;
    "a special file"
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    #[test]
    fn devices_and_directories_are_refused_files_open() {
        let err = open_regular(Path::new("/dev/zero")).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidInput);
        assert_eq!(err.to_string(), "a character device, not a regular file");
        let dir = tempfile::tempdir().unwrap();
        let err = open_regular(dir.path()).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::IsADirectory);
        let file = dir.path().join("f");
        fs::write(&file, b"abc").unwrap();
        assert_eq!(open_regular(&file).unwrap().1.len(), 3);
        assert_eq!(read_regular(&file, 3, "a test").unwrap(), b"abc");
        let err = read_regular(&file, 2, "a test").unwrap_err();
        assert_eq!(err.to_string(), "3 bytes, expected at most 2 for a test");
        let err = read_regular(Path::new("/dev/zero"), 2, "a test").unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidInput);
    }
}
