//! Level-by-level tiled sampling: the production sampler. Bit-identical to a brute-force
//! render of every triangle, at a cost that follows the visible triangles instead.
//!
//! Technique: the sphere's views come level by level (6, then 12, 48, 192 … new views). A
//! view of level `l + 1` splits an edge between two views of coarser levels
//! (`sphere::parents`), which are finished and lie next to it, so the patches they see are
//! nearly the patches it sees. Each view draws those patches first — what the same camera of
//! each of them showed before the probe pass (a near view's cube faces one by one; the probe
//! adds patches that are mostly hidden, cheaper for the tiles to reject later), plus the
//! always-visible ones, and every patch in level 0 — but not those whose normal cone faces
//! wholly away, nor their triangles that wind away from the eye (back faces, which on a
//! closed mesh are hidden and make poor occluders) — builds the farthest depth of every
//! 8×8-pixel tile from them (one level of a hierarchical Z-buffer; Greene,
//! Kass & Miller 1993), and then draws each put-off back face and each remaining patch only
//! if the tiles cannot prove it hidden: a patch by its bounding sphere's screen rectangle and
//! nearest depth, then by its oriented bounding box's (`patch_box.rs`), then each cluster of
//! its triangles (`patch_mesh.rs`) by its sphere, then each triangle by its pixel box and
//! largest corner depth; a tile that cannot decide defers to its pixels. What
//! fails cannot change any pixel, and the packed depth/triangle keys (`key_buffer.rs`) make
//! the buffer independent of drawing order, so the result equals the reference render
//! ([`super::sample`]) bit for bit. The mesh is regrouped by patch (`patch_mesh.rs`), so a
//! view transforms only the vertices of the patches it draws, and patches far from the near
//! plane and guard band (all of them, in sampling views) skip the clip-plane tests: their
//! vertices are projected four or eight at a time (`raster/batch.rs`), and a triangle whose
//! bounding box holds no pixel centre (most of them on meshes much finer than the image) is
//! dropped after a box test on its corners' centre codes (made with the projection), before
//! its coordinates are read, winding, deferral or edge setup; in patches whose triangles are
//! a little smaller than a pixel, where its outcome is a coin toss, that test is branch-free
//! (a batch of kept triangles is drawn after). A view streams the patches it draws from
//! memory (about 55 MB per view at 6.4M triangles), so their vertices and triangles are
//! prefetched a little ahead of use; with that, rendering a batch of views together patch by
//! patch no longer pays for its larger buffers, so each task renders one view
//! (docs/benchmarks/sampling.md).
//!
//! A near pass (`shell`, `near.rs`) renders each view's one or five cameras this way, each
//! seeded by the parents' rows of its own shell, and ORs their rows; a cube face passes over
//! the hinted patches wholly outside it, and those it cuts through take the clip path.
//!
//! Options: `min_pixels` (a patch counts only if it covers that many pixels), `dilate` (also
//! mark edge neighbours of visible patches that may face the eye), `always_visible` (patches
//! set in every row), `conservative_raster` (conservative rasterization, `conservative.rs`), a
//! checkpoint written after each level (`checkpoint.rs`), `views` (render only some views
//! and the ancestors that seed them: a shard of a sharded bake, `bake::Shard`), and
//! `folds_into` (the probe of a finer view leaves out what its parents hold where the fold
//! would drop it, `tiled/probe.rs`), and `finer` (the finest level's views at the centroids
//! of the faces of the level below, each seeded by the face's three corners, `finer.rs`).
//! Cost per view: a sphere test per patch, the triangles of the drawn patches (a tile test
//! for those drawn after the tiles), one pass over the pixels. Memory: one
//! `resolution² × 8`-byte buffer per thread, the result (one bit per view and patch), what
//! each camera of a view that seeds others showed (one bit per camera, view and patch: a
//! quarter of the views), and the regrouped mesh (about 12 bytes per triangle) — on the
//! heap, or in a mapped temporary file when it would take more than a quarter of
//! [`SamplingOptions::memory`], so that the heap stays independent of the mesh size. The
//! regrouped mesh, the boxes, the winding and the probe's solids belong to the [`Scene`]
//! (`scene.rs`): the passes of one bake build them once.
//! **Invariant**: the result is the same for any number of threads, and with or without a
//! resumed checkpoint; a row rendered with `views` equals the row of a run without.

use super::camera::{Camera, SphereBounds, normalize, widen};
use super::checkpoint;
use super::finer::{FinerViews, PassViews};
use super::key_buffer::{KeyBuffer, Pixel, low_half, patch_slot};
use super::marks::{Marks, needs_graph};
use super::near::{near_camera_count, near_cameras};
use super::patch_box::PatchBox;
use super::patch_graph::faces_away;
use super::patch_mesh::{PatchMesh, Section, Storage};
use super::raster::{
    ProjectedVertex, ScreenBatch, ScreenVertex, draw_triangle, prefetch, project, signed_area,
    sphere_needs_no_clip, view_planes,
};
use super::scene::Scene;
use super::solid::Cell;
use super::{SamplingParams, VisibilityMatrix};
use crate::ooc::Mesh;
use crate::progress::Progress;
use crate::runtime::Patches;
use crate::sphere::view_count;
use crate::tiling::{PatchId, Tiling};
use rayon::prelude::*;
use std::path::PathBuf;

/// What a sampling run marks besides the point-sampled visible patches, and where it keeps
/// its checkpoint.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SamplingOptions {
    /// A patch counts as seen from a view only if it covers at least this many pixels (0 and
    /// 1 both mean any pixel): the seed paper's aggressive mode.
    pub min_pixels: u32,
    /// Also mark every edge neighbour of a seen patch whose normal cone may face the eye.
    pub dilate: bool,
    /// Patches marked in every view (e.g. transparent parts that must never be culled).
    pub always_visible: Vec<PatchId>,
    /// Conservative rasterization: a triangle marks every pixel it touches, at its nearest
    /// depth there, so patches seen only as sub-pixel slivers are caught.
    pub conservative_raster: bool,
    /// Where to write a checkpoint after each sphere level; `None` writes none.
    pub checkpoint: Option<PathBuf>,
    /// Continue from the checkpoint if one exists (it must match these inputs).
    pub resume: bool,
    /// The sampler's share of the heap budget: when the mesh regrouped by patch would take
    /// more than its mesh copy's part, the copy lives in a memory-mapped temporary file
    /// instead (`patch_mesh.rs`). `None`: on the heap. Never changes the result.
    pub memory: Option<crate::memory::SamplingShare>,
    /// Render only these views (ascending ids) and the coarser views that seed them (their
    /// ancestors through `sphere::parents` or a face's corners), so that each is rendered
    /// exactly as in a full run; the other rows stay empty. `None`: every view. A sharded
    /// bake (`bake::Shard`) renders its share this way.
    pub views: Option<Vec<u32>>,
    /// The probe pass (`tiled/probe.rs`): after each view, every patch it did not show is
    /// drawn again with conservative rasterization against the view's occluders shrunk by
    /// this many pixels, skipping the triangles no camera near the view can see the visible
    /// side of (`solid.rs`); a patch with a fragment in front is added. `None`: no probe.
    pub probe: Option<u32>,
    /// With the probe: gaps between parts up to this many pixels wide (a hole in a sheet, a
    /// slit between two parts) are apertures, and every patch a camera of the view's cell may
    /// see through one by parallax is added too (`tiled/aperture.rs`). 0: none.
    pub apertures: u32,
    /// A shell's pass: the views' eyes lie on a sphere of this radius around `params.center`
    /// (at least the bounding radius: nearer than the sampling distance for the shells, beyond
    /// it for the far band) instead of at the sampling distance, and each view records every
    /// patch visible from its eye in any direction, rendering as many frustums as cover the
    /// bounding sphere from there (spec § SHEL; the cameras: [`super::near_cameras`], one
    /// framing the bounding sphere beyond `√2` radii). `None`: the sampling sphere's views.
    ///
    /// Panics in [`sample_tiled`] (caller contract) below `params.radius` or when not finite.
    pub shell: Option<f32>,
    /// The camera distances `[nearest, farthest]` (from `params.center`) whose queries the
    /// rows of this pass answer, with the views of the neighbouring shells (spec § Query):
    /// the probe's cells span them. `None`: the pass's own camera distance.
    pub band: Option<[f32; 2]>,
    /// The stored level this pass's rows are folded into, when the fold keeps from a finer
    /// view only the patches its fold targets do not hold yet ([`super::FoldCorners::Split`]
    /// and [`super::FoldCorners::Cover`], one level finer). The probe of each view one level
    /// finer than it then leaves out the patches its two parents' rows hold: its parents are
    /// its fold targets, so the fold would drop them, and the folded rows are the same bit
    /// for bit. `None`: the probe tests every patch a view did not show.
    pub folds_into: Option<u32>,
    /// Where the views of the pass's finest level lie ([`FinerViews`]): with
    /// [`FinerViews::Centroids`], the views of `params.level` beyond level `params.level − 1`'s
    /// are the centroids of that level's leaf faces, each seeded by its face's corners
    /// (`finer.rs`); a near pass ([`SamplingOptions::shell`]) puts its cameras there too.
    pub finer: FinerViews,
}

/// Why tiled sampling failed: only its checkpoint file can.
#[derive(Debug, thiserror::Error)]
pub enum SamplingError {
    /// The checkpoint could not be read or written.
    #[error("{}: cannot {action} the checkpoint: {source}", path.display())]
    Io {
        /// The checkpoint path.
        path: PathBuf,
        /// "read" or "write".
        action: &'static str,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The temporary file holding the regrouped mesh could not be created, written or mapped.
    #[error("cannot write the sampler's temporary mesh file (in $TMPDIR or /tmp): {0}")]
    TempFile(#[source] std::io::Error),
    /// The checkpoint exists but belongs to other inputs or is damaged.
    #[error("{}: {reason}", path.display())]
    Checkpoint {
        /// The checkpoint path.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
}

/// Renders every view of `params` level by level and returns which patches each one shows,
/// for the patches of `tiling` (a tiling of `mesh`). With default options the rows equal
/// [`super::sample`]`(mesh, &tiling.patch_of, …)` bit for bit.
///
/// Panics (caller contract) if an always-visible id is not a patch of `tiling`.
pub fn sample_tiled(
    mesh: &Mesh,
    tiling: &Tiling,
    params: &SamplingParams,
    options: &SamplingOptions,
    progress: &dyn Progress,
) -> Result<VisibilityMatrix, SamplingError> {
    sample_scene(&Scene::new(mesh, tiling), params, options, progress)
}

/// [`sample_tiled`] of the scene's mesh and tiling, with the set-up `scene` shares between
/// the passes that sample it (the passes of one bake: `scene.rs`).
pub fn sample_scene(
    scene: &Scene,
    params: &SamplingParams,
    options: &SamplingOptions,
    progress: &dyn Progress,
) -> Result<VisibilityMatrix, SamplingError> {
    Ok(sample_rows(scene, params, options, false, progress)?.0)
}

/// [`sample_tiled`], also returning each view's row as it was before the probe pass added
/// anything (the rows [`sample_tiled`] returns without [`SamplingOptions::probe`], bit for
/// bit): `(rows, seen)`. The split fold (`supersample::split_fold`) folds the two apart.
/// Checkpoints hold both.
pub fn sample_tiled_split(
    mesh: &Mesh,
    tiling: &Tiling,
    params: &SamplingParams,
    options: &SamplingOptions,
    progress: &dyn Progress,
) -> Result<(VisibilityMatrix, VisibilityMatrix), SamplingError> {
    sample_scene_split(&Scene::new(mesh, tiling), params, options, progress)
}

/// [`sample_tiled_split`] with the set-up `scene` shares (see [`sample_scene`]).
pub fn sample_scene_split(
    scene: &Scene,
    params: &SamplingParams,
    options: &SamplingOptions,
    progress: &dyn Progress,
) -> Result<(VisibilityMatrix, VisibilityMatrix), SamplingError> {
    let (rows, seen) = sample_rows(scene, params, options, true, progress)?;
    Ok((rows, seen.expect("sampled with the seen rows")))
}

/// [`sample_tiled`], with the seen rows of [`sample_tiled_split`] when `split`. Those are
/// sampled into one matrix with the rows: each view's row is its `W` words, then its `W` seen
/// words (`W` words a row of the patches), so that checkpoints and the levels' parallel loop
/// handle one matrix; it is cut in two at the end.
fn sample_rows(
    scene: &Scene,
    params: &SamplingParams,
    options: &SamplingOptions,
    split: bool,
    progress: &dyn Progress,
) -> Result<(VisibilityMatrix, Option<VisibilityMatrix>), SamplingError> {
    let (mesh, tiling) = (scene.mesh(), scene.tiling());
    let patch_count = u32::try_from(tiling.patches.len()).expect("more than 2^32 patches");
    assert!(
        params.radius > 0.0 && params.radius.is_finite(),
        "sampling radius must be positive and finite, got {}",
        params.radius
    );
    // Checks the shell's distance (caller contract).
    let cameras = options.shell.map_or(1, |d| near_camera_count(params, d));
    let views = view_count(params.level);
    let pass = PassViews::pass(params.level, options.finer);
    // Words of one row of the patches: the rows' prefix of the matrix's rows.
    let words = (patch_count as usize).div_ceil(64);
    let mut matrix = if split {
        VisibilityMatrix::new(views, 64 * words as u32 + patch_count)
    } else {
        VisibilityMatrix::new(views, patch_count)
    };
    let rendered = rendered_views(&pass, options.views.as_deref());
    // Views rendered below index `view`: those that exist, or those a share wants.
    let rendered_below = |view: u32| {
        rendered.as_ref().map_or(view.min(pass.end()), |r| {
            r[..view as usize].iter().filter(|&&b| b).count() as u32
        })
    };
    let marks = Marks::new(
        tiling,
        options,
        needs_graph(options).then(|| scene.patch_graph()),
    );
    let hash = options
        .checkpoint
        .as_ref()
        .map(|_| checkpoint::input_hash(mesh, tiling, params, options, split));
    let mut first_level = 0;
    if let (true, Some(path), Some(hash)) = (options.resume, &options.checkpoint, hash)
        && let Some(levels_done) = checkpoint::load(path, hash, &mut matrix)?
    {
        first_level = levels_done;
    }
    progress.start("sampling", u64::from(rendered_below(views)));
    if first_level > 0 {
        progress.inc(u64::from(rendered_below(view_count(first_level - 1))));
    }
    // What each camera of each view that seeds others (all but the finest level's) showed
    // before its probe: the patches drawn first in the same camera of the views it seeds.
    // Views loaded from a checkpoint have none; their rows seed instead (the drawing order
    // never changes a row, only its cost).
    let shown_words = cameras * words;
    let seed_views = if params.level == 0 {
        0
    } else {
        view_count(params.level - 1)
    };
    let other_needs = crate::memory::FixedNeeds {
        triangles: mesh.triangle_count(),
        resolution: params.resolution,
        workers: rayon::current_num_threads(),
        row_bytes: ((matrix.words().len() + seed_views as usize * shown_words) * 8) as u64,
        probe: options.probe.is_some(),
        apertures: options.apertures > 0,
    }
    .sampling();
    let storage = Storage::for_budget(
        u64::from(mesh.triangle_count()),
        options.memory,
        other_needs,
    );
    let setup = scene.setup(storage).map_err(SamplingError::TempFile)?;
    let context = ViewContext {
        mesh: &setup.mesh,
        boxes: &setup.boxes,
        tiling,
        params,
        options,
        marks,
        back_winding: setup.back_winding,
        patch_ball: setup.patch_ball,
        probe: options
            .probe
            .map(|radius| probe::Probe::new(radius, params, &pass, options, scene.solids())),
    };
    let mut shown = ShownRows {
        rows: vec![0u64; seed_views as usize * shown_words],
        words: shown_words,
        from: if first_level == 0 {
            0
        } else {
            view_count(first_level - 1)
        },
    };
    for level in first_level..=params.level {
        render_level(
            &context,
            &pass,
            rendered.as_deref(),
            level,
            &mut matrix,
            &mut shown,
            progress,
        );
        if let (Some(path), Some(hash)) = (&options.checkpoint, hash) {
            checkpoint::save(path, hash, level + 1, view_count(level), &matrix)?;
        }
    }
    drop(shown);
    progress.finish();
    if !split {
        return Ok((matrix, None));
    }
    let (mut rows, mut seen) = (
        VisibilityMatrix::new(views, patch_count),
        VisibilityMatrix::new(views, patch_count),
    );
    for v in 0..views {
        let (r, s) = matrix.row(v).split_at(words);
        rows.row_mut(v).copy_from_slice(r);
        seen.row_mut(v).copy_from_slice(s);
    }
    Ok((rows, Some(seen)))
}

/// What each camera of the views that seed others showed before its probe (see
/// [`SeedRows`]), one row a camera, `words` words a view.
struct ShownRows {
    rows: Vec<u64>,
    words: usize,
    /// The views below this one have none: their rows came from a checkpoint.
    from: u32,
}

/// Renders the views of `level` of `pass` (those `rendered` wants, all if `None`) into their
/// rows of `matrix`, whose coarser levels are done, and keeps what their cameras showed in
/// `shown` when they seed the next level.
fn render_level(
    context: &ViewContext,
    pass: &PassViews,
    rendered: Option<&[bool]>,
    level: u32,
    matrix: &mut VisibilityMatrix,
    shown: &mut ShownRows,
    progress: &dyn Progress,
) {
    let patch_count = context.mesh.patch_count() as u32;
    let words = (patch_count as usize).div_ceil(64);
    let words_per_row = matrix.words_per_row();
    let (resolution, probe) = (context.params.resolution, context.options.probe.is_some());
    let first_view = if level == 0 { 0 } else { view_count(level - 1) };
    let (done, rest) = matrix
        .words_mut()
        .split_at_mut(first_view as usize * words_per_row);
    let (shown_words, shown_from) = (shown.words, shown.from);
    let first_kept = (first_view as usize * shown_words).min(shown.rows.len());
    let (shown_done, shown_rest) = shown.rows.split_at_mut(first_kept);
    let (done, shown_done): (&[u64], &[u64]) = (done, shown_done);
    let new_views = (view_count(level) - first_view) as usize;
    // The finest level seeds no view: its cameras' rows go to a worker's spare one.
    let kept = if level < context.params.level {
        new_views
    } else {
        0
    };
    let shown_rows = shown_rest[..kept * shown_words]
        .par_chunks_mut(shown_words)
        .map(Some)
        .chain((kept..new_views).into_par_iter().map(|_| None));
    rest[..new_views * words_per_row]
        .par_chunks_mut(words_per_row)
        .zip(shown_rows)
        .enumerate()
        .for_each_init(
            || {
                let scratch = WorkerScratch::new(resolution, patch_count, probe);
                (scratch, vec![0u64; shown_words])
            },
            |(scratch, spare), (i, (row, shown_row))| {
                let view = first_view + i as u32;
                if !pass.exists(view) || rendered.is_some_and(|r| !r[view as usize]) {
                    return;
                }
                let seeds = pass.seeds(view);
                let mut rows: [&[u64]; 3] = [&[]; 3];
                let mut first: [Option<&[u64]>; 3] = [None; 3];
                for ((r, f), &s) in rows.iter_mut().zip(&mut first).zip(seeds.views()) {
                    *r = &done[s as usize * words_per_row..][..words];
                    *f = (s >= shown_from)
                        .then(|| &shown_done[s as usize * shown_words..][..shown_words]);
                }
                let n = seeds.views().len();
                let seeds = (n > 0).then(|| SeedRows {
                    rows: &rows[..n],
                    shown: &first[..n],
                });
                let direction = pass.direction(view);
                let shown_row = shown_row.unwrap_or(spare);
                context.render_view(view, direction, seeds, scratch, row, shown_row);
                progress.inc(1);
            },
        );
}

/// How many views of the pass `pass` a run with [`SamplingOptions::views`] `wanted`
/// renders: those that exist, and their ancestors.
pub fn rendered_view_count(pass: &PassViews, wanted: &[u32]) -> u32 {
    rendered_views(pass, Some(wanted))
        .map_or(pass.end(), |r| r.iter().filter(|&&b| b).count() as u32)
}

/// Which views of `pass` a run renders when it wants `wanted` (ascending ids below its slot
/// count): those that exist and every ancestor that seeds them; `None` when it wants every
/// view.
fn rendered_views(pass: &PassViews, wanted: Option<&[u32]>) -> Option<Vec<bool>> {
    let wanted = wanted?;
    let views = pass.slots();
    let mut rendered = vec![false; views as usize];
    for &v in wanted {
        assert!(
            v < views,
            "view {v} is not one of the {views} views sampled"
        );
        rendered[v as usize] = pass.exists(v);
    }
    // Seeds have smaller ids: one pass from the last view down closes the set.
    for v in (0..views).rev() {
        if rendered[v as usize] {
            for &s in pass.seeds(v).views() {
                rendered[s as usize] = true;
            }
        }
    }
    Some(rendered)
}

/// Most back faces a view puts off until its occlusion tiles exist (about 40 bytes each, so
/// 10 MiB per thread): on a 20M-triangle mesh the hinted patches hold millions of back
/// faces, which would otherwise make the heap grow with the mesh. Tests use a small cap, so
/// that both ways (put off, drawn at once) run in every test view.
const MAX_DEFERRED: usize = if cfg!(test) { 64 } else { 1 << 18 };

/// How a patch's triangle loop finds the triangles whose bounding box holds a pixel centre
/// (the only ones drawn): each way draws the same fragments, and which is fastest depends on
/// how often a triangle holds one, that is on the patch's pixels per triangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum BoxTest {
    /// Triangles of a pixel or more: nearly all hold a centre (93 % on the bunny), so one
    /// loop tests and draws each (a separate search loop was +3 % there).
    Plain,
    /// Between 1/16 and 1 pixel per triangle, where holding a centre is a coin toss (27 % on
    /// the 1.6M bunny): a branch-free pass writes the positions of those that hold one into a
    /// batch, then the batch is drawn.
    BranchFree,
    /// Much smaller triangles rarely hold one (7 % on the 6.4M bunny): a tight search loop
    /// skips to the next that does, so the test keeps its registers to itself (6.4M −4 %).
    Search,
}

/// The [`BoxTest`] for patch `patch` in `camera`'s image, by its triangles' average surface
/// projected at its centre's depth (at most their projected area).
fn box_test(camera: &Camera, patch: &crate::tiling::Patch) -> BoxTest {
    let scale = camera.pixels_per_unit_at(patch.center);
    let ppt = patch.area * scale * scale / f64::from(patch.count);
    if ppt >= 1.0 {
        BoxTest::Plain
    } else if ppt >= 1.0 / 16.0 {
        BoxTest::BranchFree
    } else {
        BoxTest::Search
    }
}

/// Triangles box-tested per batch before the kept ones are drawn (36 bytes each).
const CANDIDATE_BATCH: usize = 256;

/// Everything every view shares.
struct ViewContext<'a> {
    mesh: &'a PatchMesh,
    tiling: &'a Tiling,
    params: &'a SamplingParams,
    options: &'a SamplingOptions,
    /// The dilation and always-visible marks.
    marks: Marks<'a>,
    /// Every patch's oriented bounding box, the tight bound of the occlusion test.
    boxes: &'a [PatchBox],
    /// The screen winding of back faces (`scene.rs`).
    back_winding: i64,
    /// The probe pass, if any.
    probe: Option<probe::Probe<'a>>,
    /// A ball holding every patch's bounding ball (`scene.rs`).
    patch_ball: ([f32; 3], f32),
}

/// One view's buffers.
struct ViewScratch {
    /// Empty between views: resolving a view drains it.
    keys: KeyBuffer,
    /// The patches of the first pass.
    drawn: Vec<u64>,
    /// First-pass triangles put off as facing away: screen corners and key low half.
    deferred: Vec<([ScreenVertex; 3], u32)>,
    /// Whether the camera being drawn needs no clipping for any patch (`patch_ball`).
    no_clip: bool,
}

/// What drawing one patch needs besides its view's buffers.
struct DrawScratch {
    /// Positions in a run of the triangles that hold a pixel centre (`CANDIDATE_BATCH` slots).
    candidates: Box<[u32; CANDIDATE_BATCH]>,
    projected: Vec<ProjectedVertex>,
    /// Screen vertices of a patch section that needs no clipping.
    screen: ScreenBatch,
}

/// What resolving a view's keys into its row needs.
struct ResolveScratch {
    /// Pixels per patch (plus one spare entry for empty pixels), for `min_pixels`.
    pixels: Vec<u32>,
    /// Whether a patch holds a pixel (plus the spare entry).
    hit: Vec<u8>,
    seen: Vec<u64>,
}

/// One worker's buffers, reused view after view.
struct WorkerScratch {
    view: ViewScratch,
    draw: DrawScratch,
    resolve: ResolveScratch,
    probe: Option<probe::ProbeScratch>,
    /// One camera's row of a near view, before it is ORed into the view's.
    camera_row: Vec<u64>,
}

impl WorkerScratch {
    fn new(resolution: u32, patch_count: u32, probe: bool) -> WorkerScratch {
        let words = (patch_count as usize).div_ceil(64);
        WorkerScratch {
            view: ViewScratch {
                keys: KeyBuffer::new(resolution),
                drawn: vec![0; words],
                deferred: Vec::new(),
                no_clip: false,
            },
            draw: DrawScratch {
                candidates: Box::new([0; CANDIDATE_BATCH]),
                projected: Vec::new(),
                screen: ScreenBatch::default(),
            },
            resolve: ResolveScratch {
                pixels: vec![0; patch_count as usize + 1],
                hit: vec![0; patch_count as usize + 1],
                seen: vec![0; words],
            },
            probe: probe.then(|| probe::ProbeScratch::new(resolution)),
            camera_row: vec![0; words],
        }
    }
}

/// A view's seeds (`PassViews::seeds`) as its render takes them.
struct SeedRows<'r> {
    /// Their rows: what the fold holds already (`SamplingOptions::folds_into`).
    rows: &'r [&'r [u64]],
    /// Per seed, what each of its cameras showed before the probe (one row a camera), or
    /// `None` where that is not known (a view loaded from a checkpoint).
    shown: &'r [Option<&'r [u64]>],
}

/// The rows whose OR a camera draws first (see [`SeedRows::first`]).
struct FirstRows<'r> {
    rows: [&'r [u64]; 3],
    count: usize,
}

impl<'r> SeedRows<'r> {
    /// What camera `c` of a view draws first: what camera `c` of each seed showed, or the
    /// seed's row where that is not known. A probe adds patches that are mostly hidden, which
    /// cost less in the tested pass, where the tiles reject them, than drawn first.
    fn first(&self, c: usize, words: usize) -> FirstRows<'r> {
        let mut rows: [&[u64]; 3] = [&[]; 3];
        for ((r, &row), shown) in rows.iter_mut().zip(self.rows).zip(self.shown) {
            *r = shown.map_or(row, |s| &s[c * words..][..words]);
        }
        FirstRows {
            rows,
            count: self.rows.len(),
        }
    }
}

/// How a camera chooses the patches it draws first, and those its probe leaves out.
#[derive(Clone, Copy)]
struct Drawn<'r> {
    /// Rows whose OR is drawn first; `None`: every patch (the first level).
    first: Option<&'r [&'r [u64]]>,
    /// Rows whose patches the probe leaves out (`SamplingOptions::folds_into`).
    known: Option<&'r [&'r [u64]]>,
}

/// The two drawing passes of a view (see `ViewContext::render_view`).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Pass {
    /// Before the occlusion tiles exist: draw, but put off triangles facing away.
    First,
    /// After: draw only what the tiles do not hide.
    Tested,
}

/// Patches of at most this many triangles skip the test of their oriented box, whose eight
/// projections cost more than the test of their vertices' extent that follows it.
const FEW_TRIANGLES: u32 = 4;

/// Whether contents within `bounds` provably change no pixel of `keys` (by its tiles).
fn hidden<P: Pixel>(bounds: SphereBounds, keys: &KeyBuffer<P>) -> bool {
    match bounds {
        SphereBounds::Outside => true,
        SphereBounds::Unbounded => false,
        SphereBounds::Rect { rect, nearest } => {
            let mut q = nearest as f32;
            if (q as f64) < nearest {
                q = q.next_up();
            }
            q.is_finite() && keys.occludes(rect, q.to_bits())
        }
    }
}

/// Projects `section`'s vertices from `*projected_to` up to `end` into `screen` and moves
/// `*projected_to` there: the vertices are numbered by first use, so a section's clusters,
/// drawn in order, need them only that far.
#[inline(always)]
fn project_up_to(
    screen: &mut ScreenBatch,
    camera: &Camera,
    section: &Section,
    projected_to: &mut usize,
    end: usize,
) {
    if end > *projected_to {
        screen.project_from(camera, section.vertices.blocks(), *projected_to, end);
        *projected_to = end;
    }
}

/// Prefetches every cache line of `triangles` (see [`prefetch`]): a cluster's triangles
/// while the one before it is drawn, since a view streams them from memory (6.4M −2 %).
#[inline(always)]
fn prefetch_run(triangles: &[[u16; 3]]) {
    for at in (0..triangles.len()).step_by(64 / 6) {
        prefetch(triangles, at);
    }
    prefetch(triangles, triangles.len().saturating_sub(1));
}

/// How one patch's screen triangles reach a view's key buffer in one pass.
struct Placer<'c, 'a> {
    context: &'c ViewContext<'a>,
    pass: Pass,
    /// The patch's key low half.
    low: u32,
}

impl Placer<'_, '_> {
    /// Draws `tri` into `keys`: in the first pass put off (into `deferred`) if it faces
    /// away, in the tested pass only if the tiles do not hide it. Inlined into every
    /// triangle loop: out of line, the corners went through memory, and reading them back
    /// whole stalled on the narrower stores that wrote them.
    #[inline(always)]
    fn place(
        &self,
        keys: &mut KeyBuffer,
        deferred: &mut Vec<([ScreenVertex; 3], u32)>,
        tri: [ScreenVertex; 3],
    ) {
        let context = self.context;
        let area = match self.pass {
            Pass::First => {
                // Its sign is the winding; the scan needs it too.
                let area = signed_area(tri);
                // Past the cap a back face is drawn at once: slower (no tile test), same
                // result, and the heap stays bounded.
                if area.signum() == context.back_winding && deferred.len() < MAX_DEFERRED {
                    deferred.push((tri, self.low));
                    return;
                }
                area
            }
            Pass::Tested => {
                if keys.triangle_hidden(tri, context.options.conservative_raster) {
                    return;
                }
                signed_area(tri)
            }
        };
        keys.draw(tri, area, self.low, context.options.conservative_raster);
    }
}

impl ViewContext<'_> {
    /// Renders view `index` (unit direction `direction`) into `row`, `seeds` giving its seeds'
    /// rows (`None` in the first level): the sampling view's camera, or each camera of a near
    /// view (`near.rs`), whose rows are ORed. Writes into `shown` what each camera showed
    /// before its probe. A `row` of twice the words of the patches gets the seen rows of
    /// [`sample_tiled_split`] in its second half.
    fn render_view(
        &self,
        index: u32,
        direction: [f32; 3],
        seeds: Option<SeedRows>,
        scratch: &mut WorkerScratch,
        row: &mut [u64],
        shown: &mut [u64],
    ) {
        let words = scratch.camera_row.len();
        let (row, seen) = row.split_at_mut(words);
        seen.fill(0);
        let d = normalize(widen(direction));
        // What the probe may leave out (`SamplingOptions::folds_into`): the views of the level
        // just finer than the stored one have their fold targets as seeds.
        let known = match self.options.folds_into {
            Some(stored) if self.params.level == stored + 1 && index >= view_count(stored) => {
                seeds.as_ref().map(|s| s.rows)
            }
            _ => None,
        };
        let Some(distance) = self.options.shell else {
            let camera = Camera::sampling(self.params, direction);
            let cell = self.probe.as_ref().map(|p| p.cell(d, camera.eye()));
            let first = seeds.map(|s| s.first(0, words));
            let drawn = Drawn {
                first: first.as_ref().map(|f| &f.rows[..f.count]),
                known,
            };
            self.render_camera(&camera, cell.as_ref(), drawn, scratch, row, seen, shown);
            return;
        };
        let cameras = near_cameras(self.params, direction, distance);
        let cell = self.probe.as_ref().map(|p| p.cell(d, cameras[0].eye()));
        let mut part = std::mem::take(&mut scratch.camera_row);
        row.fill(0);
        for (c, (camera, shown)) in cameras.iter().zip(shown.chunks_mut(words)).enumerate() {
            let first = seeds.as_ref().map(|s| s.first(c, words));
            let drawn = Drawn {
                first: first.as_ref().map(|f| &f.rows[..f.count]),
                known,
            };
            self.render_camera(
                camera,
                cell.as_ref(),
                drawn,
                scratch,
                &mut part,
                seen,
                shown,
            );
            for (r, p) in row.iter_mut().zip(&part) {
                *r |= p;
            }
        }
        scratch.camera_row = part;
    }

    /// Renders `camera`'s image into `row` (and the probe pass for the cameras of `cell`, when
    /// there is one, leaving out the patches `drawn.known` holds), ORs what the image showed,
    /// before the probe, into `seen` (empty when not wanted) and copies it into `shown`. The
    /// patches `drawn.first` shows (every patch in the first level) are drawn first, except
    /// their triangles that face away from the eye, which are put off; then the occlusion
    /// tiles are built, and the put-off triangles and the other patches are drawn unless the
    /// tiles prove them hidden (patches by their bounding sphere and box, then each cluster by
    /// its sphere, then each triangle by its bounding box). The keys do not depend on drawing
    /// order, so the row equals a brute-force render's.
    #[allow(clippy::too_many_arguments)]
    fn render_camera(
        &self,
        camera: &Camera,
        cell: Option<&Cell>,
        drawn: Drawn,
        scratch: &mut WorkerScratch,
        row: &mut [u64],
        seen: &mut [u64],
        shown: &mut [u64],
    ) {
        let patch_count = self.mesh.patch_count();
        let near = self.options.shell.is_some();
        let valid = |w: usize| valid_bits(w, patch_count);
        let WorkerScratch { view, draw, .. } = scratch;
        view.deferred.clear();
        let (center, radius) = self.patch_ball;
        view.no_clip = sphere_needs_no_clip(camera, center, radius);
        // A hinted patch that wholly faces away makes a poor occluder and is often hidden: it
        // is left to the tested pass. Always-visible patches are always drawn first.
        let eye = camera.eye();
        for (w, d) in view.drawn.iter_mut().enumerate() {
            let hinted = drawn
                .first
                .map_or(u64::MAX, |rows| rows.iter().fold(0, |a, r| a | r[w]))
                & valid(w);
            let mut away = 0u64;
            for k in Patches::of_bits(&[hinted]) {
                let k = k as usize;
                if faces_away(&self.tiling.patches[w * 64 + k], eye) {
                    away |= 1 << k;
                }
            }
            *d = (hinted & !away) | (self.marks.always()[w] & valid(w));
        }
        for w in 0..view.drawn.len() {
            for k in Patches::of_bits(&[view.drawn[w]]) {
                let p = w * 64 + k as usize;
                let patch = &self.tiling.patches[p];
                let bounds = camera.sphere_bounds(patch.center, patch.radius);
                // A cube face of a near view sees only some of the patches.
                if near && bounds == SphereBounds::Outside {
                    continue;
                }
                self.draw_patch(p, bounds, camera, view, draw, Pass::First);
            }
        }
        view.keys.build_tiles();
        let ViewScratch { keys, deferred, .. } = &mut *view;
        for &(screen, low) in deferred.iter() {
            if !keys.triangle_hidden(screen, self.options.conservative_raster) {
                let area = signed_area(screen);
                keys.draw(screen, area, low, self.options.conservative_raster);
            }
        }
        for w in 0..view.drawn.len() {
            for k in Patches::of_bits(&[!view.drawn[w] & valid(w)]) {
                let p = w * 64 + k as usize;
                let patch = &self.tiling.patches[p];
                // The sphere first (cheap), then the tighter box (8 projections; a patch of a
                // few triangles is tested by its vertices' extent next instead).
                let bounds = camera.sphere_bounds(patch.center, patch.radius);
                let visible = !hidden(bounds, &view.keys)
                    && (patch.count <= FEW_TRIANGLES
                        || !hidden(camera.hull_bounds(&self.boxes[p].corners()), &view.keys));
                if visible {
                    self.draw_patch(p, bounds, camera, view, draw, Pass::Tested);
                }
            }
        }
        self.probe_prepare(camera, scratch);
        // Resolving empties the key buffer for the worker's next view.
        self.resolve(camera, &mut scratch.view.keys, &mut scratch.resolve, row);
        for (s, &r) in seen.iter_mut().zip(row.iter()) {
            *s |= r;
        }
        shown.copy_from_slice(row);
        if let Some(cell) = cell {
            self.probe_row(camera, cell, drawn.known, scratch, row);
        }
    }

    /// Draws the triangles of patch `p`, within `bounds` (its sphere's), into `view`'s key
    /// buffer: in the first pass all but those facing away (which go to `view.deferred`), in
    /// the tested pass those the occlusion tiles do not hide.
    fn draw_patch(
        &self,
        p: usize,
        bounds: SphereBounds,
        camera: &Camera,
        view: &mut ViewScratch,
        draw: &mut DrawScratch,
        pass: Pass,
    ) {
        let ViewScratch {
            keys,
            deferred,
            no_clip,
            ..
        } = view;
        // Where its triangles, the put-off ones included, may write.
        keys.mark(bounds);
        let DrawScratch {
            candidates,
            projected,
            screen,
        } = draw;
        let patch = &self.tiling.patches[p];
        let low = low_half(p as u32, self.mesh.patch_count() as u32);
        let conservative = self.options.conservative_raster;
        let placer = Placer {
            context: self,
            pass,
            low,
        };
        if *no_clip || sphere_needs_no_clip(camera, patch.center, patch.radius) {
            // Every patch of a sampling view: packed projection, and the sub-pixel
            // triangles (most of a mesh much finer than the image) leave after a box test.
            // Three loops, by how often a triangle holds a centre (`BoxTest`).
            // In the tested pass each cluster is tested first, and the vertices are projected
            // only as far as the clusters drawn so far use them (numbered by first use).
            let test = box_test(camera, patch);
            for section in self.mesh.sections(p) {
                let mut projected_to = 0;
                prefetch_run(section.run(0));
                for (c, cluster) in section.clusters.iter().enumerate() {
                    let run = section.run(c);
                    if c + 1 < section.clusters.len() {
                        prefetch_run(section.run(c + 1));
                    }
                    if pass == Pass::Tested
                        && section.clusters.len() > 1
                        && hidden(camera.sphere_bounds(cluster.center, cluster.radius), keys)
                    {
                        continue;
                    }
                    let vertex_end = cluster.vertex_end as usize;
                    project_up_to(screen, camera, &section, &mut projected_to, vertex_end);
                    // A tested section of one cluster (most patches of meshes not much finer
                    // than the image) is tested by the exact rectangle and largest depth of its
                    // projected vertices before its triangles one by one: its sphere's
                    // rectangle passed, but it lies mostly just behind a silhouette. (Testing
                    // each cluster of a larger section by its vertices' extent, as the probe
                    // does, measured 1.03× on a 1M-triangle grid.)
                    if pass == Pass::Tested && section.clusters.len() == 1 {
                        let (extent, q_max) = screen.extent(0..vertex_end);
                        if keys.extent_hidden(extent, q_max, conservative) {
                            continue;
                        }
                    }
                    if conservative {
                        for &tri in run {
                            placer.place(keys, deferred, screen.triangle(tri));
                        }
                        continue;
                    }
                    match test {
                        BoxTest::Plain => {
                            for &tri in run {
                                if !screen.holds_no_centre(tri) {
                                    placer.place(keys, deferred, screen.triangle(tri));
                                }
                            }
                        }
                        BoxTest::BranchFree => {
                            for chunk in run.chunks(CANDIDATE_BATCH) {
                                let kept = screen.keep_holding_centre(chunk, candidates);
                                for &i in &candidates[..kept] {
                                    let tri = screen.triangle(chunk[i as usize]);
                                    placer.place(keys, deferred, tri);
                                }
                            }
                        }
                        BoxTest::Search => {
                            let mut next = screen.next_holding_centre(run, 0);
                            while let Some(&tri) = run.get(next) {
                                placer.place(keys, deferred, screen.triangle(tri));
                                next = screen.next_holding_centre(run, next + 1);
                            }
                        }
                    }
                }
            }
            return;
        }
        let planes = view_planes(camera);
        for section in self.mesh.sections(p) {
            let vertices = section.vertices;
            projected.clear();
            projected.extend(vertices.iter().map(|v| project(camera, &planes, v)));
            for tri in section.triangles {
                draw_triangle(
                    tri.map(|i| projected[usize::from(i)]),
                    || tri.map(|i| vertices.get(usize::from(i))),
                    camera,
                    &planes,
                    |tri| placer.place(keys, deferred, tri),
                );
            }
        }
    }

    /// Turns the key buffer into the view's row: pixel counts, `min_pixels`, dilation and the
    /// always-visible patches; leaves the buffer empty ([`KeyBuffer::drain`]).
    fn resolve(
        &self,
        camera: &Camera,
        keys: &mut KeyBuffer,
        scratch: &mut ResolveScratch,
        row: &mut [u64],
    ) {
        let min_pixels = self.options.min_pixels;
        let patch_count = self.mesh.patch_count();
        // Branch-free: every pixel stores to its patch's entry, empty pixels to the spare
        // entry `patch_count` (a "same as the previous pixel" test would mispredict often).
        let slot = |key: u64| patch_slot(key, patch_count as u32);
        row.fill(0);
        let seen = &mut scratch.seen;
        seen.fill(0);
        if min_pixels <= 1 {
            // A slice of its own: through the vector, its pointer and length were reloaded
            // from the stack on every pixel.
            let hit: &mut [u8] = &mut scratch.hit;
            keys.drain(|key| hit[slot(key)] = 1);
            for (p, h) in hit[..patch_count].iter_mut().enumerate() {
                seen[p / 64] |= u64::from(*h) << (p % 64);
                *h = 0;
            }
        } else {
            let pixels = &mut scratch.pixels;
            keys.drain(|key| pixels[slot(key)] += 1);
            for (p, count) in pixels[..patch_count].iter_mut().enumerate() {
                if *count >= min_pixels {
                    seen[p / 64] |= 1 << (p % 64);
                }
                *count = 0;
            }
        }
        row.copy_from_slice(seen);
        self.marks.apply(self.tiling, camera.eye(), seen, row);
    }
}

/// The bits of row word `w` that stand for patches (all but the last word's tail).
fn valid_bits(w: usize, patch_count: usize) -> u64 {
    if (w + 1) * 64 <= patch_count {
        u64::MAX
    } else {
        (1u64 << (patch_count % 64)) - 1
    }
}

mod aperture;
mod probe;

pub use probe::probe_reach;
#[cfg(test)]
mod tests;
