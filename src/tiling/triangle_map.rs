//! Per-triangle `u32` maps (patch of each triangle, the reordered triangle list) that live on
//! the heap or in a memory-mapped temporary file, behind one slice type.
//!
//! At 20M triangles one such map is 80 MB: two of them next to the tiling's own working set
//! would not fit a 256 MiB heap budget. The out-of-core tiling therefore keeps them in
//! anonymous (already unlinked) temporary files mapped read-write: the kernel pages them in
//! and out, the heap holds nothing per triangle. Callers see `&[u32]` / `&mut [u32]` through
//! `Deref` either way, so `&tiling.patch_of` coerces to `&[u32]` wherever a slice is expected.
//!
//! This is the tiling's only `unsafe` code: viewing the mapped bytes as `u32`s.
//! Cost: O(1) to create (the file is sparse until written); access is a plain slice access.

use std::fmt;
use std::io;
use std::ops::{Deref, DerefMut};

use memmap2::MmapMut;

/// Bytes per map entry.
const ENTRY_BYTES: usize = std::mem::size_of::<u32>();

/// A `u32` per triangle (or per vertex), on the heap or in a mapped temporary file.
pub struct TriangleMap {
    storage: Storage,
}

enum Storage {
    Heap(Vec<u32>),
    /// `len` entries at the start of `map`; the file behind it is unlinked, so this process
    /// holds the only handle to it.
    Mapped {
        map: MmapMut,
        len: usize,
    },
}

impl TriangleMap {
    /// A map held on the heap.
    pub fn from_vec(values: Vec<u32>) -> TriangleMap {
        TriangleMap {
            storage: Storage::Heap(values),
        }
    }

    /// `len` zeros in a memory-mapped temporary file (in the directory `tempfile` uses:
    /// `$TMPDIR` or `/tmp`). The heap holds nothing per entry.
    pub fn mapped_zeroed(len: usize) -> io::Result<TriangleMap> {
        if len == 0 {
            return Ok(TriangleMap::from_vec(Vec::new()));
        }
        let bytes = len
            .checked_mul(ENTRY_BYTES)
            .ok_or_else(|| io::Error::new(io::ErrorKind::OutOfMemory, "map too large"))?;
        let file = tempfile::tempfile()?;
        // A sparse file of zeros: no disk is used until pages are written.
        file.set_len(bytes as u64)?;
        // SAFETY: `tempfile()` returns a file that is already unlinked (or, on systems without
        // that, opened with exclusive sharing), so no other process or handle can truncate or
        // write it while the map lives; the map keeps its own reference to the file, so
        // dropping `file` here does not invalidate it.
        let map = unsafe { MmapMut::map_mut(&file)? };
        Ok(TriangleMap {
            storage: Storage::Mapped { map, len },
        })
    }

    /// True when the entries live in a mapped file rather than on the heap.
    pub fn is_mapped(&self) -> bool {
        matches!(self.storage, Storage::Mapped { .. })
    }
}

impl Deref for TriangleMap {
    type Target = [u32];
    #[inline]
    fn deref(&self) -> &[u32] {
        match &self.storage {
            Storage::Heap(v) => v,
            Storage::Mapped { map, len } => {
                let bytes: &[u8] = &map[..len * ENTRY_BYTES];
                // SAFETY: a mapping starts on a page boundary, so the pointer is aligned for
                // `u32`; `bytes` holds exactly `len` entries; every bit pattern is a valid
                // `u32`; the returned slice borrows `self`, so the map outlives it.
                unsafe { std::slice::from_raw_parts(bytes.as_ptr().cast::<u32>(), *len) }
            }
        }
    }
}

impl DerefMut for TriangleMap {
    #[inline]
    fn deref_mut(&mut self) -> &mut [u32] {
        match &mut self.storage {
            Storage::Heap(v) => v,
            Storage::Mapped { map, len } => {
                let bytes: &mut [u8] = &mut map[..*len * ENTRY_BYTES];
                // SAFETY: as in `deref`, and the slice borrows `self` mutably, so it is the
                // only view of these bytes while it lives.
                unsafe { std::slice::from_raw_parts_mut(bytes.as_mut_ptr().cast::<u32>(), *len) }
            }
        }
    }
}

impl Clone for TriangleMap {
    /// A copy of the same kind; a mapped map whose copy cannot be mapped is copied to the heap.
    fn clone(&self) -> TriangleMap {
        if self.is_mapped()
            && let Ok(mut copy) = TriangleMap::mapped_zeroed(self.len())
        {
            copy.copy_from_slice(self);
            return copy;
        }
        TriangleMap::from_vec(self.to_vec())
    }
}

impl PartialEq for TriangleMap {
    /// Equal entries, wherever they are stored.
    fn eq(&self, other: &TriangleMap) -> bool {
        **self == **other
    }
}

impl fmt::Debug for TriangleMap {
    /// The entries of short maps; only the length and storage of long ones (a 20M-entry list
    /// helps nobody in a failed assertion).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const SHOWN: usize = 64;
        if self.len() <= SHOWN {
            f.debug_list().entries(self.iter()).finish()
        } else {
            f.debug_struct("TriangleMap")
                .field("len", &self.len())
                .field("mapped", &self.is_mapped())
                .finish()
        }
    }
}

impl<'a> IntoIterator for &'a TriangleMap {
    type Item = &'a u32;
    type IntoIter = std::slice::Iter<'a, u32>;

    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mapped_map_reads_back_what_was_written() {
        let mut m = TriangleMap::mapped_zeroed(5000).expect("temporary file");
        assert!(m.is_mapped());
        assert!(m.iter().all(|&v| v == 0));
        for (i, v) in m.iter_mut().enumerate() {
            *v = (i as u32).wrapping_mul(2_654_435_761);
        }
        let heap = TriangleMap::from_vec(m.to_vec());
        assert_eq!(m, heap);
        assert_eq!(m[4999], 4999u32.wrapping_mul(2_654_435_761));
        let copy = m.clone();
        assert!(copy.is_mapped());
        assert_eq!(copy, m);
        assert_eq!(
            format!("{copy:?}"),
            "TriangleMap { len: 5000, mapped: true }"
        );
    }

    #[test]
    fn empty_map_lives_on_the_heap() {
        let m = TriangleMap::mapped_zeroed(0).expect("no file needed");
        assert!(!m.is_mapped());
        assert!(m.is_empty());
        assert_eq!(format!("{m:?}"), "[]");
    }
}
