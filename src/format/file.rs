//! A `.pvis` file on disk, opened for the reader: what `patchvis info`, `query`, `verify` and
//! `eval` parse.
//!
//! The path must name a regular file (a FIFO would block, a device never ends), and its first
//! eight bytes must be the signature before anything else is read, so that `verify /dev/zero`
//! or a multi-gigabyte file of another kind is refused at once. The file is then memory-mapped
//! (`mapped::FileBytes`, read into memory where mapping fails), not read, so that a large file
//! costs page faults on the parts the parser touches. The mapping carries the same contract
//! as a mapped mesh: nobody truncates or rewrites the file while it is open.

use std::io::{self, Read};
use std::ops::Deref;
use std::path::Path;

use crate::mapped::{Backing, FileBytes, open_regular};
use crate::runtime::{self, consts::MAGIC};

/// The bytes of a `.pvis` file whose signature has been checked; parse them with
/// [`Pvis::parse`](crate::runtime::Pvis::parse).
pub struct PvisFile {
    /// `None` for an empty file, which cannot be mapped.
    bytes: Option<FileBytes>,
}

/// Why a `.pvis` file could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum PvisFileError {
    /// The file is missing, unreadable, or not a regular file.
    #[error("cannot read: {0}")]
    Io(#[from] io::Error),
    /// The file does not start with the `.pvis` signature (the reader's own error, so that
    /// the message is the one `Pvis::parse` gives).
    #[error("{0}")]
    Format(runtime::Error),
}

impl PvisFile {
    /// Opens the regular file at `path`, checks its signature on the first bytes alone, and
    /// maps it. A file shorter than the signature whose bytes match it is let through, for
    /// the parser to report as truncated.
    pub fn open(path: &Path) -> Result<PvisFile, PvisFileError> {
        let (file, metadata) = open_regular(path)?;
        let mut head = Vec::with_capacity(MAGIC.len());
        (&file).take(MAGIC.len() as u64).read_to_end(&mut head)?;
        if head[..] != MAGIC[..head.len()] {
            return Err(PvisFileError::Format(runtime::Error::BadMagic));
        }
        let bytes = match metadata.len() {
            0 => None,
            len => Some(FileBytes::open(&file, len, Backing::Input(path))?),
        };
        Ok(PvisFile { bytes })
    }
}

impl Deref for PvisFile {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.bytes.as_deref().unwrap_or(&[])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_signature_is_checked_before_the_rest_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sparse.pvis");
        // 64 GiB of holes: refused on its first bytes, never read.
        std::fs::File::create(&path)
            .unwrap()
            .set_len(64 << 30)
            .unwrap();
        assert!(matches!(
            PvisFile::open(&path),
            Err(PvisFileError::Format(runtime::Error::BadMagic))
        ));
        std::fs::write(&path, &MAGIC[..5]).unwrap();
        assert_eq!(&*PvisFile::open(&path).unwrap(), &MAGIC[..5]);
        std::fs::write(&path, b"").unwrap();
        assert!(PvisFile::open(&path).unwrap().is_empty());
        assert!(matches!(
            PvisFile::open(Path::new("/dev/zero")),
            Err(PvisFileError::Io(_))
        ));
    }
}
