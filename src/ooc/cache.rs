//! The conversion cache: every input that cannot be served in place is converted once,
//! streaming, into this crate's own mesh layout in a file, and that file is mapped.
//!
//! Layout (all little-endian), a `.pvmesh` file:
//!
//! | offset | size | field |
//! | --- | --- | --- |
//! | 0 | 8 | magic `PVMESH` 0 [`CACHE_VERSION`] |
//! | 8 | 8 | source file length, bytes (`u64`) |
//! | 16 | 8 | XXH64 (seed 0) of the source's bytes (`u64`) |
//! | 24 | 4 | reserved, 0 |
//! | 28 | 4 | vertex count `V` (`u32`) |
//! | 32 | 4 | triangle count `T` (`u32`) |
//! | 36 | 24 | bounds: min x, y, z, max x, y, z (`f32`) |
//! | 60 | 4 | length `P` of the source's canonical path (`u32`) |
//! | 64 | P, padded to 4 | the canonical path, UTF-8 lossy |
//! | … | 12 V | vertices: `f32 x, y, z` |
//! | … | 12 T | triangles: `u32 a, b, c` |
//! | … | 8 | XXH64 (seed 0) of every byte before it (`u64`) |
//!
//! The bounds are those of every vertex, as converted; a mesh's own bounds are those of the
//! vertices its triangles use, found when it is opened (`Mesh::bounds`). The checksum is
//! checked at every open, like a checkpoint's: a cache damaged on disk (one flipped exponent
//! bit moves a vertex by a factor of 2³²) is converted again, never baked. It costs one more
//! pass over the cache when it is written and one when it is opened, at memory speed (XXH64).
//!
//! A cache is keyed by the input's canonical path (the file name is a 64-bit FNV-1a hash of
//! it; the stored path guards against collisions), its length and a hash of all its bytes:
//! an edit anywhere makes a new conversion, even one that keeps the length and restores the
//! modification time. The hash (XXH64, the `xxhash-rust` crate) costs one pass over the input at memory speed:
//! about 7% more for a conversion, and a cache hit reads the input once (0.2 ns per byte when
//! it is in the page cache) instead of not at all.
//! A file's conversion replaces its previous one (same name), so edits do not pile up caches.
//!
//! Writing is atomic: the file is built under a temporary name in the cache directory
//! (`.pvmesh-tmp-<pid>-…`) and renamed into place when complete, so a crash or a concurrent
//! bake never sees half a cache. A process killed while converting leaves its temporary file
//! behind; the next conversion in the directory removes it ([`remove_stale_temporaries`]).
//! Triangles are spilled to a second, unnamed temporary file while vertices stream into the
//! first (inputs may give faces before, between or after vertices) and appended at the end
//! with a kernel-side copy.
//!
//! Memory: two fixed write buffers ([`WRITE_BUFFER_BYTES`] each), whatever the mesh size;
//! only the page cache grows. Where no cache directory is usable, or the finished file cannot
//! be renamed into place, the same file is used unnamed and mapped, so the mesh still opens
//! (without reuse).

use std::fs::{self, File};
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use super::Bounds;
use xxhash_rust::xxh64::xxh64;

/// Bumped whenever the layout or a converter's output changes, so stale caches are rebuilt.
/// Version 2 keys by content (a hash) instead of modification time; version 3 ends in a
/// checksum.
pub(crate) const CACHE_VERSION: u8 = 3;
/// Bytes of the checksum that ends a cache file.
const CHECKSUM_BYTES: usize = 8;
const MAGIC: [u8; 7] = *b"PVMESH\0";
/// Fixed part of the header, before the path.
const HEADER_BYTES: usize = 64;
/// Write buffer per output stream: large sequential writes, fixed memory.
const WRITE_BUFFER_BYTES: usize = 1 << 20;
/// Bytes per vertex and per triangle record.
pub(crate) const RECORD_BYTES: usize = 12;

/// Prefix of the temporary files a conversion writes in the cache directory; the process id
/// and a random part follow.
const TEMP_PREFIX: &str = ".pvmesh-tmp-";
/// A temporary file in the cache directory that nobody has written for this long is left
/// over from a killed conversion, even where the process that wrote it cannot be checked.
const STALE_TEMP_AGE: Duration = Duration::from_secs(3600);

/// Which file a cache is for: the input's canonical path and length, known before its bytes
/// are read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct CacheSource {
    path: String,
    len: u64,
}

impl CacheSource {
    /// The source at `path`, of `len` bytes.
    pub(crate) fn of(path: &Path, len: u64) -> io::Result<CacheSource> {
        let canonical = fs::canonicalize(path)?;
        Ok(CacheSource {
            path: canonical.to_string_lossy().into_owned(),
            len,
        })
    }

    /// The full key, with the hash of `bytes` (the file's contents).
    pub(crate) fn key(self, bytes: &[u8]) -> CacheKey {
        CacheKey {
            path: self.path,
            len: self.len,
            content: xxh64(bytes, 0),
        }
    }
}

/// What a cache file is for: the input's canonical path, length and content hash.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct CacheKey {
    pub(crate) path: String,
    pub(crate) len: u64,
    /// XXH64 of every byte of the input.
    pub(crate) content: u64,
}

impl CacheKey {
    /// The cache file's name in the cache directory.
    pub(crate) fn file_name(&self) -> String {
        // FNV-1a, 64-bit: stable across Rust versions, unlike the std hasher.
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in self.path.bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        format!("{h:016x}.v{CACHE_VERSION}.pvmesh")
    }
}

/// The default cache directory: `$XDG_CACHE_HOME/patchvis`, else `$HOME/.cache/patchvis`, else
/// `patchvis-cache` in the temporary directory.
pub fn default_cache_dir() -> PathBuf {
    let nonempty = |k| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if let Some(dir) = nonempty("XDG_CACHE_HOME") {
        return dir.join("patchvis");
    }
    if let Some(home) = nonempty("HOME") {
        return home.join(".cache").join("patchvis");
    }
    std::env::temp_dir().join("patchvis-cache")
}

/// Bytes of the header and the padded path.
fn data_offset(path_len: usize) -> usize {
    HEADER_BYTES + path_len.next_multiple_of(4)
}

/// A validated view of a cache file's header.
pub(crate) struct CacheHeader {
    pub(crate) vertex_count: u32,
    pub(crate) triangle_count: u32,
    /// Offset of vertex 0.
    pub(crate) vertices_at: usize,
}

/// Reads a cache file's header; `None` unless it is complete, current, whole (its checksum)
/// and made from `key`. Index ranges are checked by the caller.
pub(crate) fn read_header(bytes: &[u8], key: Option<&CacheKey>) -> Option<CacheHeader> {
    let head = bytes.get(..HEADER_BYTES)?;
    let u32_at = |at: usize| u32::from_le_bytes(head[at..at + 4].try_into().unwrap());
    if head[..7] != MAGIC || head[7] != CACHE_VERSION {
        return None;
    }
    let path_len = u32_at(60) as usize;
    let vertices_at = data_offset(path_len);
    if let Some(key) = key {
        let stored = CacheKey {
            path: String::from_utf8_lossy(bytes.get(HEADER_BYTES..HEADER_BYTES + path_len)?)
                .into_owned(),
            len: u64::from_le_bytes(head[8..16].try_into().unwrap()),
            content: u64::from_le_bytes(head[16..24].try_into().unwrap()),
        };
        if stored != *key {
            return None;
        }
    }
    let (vertex_count, triangle_count) = (u32_at(28), u32_at(32));
    let expected = vertices_at as u64
        + RECORD_BYTES as u64 * (u64::from(vertex_count) + u64::from(triangle_count))
        + CHECKSUM_BYTES as u64;
    if bytes.len() as u64 != expected {
        return None;
    }
    let (body, stored) = bytes.split_at(bytes.len() - CHECKSUM_BYTES);
    if xxh64(body, 0) != u64::from_le_bytes(stored.try_into().ok()?) {
        return None;
    }
    Some(CacheHeader {
        vertex_count,
        triangle_count,
        vertices_at,
    })
}

/// Where a conversion goes.
enum Target {
    /// Renamed to `final_path` when complete.
    Named {
        tmp: tempfile::NamedTempFile,
        final_path: PathBuf,
    },
    /// An unnamed temporary file, mapped and then forgotten.
    Anonymous(File),
}

/// Streams a converted mesh into a cache file.
pub(crate) struct CacheWriter {
    target: Target,
    key: Option<CacheKey>,
    vertices: BufWriter<File>,
    triangles: BufWriter<File>,
    vertex_count: u64,
    triangle_count: u64,
    data_at: usize,
}

impl CacheWriter {
    /// Starts a cache for `key` in `dir` (created if needed, and cleared of what killed
    /// conversions left); with no directory, or when it cannot be written, an unnamed
    /// temporary file.
    pub(crate) fn create(dir: Option<&Path>, key: Option<CacheKey>) -> io::Result<CacheWriter> {
        let named = match (dir, &key) {
            (Some(dir), Some(key)) => fs::create_dir_all(dir)
                .and_then(|()| {
                    remove_stale_temporaries(dir);
                    tempfile::Builder::new()
                        .prefix(&format!("{TEMP_PREFIX}{}-", std::process::id()))
                        .tempfile_in(dir)
                })
                .ok()
                .map(|tmp| (tmp, dir.join(key.file_name()))),
            _ => None,
        };
        let (target, file, spill) = match named {
            Some((tmp, final_path)) => {
                let file = tmp.as_file().try_clone()?;
                let spill = tempfile::tempfile_in(final_path.parent().unwrap_or(Path::new(".")))?;
                (Target::Named { tmp, final_path }, file, spill)
            }
            None => {
                let file = tempfile::tempfile()?;
                (
                    Target::Anonymous(file.try_clone()?),
                    file,
                    tempfile::tempfile()?,
                )
            }
        };
        let path_len = key.as_ref().map_or(0, |k| k.path.len());
        let data_at = data_offset(path_len);
        let mut vertices = BufWriter::with_capacity(WRITE_BUFFER_BYTES, file);
        // Placeholder header and the path; the header is rewritten in `finish`.
        vertices.write_all(&vec![0u8; data_at])?;
        Ok(CacheWriter {
            target,
            key,
            vertices,
            triangles: BufWriter::with_capacity(WRITE_BUFFER_BYTES, spill),
            vertex_count: 0,
            triangle_count: 0,
            data_at,
        })
    }

    /// Appends vertex number `vertex_count()`.
    #[inline]
    pub(crate) fn vertex(&mut self, p: [f32; 3]) -> io::Result<()> {
        let mut record = [0u8; RECORD_BYTES];
        for (field, c) in record.chunks_exact_mut(4).zip(p) {
            field.copy_from_slice(&c.to_le_bytes());
        }
        self.vertex_count += 1;
        self.vertices.write_all(&record)
    }

    /// Appends a triangle; its indices must be checked against the final vertex count by the
    /// caller before [`finish`](Self::finish).
    #[inline]
    pub(crate) fn triangle(&mut self, t: [u32; 3]) -> io::Result<()> {
        let mut record = [0u8; RECORD_BYTES];
        for (field, i) in record.chunks_exact_mut(4).zip(t) {
            field.copy_from_slice(&i.to_le_bytes());
        }
        self.triangle_count += 1;
        self.triangles.write_all(&record)
    }

    /// Vertices written so far.
    pub(crate) fn vertex_count(&self) -> u64 {
        self.vertex_count
    }
    /// Triangles written so far.
    pub(crate) fn triangle_count(&self) -> u64 {
        self.triangle_count
    }

    /// Completes the file: triangles appended, header written, renamed into place. Returns the
    /// finished file, ready to map. Counts must fit `u32` (checked by the converters).
    pub(crate) fn finish(self, bounds: Bounds) -> io::Result<File> {
        let mut file = self.vertices.into_inner().map_err(|e| e.into_error())?;
        let mut spill = self.triangles.into_inner().map_err(|e| e.into_error())?;
        spill.seek(SeekFrom::Start(0))?;
        file.seek(SeekFrom::End(0))?;
        io::copy(&mut spill, &mut file)?;
        drop(spill);

        let mut head = vec![0u8; self.data_at];
        head[..7].copy_from_slice(&MAGIC);
        head[7] = CACHE_VERSION;
        if let Some(key) = &self.key {
            head[8..16].copy_from_slice(&key.len.to_le_bytes());
            head[16..24].copy_from_slice(&key.content.to_le_bytes());
            head[60..64].copy_from_slice(&(key.path.len() as u32).to_le_bytes());
            head[HEADER_BYTES..HEADER_BYTES + key.path.len()].copy_from_slice(key.path.as_bytes());
        }
        head[28..32].copy_from_slice(&(self.vertex_count as u32).to_le_bytes());
        head[32..36].copy_from_slice(&(self.triangle_count as u32).to_le_bytes());
        for (i, c) in bounds.min.iter().chain(&bounds.max).enumerate() {
            head[36 + 4 * i..40 + 4 * i].copy_from_slice(&c.to_le_bytes());
        }
        file.seek(SeekFrom::Start(0))?;
        file.write_all(&head)?;
        let checksum = checksum(&mut file)?;
        file.seek(SeekFrom::End(0))?;
        file.write_all(&checksum.to_le_bytes())?;
        file.flush()?;
        match self.target {
            Target::Named { tmp, final_path } => {
                drop(file);
                // Someone removed the temporary file (e.g. took it for a killed conversion's)
                // or the directory went read-only: the open handle still holds the whole
                // file, so the mesh opens, only without reuse.
                Ok(tmp
                    .persist(&final_path)
                    .unwrap_or_else(|e| e.file.into_file()))
            }
            Target::Anonymous(file) => Ok(file),
        }
    }
}

/// XXH64 (seed 0) of every byte of `file`, read from its start through a fixed buffer.
fn checksum(file: &mut File) -> io::Result<u64> {
    file.seek(SeekFrom::Start(0))?;
    let mut hasher = xxhash_rust::xxh64::Xxh64::new(0);
    let mut buffer = vec![0u8; WRITE_BUFFER_BYTES];
    loop {
        let n = io::Read::read(file, &mut buffer)?;
        if n == 0 {
            return Ok(hasher.digest());
        }
        hasher.update(&buffer[..n]);
    }
}

/// Removes from the cache directory `dir` the temporary files of conversions that were killed:
/// those whose process is gone (where `/proc` tells), and any nobody wrote for
/// [`STALE_TEMP_AGE`] (also the unprefixed `.tmp…` names of cache version 1). Best effort:
/// errors are ignored, and a live conversion whose file is removed still finishes (see
/// [`CacheWriter::finish`]). Cost: one directory listing per conversion.
pub(crate) fn remove_stale_temporaries(dir: &Path) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    let now = SystemTime::now();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let ours = name.strip_prefix(TEMP_PREFIX);
        if ours.is_none() && !name.starts_with(".tmp") {
            continue;
        }
        let Ok(metadata) = entry.metadata() else {
            continue;
        };
        if !metadata.is_file() {
            continue;
        }
        let idle = metadata
            .modified()
            .ok()
            .and_then(|m| now.duration_since(m).ok())
            .is_some_and(|idle| idle > STALE_TEMP_AGE);
        let writer_gone = ours
            .and_then(|rest| rest.split('-').next())
            .and_then(|pid| pid.parse::<u32>().ok())
            .is_some_and(process_is_gone);
        if idle || writer_gone {
            let _ = fs::remove_file(entry.path());
        }
    }
}

/// True when no process `pid` runs, as far as `/proc` can tell; false where there is no
/// `/proc` (the age rule then applies alone).
fn process_is_gone(pid: u32) -> bool {
    pid != std::process::id()
        && Path::new("/proc/self").exists()
        && !Path::new("/proc").join(pid.to_string()).exists()
}
