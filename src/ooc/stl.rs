//! STL (binary and ASCII) to the conversion cache, vertices welded by exact position.
//!
//! STL stores three positions per triangle and no indices, so corners at the same position
//! must be merged into one vertex for the mesh to be connected. Welding is by exact `f32`
//! bits (with `-0.0` taken as `0.0`): no tolerance, so distinct vertices never merge.
//!
//! Bounded memory, in three steps:
//! 1. Parse: every corner's position is appended to a spill file (12 bytes per corner), binary
//!    or ASCII alike; non-finite values are refused here with their position.
//! 2. Weld: the corners are split into `P` partitions by a hash of the position, `P` chosen
//!    so that one partition's hash table (at most [`TABLE_ENTRY_BYTES`] per corner) fits in
//!    half the memory budget. Pass `p` over the mapped spill file gives each new position of
//!    partition `p` the next vertex number (written to the cache) and appends each corner's
//!    vertex number to partition `p`'s id file. Usually `P = 1`: a 512 MiB budget welds about
//!    6.7M corners per pass.
//! 3. Assemble: one more pass over the corners pulls each corner's number from its
//!    partition's id file, in order, and writes the triangles.
//!
//! Heap: one table of at most half the budget and `P` small read buffers; the spill and id
//! files live in the page cache. Cost: one parse, `P + 1` sequential passes over the corners.
//! A binary STL is recognised by its size (`84 + 50 × count` bytes), by not starting with
//! `solid`, or by a NUL byte after its 80-byte header (never in ASCII STL; binary records
//! hold them in nearly every zero coordinate or attribute); anything else is read as ASCII.
//!
//! **The count field.** Many exporters write a wrong triangle count in the binary header
//! (often 0, or the count of one part of a multi-part export), so a file of exactly
//! `84 + 50 × n` bytes with `n` above the header's count is read whole: all `n` triangles,
//! with a warning naming both counts ([`count_warning`]). A file that is shorter than the
//! count says, or whose length is not `84 + 50 × n` for any `n`, is an error with its
//! position.

use std::collections::HashMap;
use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Write};

use super::Bounds;
use super::cache::CacheWriter;
use super::error::{Fault, MeshErrorKind, snippet};
use super::ply::BoundsBuilder;
use super::text::{Lines, finite_f32, tokens};
use crate::mapped::{Backing, FileBytes};

/// Binary STL: an 80-byte free-text header, then a `u32` triangle count.
const BINARY_HEADER_BYTES: usize = 84;
/// Binary STL triangle: normal and three corners (12 `f32`), then a `u16` attribute.
const BINARY_TRIANGLE_BYTES: usize = 50;
/// Heap per welding-table entry, generously: a 16-byte key and value, the table's control
/// byte and its spare capacity (the table is sized up front, so it never doubles).
const TABLE_ENTRY_BYTES: u64 = 40;
/// Buffer for each spill, id and partition stream.
const STREAM_BUFFER_BYTES: usize = 64 * 1024;

/// Converts an STL file into `sink`, welding corners; returns the bounds.
pub(crate) fn convert(
    bytes: &[u8],
    sink: &mut CacheWriter,
    memory_budget: u64,
) -> Result<Bounds, Fault> {
    let mut spill = BufWriter::with_capacity(
        STREAM_BUFFER_BYTES,
        tempfile::tempfile().map_err(Fault::cache)?,
    );
    let mut bounds = BoundsBuilder::new();
    let mut corners: u64 = 0;
    let mut add = |p: [f32; 3]| -> Result<(), Fault> {
        let p = p.map(|c| c + 0.0); // -0.0 becomes 0.0: one position, one vertex
        bounds.add(p);
        corners += 1;
        let mut record = [0u8; 12];
        for (field, c) in record.chunks_exact_mut(4).zip(p) {
            field.copy_from_slice(&c.to_le_bytes());
        }
        spill.write_all(&record).map_err(Fault::cache)
    };
    match binary_count(bytes) {
        Some(count) => read_binary(bytes, present(bytes, count), &mut add)?,
        None => read_ascii(bytes, &mut add)?,
    }
    if corners == 0 {
        return Err(Fault::at_byte(
            MeshErrorKind::NoFaces,
            bytes.len(),
            "the file holds no triangles, expected at least one facet",
        ));
    }
    if corners / 3 > u64::from(u32::MAX) {
        return Err(Fault::new(
            MeshErrorKind::TooLarge,
            None,
            format!("{} triangles, expected at most {}", corners / 3, u32::MAX),
        ));
    }
    let spill = spill
        .into_inner()
        .map_err(|e| Fault::cache(e.into_error()))?;
    weld(&spill, corners, sink, memory_budget).map_err(Fault::cache)?;
    Ok(bounds.finish())
}

/// Bytes of the body scanned for a NUL byte when a file starting with `solid` is not of the
/// size its count says: enough for 20 triangle records.
const NUL_SCAN_BYTES: usize = 20 * BINARY_TRIANGLE_BYTES;

/// The header's triangle count when `bytes` is a binary STL: exactly `84 + 50 × count`
/// bytes, not starting with `solid`, or holding a NUL byte in the first records (then a
/// size mismatch is reported by [`read_binary`] or recovered by [`present`]).
fn binary_count(bytes: &[u8]) -> Option<u64> {
    let count = bytes
        .get(80..84)
        .map(|c| u64::from(u32::from_le_bytes([c[0], c[1], c[2], c[3]])));
    let exact = count.is_some_and(|n| {
        bytes.len() as u64 == BINARY_HEADER_BYTES as u64 + n * BINARY_TRIANGLE_BYTES as u64
    });
    let ascii = bytes.trim_ascii_start().starts_with(b"solid");
    let body = bytes.get(BINARY_HEADER_BYTES..).unwrap_or_default();
    let nul = body[..body.len().min(NUL_SCAN_BYTES)].contains(&0);
    if exact || !ascii || nul {
        Some(count.unwrap_or(0))
    } else {
        None
    }
}

/// The triangles a binary STL holds: the header's `count`, or more when the file is exactly
/// `84 + 50 × n` bytes for a larger `n` (see the module documentation).
fn present(bytes: &[u8], count: u64) -> u64 {
    let body = bytes.len().saturating_sub(BINARY_HEADER_BYTES) as u64;
    let whole = body / BINARY_TRIANGLE_BYTES as u64;
    if bytes.len() >= BINARY_HEADER_BYTES
        && body.is_multiple_of(BINARY_TRIANGLE_BYTES as u64)
        && whole > count
    {
        whole
    } else {
        count
    }
}

/// The warning for a binary STL whose header counts fewer triangles than the file holds
/// (all of them are read), or `None`. Costs a few byte reads: a cache hit warns too.
pub(crate) fn count_warning(bytes: &[u8]) -> Option<String> {
    let count = binary_count(bytes)?;
    let n = present(bytes, count);
    (n > count).then(|| {
        format!(
            "the binary STL header declares {count} triangles but the file holds {n} \
             ({} bytes = 84 + 50 × {n}); reading all {n}",
            bytes.len()
        )
    })
}

fn read_binary(
    bytes: &[u8],
    count: u64,
    add: &mut impl FnMut([f32; 3]) -> Result<(), Fault>,
) -> Result<(), Fault> {
    use MeshErrorKind::*;
    if bytes.len() < BINARY_HEADER_BYTES {
        return Err(Fault::at_byte(
            Truncated,
            bytes.len(),
            format!(
                "the file ends after {} bytes, expected an 84-byte binary STL header \
                 (or an ASCII STL starting with 'solid')",
                bytes.len()
            ),
        ));
    }
    let needed = BINARY_HEADER_BYTES as u128 + u128::from(count) * BINARY_TRIANGLE_BYTES as u128;
    if needed > bytes.len() as u128 {
        return Err(Fault::at_byte(
            Truncated,
            bytes.len(),
            format!(
                "the header says {count} triangles ({needed} bytes), but the file ends after {} bytes",
                bytes.len()
            ),
        ));
    }
    if needed < bytes.len() as u128 {
        // Not a whole number of records (a whole number was taken by `present`).
        let extra = bytes.len() as u128 - needed;
        return Err(Fault::at_byte(
            CountMismatch,
            needed as usize,
            format!(
                "{extra} bytes after the header's {count} triangles, and the file ({} bytes) is \
                 not 84 + 50 × n bytes for any n: a binary STL truncated or with data appended",
                bytes.len()
            ),
        ));
    }
    let body = &bytes[BINARY_HEADER_BYTES..needed as usize];
    for (t, record) in body.chunks_exact(BINARY_TRIANGLE_BYTES).enumerate() {
        for k in 0..3 {
            let at = 12 + 12 * k;
            let p = [0, 1, 2].map(|c| {
                let o = at + 4 * c;
                f32::from_le_bytes([record[o], record[o + 1], record[o + 2], record[o + 3]])
            });
            if !p.iter().all(|c| c.is_finite()) {
                return Err(Fault::at_byte(
                    NonFinite,
                    BINARY_HEADER_BYTES + t * BINARY_TRIANGLE_BYTES + at,
                    format!("triangle {t} corner {k} is {p:?}, expected finite coordinates"),
                ));
            }
            add(p)?;
        }
    }
    Ok(())
}

/// ASCII STL: `solid`, facets of `facet normal … / outer loop / vertex x y z … / endloop /
/// endfacet`, `endsolid`; several solids in one file are one mesh. Loops of more than three
/// vertices are fan-triangulated.
fn read_ascii(
    bytes: &[u8],
    add: &mut impl FnMut([f32; 3]) -> Result<(), Fault>,
) -> Result<(), Fault> {
    use MeshErrorKind::*;
    let mut loop_corners: Vec<[f32; 3]> = Vec::new();
    let mut in_loop: Option<u64> = None;
    let mut last = 0;
    for (line, text) in Lines::new(bytes) {
        last = line;
        let mut words = tokens(text);
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            b"vertex" => {
                if in_loop.is_none() {
                    return Err(Fault::at_line(
                        BadHeader,
                        line,
                        "'vertex' outside a facet, expected 'outer loop' first",
                    ));
                }
                let x = finite_f32(words.next(), line, "x")?;
                let y = finite_f32(words.next(), line, "y")?;
                let z = finite_f32(words.next(), line, "z")?;
                loop_corners.push([x, y, z]);
            }
            b"outer" => {
                in_loop = Some(line);
                loop_corners.clear();
            }
            b"endloop" => {
                let Some(start) = in_loop.take() else {
                    return Err(Fault::at_line(
                        BadHeader,
                        line,
                        "'endloop' without 'outer loop'",
                    ));
                };
                if loop_corners.len() < 3 {
                    return Err(Fault::at_line(
                        BadFace,
                        start,
                        format!(
                            "facet with {} vertices, expected at least 3",
                            loop_corners.len()
                        ),
                    ));
                }
                for pair in loop_corners[1..].windows(2) {
                    add(loop_corners[0])?;
                    add(pair[0])?;
                    add(pair[1])?;
                }
            }
            b"solid" | b"endsolid" | b"facet" | b"endfacet" => {}
            _ => {
                return Err(Fault::at_line(
                    BadHeader,
                    line,
                    format!(
                        "unknown keyword '{}', expected an ASCII STL keyword (solid, facet, \
                         outer loop, vertex, endloop, endfacet, endsolid)",
                        snippet(keyword)
                    ),
                ));
            }
        }
    }
    if let Some(start) = in_loop {
        return Err(Fault::at_line(
            Truncated,
            last,
            format!(
                "the file ends inside the facet loop opened on line {start}, expected 'endloop'"
            ),
        ));
    }
    Ok(())
}

/// A position's partition: a mix of its bits unrelated to the table's own hash.
fn partition(bits: [u32; 3], partitions: u64) -> usize {
    let mut h = u64::from(bits[0]) ^ (u64::from(bits[1]) << 21) ^ (u64::from(bits[2]) << 42);
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    (h % partitions) as usize
}

/// Steps 2 and 3 of the module documentation.
fn weld(spill: &File, corners: u64, sink: &mut CacheWriter, memory_budget: u64) -> io::Result<()> {
    let len = corners * 12;
    let map = FileBytes::open(spill, len, Backing::Temporary)?;
    let table_budget = (memory_budget / 2).max(TABLE_ENTRY_BYTES);
    let per_partition = (table_budget / TABLE_ENTRY_BYTES).max(1);
    let partitions = corners.div_ceil(per_partition).max(1);
    let bits_of = |c: &[u8]| -> [u32; 3] {
        [0, 4, 8].map(|o| u32::from_le_bytes([c[o], c[o + 1], c[o + 2], c[o + 3]]))
    };
    let mut id_files = Vec::new();
    for p in 0..partitions as usize {
        let mut table: HashMap<[u32; 3], u32> =
            HashMap::with_capacity(per_partition.min(corners) as usize);
        let mut ids = BufWriter::with_capacity(STREAM_BUFFER_BYTES, tempfile::tempfile()?);
        for corner in map.chunks_exact(12) {
            let bits = bits_of(corner);
            if partitions > 1 && partition(bits, partitions) != p {
                continue;
            }
            let next = sink.vertex_count() as u32;
            let id = *table.entry(bits).or_insert(next);
            if id == next {
                sink.vertex(bits.map(f32::from_bits))?;
            }
            ids.write_all(&id.to_le_bytes())?;
        }
        let mut file = ids.into_inner().map_err(|e| e.into_error())?;
        io::Seek::rewind(&mut file)?;
        id_files.push(BufReader::with_capacity(STREAM_BUFFER_BYTES, file));
    }
    let mut triangle = [0u32; 3];
    for (c, corner) in map.chunks_exact(12).enumerate() {
        let p = if partitions > 1 {
            partition(bits_of(corner), partitions)
        } else {
            0
        };
        let mut id = [0u8; 4];
        id_files[p].read_exact(&mut id)?;
        triangle[c % 3] = u32::from_le_bytes(id);
        if c % 3 == 2 {
            sink.triangle(triangle)?;
        }
    }
    Ok(())
}
