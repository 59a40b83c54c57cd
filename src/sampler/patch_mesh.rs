//! The mesh regrouped patch by patch for tiled sampling: each patch's distinct vertices in
//! one contiguous run and its triangles as indices into that run, on the heap or, for meshes
//! that would not fit the memory budget, in a memory-mapped temporary file.
//!
//! A view then transforms only the vertices of the patches it draws, and a patch's vertices
//! and triangles sit together in memory, so skipped patches cost nothing and drawn ones stream
//! through the cache. Vertices on a patch border appear once per patch that uses them (about
//! `2·sqrt(triangles per patch)` extra per patch); both copies hold the same `f32` position,
//! so they project to bit-identical screen vertices and the mesh stays watertight.
//!
//! **Storage.** The copy is about 18 bytes per triangle (12 per triangle, 12 per patch
//! vertex): 360 MB at 20M triangles, more than a 512 MiB budget can hold next to everything
//! else. [`Storage::Mapped`] writes it, batch of patches after batch, to an unlinked temporary
//! file and maps that read-only: the kernel's page cache holds it, the heap holds only one
//! batch while it is built and the per-patch offsets afterwards. Views read it through the
//! same slices either way, patch by patch in file order, so a view's reads are sequential
//! runs of the file.
//!
//! This file's only `unsafe` code views the mapped bytes as `[f32; 3]` / `[u32; 3]`.
//! Cost: one pass over the triangles plus a sort per patch.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::ops::Deref;

use memmap2::Mmap;
use rayon::prelude::*;

use crate::ooc::Mesh;
use crate::tiling::Tiling;

/// Bytes per regrouped triangle (three `u32` corners) and per patch vertex (three `f32`).
const RECORD_BYTES: usize = 12;

/// Triangles regrouped per batch when the result goes to a mapped file: bounds the heap the
/// build needs (about 60 bytes per triangle in flight: corners, their sorted copy, positions)
/// to a few tens of MB, while batches stay large enough to keep every thread busy.
const MAPPED_BATCH_TRIANGLES: usize = 1 << 19;

/// Where the regrouped mesh lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Storage {
    /// In heap vectors.
    Heap,
    /// In an unlinked, memory-mapped temporary file (in `$TMPDIR` or `/tmp`).
    Mapped,
}

impl Storage {
    /// Heap when the copy takes at most a quarter of `budget` (the rest is for the per-thread
    /// buffers, the tiling's maps and the allocator's slack), mapped otherwise; heap when
    /// there is no budget.
    pub(crate) fn for_budget(triangles: u64, budget: Option<u64>) -> Storage {
        match budget {
            Some(budget) if estimated_bytes(triangles) > budget / 4 => Storage::Mapped,
            _ => Storage::Heap,
        }
    }
}

/// The regrouped mesh's expected size: 12 bytes per triangle and, on a typical mesh (half
/// as many vertices as triangles, plus the border copies), about 6 more for vertices.
pub(crate) fn estimated_bytes(triangles: u64) -> u64 {
    triangles.saturating_mul(18)
}

/// Records of one kind (`[f32; 3]` or `[u32; 3]`) on the heap or in a mapped file.
#[derive(Debug)]
enum Records<T: Plain> {
    Heap(Vec<T>),
    /// `len` records at the start of `map`; the file behind it is unlinked, so this process
    /// holds the only handle to it.
    Mapped {
        map: Mmap,
        len: usize,
    },
}

/// Three 32-bit numbers: 4-byte aligned, 12 bytes, every bit pattern valid.
trait Plain: Copy + Default + std::fmt::Debug {
    fn write_to(&self, out: &mut impl Write) -> io::Result<()>;
}

impl Plain for [f32; 3] {
    fn write_to(&self, out: &mut impl Write) -> io::Result<()> {
        for x in self {
            out.write_all(&x.to_ne_bytes())?;
        }
        Ok(())
    }
}

impl Plain for [u32; 3] {
    fn write_to(&self, out: &mut impl Write) -> io::Result<()> {
        for x in self {
            out.write_all(&x.to_ne_bytes())?;
        }
        Ok(())
    }
}

impl<T: Plain> Deref for Records<T> {
    type Target = [T];
    #[inline]
    fn deref(&self) -> &[T] {
        match self {
            Records::Heap(v) => v,
            Records::Mapped { map, len } => {
                let bytes: &[u8] = &map[..len * RECORD_BYTES];
                // SAFETY: `T` is `[f32; 3]` or `[u32; 3]` (the sealed `Plain`): 12 bytes,
                // align 4, every bit pattern valid. A mapping starts on a page boundary, so
                // the pointer is aligned; `bytes` holds exactly `len` records, written in
                // native byte order by `Sink::push`; the slice borrows `self`, so the map
                // outlives it, and nothing writes the unlinked file while it is mapped.
                unsafe { std::slice::from_raw_parts(bytes.as_ptr().cast::<T>(), *len) }
            }
        }
    }
}

/// Where records go while the mesh is regrouped.
enum Sink<T: Plain> {
    Heap(Vec<T>),
    File { out: BufWriter<File>, len: usize },
}

impl<T: Plain> Sink<T> {
    fn new(storage: Storage) -> io::Result<Sink<T>> {
        Ok(match storage {
            Storage::Heap => Sink::Heap(Vec::new()),
            Storage::Mapped => Sink::File {
                out: BufWriter::with_capacity(1 << 20, tempfile::tempfile()?),
                len: 0,
            },
        })
    }

    fn push(&mut self, records: &[T]) -> io::Result<()> {
        match self {
            Sink::Heap(v) => v.extend_from_slice(records),
            Sink::File { out, len } => {
                for r in records {
                    r.write_to(out)?;
                }
                *len += records.len();
            }
        }
        Ok(())
    }

    fn len(&self) -> usize {
        match self {
            Sink::Heap(v) => v.len(),
            Sink::File { len, .. } => *len,
        }
    }

    fn finish(self) -> io::Result<Records<T>> {
        match self {
            Sink::Heap(v) => Ok(Records::Heap(v)),
            // An empty file cannot be mapped on every system; nothing to map anyway.
            Sink::File { len: 0, .. } => Ok(Records::Heap(Vec::new())),
            Sink::File { out, len } => {
                let file = out.into_inner().map_err(|e| e.into_error())?;
                // SAFETY: `tempfile()` returns an already unlinked file (or one opened with
                // exclusive sharing where unlinking open files is impossible): no other
                // process or handle can change it while the map lives, and the map keeps its
                // own reference to the file.
                let map = unsafe { Mmap::map(&file)? };
                Ok(Records::Mapped { map, len })
            }
        }
    }
}

/// One patch's distinct vertices and its triangles' corners as indices into them.
type PatchPart = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// Vertices and triangles grouped by patch; triangle `first + k` of patch `p` (in the tiling's
/// order) is input triangle `order[first + k]`.
#[derive(Debug)]
pub(crate) struct PatchMesh {
    /// Distinct vertices of every patch, patch after patch.
    positions: Records<[f32; 3]>,
    /// `positions[vertex_start[p]..vertex_start[p + 1]]` are patch `p`'s vertices.
    vertex_start: Vec<usize>,
    /// Corners of reordered triangle `i`, as indices into its patch's vertex run.
    triangles: Records<[u32; 3]>,
    /// `triangle_start[p]..triangle_start[p + 1]` are patch `p`'s reordered triangles.
    triangle_start: Vec<usize>,
}

impl PatchMesh {
    /// Regroups `mesh` by the patches of `tiling` (which must be a tiling of `mesh`) into
    /// `storage`. Fails only if a mapped copy's temporary file cannot be created or written.
    pub(crate) fn new(mesh: &Mesh, tiling: &Tiling, storage: Storage) -> io::Result<PatchMesh> {
        let batch_triangles = match storage {
            Storage::Heap => usize::MAX,
            Storage::Mapped => MAPPED_BATCH_TRIANGLES,
        };
        PatchMesh::build(mesh, tiling, storage, batch_triangles)
    }

    /// [`Self::new`], regrouping `batch_triangles` triangles (whole patches, at least one) at
    /// a time.
    fn build(
        mesh: &Mesh,
        tiling: &Tiling,
        storage: Storage,
        batch_triangles: usize,
    ) -> io::Result<PatchMesh> {
        assert_eq!(
            tiling.order.len(),
            mesh.triangle_count() as usize,
            "the tiling must cover the mesh's triangles"
        );
        let part = |p: usize| -> PatchPart {
            let patch = &tiling.patches[p];
            let range = patch.first as usize..(patch.first + patch.count) as usize;
            let corners: Vec<[u32; 3]> = tiling.order[range]
                .iter()
                .map(|&t| mesh.triangle(t))
                .collect();
            let mut distinct: Vec<u32> = corners.iter().flatten().copied().collect();
            distinct.sort_unstable();
            distinct.dedup();
            let local = |v: u32| distinct.binary_search(&v).unwrap_or(0) as u32;
            let triangles = corners.iter().map(|c| c.map(local)).collect();
            let positions = distinct.iter().map(|&v| mesh.position(v)).collect();
            (positions, triangles)
        };
        let patch_count = tiling.patches.len();
        let mut positions = Sink::new(storage)?;
        let mut triangles = Sink::new(storage)?;
        let mut vertex_start = Vec::with_capacity(patch_count + 1);
        let mut triangle_start = Vec::with_capacity(patch_count + 1);
        vertex_start.push(0);
        triangle_start.push(0);
        let mut first = 0;
        while first < patch_count {
            // Whole patches up to the batch size (at least one, however large).
            let mut end = first + 1;
            let mut in_batch = tiling.patches[first].count as usize;
            while end < patch_count {
                let next = tiling.patches[end].count as usize;
                if in_batch.saturating_add(next) > batch_triangles {
                    break;
                }
                in_batch += next;
                end += 1;
            }
            let parts: Vec<PatchPart> = (first..end).into_par_iter().map(part).collect();
            for (p, t) in parts {
                positions.push(&p)?;
                triangles.push(&t)?;
                vertex_start.push(positions.len());
                triangle_start.push(triangles.len());
            }
            first = end;
        }
        Ok(PatchMesh {
            positions: positions.finish()?,
            vertex_start,
            triangles: triangles.finish()?,
            triangle_start,
        })
    }

    /// Number of patches.
    pub(crate) fn patch_count(&self) -> usize {
        self.vertex_start.len() - 1
    }

    /// Patch `p`'s vertices.
    pub(crate) fn vertices(&self, p: usize) -> &[[f32; 3]] {
        &self.positions[self.vertex_start[p]..self.vertex_start[p + 1]]
    }

    /// Patch `p`'s triangles (local corner indices) and the reordered index of the first.
    pub(crate) fn triangles(&self, p: usize) -> (usize, &[[u32; 3]]) {
        let start = self.triangle_start[p];
        (start, &self.triangles[start..self.triangle_start[p + 1]])
    }

    /// Bytes of the regrouped mesh, wherever it lives.
    #[cfg(test)]
    pub(crate) fn bytes(&self) -> usize {
        (self.positions.len() + self.triangles.len()) * RECORD_BYTES
            + (self.vertex_start.len() + self.triangle_start.len()) * 8
    }

    /// Heap bytes held: [`Self::bytes`] on the heap, the per-patch offsets when mapped.
    #[cfg(test)]
    pub(crate) fn heap_bytes(&self) -> usize {
        let offsets = (self.vertex_start.len() + self.triangle_start.len()) * 8;
        match (&self.positions, &self.triangles) {
            (Records::Heap(_), Records::Heap(_)) => self.bytes(),
            (Records::Heap(p), _) => offsets + p.len() * RECORD_BYTES,
            (_, Records::Heap(t)) => offsets + t.len() * RECORD_BYTES,
            _ => offsets,
        }
    }

    /// True when the vertices and triangles live in a mapped file.
    #[cfg(test)]
    pub(crate) fn is_mapped(&self) -> bool {
        matches!(self.triangles, Records::Mapped { .. })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::test_meshes::noisy_sphere;

    #[test]
    fn mapped_and_heap_copies_hold_the_same_patches() {
        let mesh = noisy_sphere(30, 60, 0.3, 7);
        let tiling = crate::tiling::tile(&mesh, 40).unwrap();
        let heap = PatchMesh::new(&mesh, &tiling, Storage::Heap).unwrap();
        // Small batches, so that the file is written in many pieces.
        let mapped = PatchMesh::build(&mesh, &tiling, Storage::Mapped, 500).unwrap();
        assert!(!heap.is_mapped() && mapped.is_mapped());
        assert_eq!(heap.patch_count(), tiling.patches.len());
        assert_eq!(mapped.patch_count(), tiling.patches.len());
        assert!(mapped.heap_bytes() < heap.heap_bytes() / 10);
        assert_eq!(mapped.bytes(), heap.bytes());
        for p in 0..heap.patch_count() {
            assert_eq!(heap.vertices(p), mapped.vertices(p));
            assert_eq!(heap.triangles(p), mapped.triangles(p));
            // The regrouped triangles are the tiling's, corner for corner.
            let (first, tris) = heap.triangles(p);
            for (k, local) in tris.iter().enumerate() {
                let input = mesh.triangle(tiling.order[first + k]);
                let expect = input.map(|v| mesh.position(v));
                assert_eq!(local.map(|v| heap.vertices(p)[v as usize]), expect);
            }
        }
    }

    #[test]
    fn the_budget_picks_the_storage() {
        assert_eq!(Storage::for_budget(20_000_000, None), Storage::Heap);
        assert_eq!(
            Storage::for_budget(20_000_000, Some(512 << 20)),
            Storage::Mapped
        );
        assert_eq!(Storage::for_budget(100_000, Some(512 << 20)), Storage::Heap);
    }
}
