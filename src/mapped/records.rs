//! Plain records written once, in order, then only read: on the heap or in a memory-mapped
//! temporary file, behind one slice type.
//!
//! A [`RecordWriter`] appends batches of records; [`RecordWriter::finish`] turns it into an
//! [`Array`], which derefs to `&[T]`. Writing to a file goes through a 1 MiB buffer, so the
//! heap holds only the batch in flight; the finished file is mapped (by `Array`, which holds
//! the map's `unsafe`) and the kernel's page cache holds it. Records are stored in native byte
//! order: the file lives only as long as this process.
//!
//! Cost: one buffered write per batch and one map per file.

use std::fs::File;
use std::io::{self, BufWriter, Write};

use bytemuck::Pod;

use super::Array;

/// Bytes buffered before a write to the file.
const WRITE_BUFFER_BYTES: usize = 1 << 20;

/// Where records go while they are written.
pub(crate) struct RecordWriter<T> {
    target: Target<T>,
}

enum Target<T> {
    Heap(Vec<T>),
    /// `len` records written so far.
    File {
        out: BufWriter<File>,
        len: usize,
    },
}

impl<T: Pod> RecordWriter<T> {
    /// A writer that keeps the records in a heap vector.
    pub(crate) fn heap() -> RecordWriter<T> {
        RecordWriter {
            target: Target::Heap(Vec::new()),
        }
    }

    /// A writer into an unlinked temporary file (in `$TMPDIR` or `/tmp`).
    pub(crate) fn temp_file() -> io::Result<RecordWriter<T>> {
        Ok(RecordWriter {
            target: Target::File {
                out: BufWriter::with_capacity(WRITE_BUFFER_BYTES, tempfile::tempfile()?),
                len: 0,
            },
        })
    }

    /// Appends `records`.
    pub(crate) fn push(&mut self, records: &[T]) -> io::Result<()> {
        match &mut self.target {
            Target::Heap(v) => v.extend_from_slice(records),
            Target::File { out, len } => {
                out.write_all(bytemuck::cast_slice(records))?;
                *len += records.len();
            }
        }
        Ok(())
    }

    /// Records written so far.
    pub(crate) fn len(&self) -> usize {
        match &self.target {
            Target::Heap(v) => v.len(),
            Target::File { len, .. } => *len,
        }
    }

    /// The records written; a file is flushed and mapped. An empty file needs no map, and its
    /// records live on the heap.
    pub(crate) fn finish(self) -> io::Result<Array<T>> {
        match self.target {
            Target::Heap(v) => Ok(Array::from_vec(v)),
            // An empty file cannot be mapped on every system; nothing to map anyway.
            Target::File { len: 0, .. } => Ok(Array::from_vec(Vec::new())),
            Target::File { out, .. } => {
                let file = out.into_inner().map_err(|e| e.into_error())?;
                Array::in_file(&file)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_and_heap_writers_give_the_same_records() {
        let blocks: Vec<[f32; 12]> = (0..3000)
            .map(|i| std::array::from_fn(|k| (i * 12 + k) as f32 * 0.5))
            .collect();
        let mut heap = RecordWriter::heap();
        let mut file = RecordWriter::temp_file().expect("temporary file");
        // Batches of uneven sizes, so that some straddle the write buffer.
        for batch in blocks.chunks(777) {
            heap.push(batch).unwrap();
            file.push(batch).unwrap();
        }
        assert_eq!((heap.len(), file.len()), (3000, 3000));
        let (heap, file) = (heap.finish().unwrap(), file.finish().unwrap());
        assert!(!heap.is_mapped() && file.is_mapped());
        assert_eq!(*heap, *blocks);
        assert_eq!(*file, *blocks);
    }

    #[test]
    fn an_empty_file_is_not_mapped() {
        let mut file = RecordWriter::<[u16; 3]>::temp_file().expect("temporary file");
        file.push(&[]).unwrap();
        let records = file.finish().unwrap();
        assert!(!records.is_mapped() && records.is_empty());
    }
}
