//! Per-view evaluation of a `.pvis` against the mesh it was baked from: render everything,
//! render only what the query returns, compare.
//!
//! Both renders carry triangle ids (the identity `patch_of`), so a pixel "differs" exactly when
//! the reconstruction shows another triangle there, or none. The reconstruction draws a
//! compacted sub-mesh of the kept triangles, in their original order and with their original
//! vertex positions: the rasterizer then picks the same winner in every pixel whose winner was
//! kept (its depth test keeps the first of equally near fragments, and the order is preserved),
//! and its run time is what a renderer drawing only the culled set would pay — the seed
//! paper's frame-cost comparison with the CPU rasterizer standing in for the GPU.
//! Cost per view: two renders, one query, one pass over the triangles (to select) and one over
//! the pixels (to compare).

use super::metrics;
use super::shade::{RgbImage, Shader, face_normals};
use crate::ooc::Mesh;
use crate::progress::Progress;
use crate::runtime::Pvis;
use crate::sampler::{Camera, IdBuffer, NO_PATCH, Rasterizer, SamplingParams};
use crate::tiling::{self, PatchId, Tiling};
use rayon::prelude::*;
use std::collections::{HashMap, VecDeque};
use std::time::Instant;

/// Why a `.pvis` cannot be evaluated against a mesh.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EvalError {
    /// The file covers another number of triangles than the mesh has.
    #[error(
        "the file covers {file} triangles but the mesh has {mesh}: the file was not baked from this mesh"
    )]
    TriangleCount {
        /// Triangles in the file.
        file: u64,
        /// Triangles in the mesh.
        mesh: u32,
    },
    /// Re-tiling the mesh gave other patches than the file holds.
    #[error(
        "patch {patch}: the file has triangles {file_first}+{file_count}, re-tiling the mesh gives {mesh_first}+{mesh_count} (or other bounds): the file was not baked from this mesh with these settings"
    )]
    PatchMismatch {
        /// First differing patch.
        patch: u32,
        /// Its first triangle in the file.
        file_first: u32,
        /// Its triangle count in the file.
        file_count: u32,
        /// Its first triangle after re-tiling.
        mesh_first: u32,
        /// Its triangle count after re-tiling.
        mesh_count: u32,
    },
    /// Tiling the mesh failed.
    #[error("tiling the mesh failed: {0}")]
    Tiling(#[from] tiling::TilingError),
    /// A temporary file for the renumbered tiling could not be written.
    #[error("cannot write a temporary file for the tiling: {0}")]
    TempFile(String),
    /// Sampling the mesh (`eval --sweep`'s bakes) failed; the sampler's error as text, so
    /// that this error stays `Clone` and comparable. Only a checkpoint file makes sampling
    /// fail, and the sweep writes none.
    #[error("sampling the mesh failed: {0}")]
    Sampling(String),
}

/// What one view shows: the full render against the render of the query's answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewMetrics {
    /// Eye position (model space) the query was asked for.
    pub eye: [f32; 3],
    /// Whether the query found the eye inside the sampling sphere.
    pub inside_sphere: bool,
    /// Pixels the full render covers.
    pub covered_pixels: u64,
    /// Pixels whose triangle differs between the full render and the reconstruction.
    pub missed_pixels: u64,
    /// Patches the full render shows.
    pub visible_patches: u32,
    /// Patches the query returns.
    pub answer_patches: u32,
    /// Patches the full render shows that the query does not return.
    pub missed_patches: u32,
    /// Triangles of the returned patches: what a renderer draws.
    pub triangles_drawn: u64,
    /// Fraction of the mesh's triangles not drawn.
    pub culling_rate: f64,
    /// Fraction of triangles in patches the full render does not show: the best any patch
    /// visibility answer could cull at this view.
    pub ideal_culling_rate: f64,
    /// PSNR (dB) of the shaded reconstruction against the shaded full render; `+∞` when equal.
    pub psnr_db: f64,
    /// Seconds to render the whole mesh.
    pub full_seconds: f64,
    /// Seconds to render the culled set.
    pub culled_seconds: f64,
}

/// The renders of one view as pictures.
#[derive(Clone, Debug)]
pub struct Pictures {
    /// The whole mesh, shaded.
    pub full: RgbImage,
    /// Only the patches the query returns, shaded.
    pub reconstruction: RgbImage,
    /// The full render dimmed, with the missed pixels in red.
    pub difference: RgbImage,
}

/// A mesh, the tiling of it that a `.pvis` was baked with, and what evaluation needs per
/// triangle. Holds no reference to the file, so one evaluator serves several files baked with
/// the same patch count (`sweep`).
pub struct Evaluator<'m> {
    mesh: &'m Mesh,
    tiling: Tiling,
    patch_triangles: Vec<u32>,
    identity: Vec<u32>,
    normals: Vec<[f32; 3]>,
}

impl<'m> Evaluator<'m> {
    /// Re-derives the triangle → patch map of `pvis` by tiling `mesh` again (tiling is
    /// deterministic) and matching every patch record of the file — triangle count, bounding
    /// sphere, normal cone, bit for bit — to one of the tiling's, in whatever numbering the
    /// file uses (see `match_tiling`).
    pub fn new(mesh: &'m Mesh, pvis: &Pvis<'_>) -> Result<Evaluator<'m>, EvalError> {
        if pvis.triangle_count() != u64::from(mesh.triangle_count()) {
            return Err(EvalError::TriangleCount {
                file: pvis.triangle_count(),
                mesh: mesh.triangle_count(),
            });
        }
        let tiling = tiling::tile(mesh, pvis.patch_count())?;
        let order = match_tiling(&tiling, pvis)?;
        let tiling = tiling
            .renumbered(&order)
            .map_err(|e| EvalError::TempFile(e.to_string()))?;
        Ok(Evaluator::from_tiling(mesh, tiling))
    }

    /// An evaluator for files baked from `mesh` with `tiling` (unchecked: the caller made both).
    pub fn from_tiling(mesh: &'m Mesh, tiling: Tiling) -> Evaluator<'m> {
        Evaluator {
            mesh,
            patch_triangles: tiling.patches.iter().map(|p| p.count).collect(),
            tiling,
            identity: (0..mesh.triangle_count()).collect(),
            normals: face_normals(mesh),
        }
    }

    /// The mesh.
    pub fn mesh(&self) -> &'m Mesh {
        self.mesh
    }

    /// The tiling the files were baked with: patch ranges into its reordered mesh.
    pub fn tiling(&self) -> &Tiling {
        &self.tiling
    }

    /// Number of patches.
    pub fn patch_count(&self) -> u32 {
        self.patch_triangles.len() as u32
    }

    /// Evaluates every camera (in parallel, one view per task); the result is in camera order.
    pub fn evaluate(
        &self,
        pvis: &Pvis<'_>,
        cameras: &[Camera],
        progress: &dyn Progress,
    ) -> Vec<ViewMetrics> {
        assert_eq!(
            pvis.patch_count(),
            self.patch_count(),
            "the file and the evaluator differ in patch count"
        );
        progress.start("eval", cameras.len() as u64);
        let out = cameras
            .par_iter()
            .map_init(
                || Scratch::new(pvis),
                |scratch, camera| {
                    let metrics = self.view(pvis, camera, scratch);
                    progress.inc(1);
                    metrics
                },
            )
            .collect();
        progress.finish();
        out
    }

    /// The pictures of one view (renders it again).
    pub fn pictures(&self, pvis: &Pvis<'_>, camera: &Camera) -> Pictures {
        let mut scratch = Scratch::new(pvis);
        self.view(pvis, camera, &mut scratch);
        let shader = Shader::new(&self.normals, camera.forward());
        let resolution = camera.resolution();
        let (full, rec) = (scratch.full.ids(), scratch.reconstruction.ids());
        Pictures {
            full: shader.image(full, resolution),
            reconstruction: shader.image(rec, resolution),
            difference: shader.difference(full, rec, resolution),
        }
    }

    fn view(&self, pvis: &Pvis<'_>, camera: &Camera, s: &mut Scratch) -> ViewMetrics {
        let mesh = self.mesh;
        let eye = camera.eye().map(|c| c as f32);
        if s.full.resolution() != camera.resolution() {
            s.full = IdBuffer::new(camera.resolution());
            s.reconstruction = IdBuffer::new(camera.resolution());
        }

        s.full.clear();
        let start = Instant::now();
        s.rasterizer
            .render(mesh, &self.identity, camera, &mut s.full);
        let full_seconds = start.elapsed().as_secs_f64();

        let visible = pvis.query(eye, &mut s.scratch);
        let inside_sphere = visible.inside_sphere;
        let answer_patches = visible.count();
        s.answer.fill(0);
        for (word, &bits) in s.answer.iter_mut().zip(visible.bits()) {
            *word = bits;
        }
        let culled = self.culled_mesh(|p| visible.contains(p), &mut s.remap);

        s.reconstruction.clear();
        let culled_seconds = match &culled {
            Some((sub, ids)) => {
                let start = Instant::now();
                s.rasterizer.render(sub, ids, camera, &mut s.reconstruction);
                start.elapsed().as_secs_f64()
            }
            None => 0.0,
        };
        let triangles_drawn = culled.as_ref().map_or(0, |(_, ids)| ids.len() as u64);

        // Compare, collect the truly visible patches, and sum the shaded error.
        s.seen.fill(0);
        let shader = Shader::new(&self.normals, camera.forward());
        let (mut covered, mut missed, mut squared_error) = (0u64, 0u64, 0u64);
        let mut previous = NO_PATCH;
        for (&a, &b) in s.full.ids().iter().zip(s.reconstruction.ids()) {
            if a != NO_PATCH {
                covered += 1;
                if a != previous {
                    previous = a;
                    let p = self.tiling.patch_of[a as usize];
                    s.seen[p as usize / 64] |= 1 << (p % 64);
                }
            }
            if a != b {
                missed += 1;
                let (x, y) = (shader.colour(a), shader.colour(b));
                squared_error += (0..3)
                    .map(|k| u64::from(x[k].abs_diff(y[k])).pow(2))
                    .sum::<u64>();
            }
        }
        let pixels = s.full.ids().len() as f64;
        let answer = s.answer.as_slice();
        let (mut visible_patches, mut missed_patches, mut visible_triangles) = (0, 0, 0u64);
        for (w, &word) in s.seen.iter().enumerate() {
            visible_patches += word.count_ones();
            missed_patches += (word & !answer[w]).count_ones();
            let mut bits = word;
            while bits != 0 {
                let p = w * 64 + bits.trailing_zeros() as usize;
                visible_triangles += u64::from(self.patch_triangles[p]);
                bits &= bits - 1;
            }
        }
        let total = f64::from(mesh.triangle_count());
        ViewMetrics {
            eye,
            inside_sphere,
            covered_pixels: covered,
            missed_pixels: missed,
            visible_patches,
            answer_patches,
            missed_patches,
            triangles_drawn,
            culling_rate: 1.0 - triangles_drawn as f64 / total,
            ideal_culling_rate: 1.0 - visible_triangles as f64 / total,
            psnr_db: metrics::psnr(squared_error as f64 / (pixels * 3.0)),
            full_seconds,
            culled_seconds,
        }
    }

    /// The triangles whose patch `keep` accepts, as a compact mesh (only the vertices they
    /// use) in their original order, with their original triangle indices as ids; `None` if
    /// nothing is kept.
    fn culled_mesh(
        &self,
        keep: impl Fn(PatchId) -> bool,
        remap: &mut Vec<u32>,
    ) -> Option<(Mesh, Vec<u32>)> {
        let mesh = self.mesh;
        remap.clear();
        remap.resize(mesh.vertex_count() as usize, u32::MAX);
        let (mut positions, mut triangles, mut ids) = (Vec::new(), Vec::new(), Vec::new());
        for t in 0..mesh.triangle_count() {
            if !keep(self.tiling.patch_of[t as usize]) {
                continue;
            }
            let corners = mesh.triangle(t).map(|v| {
                let slot = &mut remap[v as usize];
                if *slot == u32::MAX {
                    *slot = positions.len() as u32;
                    positions.push(mesh.position(v));
                }
                *slot
            });
            triangles.push(corners);
            ids.push(t);
        }
        if triangles.is_empty() {
            return None;
        }
        // The positions and indices come from a validated mesh, so this cannot fail.
        let sub = Mesh::from_memory("culled", positions, triangles).ok()?;
        Some((sub, ids))
    }
}

/// Per-worker buffers.
struct Scratch {
    rasterizer: Rasterizer,
    full: IdBuffer,
    reconstruction: IdBuffer,
    /// The query's scratch space.
    scratch: Vec<u64>,
    /// The answer's bits, one row.
    answer: Vec<u64>,
    /// The patches the full render shows, one row.
    seen: Vec<u64>,
    remap: Vec<u32>,
}

impl Scratch {
    fn new(pvis: &Pvis<'_>) -> Scratch {
        Scratch {
            rasterizer: Rasterizer::new(),
            full: IdBuffer::new(1),
            reconstruction: IdBuffer::new(1),
            scratch: vec![0; pvis.scratch_words()],
            answer: vec![0; pvis.row_words()],
            seen: vec![0; pvis.row_words()],
            remap: Vec::new(),
        }
    }
}

/// The file's numbering of the patches of `tiling`: `order[i]` is the tiling patch that the
/// file calls `i`. Patches are matched by their records (triangle count, bounding sphere and
/// normal cone, bit for bit), so files that renumber their patches (`bake --patch-order
/// covisibility`, the default) match as well as files in the tiling's own numbering; equal
/// records are matched in id order. Fails on the first file patch nothing matches.
fn match_tiling(tiling: &Tiling, pvis: &Pvis<'_>) -> Result<Vec<PatchId>, EvalError> {
    type Key = (u32, [u32; 3], u32, [u32; 3], u32);
    let key = |count: u32, center: [f32; 3], radius: f32, axis: [f32; 3], cos: f32| -> Key {
        (
            count,
            center.map(f32::to_bits),
            radius.to_bits(),
            axis.map(f32::to_bits),
            cos.to_bits(),
        )
    };
    let mut unmatched: HashMap<Key, VecDeque<PatchId>> = HashMap::new();
    for (id, m) in tiling.patches.iter().enumerate() {
        unmatched
            .entry(key(m.count, m.center, m.radius, m.cone_axis, m.cone_cos))
            .or_default()
            .push_back(id as PatchId);
    }
    let count = pvis.patch_count();
    let mut order = Vec::with_capacity(count as usize);
    for p in 0..count {
        let f = pvis.patch(p);
        let found = unmatched
            .get_mut(&key(
                f.triangle_count,
                f.center,
                f.radius,
                f.cone_axis,
                f.cone_cos,
            ))
            .and_then(VecDeque::pop_front);
        match found {
            Some(id) => order.push(id),
            None => {
                let mesh = tiling.patches.get(p as usize);
                return Err(EvalError::PatchMismatch {
                    patch: p,
                    file_first: f.first_triangle,
                    file_count: f.triangle_count,
                    mesh_first: mesh.map_or(0, |m| m.first),
                    mesh_count: mesh.map_or(0, |m| m.count),
                });
            }
        }
    }
    if order.len() != tiling.patches.len() {
        let mesh = tiling.patches.get(order.len());
        return Err(EvalError::PatchMismatch {
            patch: count,
            file_first: 0,
            file_count: 0,
            mesh_first: mesh.map_or(0, |m| m.first),
            mesh_count: mesh.map_or(0, |m| m.count),
        });
    }
    Ok(order)
}

/// The sampling parameters stored in `pvis`, rendered at `resolution` with the cameras
/// `distance_scale` times as far from the centre as the sampling cameras.
pub fn sampling_params(pvis: &Pvis<'_>, resolution: u32, distance_scale: f32) -> SamplingParams {
    let s = pvis.sampling();
    SamplingParams {
        level: s.level,
        resolution,
        fov_deg: s.fov_deg,
        center: s.center,
        // The camera distance is radius / sin(fov / 2): scaling the radius scales it. At scale
        // 1 this is the bake's own camera, bit for bit.
        radius: s.radius * distance_scale,
    }
}
