//! The bytes a mesh is read from: a read-only memory map, always.
//!
//! A mesh file is mapped in place (memmap2), so opening a multi-gigabyte binary PLY costs page
//! faults on first touch rather than a copy. Where the file cannot be mapped (some network or
//! virtual file systems, pipes) it is read into an anonymous mapping instead, and converted
//! meshes are written into one too. Keeping a single type behind `Deref<Target = [u8]>` is what
//! lets `Mesh::position` and `Mesh::triangle` run without a per-call match on the storage kind.
//!
//! A file mapped in place is registered with the fault handler (`fault.rs`), so that a read
//! of a page another program truncated away is an error line naming the file, not a crash.
//!
//! One `unsafe` call: `Mmap::map` of the input file.

use std::fs::File;
use std::io::{self, Read};
use std::ops::Deref;

use memmap2::{Mmap, MmapMut};

use super::fault::{Backing, Covered};

/// Read-only bytes of a file: the file mapped in place, or an anonymous mapping filled by this
/// process.
pub(crate) struct FileBytes {
    /// The map's registration with the fault handler when `map` is the file itself (zero
    /// copy); `None` for a private copy, which no other program can shorten. Declared before
    /// `map`, so that it is unregistered before the map goes.
    covered: Option<Covered>,
    map: Mmap,
}

impl FileBytes {
    /// Maps `file` (of `len` bytes, `backing` says what it is for the fault message)
    /// read-only; when mapping fails, reads it into memory.
    ///
    /// # Safety
    ///
    /// This function is safe to call, but it relies on an assumption the type system cannot
    /// check: nobody truncates or rewrites the file while the bytes are alive. Truncation
    /// makes a later read of a vanished page raise `SIGBUS`, which the fault handler turns
    /// into an error line and exit (`fault.rs`; a crash on targets without it); rewriting
    /// changes the bytes under the validated layout. The pipeline opens its input read-only
    /// and never writes it; the `patchvis` documentation tells users not to edit a mesh during
    /// a bake, the same contract ripgrep and every mmap-based mesh tool make.
    pub(crate) fn open(file: &File, len: u64, backing: Backing<'_>) -> io::Result<FileBytes> {
        // SAFETY: the mapping is read-only and private to this process; the remaining hazard
        // (the file changing underneath) is the documented contract above. Every read through
        // the map is a bounds-checked slice access, so changed bytes give wrong values, never
        // out-of-bounds access.
        match unsafe { Mmap::map(file) } {
            Ok(map) => Ok(FileBytes {
                covered: Some(Covered::new(&map, backing)),
                map,
            }),
            Err(_) => Self::read(file, len),
        }
    }

    /// The fallback: the file's bytes copied into an anonymous mapping.
    fn read(mut file: &File, len: u64) -> io::Result<FileBytes> {
        let len = usize::try_from(len)
            .map_err(|_| io::Error::new(io::ErrorKind::OutOfMemory, "file too large to read"))?;
        let mut map = MmapMut::map_anon(len)?;
        file.read_exact(&mut map)?;
        Ok(FileBytes {
            covered: None,
            map: map.make_read_only()?,
        })
    }

    /// `len` bytes written by `fill`, held in an anonymous mapping (converted meshes).
    pub(crate) fn filled(len: usize, fill: impl FnOnce(&mut [u8])) -> io::Result<FileBytes> {
        let mut map = MmapMut::map_anon(len)?;
        fill(&mut map);
        Ok(FileBytes {
            covered: None,
            map: map.make_read_only()?,
        })
    }

    /// True when these bytes are the file itself, mapped in place.
    pub(crate) fn is_file_backed(&self) -> bool {
        self.covered.is_some()
    }
}

impl Deref for FileBytes {
    type Target = [u8];
    #[inline]
    fn deref(&self) -> &[u8] {
        &self.map
    }
}
