//! External merge sort of fixed-size records in bounded memory.
//!
//! Records are buffered up to a byte budget; a full buffer is sorted (in parallel) and written
//! to a temporary file as one sorted run. Reading back merges the runs with a small heap of
//! run heads, each run read through its own buffer; every [`MAX_FAN_IN`] runs of one level
//! are merged into one run of the next level as they appear, so open files and read buffers
//! stay bounded however small the buffer. When
//! everything fits the buffer, no file is written at all. The out-of-core tiling sorts
//! triangles by Morton code and border edges by key with it.
//!
//! Records are totally ordered (`Ord`) and equal records are identical, so the output does not
//! depend on run boundaries or on the thread count.
//! Cost: O(n log n) comparisons; every record is written and read once per merge level (one
//! level: one unless there are more than [`MAX_FAN_IN`] runs); heap at most the buffer budget plus
//! the read buffers.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Seek, SeekFrom, Write};

use rayon::prelude::*;

/// Most runs merged at once. 64 read buffers of a few hundred KiB each keep the disk reading
/// long sequential stretches; a 20M-triangle tiling under 256 MiB makes fewer than ten runs.
pub(crate) const MAX_FAN_IN: usize = 64;

/// Smallest read or write buffer per run file; below a page, system calls would dominate.
const MIN_IO_BUFFER: usize = 4096;

/// Largest record encoding.
const MAX_RECORD_BYTES: usize = 16;

/// A record with a fixed-size little-endian encoding.
pub(crate) trait Record: Copy + Ord + Send + Sync {
    /// Encoded size, at most [`MAX_RECORD_BYTES`].
    const BYTES: usize;
    /// Writes the record into `out` (`BYTES` long).
    fn encode(&self, out: &mut [u8]);
    /// Reads a record from `bytes` (`BYTES` long).
    fn decode(bytes: &[u8]) -> Self;
}

/// A 64-bit key with a 32-bit payload (Morton code and triangle, edge key and triangle).
impl Record for (u64, u32) {
    const BYTES: usize = 12;
    fn encode(&self, out: &mut [u8]) {
        out[..8].copy_from_slice(&self.0.to_le_bytes());
        out[8..12].copy_from_slice(&self.1.to_le_bytes());
    }
    fn decode(b: &[u8]) -> Self {
        let mut key = [0u8; 8];
        key.copy_from_slice(&b[..8]);
        let mut value = [0u8; 4];
        value.copy_from_slice(&b[8..12]);
        (u64::from_le_bytes(key), u32::from_le_bytes(value))
    }
}

/// A sorted run on disk: its file (rewound before reading), record count, and merge level
/// (0 for a spilled buffer, one more than its inputs for a merged run).
struct Run {
    file: File,
    records: u64,
    level: u32,
}

/// Collects records, spilling sorted runs to temporary files when the buffer is full.
pub(crate) struct ExternalSort<R: Record> {
    buffer: Vec<R>,
    capacity: usize,
    io_bytes: usize,
    runs: Vec<Run>,
}

impl<R: Record> ExternalSort<R> {
    /// A sorter whose buffer holds at most `buffer_bytes` of records and whose file reads and
    /// writes together use about `io_bytes` of buffers.
    pub fn new(buffer_bytes: usize, io_bytes: usize) -> ExternalSort<R> {
        ExternalSort {
            buffer: Vec::new(),
            capacity: (buffer_bytes / std::mem::size_of::<R>()).max(1),
            io_bytes,
            runs: Vec::new(),
        }
    }

    /// Adds a record.
    pub fn push(&mut self, record: R) -> io::Result<()> {
        if self.buffer.len() == self.capacity {
            self.spill()?;
        }
        if self.buffer.len() == self.buffer.capacity() {
            // Grow by doubling but never past the budget (`Vec`'s own growth could overshoot
            // it by almost a factor of two).
            let more = self
                .buffer
                .len()
                .max(1024)
                .min(self.capacity - self.buffer.len());
            self.buffer.reserve_exact(more);
        }
        self.buffer.push(record);
        Ok(())
    }

    /// Number of runs written to disk so far.
    #[cfg(test)]
    pub fn runs(&self) -> usize {
        self.runs.len()
    }

    /// Sorts the buffer and writes it as a run.
    fn spill(&mut self) -> io::Result<()> {
        self.buffer.par_sort_unstable();
        let run = write_run(self.buffer.iter().copied().map(Ok), self.io_bytes, 0)?;
        self.runs.push(run);
        self.buffer.clear();
        // Whenever `MAX_FAN_IN` runs of one level accumulate, they become one run of the next
        // level, so at most `MAX_FAN_IN` files per level are open and every record is
        // rewritten once per level (log base `MAX_FAN_IN` of the run count).
        while self.runs.len() >= MAX_FAN_IN {
            let tail = &self.runs[self.runs.len() - MAX_FAN_IN..];
            let level = tail[0].level;
            if tail.iter().any(|r| r.level != level) {
                break;
            }
            let group = self.runs.split_off(self.runs.len() - MAX_FAN_IN);
            let mut merge = Merge::<R>::new(group, self.io_bytes / 2)?;
            let merged = std::iter::from_fn(|| merge.next().transpose());
            let run = write_run(merged, self.io_bytes / 2, level + 1)?;
            self.runs.push(run);
        }
        Ok(())
    }

    /// Finishes the input and returns the records in sorted order.
    pub fn finish(mut self) -> io::Result<Sorted<R>> {
        if self.runs.is_empty() {
            self.buffer.par_sort_unstable();
            return Ok(Sorted::Memory(self.buffer.into_iter()));
        }
        if !self.buffer.is_empty() {
            self.spill()?;
        }
        // The buffer's memory goes to the read buffers now.
        drop(std::mem::take(&mut self.buffer));
        // Fewer than `MAX_FAN_IN` per level remain; a last merge of several levels can exceed
        // it, and then the longest runs are merged first.
        let mut runs = self.runs;
        while runs.len() > MAX_FAN_IN {
            let group: Vec<Run> = runs.drain(..MAX_FAN_IN).collect();
            let level = group.iter().map(|r| r.level).max().unwrap_or(0) + 1;
            let mut merge = Merge::<R>::new(group, self.io_bytes / 2)?;
            let merged = std::iter::from_fn(|| merge.next().transpose());
            runs.push(write_run(merged, self.io_bytes / 2, level)?);
        }
        Ok(Sorted::Disk(Merge::new(runs, self.io_bytes)?))
    }
}

/// Writes sorted records to a new temporary file.
fn write_run<R: Record>(
    records: impl Iterator<Item = io::Result<R>>,
    io_bytes: usize,
    level: u32,
) -> io::Result<Run> {
    let mut out = BufWriter::with_capacity(io_bytes.max(MIN_IO_BUFFER), tempfile::tempfile()?);
    let mut bytes = [0u8; MAX_RECORD_BYTES];
    let mut count = 0u64;
    for r in records {
        r?.encode(&mut bytes[..R::BYTES]);
        out.write_all(&bytes[..R::BYTES])?;
        count += 1;
    }
    let mut file = out.into_inner().map_err(|e| e.into_error())?;
    file.seek(SeekFrom::Start(0))?;
    Ok(Run {
        file,
        records: count,
        level,
    })
}

/// The sorted records: straight from memory, or merged from runs on disk.
pub(crate) enum Sorted<R: Record> {
    /// Everything fit the buffer.
    Memory(std::vec::IntoIter<R>),
    /// A k-way merge of sorted runs.
    Disk(Merge<R>),
}

impl<R: Record> Sorted<R> {
    /// The next record in order, `None` at the end.
    pub fn next(&mut self) -> io::Result<Option<R>> {
        match self {
            Sorted::Memory(it) => Ok(it.next()),
            Sorted::Disk(merge) => merge.next(),
        }
    }
}

/// A k-way merge of sorted runs with a heap of run heads.
pub(crate) struct Merge<R: Record> {
    readers: Vec<(BufReader<File>, u64)>,
    heads: BinaryHeap<Reverse<(R, usize)>>,
}

impl<R: Record> Merge<R> {
    fn new(runs: Vec<Run>, io_bytes: usize) -> io::Result<Merge<R>> {
        let per_run = (io_bytes / runs.len().max(1)).max(MIN_IO_BUFFER);
        let mut merge = Merge {
            readers: runs
                .into_iter()
                .map(|r| (BufReader::with_capacity(per_run, r.file), r.records))
                .collect(),
            heads: BinaryHeap::new(),
        };
        for i in 0..merge.readers.len() {
            merge.refill(i)?;
        }
        Ok(merge)
    }

    /// Reads the next record of run `i` into the heap, if the run has one left.
    fn refill(&mut self, i: usize) -> io::Result<()> {
        let (reader, left) = &mut self.readers[i];
        if *left > 0 {
            let mut bytes = [0u8; MAX_RECORD_BYTES];
            reader.read_exact(&mut bytes[..R::BYTES])?;
            *left -= 1;
            self.heads.push(Reverse((R::decode(&bytes[..R::BYTES]), i)));
        }
        Ok(())
    }

    fn next(&mut self) -> io::Result<Option<R>> {
        let Some(Reverse((r, i))) = self.heads.pop() else {
            return Ok(None);
        };
        self.refill(i)?;
        Ok(Some(r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sort_all(records: &[(u64, u32)], buffer_bytes: usize) -> (Vec<(u64, u32)>, usize) {
        let mut s = ExternalSort::new(buffer_bytes, 1 << 16);
        for &r in records {
            s.push(r).expect("temporary file");
        }
        let runs = s.runs();
        let mut sorted = s.finish().expect("merge");
        let mut out = Vec::new();
        while let Some(r) = sorted.next().expect("read") {
            out.push(r);
        }
        (out, runs)
    }

    #[test]
    fn sorts_across_runs_and_merge_levels() {
        let mut noise = crate::test_kit::rng::Rng::new(11);
        let records: Vec<(u64, u32)> = (0..10_000u32)
            .map(|i| ((noise.signed().abs() * 1000.0) as u64, i % 7))
            .collect();
        let mut expected = records.clone();
        expected.sort_unstable();
        // In memory; a few runs; 625 runs (merged to 9 on level 1 + 49 on level 0);
        // 10,000 runs of one record (two levels of merging).
        for (buffer, min_runs) in [(1 << 20, 0), (40_000, 3), (1000, 2), (24, 3)] {
            let (out, runs) = sort_all(&records, buffer);
            assert!(runs < MAX_FAN_IN);
            assert!(runs >= min_runs, "{runs} runs for a {buffer}-byte buffer");
            assert_eq!(out, expected);
        }
    }

    #[test]
    fn encoding_round_trips() {
        let r = (0x0123_4567_89ab_cdefu64, 0xfedc_ba98u32);
        let mut b = [0u8; 12];
        r.encode(&mut b);
        assert_eq!(<(u64, u32)>::decode(&b), r);
    }
}
