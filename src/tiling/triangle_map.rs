//! Per-triangle `u32` maps (patch of each triangle, the reordered triangle list) that live on
//! the heap or in a memory-mapped temporary file, behind one slice type.
//!
//! At 20M triangles one such map is 80 MB: two of them next to the tiling's own working set
//! would not fit a 256 MiB heap budget. The out-of-core tiling therefore keeps them in
//! anonymous (already unlinked) temporary files mapped read-write: the kernel pages them in
//! and out, the heap holds nothing per triangle. Callers see `&[u32]` / `&mut [u32]` through
//! `Deref` either way, so `&tiling.patch_of` coerces to `&[u32]` wherever a slice is expected.
//!
//! The storage is the crate's [`Array`](crate::mapped::Array), which owns the map; this type
//! names it for the tiling's public API and prints long maps briefly.
//! Cost: O(1) to create (the file is sparse until written); access is a plain slice access.

use std::fmt;
use std::io;
use std::ops::{Deref, DerefMut};

use crate::mapped::Array;

/// A `u32` per triangle (or per vertex), on the heap or in a mapped temporary file.
#[derive(Clone, PartialEq)]
pub struct TriangleMap {
    entries: Array<u32>,
}

impl TriangleMap {
    /// A map held on the heap.
    pub fn from_vec(values: Vec<u32>) -> TriangleMap {
        TriangleMap {
            entries: Array::from_vec(values),
        }
    }

    /// `len` zeros in a memory-mapped temporary file (in the directory `tempfile` uses:
    /// `$TMPDIR` or `/tmp`). The heap holds nothing per entry. An empty map lives on the heap.
    pub fn mapped_zeroed(len: usize) -> io::Result<TriangleMap> {
        Ok(TriangleMap {
            entries: Array::zeroed_in_file(len)?,
        })
    }

    /// True when the entries live in a mapped file rather than on the heap.
    pub fn is_mapped(&self) -> bool {
        self.entries.is_mapped()
    }
}

impl Deref for TriangleMap {
    type Target = [u32];
    #[inline]
    fn deref(&self) -> &[u32] {
        &self.entries
    }
}

impl DerefMut for TriangleMap {
    #[inline]
    fn deref_mut(&mut self) -> &mut [u32] {
        &mut self.entries
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
