//! The tiling file (`patchvis tile INPUT -o T.ptile`): a mesh's tiling computed once and read
//! by every shard of a sharded bake (`patchvis bake --tiling-file T.ptile --shard I/N`), so
//! that N shards do not tile N times.
//!
//! It holds the tiling in the frame the bake samples in (`frame.rs`): the patch records and
//! the reordered triangle list, from which each triangle's patch follows. A separate step
//! rather than the first shard's output, so that every shard can start at once after it
//! (on a cluster: one tiling job, the array depending on it, the merge on the array).
//!
//! Layout, little-endian: magic `PVISTILE`, `u32` version, `u64` mesh hash
//! ([`super::fingerprint::mesh_hash`]), `u32` triangles, `u32` patches asked for
//! (`--patches`), `u32` patches, the tiling's statistics (`u32` components, merged
//! components, out of core (0 or 1), chunks) and quality (`u32` patches, triangles
//! min/median/max, `f64` compactness median and p95), the patch records (48 bytes each,
//! `wire.rs`), the reordered triangles (`u32` each), then the `u32` CRC-32C of every byte
//! before it. Written atomically; read streaming, into mapped maps when the tiling ran out of
//! core (as the tiling itself keeps them), so the heap does not grow with the mesh.

use super::wire::{Fields, PATCH_BYTES, Put};
use crate::runtime::crc32c::crc32c_append;
use crate::tiling::{Tiling, TilingQuality, TilingStats, TriangleMap};
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::Path;

const MAGIC: &[u8; 8] = b"PVISTILE";
/// The layout's version; bumped when it or the tiling's output changes.
const VERSION: u32 = 1;
const HEADER_BYTES: usize = 8 + 4 + 8 + 4 * 11 + 8 * 2;
/// Triangles streamed per read or write.
const CHUNK: usize = 1 << 16;
/// What a refused tiling file's message tells the user to do.
const TILE_AGAIN: &str = "run patchvis tile again";

/// A tiling read back from its file.
#[derive(Debug)]
pub struct TilingFile {
    /// The content hash of the mesh it tiles.
    pub mesh_hash: u64,
    /// The patch count asked for (`--patches`).
    pub patches_asked: u32,
    /// The tiling.
    pub tiling: Tiling,
}

/// Writes `tiling` of a mesh hashing to `mesh_hash`, tiled into `patches_asked` patches, to
/// `path` atomically.
pub fn write_tiling_file(
    path: &Path,
    mesh_hash: u64,
    patches_asked: u32,
    tiling: &Tiling,
) -> std::io::Result<()> {
    let mut file = crate::output::AtomicFile::create(path)?;
    {
        let mut out = Checksummed {
            out: BufWriter::new(file.file()),
            crc: 0,
        };
        let mut head = Vec::with_capacity(HEADER_BYTES + tiling.patches.len() * PATCH_BYTES);
        head.extend_from_slice(MAGIC);
        head.put_u32(VERSION);
        head.put_u64(mesh_hash);
        head.put_u32(tiling.order.len() as u32);
        head.put_u32(patches_asked);
        head.put_u32(tiling.patches.len() as u32);
        let (s, q) = (tiling.stats, tiling.quality);
        for v in [
            s.components,
            s.merged_components,
            u32::from(s.out_of_core),
            s.chunks,
        ] {
            head.put_u32(v);
        }
        for v in [
            q.patches,
            q.triangles_min,
            q.triangles_median,
            q.triangles_max,
        ] {
            head.put_u32(v);
        }
        head.put_u64(q.compactness_median.to_bits());
        head.put_u64(q.compactness_p95.to_bits());
        for p in &tiling.patches {
            head.put_patch(p);
        }
        out.write(&head)?;
        let mut chunk = Vec::with_capacity(CHUNK * 4);
        for triangles in tiling.order.chunks(CHUNK) {
            chunk.clear();
            for &t in triangles {
                chunk.put_u32(t);
            }
            out.write(&chunk)?;
        }
        let crc = out.crc;
        out.out.write_all(&crc.to_le_bytes())?;
        out.out.flush()?;
    }
    file.commit()
}

/// A writer that keeps the CRC-32C of what went through it.
struct Checksummed<W> {
    out: W,
    crc: u32,
}

impl<W: Write> Checksummed<W> {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.crc = crc32c_append(self.crc, bytes);
        self.out.write_all(bytes)
    }
}

/// Reads the tiling file at `path`, checking its magic, version, size, checksum and that its
/// records make a tiling (ranges adjacent from 0, every triangle once); the error says what
/// is wrong and what to do, without the path.
pub fn read_tiling_file(path: &Path) -> Result<TilingFile, String> {
    let (file, meta) =
        crate::mapped::open_regular(path).map_err(|e| format!("cannot read: {e}"))?;
    let mut input = BufReader::new(file);
    let length = meta.len();
    let mut head = vec![0; HEADER_BYTES];
    let not_ours = || {
        format!(
            "not a patchvis tiling file ({length} bytes, expected the magic PVISTILE); make one \
             with patchvis tile"
        )
    };
    input.read_exact(&mut head).map_err(|_| not_ours())?;
    let mut f = Fields::new(&head);
    if f.take(8) != Some(&MAGIC[..]) {
        return Err(not_ours());
    }
    let short = || format!("tiling file header cut short; {TILE_AGAIN}");
    let version = f.u32().ok_or_else(short)?;
    if version != VERSION {
        return Err(format!(
            "tiling file version {version}, expected {VERSION} (written by another patchvis \
             build); {TILE_AGAIN}"
        ));
    }
    let mesh_hash = f.u64().ok_or_else(short)?;
    let mut next = || f.u32().ok_or_else(short);
    let triangles = next()?;
    let patches_asked = next()?;
    let patch_count = next()?;
    let stats = TilingStats {
        components: next()?,
        merged_components: next()?,
        out_of_core: next()? != 0,
        chunks: next()?,
    };
    let (qp, qmin, qmed, qmax) = (next()?, next()?, next()?, next()?);
    let quality = TilingQuality {
        patches: qp,
        triangles_min: qmin,
        triangles_median: qmed,
        triangles_max: qmax,
        compactness_median: f64::from_bits(f.u64().ok_or_else(short)?),
        compactness_p95: f64::from_bits(f.u64().ok_or_else(short)?),
    };
    let expected = HEADER_BYTES as u64
        + u64::from(patch_count) * PATCH_BYTES as u64
        + u64::from(triangles) * 4
        + 4;
    if length != expected {
        return Err(format!(
            "tiling file is {length} bytes, expected {expected} for {triangles} triangles in \
             {patch_count} patches (cut short or damaged); {TILE_AGAIN}"
        ));
    }
    let mut crc = crc32c_append(0, &head);
    let mut records = vec![0; patch_count as usize * PATCH_BYTES];
    let io = |e: std::io::Error| format!("cannot read: {e}");
    input.read_exact(&mut records).map_err(io)?;
    crc = crc32c_append(crc, &records);
    let mut f = Fields::new(&records);
    let patches: Vec<_> = (0..patch_count).map_while(|_| f.patch()).collect();
    let mapped = stats.out_of_core;
    let fresh = |len: usize| {
        if mapped {
            TriangleMap::mapped_zeroed(len).map_err(|e| format!("cannot map a temporary file: {e}"))
        } else {
            Ok(TriangleMap::from_vec(vec![0; len]))
        }
    };
    let mut order = fresh(triangles as usize)?;
    let mut chunk = vec![0; CHUNK * 4];
    for part in order.chunks_mut(CHUNK) {
        let bytes = &mut chunk[..part.len() * 4];
        input.read_exact(bytes).map_err(io)?;
        crc = crc32c_append(crc, bytes);
        for (t, b) in part.iter_mut().zip(bytes.chunks_exact(4)) {
            *t = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        }
    }
    let mut tail = [0; 4];
    input.read_exact(&mut tail).map_err(io)?;
    if crc != u32::from_le_bytes(tail) {
        return Err(format!(
            "tiling file is damaged (checksum mismatch over its {length} bytes); {TILE_AGAIN}"
        ));
    }
    let mut patch_of = fresh(triangles as usize)?;
    patch_of.fill(u32::MAX);
    let mut first = 0u32;
    for (id, p) in patches.iter().enumerate() {
        let end = first.checked_add(p.count).filter(|&e| e <= triangles);
        let (true, Some(end)) = (p.first == first, end) else {
            return Err(format!(
                "patch {id}'s triangles do not follow the previous patch's; {TILE_AGAIN}"
            ));
        };
        for &t in &order[first as usize..end as usize] {
            match patch_of.get_mut(t as usize) {
                Some(slot) if *slot == u32::MAX => *slot = id as u32,
                _ => {
                    return Err(format!(
                        "triangle {t} is out of range or in two patches; {TILE_AGAIN}"
                    ));
                }
            }
        }
        first = end;
    }
    if first != triangles {
        return Err(format!(
            "the patches hold {first} of the {triangles} triangles; {TILE_AGAIN}"
        ));
    }
    Ok(TilingFile {
        mesh_hash,
        patches_asked,
        tiling: Tiling {
            patch_of,
            order,
            patches,
            stats,
            quality,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_kit::meshes::grid;

    #[test]
    fn a_tiling_reads_back_and_damage_is_refused() {
        let mesh = grid(9, 7, 0.2, 3, |_, _| false).mesh();
        let tiling = crate::tiling::tile(&mesh, 6).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.ptile");
        write_tiling_file(&path, 42, 6, &tiling).unwrap();
        let back = read_tiling_file(&path).unwrap();
        assert_eq!((back.mesh_hash, back.patches_asked), (42, 6));
        assert_eq!(back.tiling, tiling);
        let bytes = std::fs::read(&path).unwrap();
        for bit in (0..bytes.len() * 8).step_by(7) {
            let mut damaged = bytes.clone();
            damaged[bit / 8] ^= 1 << (bit % 8);
            std::fs::write(&path, &damaged).unwrap();
            assert!(read_tiling_file(&path).is_err(), "bit {bit}");
        }
        for len in [0, 7, HEADER_BYTES, bytes.len() - 1] {
            std::fs::write(&path, &bytes[..len]).unwrap();
            assert!(read_tiling_file(&path).is_err(), "{len} bytes");
        }
    }
}
