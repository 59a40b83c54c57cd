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
use super::shade::{RgbImage, Shader, face_normal};
use crate::bake::BakeError;
use crate::format::{RecordKey, record_key, stored_record};
use crate::memory::MemoryBudget;
use crate::ooc::{Mesh, MeshError, OpenOptions};
use crate::progress::Progress;
use crate::runtime::{PatchInfo, Pvis};
use crate::sampler::{Camera, IdBuffer, NO_PATCH, Rasterizer};
use crate::tiling::{self, Patch, PatchId, Tiling, TilingMode, TilingOptions, TriangleMap};
use crate::visibility::SamplingParams;
use rayon::prelude::*;
use std::collections::{HashMap, VecDeque};
use std::ops::Range;
use std::path::Path;
use std::time::Instant;

/// What the full render shows at a pixel, given the reconstruction's fragment there: the
/// full render's triangle `a`, unless the reconstruction's `b` lies at the same depth within
/// [`DEPTH_TIE_ULPS`] (a depth tie, won by `a` only through drawing order or rounding: at the
/// rim where a front face and the back face folded under it meet, or where two parts touch
/// along a shared plane and their interpolated depths differ in the last bits). Either is
/// then a true picture of the mesh there, so the pixel counts as showing `b`: a tie is not a
/// visible part culled.
fn tie_resolved(a: u32, b: u32, a_depth: f32, b_depth: f32) -> u32 {
    let tied = a_depth.to_bits().abs_diff(b_depth.to_bits()) <= DEPTH_TIE_ULPS;
    if a != b && a != NO_PATCH && b != NO_PATCH && tied {
        b
    } else {
        a
    }
}

/// Depths (positive `f32`, so their bit patterns order like them) this many units in the
/// last place apart or closer count as a tie. Two triangles in one plane interpolate the
/// same pixel's depth 1–2 ulps apart; 4 ulps of a depth at the sampling distance is a few
/// millionths of the model's size, far below any gap a model means.
const DEPTH_TIE_ULPS: u32 = 4;

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
    /// The mesh is neither in the file's patch order with the file's bounds (a `--mesh-out`
    /// mesh) nor tiles into the file's patches. The message says which of the patch's
    /// values differ, and what to evaluate instead.
    #[error("{}", patch_mismatch(*.patch, .file, .mesh, *.in_file_order))]
    PatchMismatch {
        /// First patch of the file without an equal in the mesh.
        patch: u32,
        /// The file's record of it.
        file: PatchInfo,
        /// What the mesh gives instead: for a mesh in the file's order, the same triangles'
        /// bounds; for a mesh tiled again, the patch of the tiling nearest to it (its bounding
        /// sphere's centre; `first_triangle` is then its place in the tiling's order).
        mesh: PatchInfo,
        /// Whether the mesh was taken for one in the file's order (a `--mesh-out` mesh,
        /// because patch 0 matched), rather than tiled again.
        in_file_order: bool,
    },
    /// Tiling the mesh gave another number of patches than the file has.
    #[error(
        "the file has {file} patches, tiling the mesh gives {mesh}: eval needs the mesh file the bake read, or its --mesh-out mesh, and the bake's --memory and --tiling"
    )]
    PatchCount {
        /// Patches in the file.
        file: u32,
        /// Patches of the tiling.
        mesh: u32,
    },
    /// Tiling the mesh failed.
    #[error("tiling the mesh failed: {0}")]
    Tiling(#[from] tiling::TilingError),
    /// A temporary file for the renumbered tiling could not be written.
    #[error("cannot write a temporary file for the tiling: {0}")]
    TempFile(String),
    /// A sweep setting is out of range.
    #[error("{0}")]
    Settings(String),
    /// A camera of a path names no target and its eye is the model's centre, so it has no
    /// direction to look in.
    #[error("camera {camera}: the eye is at the model's centre, expected it elsewhere")]
    EyeAtCentre {
        /// The camera, 1-based.
        camera: usize,
    },
    /// A sweep's bake failed; its error as text, so that this error stays `Clone` and
    /// comparable.
    #[error("{0}")]
    Bake(String),
}

impl EvalError {
    /// A bake error of `eval --sweep`.
    pub(crate) fn bake(e: BakeError) -> EvalError {
        match e {
            BakeError::Tiling(t) => EvalError::Tiling(t),
            BakeError::Settings(m) => EvalError::Settings(m),
            other => EvalError::Bake(other.to_string()),
        }
    }
}

/// How [`Evaluator::new`] finds a file's patches in a mesh, and within which heap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EvalOptions {
    /// The heap budget: bounds the tiling (when the mesh must be tiled again) and the number
    /// of views rendered at once.
    pub memory: MemoryBudget,
    /// The tiling algorithm, when the mesh must be tiled again (the bake's `--tiling`).
    pub tiling: TilingMode,
}

/// Opens the mesh at `path` for an evaluation: within the input's share of `memory`, as the
/// bake's `Recipe::open` does, without the bake's conversion cache.
pub fn open_mesh(path: &Path, memory: MemoryBudget) -> Result<Mesh, MeshError> {
    Mesh::open_with(
        path,
        &OpenOptions {
            memory_budget: memory.split().input,
            ..Default::default()
        },
    )
}

/// What one view shows: the full render against the render of the query's answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewMetrics {
    /// Eye position (model space) the query was asked for.
    pub eye: [f32; 3],
    /// Whether the query flagged the eye `inside_sphere` (inside the sampling sphere of a
    /// version-4 file, which an eye at exactly the sampling distance is about half the time
    /// by rounding; inside the innermost sampling shell of a version-5 one). A renderer may
    /// then draw every patch; the figures here are still those of the query's answer.
    pub inside_sphere: bool,
    /// Pixels the full render covers.
    pub covered_pixels: u64,
    /// Pixels whose triangle differs between the full render and the reconstruction, not
    /// counting depth ties (`tied_pixels`).
    pub missed_pixels: u64,
    /// Pixels where the reconstruction shows another triangle at the full render's depth
    /// (within 4 units in the last place): the full render's won the tie only by drawing
    /// order or rounding, so they count as equal.
    pub tied_pixels: u64,
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
    /// visibility answer culled by this camera's frustum could cull (the full render shows
    /// only what is in the frustum): the ideal *with* the frustum, for
    /// `frustum_culling_rate`.
    pub ideal_culling_rate: f64,
    /// Patches visible from the eye in some direction: those the full render shows, and
    /// those renders covering every direction of the model from the eye show
    /// ([`super::surround_cameras`]; not drawn when the camera's image holds the whole mesh).
    pub visible_patches_all_directions: u32,
    /// Fraction of triangles in patches not visible from the eye in any direction: the best
    /// a direction-independent answer (what a query returns) could cull: the ideal *without*
    /// the frustum, for `culling_rate`. At most `ideal_culling_rate`.
    pub ideal_culling_rate_all_directions: f64,
    /// Patches of the answer inside the camera's frustum ([`super::camera_frustum`]): what
    /// `query_in_frustum` returns for this camera.
    pub frustum_answer_patches: u32,
    /// Triangles of those patches.
    pub frustum_triangles_drawn: u64,
    /// Fraction of the mesh's triangles not drawn when the answer is also culled by the
    /// frustum: `1 − |answer ∩ frustum| / triangles`, counted in triangles.
    pub frustum_culling_rate: f64,
    /// Patches the frustum drops from the answer although the answer's render shows them:
    /// 0 unless the frustum test is wrong (it may drop only patches that draw no pixel, so the
    /// missed pixels with the frustum are the missed pixels above).
    pub frustum_lost_patches: u32,
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

/// A mesh, where each patch of a `.pvis` lies in it, and what evaluation needs per view.
/// Holds no reference to the file, so one evaluator serves several files baked with the same
/// patches (`sweep`).
///
/// Memory: the file's patch order of the triangles (4 bytes per triangle, memory-mapped when
/// the tiling was; nothing for a `--mesh-out` mesh, already in that order), one start per
/// patch, and per worker two ID buffers and the projected vertices (16 bytes per vertex).
pub struct Evaluator<'m> {
    mesh: &'m Mesh,
    /// `order[i]` is the mesh triangle at position `i` of the file's patch order; `None` when
    /// the mesh is in that order already.
    order: Option<TriangleMap>,
    /// Patch `p` holds positions `starts[p]..starts[p + 1]`.
    starts: Vec<u32>,
    /// The heap budget of the evaluation.
    budget: u64,
    /// File patches matched by a record that another patch shares (see `match_tiling`).
    shared_records: u32,
}

impl<'m> Evaluator<'m> {
    /// Finds the patches of `pvis` in `mesh`: a mesh in the file's patch order (the bake's
    /// `--mesh-out`) is used as it is, once every patch's triangle range gives the file's
    /// bounding sphere and normal cone bit for bit; any other mesh is tiled again with
    /// `options` (tiling is deterministic, so the bake's `--memory` and `--tiling` give the
    /// bake's patches) and every patch record of the file — triangle count, bounding sphere,
    /// normal cone, bit for bit — is matched to one of the tiling's, in whatever numbering
    /// the file uses (see `match_tiling`).
    pub fn new(
        mesh: &'m Mesh,
        pvis: &Pvis<'_>,
        options: &EvalOptions,
    ) -> Result<Evaluator<'m>, EvalError> {
        if pvis.triangle_count() != u64::from(mesh.triangle_count()) {
            return Err(EvalError::TriangleCount {
                file: pvis.triangle_count(),
                mesh: mesh.triangle_count(),
            });
        }
        let starts = file_starts(pvis);
        let budget = options.memory.split().eval;
        if in_file_order(mesh, pvis, 0) {
            if let Some(p) = (0..pvis.patch_count())
                .into_par_iter()
                .find_first(|&p| !in_file_order(mesh, pvis, p))
            {
                let file = pvis.patch(p);
                return Err(EvalError::PatchMismatch {
                    patch: p,
                    file,
                    mesh: bounds_in_file_order(mesh, pvis, file),
                    in_file_order: true,
                });
            }
            return Ok(Evaluator::with_order(mesh, None, starts, budget));
        }
        let tiling = tiling::tile_with(
            mesh,
            pvis.patch_count(),
            &TilingOptions {
                mode: options.tiling,
                memory_budget: options.memory.split().tiling,
            },
        )?;
        let (order, shared_records) = match_tiling(&tiling, pvis)?;
        let tiling = tiling
            .renumbered(&order)
            .map_err(|e| EvalError::TempFile(e.to_string()))?;
        Ok(Evaluator {
            shared_records,
            ..Evaluator::with_order(mesh, Some(tiling.order), starts, budget)
        })
    }

    /// An evaluator for files baked from `mesh` with `tiling`, in its numbering (unchecked:
    /// the caller made both), rendering as many views at once as `memory` holds.
    pub fn from_tiling(mesh: &'m Mesh, tiling: &Tiling, memory: MemoryBudget) -> Evaluator<'m> {
        Evaluator::with_order(
            mesh,
            Some(tiling.order.clone()),
            tiling.starts(),
            memory.split().eval,
        )
    }

    fn with_order(
        mesh: &'m Mesh,
        order: Option<TriangleMap>,
        starts: Vec<u32>,
        budget: u64,
    ) -> Evaluator<'m> {
        Evaluator {
            mesh,
            order,
            starts,
            budget,
            shared_records: 0,
        }
    }

    /// How many of the file's patches were found in a mesh tiled again by a record that
    /// another patch shares (small patches whose quantised bounds coincide). They are matched
    /// in tiling order, the order `patchvis bake` keeps them in, so the figures are exact for
    /// its files; a file numbered otherwise is measured exactly only against its
    /// `--mesh-out` mesh. 0 for a mesh in the file's order.
    pub fn shared_records(&self) -> u32 {
        self.shared_records
    }

    /// The mesh.
    pub fn mesh(&self) -> &'m Mesh {
        self.mesh
    }

    /// The file's patch order of the triangles: `order()[i]` is the mesh triangle at
    /// position `i`, patch `p` holding positions [`Evaluator::patch_range`]`(p)`; `None` when
    /// the mesh is in that order already.
    pub fn order(&self) -> Option<&[u32]> {
        self.order.as_deref()
    }

    /// The positions of patch `p`'s triangles in the file's patch order.
    pub fn patch_range(&self, p: PatchId) -> Range<u32> {
        self.starts[p as usize]..self.starts[p as usize + 1]
    }

    /// Number of patches.
    pub fn patch_count(&self) -> u32 {
        (self.starts.len() - 1) as u32
    }

    /// Where each patch starts in the file's patch order, and the triangle count after the
    /// last.
    pub fn starts(&self) -> &[u32] {
        &self.starts
    }

    /// The heap budget.
    pub fn budget(&self) -> u64 {
        self.budget
    }

    /// Views rendered at once with cameras like `camera`: as many workers as the budget holds
    /// besides the triangle order (when it is on the heap), at least one, at most the thread
    /// count.
    pub fn workers(&self, camera: &Camera) -> usize {
        let fixed = self
            .order
            .as_ref()
            .filter(|o| !o.is_mapped())
            .map_or(0, |o| o.len() as u64 * 4)
            + self.starts.len() as u64 * 4;
        (self.budget.saturating_sub(fixed) / worker_bytes(self.mesh, camera).max(1))
            .clamp(1, rayon::current_num_threads() as u64) as usize
    }

    /// The patch holding position `i`.
    fn patch_at(&self, i: u32) -> usize {
        self.starts.partition_point(|&s| s <= i) - 1
    }

    /// Triangles of the patches whose bits are set in `row`.
    fn triangles_of(&self, row: &[u64]) -> u64 {
        crate::runtime::Patches::of_bits(row)
            .map(|p| {
                let r = self.patch_range(p);
                u64::from(r.end - r.start)
            })
            .sum()
    }

    /// Renders the whole mesh with `camera` into the surround buffer and sets in
    /// `s.seen_all` the patches it shows.
    fn mark_shown(&self, camera: &Camera, s: &mut Scratch) {
        if s.surround.resolution() != camera.resolution() {
            s.surround = IdBuffer::new(camera.resolution());
        }
        s.surround.clear();
        let everything = 0..self.mesh.triangle_count();
        s.rasterizer.render_runs(
            self.mesh,
            self.order.as_deref(),
            std::slice::from_ref(&everything),
            camera,
            &mut s.surround,
        );
        let mut previous = NO_PATCH;
        for &id in s.surround.ids() {
            if id != NO_PATCH && id != previous {
                previous = id;
                let p = self.patch_at(id);
                s.seen_all[p / 64] |= 1 << (p % 64);
            }
        }
    }

    /// The mesh triangle at position `i`.
    fn triangle_at(&self, i: u32) -> u32 {
        self.order.as_ref().map_or(i, |o| o[i as usize])
    }

    /// Evaluates every camera (in parallel, one view per task, at most
    /// [`Evaluator::workers`] at once); the result is in camera order.
    ///
    /// Panics (caller contract) if the file's patch count is not the evaluator's.
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
        let workers = cameras.first().map_or(1, |c| self.workers(c));
        let run = || {
            cameras
                .par_iter()
                .map_init(
                    || Scratch::new(pvis),
                    |scratch, camera| {
                        let metrics = self.view(pvis, camera, scratch);
                        progress.inc(1);
                        metrics
                    },
                )
                .collect()
        };
        let out = match rayon::ThreadPoolBuilder::new().num_threads(workers).build() {
            Ok(pool) if workers < rayon::current_num_threads() => pool.install(run),
            _ => run(),
        };
        progress.finish();
        out
    }

    /// The pictures of one view (renders it again).
    pub fn pictures(&self, pvis: &Pvis<'_>, camera: &Camera) -> Pictures {
        let mut scratch = Scratch::new(pvis);
        self.view(pvis, camera, &mut scratch);
        let normal = |id: u32| face_normal(self.mesh, self.triangle_at(id));
        let shader = Shader::new(&normal, camera.forward());
        let resolution = camera.resolution();
        let (full, rec) = (scratch.full.ids(), scratch.reconstruction.ids());
        let (full_depth, rec_depth) = (scratch.full.depth(), scratch.reconstruction.depth());
        let full: Vec<u32> = (0..full.len())
            .map(|i| tie_resolved(full[i], rec[i], full_depth[i], rec_depth[i]))
            .collect();
        let full = full.as_slice();
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
        let order = self.order.as_deref();

        s.full.clear();
        let everything = 0..mesh.triangle_count();
        let start = Instant::now();
        s.rasterizer.render_runs(
            mesh,
            order,
            std::slice::from_ref(&everything),
            camera,
            &mut s.full,
        );
        let full_seconds = start.elapsed().as_secs_f64();

        let visible = pvis.query(eye, &mut s.scratch);
        let inside_sphere = visible.inside_sphere;
        let answer_patches = visible.count();
        s.answer.fill(0);
        for (word, &bits) in s.answer.iter_mut().zip(visible.bits()) {
            *word = bits;
        }
        s.runs.clear();
        extend_runs(visible.bits(), &self.starts, &mut s.runs);
        let triangles_drawn: u64 = s.runs.iter().map(|r| u64::from(r.end - r.start)).sum();
        // The answer culled by the camera's frustum, as `query_in_frustum` gives it.
        s.in_frustum.copy_from_slice(&s.answer);
        super::camera_frustum(camera).cull(pvis, &mut s.in_frustum);
        let frustum_answer_patches = s.in_frustum.iter().map(|w| w.count_ones()).sum();
        let frustum_triangles_drawn = self.triangles_of(&s.in_frustum);

        s.reconstruction.clear();
        let start = Instant::now();
        s.rasterizer
            .render_runs(mesh, order, &s.runs, camera, &mut s.reconstruction);
        let culled_seconds = if s.runs.is_empty() {
            0.0
        } else {
            start.elapsed().as_secs_f64()
        };

        // Compare, collect the truly visible patches, and sum the shaded error.
        s.seen.fill(0);
        s.drawn.fill(0);
        let normal = |id: u32| face_normal(mesh, self.triangle_at(id));
        let shader = Shader::new(&normal, camera.forward());
        let (mut covered, mut missed, mut squared_error, mut tied) = (0u64, 0u64, 0u64, 0u64);
        let (mut previous, mut previous_drawn) = (NO_PATCH, NO_PATCH);
        let (full_depth, rec_depth) = (s.full.depth(), s.reconstruction.depth());
        for (i, (&a, &b)) in s.full.ids().iter().zip(s.reconstruction.ids()).enumerate() {
            if b != NO_PATCH && b != previous_drawn {
                previous_drawn = b;
                let p = self.patch_at(b);
                s.drawn[p / 64] |= 1 << (p % 64);
            }
            let shown = tie_resolved(a, b, full_depth[i], rec_depth[i]);
            tied += u64::from(shown != a);
            let a = shown;
            if a != NO_PATCH {
                covered += 1;
                if a != previous {
                    previous = a;
                    let p = self.patch_at(a);
                    s.seen[p / 64] |= 1 << (p % 64);
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
        let (mut visible_patches, mut missed_patches) = (0, 0);
        for (w, &word) in s.seen.iter().enumerate() {
            visible_patches += word.count_ones();
            missed_patches += (word & !answer[w]).count_ones();
        }
        let frustum_lost_patches = s
            .drawn
            .iter()
            .zip(&s.in_frustum)
            .map(|(&drawn, &kept)| (drawn & !kept).count_ones())
            .sum();
        let visible_triangles = self.triangles_of(&s.seen);
        // The ideal without the frustum: what the eye sees in any direction.
        s.seen_all.copy_from_slice(&s.seen);
        if !super::frames_whole_mesh(camera, mesh) {
            let sampling = pvis.sampling();
            for around in super::surround_cameras(camera, sampling.center, sampling.radius) {
                self.mark_shown(&around, s);
            }
        }
        let visible_patches_all_directions = s.seen_all.iter().map(|w| w.count_ones()).sum();
        let visible_triangles_all_directions = self.triangles_of(&s.seen_all);
        let total = f64::from(mesh.triangle_count());
        ViewMetrics {
            eye,
            inside_sphere,
            covered_pixels: covered,
            missed_pixels: missed,
            tied_pixels: tied,
            visible_patches,
            answer_patches,
            missed_patches,
            triangles_drawn,
            culling_rate: 1.0 - triangles_drawn as f64 / total,
            ideal_culling_rate: 1.0 - visible_triangles as f64 / total,
            visible_patches_all_directions,
            ideal_culling_rate_all_directions: 1.0
                - visible_triangles_all_directions as f64 / total,
            frustum_answer_patches,
            frustum_triangles_drawn,
            frustum_culling_rate: 1.0 - frustum_triangles_drawn as f64 / total,
            frustum_lost_patches,
            psnr_db: metrics::psnr(squared_error as f64 / (pixels * 3.0)),
            full_seconds,
            culled_seconds,
        }
    }
}

/// The triangle positions (in the file's patch order) of the patches whose bits are set in
/// `bits`, consecutive patches merged into one run: patch `p` holds `starts[p]..starts[p +
/// 1]`. Ascending; empty patches add nothing. What a renderer draws for an answer.
///
/// Panics (caller contract) if a bit is set for a patch beyond `starts.len() - 1`.
pub fn visible_runs(bits: &[u64], starts: &[u32]) -> Vec<Range<u32>> {
    let mut runs = Vec::new();
    extend_runs(bits, starts, &mut runs);
    runs
}

/// [`visible_runs`] appended to `runs`.
fn extend_runs(bits: &[u64], starts: &[u32], runs: &mut Vec<Range<u32>>) {
    for p in crate::runtime::Patches::of_bits(bits) {
        let range = starts[p as usize]..starts[p as usize + 1];
        match runs.last_mut() {
            _ if range.is_empty() => {}
            Some(last) if last.end == range.start => last.end = range.end,
            _ => runs.push(range),
        }
    }
}

/// Heap bytes one evaluation worker holds for `camera`: two ID buffers (an id and a depth
/// per pixel) at its resolution, one at the largest resolution of the renders around its eye
/// ([`super::surround_resolution`]), and the projected vertices with their stamps.
pub fn worker_bytes(mesh: &Mesh, camera: &Camera) -> u64 {
    let square = |r: u32| u64::from(r) * u64::from(r);
    let pixels = 2 * square(camera.resolution()) + square(super::surround_resolution(camera));
    pixels * 8 + u64::from(mesh.vertex_count()) * 20
}

/// Where each patch of `pvis` starts, and the triangle count after the last.
fn file_starts(pvis: &Pvis<'_>) -> Vec<u32> {
    let mut starts: Vec<u32> = (0..pvis.patch_count())
        .map(|p| pvis.patch(p).first_triangle)
        .collect();
    // The reader checked that the ranges are contiguous and sum to the triangle count.
    starts.push(pvis.triangle_count() as u32);
    starts
}

/// Whether patch `p`'s triangle range of `mesh` has exactly the file's bounding sphere and
/// normal cone (as the file stores them: quantised in a compact table): true for every patch
/// when `mesh` is the bake's `--mesh-out`.
fn in_file_order(mesh: &Mesh, pvis: &Pvis<'_>, p: u32) -> bool {
    if p >= pvis.patch_count() {
        return true;
    }
    let f = pvis.patch(p);
    let triangles: Vec<u32> = (f.first_triangle..f.first_triangle + f.triangle_count).collect();
    let (m, _) = tiling::patch_bounds(mesh, &triangles, f.first_triangle);
    record_key(&as_stored(pvis, &m)) == record_key(&f)
}

/// The record `pvis` would hold for `patch` (spec § PTCH).
fn as_stored(pvis: &Pvis<'_>, patch: &Patch) -> PatchInfo {
    stored_record(pvis.quantisation(), patch)
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
    /// The patches the answer's render shows, one row.
    drawn: Vec<u64>,
    /// The answer without the patches outside the camera's frustum, one row.
    in_frustum: Vec<u64>,
    /// The renders around the eye, for the ideal without the frustum.
    surround: IdBuffer,
    /// The patches those renders or the full render show, one row.
    seen_all: Vec<u64>,
    /// The answer's triangle positions, as runs.
    runs: Vec<Range<u32>>,
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
            drawn: vec![0; pvis.row_words()],
            in_frustum: vec![0; pvis.row_words()],
            surround: IdBuffer::new(1),
            seen_all: vec![0; pvis.row_words()],
            runs: Vec::new(),
        }
    }
}

/// The file's numbering of the patches of `tiling`: `order[i]` is the tiling patch that the
/// file calls `i`. Patches are matched by their records (triangle count, bounding sphere and
/// normal cone, bit for bit), so files that renumber their patches (`bake --patch-order
/// covisibility`, the default) match as well as files in the tiling's own numbering. Patches
/// of equal records are matched in id order, the order the bake keeps them in
/// (`format::keep_equal_records_in_order`), so the match is exact for its files; a file
/// numbered otherwise is measured exactly only against its `--mesh-out` mesh. Fails on the
/// first file patch nothing matches. Also returns how many patches share their record.
fn match_tiling(tiling: &Tiling, pvis: &Pvis<'_>) -> Result<(Vec<PatchId>, u32), EvalError> {
    let mut unmatched: HashMap<RecordKey, VecDeque<PatchId>> = HashMap::new();
    for (id, m) in tiling.patches.iter().enumerate() {
        unmatched
            .entry(record_key(&as_stored(pvis, m)))
            .or_default()
            .push_back(id as PatchId);
    }
    let shared = unmatched
        .values()
        .filter(|ids| ids.len() > 1)
        .map(|ids| ids.len() as u32)
        .sum();
    let count = pvis.patch_count();
    let mut order = Vec::with_capacity(count as usize);
    for p in 0..count {
        let f = pvis.patch(p);
        let found = unmatched
            .get_mut(&record_key(&f))
            .and_then(VecDeque::pop_front);
        match found {
            Some(id) => order.push(id),
            None => {
                return Err(match nearest(tiling, pvis, f.center) {
                    Some(mesh) => EvalError::PatchMismatch {
                        patch: p,
                        file: f,
                        mesh,
                        in_file_order: false,
                    },
                    None => EvalError::PatchCount {
                        file: count,
                        mesh: 0,
                    },
                });
            }
        }
    }
    if order.len() != tiling.patches.len() {
        return Err(EvalError::PatchCount {
            file: count,
            mesh: tiling.patches.len() as u32,
        });
    }
    Ok((order, shared))
}

/// The record that triangles `file.first_triangle..+triangle_count` of `mesh` give, as the
/// file would store it.
fn bounds_in_file_order(mesh: &Mesh, pvis: &Pvis<'_>, file: PatchInfo) -> PatchInfo {
    let triangles: Vec<u32> =
        (file.first_triangle..file.first_triangle + file.triangle_count).collect();
    let (m, _) = tiling::patch_bounds(mesh, &triangles, file.first_triangle);
    as_stored(pvis, &m)
}

/// The tiling's patch whose bounding sphere's centre is nearest `center` (lowest id on a
/// tie), as the file would store it; `None` for an empty tiling.
fn nearest(tiling: &Tiling, pvis: &Pvis<'_>, center: [f32; 3]) -> Option<PatchInfo> {
    let distance = |c: [f32; 3]| -> f64 {
        (0..3)
            .map(|i| (f64::from(c[i]) - f64::from(center[i])).powi(2))
            .sum()
    };
    tiling
        .patches
        .iter()
        .min_by(|a, b| distance(a.center).total_cmp(&distance(b.center)))
        .map(|m| as_stored(pvis, m))
}

/// The message of [`EvalError::PatchMismatch`]: the file's patch, what the mesh gives in its
/// place (only the values that differ), and what the user must evaluate instead.
fn patch_mismatch(patch: u32, file: &PatchInfo, mesh: &PatchInfo, in_file_order: bool) -> String {
    let sphere = |p: &PatchInfo| format!("bounding sphere at {:?} radius {}", p.center, p.radius);
    let cone = |p: &PatchInfo| format!("normal cone axis {:?} cos {}", p.cone_axis, p.cone_cos);
    let mut differences = Vec::new();
    if mesh.triangle_count != file.triangle_count {
        differences.push(format!("{} triangles", mesh.triangle_count));
    }
    let bits = |c: [f32; 3], r: f32| (c.map(f32::to_bits), r.to_bits());
    if bits(mesh.center, mesh.radius) != bits(file.center, file.radius) {
        differences.push(sphere(mesh));
    }
    if bits(mesh.cone_axis, mesh.cone_cos) != bits(file.cone_axis, file.cone_cos) {
        differences.push(cone(mesh));
    }
    let differences = if differences.is_empty() {
        // Unreachable for a real mismatch; said plainly rather than as two equal values.
        "values equal to the file's in every bit shown".to_string()
    } else {
        differences.join(", ")
    };
    let record = format!(
        "{} triangles from triangle {}, {}, {}",
        file.triangle_count,
        file.first_triangle,
        sphere(file),
        cone(file)
    );
    let found = if in_file_order {
        format!(
            "the mesh holds patch 0 in the file's triangle order, but its triangles {}..{} give {differences}",
            file.first_triangle,
            u64::from(file.first_triangle) + u64::from(file.triangle_count)
        )
    } else {
        format!("no patch of the mesh tiled again has these values; the nearest has {differences}")
    };
    format!(
        "patch {patch} of the file ({record}): {found}; evaluate the exact mesh file that was \
         baked (another export of the same model, e.g. .glb against .ply, can hold other \
         triangles, vertices or order), or the bake's --mesh-out mesh, with the bake's \
         --memory and --tiling (a file baked by another patchvis version may hold other \
         patches: the tiling changes between versions; its --mesh-out mesh still matches)"
    )
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

#[cfg(test)]
mod tie_tests {
    use super::*;

    #[test]
    fn depths_a_few_ulps_apart_tie_and_farther_ones_do_not() {
        let d = 0.143_461_2f32;
        let up = |k: u32| f32::from_bits(d.to_bits() + k);
        // Exactly equal, and within the tolerance either way: the reconstruction's shows.
        assert_eq!(tie_resolved(1, 2, d, d), 2);
        assert_eq!(tie_resolved(1, 2, d, up(DEPTH_TIE_ULPS)), 2);
        assert_eq!(tie_resolved(1, 2, up(DEPTH_TIE_ULPS), d), 2);
        // One ulp past it: a different surface, the full render's counts.
        assert_eq!(tie_resolved(1, 2, d, up(DEPTH_TIE_ULPS + 1)), 1);
        // An empty pixel on either side is never a tie.
        assert_eq!(tie_resolved(NO_PATCH, 2, d, d), NO_PATCH);
        assert_eq!(tie_resolved(1, NO_PATCH, d, d), 1);
    }
}
