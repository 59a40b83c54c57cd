//! A fixed-length array of plain records, created zeroed and then written in place, on the
//! heap or in a memory-mapped temporary file, behind one slice type.
//!
//! Per-triangle arrays of a large mesh do not fit a small heap budget (at 20M triangles one
//! `u32` per triangle is 80 MB), so [`Array::zeroed_in_file`] keeps them in an anonymous
//! (already unlinked) temporary file mapped read-write: the kernel pages them in and out, the
//! heap holds nothing per record. Callers see `&[T]` / `&mut [T]` through `Deref` either way.
//!
//! The zeroed file is sparse: a write into the map is where its disk blocks are taken, so a
//! full disk shows there, as `SIGBUS`. Every map is registered with the fault handler
//! (`fault.rs`), which turns that into an error line naming the temporary directory.
//!
//! One `unsafe` call: `MmapMut::map_mut` of a temporary file (a zeroed one, or one that
//! `RecordWriter` filled); the bytes are viewed as records by `bytemuck`. Cost: O(1) to create (the
//! file is sparse until written); access is a plain slice access after a match on the storage kind.

use std::io;
use std::ops::{Deref, DerefMut};

use bytemuck::Pod;
use memmap2::MmapMut;

use super::fault::{Backing, Covered};

/// Records of type `T` on the heap or in a mapped temporary file.
pub(crate) struct Array<T> {
    storage: Storage<T>,
}

enum Storage<T> {
    Heap(Vec<T>),
    /// Exactly the records' bytes; the file behind the map is unlinked, so this process holds
    /// the only handle to it. The map's registration with the fault handler is held for its
    /// drop, declared first so that it is unregistered before the map goes.
    Mapped {
        _covered: Covered,
        map: MmapMut,
    },
}

impl<T: Pod> Array<T> {
    /// An array held on the heap.
    pub(crate) fn from_vec(values: Vec<T>) -> Array<T> {
        Array {
            storage: Storage::Heap(values),
        }
    }

    /// `len` zeroed records in a memory-mapped temporary file (in the directory `tempfile`
    /// uses: `$TMPDIR` or `/tmp`). The heap holds nothing per record. An empty array needs no
    /// file and lives on the heap.
    pub(crate) fn zeroed_in_file(len: usize) -> io::Result<Array<T>> {
        let bytes = len
            .checked_mul(size_of::<T>())
            .ok_or_else(|| io::Error::new(io::ErrorKind::OutOfMemory, "array too large"))?;
        if bytes == 0 {
            // An empty file cannot be mapped on every system; nothing to map anyway.
            return Ok(Array::from_vec(vec![T::zeroed(); len]));
        }
        let file = tempfile::tempfile()?;
        // A sparse file of zeros: no disk is used until pages are written.
        file.set_len(bytes as u64)?;
        Array::map(&file)
    }

    /// The records in `file`, an unlinked temporary file this process alone holds, whose
    /// length is a whole number of records (at least one).
    pub(crate) fn in_file(file: &std::fs::File) -> io::Result<Array<T>> {
        Array::map(file)
    }

    /// Maps `file` read-write.
    fn map(file: &std::fs::File) -> io::Result<Array<T>> {
        // SAFETY: the callers pass files from `tempfile()`, which are already unlinked (or, on
        // systems without that, opened with exclusive sharing), so no other process or handle
        // can truncate or write them while the map lives; the map keeps its own reference to
        // the file, so dropping `file` afterwards does not invalidate it.
        let map = unsafe { MmapMut::map_mut(file)? };
        Ok(Array {
            storage: Storage::Mapped {
                _covered: Covered::new(&map, Backing::Temporary),
                map,
            },
        })
    }

    /// True when the records live in a mapped file rather than on the heap.
    pub(crate) fn is_mapped(&self) -> bool {
        matches!(self.storage, Storage::Mapped { .. })
    }
}

impl<T: Pod> Deref for Array<T> {
    type Target = [T];
    #[inline]
    fn deref(&self) -> &[T] {
        match &self.storage {
            Storage::Heap(v) => v,
            // A map starts on a page boundary and holds whole records: the cast cannot fail.
            Storage::Mapped { map, .. } => bytemuck::cast_slice(map),
        }
    }
}

impl<T: Pod> DerefMut for Array<T> {
    #[inline]
    fn deref_mut(&mut self) -> &mut [T] {
        match &mut self.storage {
            Storage::Heap(v) => v,
            Storage::Mapped { map, .. } => bytemuck::cast_slice_mut(map),
        }
    }
}

impl<T: Pod> Clone for Array<T> {
    /// A copy of the same kind; a mapped array whose copy cannot be mapped is copied to the
    /// heap.
    fn clone(&self) -> Array<T> {
        if self.is_mapped()
            && let Ok(mut copy) = Array::zeroed_in_file(self.len())
        {
            copy.copy_from_slice(self);
            return copy;
        }
        Array::from_vec(self.to_vec())
    }
}

impl<T> std::fmt::Debug for Array<T> {
    /// The length and where the records are, not the records.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (len, mapped) = match &self.storage {
            Storage::Heap(v) => (v.len(), false),
            Storage::Mapped { map, .. } => (map.len() / size_of::<T>().max(1), true),
        };
        f.debug_struct("Array")
            .field("len", &len)
            .field("mapped", &mapped)
            .finish()
    }
}

impl<T: Pod + PartialEq> PartialEq for Array<T> {
    /// Equal records, wherever they are stored.
    fn eq(&self, other: &Array<T>) -> bool {
        **self == **other
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mapped_records_of_any_size_read_back_what_was_written() {
        let mut a = Array::<[u16; 3]>::zeroed_in_file(1001).expect("temporary file");
        assert!(a.is_mapped());
        assert_eq!(a.len(), 1001);
        assert!(a.iter().all(|&r| r == [0; 3]));
        for (i, r) in a.iter_mut().enumerate() {
            *r = [i as u16, !(i as u16), 7];
        }
        let copy = a.clone();
        assert!(copy.is_mapped());
        assert!(copy == a);
        assert!(Array::from_vec(a.to_vec()) == a);
        assert_eq!(a[1000], [1000, !1000, 7]);
    }

    #[test]
    fn empty_array_lives_on_the_heap() {
        let a = Array::<u32>::zeroed_in_file(0).expect("no file needed");
        assert!(!a.is_mapped() && a.is_empty());
        assert!(!a.clone().is_mapped());
    }
}
