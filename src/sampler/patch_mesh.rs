//! The mesh regrouped patch by patch for tiled sampling: each patch's distinct vertices in
//! one contiguous run and its triangles as 16-bit indices into that run, on the heap or, for
//! meshes that would not fit the memory budget, in a memory-mapped temporary file.
//!
//! A view then transforms only the vertices of the patches it draws, and a patch's vertices
//! and triangles sit together in memory, so skipped patches cost nothing and drawn ones stream
//! through the cache. Vertices on a patch border appear once per patch that uses them (about
//! `2·sqrt(triangles per patch)` extra per patch); both copies hold the same `f32` position,
//! so they project to bit-identical screen vertices and the mesh stays watertight.
//!
//! **Blocks.** A section's vertices are stored four to a block, `[x0..x3, y0..y3, z0..z3]`
//! ([`PointBlock`], the last block filled with copies of the last vertex), so that the
//! projection's four lanes of a coordinate are one plain load: as `[f32; 3]` records they
//! took twelve single loads and nine shuffles per four vertices.
//!
//! **Sections.** A patch's triangles are cut, in the tiling's order, into *sections* of at
//! most [`SECTION_VERTICES`] distinct vertices (65,536: one section per patch unless a patch
//! holds more than about 130,000 triangles), each with its own vertex run, so that a corner
//! is a `u16`. That halves the bytes a view streams per triangle (6 instead of 12), and the
//! sampler looks corners up in a 65,536-entry table without bounds checks (measured in
//! docs/benchmarks/sampling.md). A section border duplicates
//! vertices the way a patch border does, with the same bits.
//!
//! **Clusters.** A section's vertices are numbered by first use, and its triangles are cut
//! into runs of [`CLUSTER_TRIANGLES`] with a bounding sphere each: the first `k` runs use a
//! prefix of the vertices, so a view that tests clusters one after the other projects only
//! as far as the ones it draws need (at 6.4M triangles, 31 % of the clusters of the patches
//! a view tests are hidden by their sphere).
//!
//! **Storage.** The copy is about 12 bytes per triangle (6 per triangle, 12 per patch
//! vertex): 240 MB at 20M triangles, more than a 512 MiB budget can hold next to everything
//! else. [`Storage::Mapped`] writes it, batch of patches after batch, to an unlinked temporary
//! file and maps that read-only: the kernel's page cache holds it, the heap holds only one
//! batch while it is built and the per-section offsets afterwards. Views read it through the
//! same slices either way, patch by patch in file order, so a view's reads are sequential
//! runs of the file.
//!
//! Both storages are the crate's record arrays (`crate::mapped::{Array, RecordWriter}`),
//! which own the temporary file and its map: this file holds no `unsafe` code.
//! Cost: one pass over the triangles plus a sort per patch.

use std::io;

use bytemuck::Pod;
use rayon::prelude::*;

use crate::mapped::{Array, RecordWriter};
use crate::memory::SamplingShare;
use crate::ooc::Mesh;
use crate::tiling::{Tiling, bounding_sphere};

/// Most distinct vertices in one section: what a `u16` corner can index.
pub(crate) const SECTION_VERTICES: usize = 1 << 16;

/// The section size the build uses: small under `cfg(test)`, so that the tests' meshes have
/// patches of several sections.
const BUILD_SECTION_VERTICES: usize = if cfg!(test) { 100 } else { SECTION_VERTICES };

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
    /// Heap when the copy fits the mesh copy's part of the sampler's `share`
    /// (`MemoryBudget::split`: the rest is for the per-thread buffers, the tiling's maps and
    /// the allocator's slack) and, built whole with its vectors growing by doubling, next to
    /// the sampler's `other_needs` ([`crate::memory::FixedNeeds::sampling`]); mapped
    /// otherwise; heap when there is no budget.
    pub(crate) fn for_budget(
        triangles: u64,
        share: Option<SamplingShare>,
        other_needs: u64,
    ) -> Storage {
        let copy = estimated_bytes(triangles);
        match share {
            Some(share)
                if copy > share.mesh_copy
                    || copy.saturating_mul(2).saturating_add(other_needs) > share.total =>
            {
                Storage::Mapped
            }
            _ => Storage::Heap,
        }
    }

    /// An empty writer for records kept in this storage.
    fn writer<T: Pod>(self) -> io::Result<RecordWriter<T>> {
        match self {
            Storage::Heap => Ok(RecordWriter::heap()),
            Storage::Mapped => RecordWriter::temp_file(),
        }
    }
}

/// The regrouped mesh's expected size: 6 bytes per triangle and, on a typical mesh (half
/// as many vertices as triangles, plus the border copies), about 6 more for vertices.
pub(crate) fn estimated_bytes(triangles: u64) -> u64 {
    triangles.saturating_mul(12)
}

/// One patch's sections: each one's distinct vertices, its triangles' corners as indices
/// into them, and its clusters.
type PatchPart = Vec<(Vec<[f32; 3]>, Vec<[u16; 3]>, Vec<Cluster>)>;

/// Triangles per cluster: a run of a section's triangles, in the tiling's order, with its
/// own bounding sphere, tested as a whole against a view's occlusion tiles before its
/// triangles are looped over. Small in tests, so that their patches have many.
pub(crate) const CLUSTER_TRIANGLES: usize = if cfg!(test) { 16 } else { 256 };

/// A run of a section's triangles: the sphere around their corners, where the run ends, and
/// the range of the section's vertices (numbered by first use) that holds its corners.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cluster {
    /// Bounding-sphere centre.
    pub(crate) center: [f32; 3],
    /// Bounding-sphere radius (holds every corner in `f32`).
    pub(crate) radius: f32,
    /// End of the run in the section's triangles.
    pub(crate) triangle_end: u32,
    /// The run's smallest corner index: its corners lie in `vertex_start..vertex_end`, so
    /// the screen extent of that range bounds the run's triangles (with a few vertices of
    /// earlier runs; measured on a 1M-triangle grid, such an extent hides 93 % of the
    /// triangles that the run's exact one hides).
    pub(crate) vertex_start: u32,
    /// The run's and all earlier runs' corners are below this.
    pub(crate) vertex_end: u32,
}

impl Cluster {
    /// The section vertices that hold the run's corners (and maybe a few more).
    pub(crate) fn vertices(&self) -> std::ops::Range<usize> {
        self.vertex_start as usize..self.vertex_end as usize
    }
}

/// The clusters of a section's `triangles` over its `positions`.
fn clusters(positions: &[[f32; 3]], triangles: &[[u16; 3]]) -> Vec<Cluster> {
    let mut vertex_end = 0;
    let mut corners = Vec::with_capacity(3 * CLUSTER_TRIANGLES);
    let mut out = Vec::with_capacity(triangles.len().div_ceil(CLUSTER_TRIANGLES));
    for (k, run) in triangles.chunks(CLUSTER_TRIANGLES).enumerate() {
        corners.clear();
        let mut vertex_start = u32::MAX;
        for &i in run.iter().flatten() {
            vertex_start = vertex_start.min(u32::from(i));
            vertex_end = vertex_end.max(u32::from(i) + 1);
            corners.push(positions[usize::from(i)]);
        }
        let (center, radius) = bounding_sphere(&corners);
        out.push(Cluster {
            center,
            radius,
            triangle_end: (k * CLUSTER_TRIANGLES + run.len()) as u32,
            vertex_start,
            vertex_end,
        });
    }
    out
}

/// Vertices and triangles grouped by patch and section; triangle `first + k` of patch `p` (in
/// the tiling's order, across its sections) is input triangle `order[first + k]`.
#[derive(Debug)]
pub(crate) struct PatchMesh {
    /// Distinct vertices of every section, four to a block, section after section, patch
    /// after patch.
    positions: Array<PointBlock>,
    /// `positions[block_start[s]..block_start[s + 1]]` are section `s`'s vertices.
    block_start: Vec<usize>,
    /// Corners of reordered triangle `i`, as indices into its section's vertex run.
    triangles: Array<[u16; 3]>,
    /// `triangle_start[s]..triangle_start[s + 1]` are section `s`'s reordered triangles.
    triangle_start: Vec<usize>,
    /// `section_start[p]..section_start[p + 1]` are patch `p`'s sections.
    section_start: Vec<usize>,
    /// Every section's clusters, section after section (on the heap: 28 bytes per
    /// [`CLUSTER_TRIANGLES`] triangles).
    clusters: Vec<Cluster>,
    /// `clusters[cluster_start[s]..cluster_start[s + 1]]` are section `s`'s clusters.
    cluster_start: Vec<usize>,
}

/// Four points as `[x0, x1, x2, x3, y0, …, z3]`: the projection's lanes are three plain
/// loads.
pub(crate) type PointBlock = [f32; 12];

/// `points` four to a block, the last block filled up with copies of the last point.
pub(crate) fn to_blocks(points: &[[f32; 3]]) -> Vec<PointBlock> {
    points
        .chunks(4)
        .map(|chunk| {
            let at = |i: usize| chunk[i.min(chunk.len() - 1)];
            std::array::from_fn(|k| at(k % 4)[k / 4])
        })
        .collect()
}

/// A section's vertices, four to a [`PointBlock`]; its length is a whole number of blocks
/// (the copies at the end are never a triangle's corner).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Points<'a> {
    blocks: &'a [PointBlock],
}

impl<'a> Points<'a> {
    /// The vertices in blocks of four.
    pub(crate) fn blocks(self) -> &'a [PointBlock] {
        self.blocks
    }

    /// How many vertices, a multiple of 4.
    pub(crate) fn len(self) -> usize {
        self.blocks.len() * 4
    }

    /// Vertex `i`.
    #[inline]
    pub(crate) fn get(self, i: usize) -> [f32; 3] {
        let (block, lane) = (&self.blocks[i / 4], i % 4);
        [block[lane], block[4 + lane], block[8 + lane]]
    }

    /// Every vertex, in order.
    pub(crate) fn iter(self) -> impl Iterator<Item = [f32; 3]> + 'a {
        (0..self.len()).map(move |i| self.get(i))
    }
}

/// One section of a patch: its vertices and its triangles' corners, indices into them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Section<'a> {
    /// The section's distinct vertices (at most [`SECTION_VERTICES`]).
    pub(crate) vertices: Points<'a>,
    /// The section's triangles.
    pub(crate) triangles: &'a [[u16; 3]],
    /// The section's clusters, in order (every triangle in one).
    pub(crate) clusters: &'a [Cluster],
}

impl<'a> Section<'a> {
    /// The triangles of cluster `c`.
    #[inline(always)]
    pub(crate) fn run(&self, c: usize) -> &'a [[u16; 3]] {
        let start = match c {
            0 => 0,
            _ => self.clusters[c - 1].triangle_end as usize,
        };
        &self.triangles[start..self.clusters[c].triangle_end as usize]
    }
}

/// Cuts the triangles `corners` (global vertex indices, in order) into runs of at most
/// `max_vertices` distinct vertices each, and returns every run's vertices (global indices,
/// in order of first use) and its corners as indices into them.
fn sections(corners: &[[u32; 3]], max_vertices: usize) -> Vec<(Vec<u32>, Vec<[u16; 3]>)> {
    assert!((3..=SECTION_VERTICES).contains(&max_vertices));
    let mut out = Vec::new();
    let mut start = 0;
    while start < corners.len() {
        // Fast path: the whole rest fits (always so for patches of under 21,846 triangles).
        let mut end = corners.len();
        if 3 * (end - start) > max_vertices {
            let mut seen = std::collections::HashSet::new();
            end = start;
            while end < corners.len() {
                let new = corners[end].iter().filter(|v| !seen.contains(*v)).count();
                if seen.len() + new > max_vertices {
                    break;
                }
                seen.extend(corners[end]);
                end += 1;
            }
        }
        let run = &corners[start..end];
        let mut sorted: Vec<u32> = run.iter().flatten().copied().collect();
        sorted.sort_unstable();
        sorted.dedup();
        // Local numbers in order of first use, so that the vertices of the first `k`
        // triangles are a prefix of the run (what lets a view project a section's clusters
        // one after the other).
        let mut rank = vec![u32::MAX; sorted.len()];
        let mut distinct = Vec::with_capacity(sorted.len());
        let triangles = run
            .iter()
            .map(|c| {
                c.map(|v| {
                    let s = sorted.binary_search(&v).unwrap_or(0);
                    if rank[s] == u32::MAX {
                        rank[s] = distinct.len() as u32;
                        distinct.push(v);
                    }
                    rank[s] as u16
                })
            })
            .collect();
        out.push((distinct, triangles));
        start = end;
    }
    out
}

impl PatchMesh {
    /// Regroups `mesh` by the patches of `tiling` (which must be a tiling of `mesh`) into
    /// `storage`. Fails only if a mapped copy's temporary file cannot be created or written.
    pub(crate) fn new(mesh: &Mesh, tiling: &Tiling, storage: Storage) -> io::Result<PatchMesh> {
        let batch_triangles = match storage {
            Storage::Heap => usize::MAX,
            Storage::Mapped => MAPPED_BATCH_TRIANGLES,
        };
        PatchMesh::build(
            mesh,
            tiling,
            storage,
            batch_triangles,
            BUILD_SECTION_VERTICES,
        )
    }

    /// [`Self::new`], regrouping `batch_triangles` triangles (whole patches, at least one) at
    /// a time into sections of at most `section_vertices` vertices.
    fn build(
        mesh: &Mesh,
        tiling: &Tiling,
        storage: Storage,
        batch_triangles: usize,
        section_vertices: usize,
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
            sections(&corners, section_vertices)
                .into_iter()
                .map(|(distinct, triangles)| {
                    let positions: Vec<[f32; 3]> =
                        distinct.iter().map(|&v| mesh.position(v)).collect();
                    let clusters = clusters(&positions, &triangles);
                    (positions, triangles, clusters)
                })
                .collect()
        };
        let patch_count = tiling.patches.len();
        let mut positions = storage.writer()?;
        let mut triangles = storage.writer()?;
        let mut block_start = Vec::with_capacity(patch_count + 1);
        let mut triangle_start = Vec::with_capacity(patch_count + 1);
        let mut section_start = Vec::with_capacity(patch_count + 1);
        let (mut clusters, mut cluster_start) = (Vec::new(), vec![0]);
        block_start.push(0);
        triangle_start.push(0);
        section_start.push(0);
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
            for sections in parts {
                for (p, t, c) in sections {
                    positions.push(&to_blocks(&p))?;
                    triangles.push(&t)?;
                    clusters.extend_from_slice(&c);
                    cluster_start.push(clusters.len());
                    block_start.push(positions.len());
                    triangle_start.push(triangles.len());
                }
                section_start.push(block_start.len() - 1);
            }
            first = end;
        }
        Ok(PatchMesh {
            positions: positions.finish()?,
            block_start,
            triangles: triangles.finish()?,
            triangle_start,
            section_start,
            clusters,
            cluster_start,
        })
    }

    /// Number of patches.
    pub(crate) fn patch_count(&self) -> usize {
        self.section_start.len() - 1
    }

    /// Patch `p`'s vertices: its sections' runs, one after the other (each with the
    /// copies that fill its last block).
    pub(crate) fn vertices(&self, p: usize) -> impl Iterator<Item = [f32; 3]> + '_ {
        self.sections(p).flat_map(|s| s.vertices.iter())
    }

    /// Patch `p`'s sections, in order.
    pub(crate) fn sections(&self, p: usize) -> impl Iterator<Item = Section<'_>> {
        (self.section_start[p]..self.section_start[p + 1]).map(|s| Section {
            vertices: Points {
                blocks: &self.positions[self.block_start[s]..self.block_start[s + 1]],
            },
            triangles: &self.triangles[self.triangle_start[s]..self.triangle_start[s + 1]],
            clusters: &self.clusters[self.cluster_start[s]..self.cluster_start[s + 1]],
        })
    }

    /// The reordered index of patch `p`'s first triangle.
    #[cfg(test)]
    fn first_triangle(&self, p: usize) -> usize {
        self.triangle_start[self.section_start[p]]
    }

    /// Bytes of the regrouped mesh, wherever it lives.
    #[cfg(test)]
    pub(crate) fn bytes(&self) -> usize {
        self.positions.len() * 48 + self.triangles.len() * 6 + self.offset_bytes()
    }

    /// Heap bytes of the per-section and per-patch offsets and of the clusters.
    #[cfg(test)]
    fn offset_bytes(&self) -> usize {
        (self.block_start.len() + self.triangle_start.len() + self.section_start.len()) * 8
            + self.cluster_start.len() * 8
            + self.clusters.len() * std::mem::size_of::<Cluster>()
    }

    /// Heap bytes held: [`Self::bytes`] on the heap, the offsets and clusters when mapped.
    #[cfg(test)]
    pub(crate) fn heap_bytes(&self) -> usize {
        let on_heap = |mapped: bool, bytes: usize| if mapped { 0 } else { bytes };
        self.offset_bytes()
            + on_heap(self.positions.is_mapped(), self.positions.len() * 48)
            + on_heap(self.triangles.is_mapped(), self.triangles.len() * 6)
    }

    /// True when the vertices and triangles live in a mapped file.
    #[cfg(test)]
    pub(crate) fn is_mapped(&self) -> bool {
        self.triangles.is_mapped()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_kit::meshes::noisy_sphere;

    #[test]
    fn mapped_and_heap_copies_hold_the_same_patches() {
        let mesh = noisy_sphere(30, 60, 0.3, 7);
        let tiling = crate::tiling::tile(&mesh, 40).unwrap();
        let heap = PatchMesh::new(&mesh, &tiling, Storage::Heap).unwrap();
        // Small batches, so that the file is written in many pieces.
        let mapped = PatchMesh::build(&mesh, &tiling, Storage::Mapped, 500, 100).unwrap();
        assert!(!heap.is_mapped() && mapped.is_mapped());
        assert_eq!(heap.patch_count(), tiling.patches.len());
        assert_eq!(mapped.patch_count(), tiling.patches.len());
        // Mapped, the heap holds only the offsets and the clusters (28 bytes per 256
        // triangles outside tests, where clusters are small).
        assert_eq!(mapped.heap_bytes(), mapped.offset_bytes());
        assert!(mapped.heap_bytes() < heap.heap_bytes() / 4);
        assert_eq!(mapped.bytes(), heap.bytes());
        let mut multi_section = 0;
        for p in 0..heap.patch_count() {
            assert!(heap.vertices(p).eq(mapped.vertices(p)));
            assert!(heap.sections(p).eq(mapped.sections(p)));
            multi_section += usize::from(heap.sections(p).count() > 1);
            // The regrouped triangles are the tiling's, corner for corner, across sections.
            let first = heap.first_triangle(p);
            for s in heap.sections(p) {
                check_clusters(&s);
            }
            let local = heap.sections(p).flat_map(|s| {
                assert!(s.vertices.len() <= 100);
                s.triangles
                    .iter()
                    .map(move |t| t.map(|v| s.vertices.get(v as usize)))
            });
            let input = (first..).map(|k| mesh.triangle(tiling.order[k]).map(|v| mesh.position(v)));
            let count = tiling.patches[p].count as usize;
            assert!(local.eq(input.take(count)));
        }
        assert!(
            multi_section > 0,
            "the test mesh must have patches of several sections"
        );
    }

    /// A section's clusters cover its triangles in runs of [`CLUSTER_TRIANGLES`], each
    /// sphere holds its run's corners, and each run uses only vertices below its
    /// `vertex_end`, which is the smallest such bound (first-use numbering), and from its
    /// `vertex_start` up, the run's smallest corner.
    fn check_clusters(s: &Section) {
        let mut start = 0;
        for c in s.clusters {
            let end = c.triangle_end as usize;
            assert!(end > start && end - start <= CLUSTER_TRIANGLES);
            let used = s.triangles[..end]
                .iter()
                .flatten()
                .map(|&i| u32::from(i) + 1);
            assert_eq!(used.max(), Some(c.vertex_end));
            let run = s.triangles[start..end]
                .iter()
                .flatten()
                .map(|&i| u32::from(i));
            assert_eq!(run.min(), Some(c.vertex_start));
            for &i in s.triangles[start..end].iter().flatten() {
                let q = s.vertices.get(usize::from(i));
                let d2: f32 = (0..3).map(|k| (q[k] - c.center[k]).powi(2)).sum();
                assert!(d2 <= c.radius * c.radius);
            }
            start = end;
        }
        assert_eq!(start, s.triangles.len());
    }

    #[test]
    fn sections_hold_at_most_their_vertex_limit() {
        // A strip of triangles: each adds one new vertex after the first.
        let corners: Vec<[u32; 3]> = (0..1000).map(|i| [i, i + 1, i + 2]).collect();
        for limit in [3, 4, 10, 999, 1002, 4000] {
            let sections = sections(&corners, limit);
            let mut k = 0;
            for (distinct, tris) in &sections {
                assert!(distinct.len() <= limit && !tris.is_empty());
                for t in tris {
                    assert_eq!(t.map(|v| distinct[v as usize]), corners[k]);
                    k += 1;
                }
            }
            assert_eq!(k, corners.len());
            // Greedy: each section but the last is full (one more triangle would not fit).
            let expected = if limit >= 1002 {
                1
            } else {
                1000usize.div_ceil(limit - 2)
            };
            assert_eq!(sections.len(), expected, "limit {limit}");
        }
    }

    fn share(total: u64) -> SamplingShare {
        crate::memory::MemoryBudget::new(total).split().sampling
    }

    #[test]
    fn the_budget_picks_the_storage() {
        assert_eq!(Storage::for_budget(20_000_000, None, 0), Storage::Heap);
        assert_eq!(
            Storage::for_budget(20_000_000, Some(share(512 << 20)), 0),
            Storage::Mapped
        );
        assert_eq!(
            Storage::for_budget(100_000, Some(share(512 << 20)), 0),
            Storage::Heap
        );
        // A copy that fits its share but not beside the sampler's other needs is mapped.
        assert_eq!(
            Storage::for_budget(100_000, Some(share(8 << 20)), 7 << 20),
            Storage::Mapped
        );
    }
}
