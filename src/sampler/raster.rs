//! The CPU ID-buffer rasterizer: draws triangles into an [`IdBuffer`] with a depth test.
//!
//! Technique: half-space (edge function) rasterization as in Pineda 1988 and current GPUs.
//! Vertices are projected once per view into a scratch buffer (a vertex is shared by about six
//! triangles) and snapped to fixed point with `SUBPIXEL_BITS` fractional bits; edge functions
//! are exact `i64` integers and the top-left fill rule decides pixel centres exactly on an
//! edge, so a pixel on an edge shared by two triangles is covered exactly once: meshes
//! rasterize watertight. Pixel centres are sampled; triangles covering none draw nothing.
//! Triangles reaching behind the near plane or beyond the guard band are clipped first (see
//! `clip.rs`); all others, which is every triangle of a sampling view, go straight to setup.
//! Depth is `1/w`, interpolated affinely in screen space from `f32` plane coefficients (one
//! `f32` division per triangle); a fragment wins if nearer, or as near with a smaller patch
//! id ([`IdBuffer`]'s test), so the result does not depend on the order triangles are drawn in.
//!
//! Cost per view: one `f32` transform per vertex (four at a time where no clipping is
//! needed; clipping itself runs in `f64`), ~20 integer operations of setup per
//! triangle, and per covered bounding-box pixel three adds and a compare. Triangles spanning
//! under 4 pixels (most of those that draw anything on scanned and finer meshes) set up
//! their three edge functions together in `f32` lanes, where those integers are exact
//! (`LaneEdges`; measured in docs/benchmarks/sampling.md). Bounding boxes up
//! to `SPAN_MIN_WIDTH` pixels wide are walked pixel by pixel (those of up to 3 columns, most
//! triangles of scanned meshes, with rows unrolled to their width); wider ones solve each
//! row's covered span directly so large triangles cost their area, not their bounding box.

use super::camera::Camera;
use super::clip::{self, PLANE_COUNT, Plane};
use super::id_buffer::IdBuffer;
use crate::ooc::Mesh;
use crate::tiling::PatchId;
use wide::{CmpEq, CmpGt, CmpLt, f32x4, i32x4};

mod batch;
pub(crate) use batch::{ScreenBatch, has_avx2, prefetch};
#[cfg(test)]
pub(crate) use batch::{centre_code, codes_hold_no_centre, covers_no_centre};

/// Fractional bits of snapped screen coordinates (1/256 pixel, as on D3D11-class hardware).
pub const SUBPIXEL_BITS: u32 = 8;
const SUBPIXEL: i64 = 1 << SUBPIXEL_BITS;
const HALF_PIXEL: i64 = SUBPIXEL / 2;

/// How far, in pixels, the guard band reaches beyond each image edge. Triangles inside it are
/// rasterized without clipping. With `MAX_RESOLUTION` ≤ 2^15 a snapped coordinate stays below
/// 2^28 sub-pixel units, so edge functions (products of two coordinate differences) stay
/// below 2^59 and never overflow `i64`.
const GUARD_BAND: f64 = (1u32 << 19) as f64;

/// Clamp for snapped coordinates (sub-pixel units): a backstop against rounding at clipped
/// vertices; clipping already keeps them within `±(MAX_RESOLUTION + GUARD_BAND) · 2^8`.
const COORD_LIMIT: f64 = (1u32 << 28) as f64;

/// Bounding boxes narrower than this many pixels are scanned pixel by pixel; wider ones solve
/// each row's covered span first. Small triangles dominate scanned meshes, and for them the
/// three divisions per row of span solving cost more than testing a few pixels.
const SPAN_MIN_WIDTH: i64 = 8;

// Outcodes of a projected vertex. The first five are the clip half-spaces (image edges and
// near plane): a triangle whose three vertices are all outside one of them is invisible.
const LEFT: u32 = 1;
const RIGHT: u32 = 2;
const TOP: u32 = 4;
const BOTTOM: u32 = 8;
const NEAR: u32 = 16;
const GUARD: u32 = 32;
const REJECT: u32 = LEFT | RIGHT | TOP | BOTTOM | NEAR;
const NEEDS_CLIP: u32 = NEAR | GUARD;

/// A vertex in screen space: snapped position in sub-pixel units and depth `1/w`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct ScreenVertex {
    pub(crate) x: i32,
    pub(crate) y: i32,
    pub(crate) q: f32,
}

#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct ProjectedVertex {
    /// Valid only if `outcode & NEEDS_CLIP == 0`.
    screen: ScreenVertex,
    outcode: u32,
}

/// Draws every triangle `t` of `mesh` with id `patch_of[t]` into `buffer` (which is not
/// cleared first). `patch_of.len()` must equal the triangle count and `buffer` must have the
/// camera's resolution.
pub fn render_ids(mesh: &Mesh, patch_of: &[PatchId], camera: &Camera, buffer: &mut IdBuffer) {
    Rasterizer::new().render_filtered(mesh, patch_of, camera, buffer, |_| true);
}

/// Like [`render_ids`], but draws only the triangles whose patch `keep` accepts.
pub fn render_ids_filtered(
    mesh: &Mesh,
    patch_of: &[PatchId],
    camera: &Camera,
    buffer: &mut IdBuffer,
    keep: impl FnMut(PatchId) -> bool,
) {
    Rasterizer::new().render_filtered(mesh, patch_of, camera, buffer, keep);
}

/// A rasterizer with its per-view scratch (projected vertices); reuse one per thread to
/// render many views without allocating.
#[derive(Debug, Default)]
pub struct Rasterizer {
    /// Each vertex projected for the current view (valid where its stamp is current).
    vertices: Vec<ProjectedVertex>,
    /// The render in which each vertex was last projected.
    stamps: Vec<u32>,
    /// The current render's stamp.
    generation: u32,
}

impl Rasterizer {
    /// A rasterizer with empty scratch.
    pub fn new() -> Rasterizer {
        Rasterizer::default()
    }

    /// [`render_ids`] with this rasterizer's scratch.
    pub fn render(
        &mut self,
        mesh: &Mesh,
        patch_of: &[PatchId],
        camera: &Camera,
        buffer: &mut IdBuffer,
    ) {
        self.render_filtered(mesh, patch_of, camera, buffer, |_| true);
    }

    /// [`render_ids_filtered`] with this rasterizer's scratch.
    pub fn render_filtered(
        &mut self,
        mesh: &Mesh,
        patch_of: &[PatchId],
        camera: &Camera,
        buffer: &mut IdBuffer,
        mut keep: impl FnMut(PatchId) -> bool,
    ) {
        assert_eq!(
            patch_of.len(),
            mesh.triangle_count() as usize,
            "patch_of must hold one patch per triangle"
        );
        assert_eq!(
            buffer.resolution(),
            camera.resolution(),
            "ID buffer and camera resolutions differ"
        );
        let triangles = (0..mesh.triangle_count()).filter_map(|t| {
            let id = patch_of[t as usize];
            keep(id).then_some((t, id))
        });
        self.rasterize(mesh, camera, triangles, true, |id, index, q, covered| {
            buffer.plot(index, q, id, covered)
        });
    }

    /// Draws the triangles at positions `runs` (ascending, disjoint) of `order` — the
    /// mesh's own triangle order when `None` — each with its position as its id: the
    /// evaluator's renders of a whole mesh and of a query's answer, drawn in the same relative
    /// order so that equally near fragments resolve alike. A culled draw projects only the
    /// vertices its triangles use, as an indexed draw on a GPU would.
    pub fn render_runs(
        &mut self,
        mesh: &Mesh,
        order: Option<&[u32]>,
        runs: &[std::ops::Range<u32>],
        camera: &Camera,
        buffer: &mut IdBuffer,
    ) {
        assert_eq!(
            buffer.resolution(),
            camera.resolution(),
            "ID buffer and camera resolutions differ"
        );
        let drawn: u64 = runs.iter().map(|r| u64::from(r.end - r.start)).sum();
        let triangles = runs.iter().flat_map(|run| {
            run.clone()
                .map(move |i| (order.map_or(i, |o| o[i as usize]), i))
        });
        // A whole-mesh draw projects every vertex in one pass; a culled one only those used.
        let all_vertices = drawn == u64::from(mesh.triangle_count());
        self.rasterize(
            mesh,
            camera,
            triangles,
            all_vertices,
            |id, index, q, covered| buffer.plot(index, q, id, covered),
        );
    }

    /// Draws each `(triangle, id)` of `triangles` in that order, calling
    /// `plot(id, pixel_index, depth, covered)` for every pixel it may cover (no depth test
    /// here; see [`scan_triangle`] for `covered`). With `all_vertices` every vertex is
    /// projected first, in one streaming pass (for draws of most of the mesh); otherwise each
    /// on first use.
    fn rasterize(
        &mut self,
        mesh: &Mesh,
        camera: &Camera,
        triangles: impl Iterator<Item = (u32, u32)>,
        all_vertices: bool,
        mut plot: impl FnMut(u32, usize, f32, bool),
    ) {
        let resolution = camera.resolution();
        let planes = clip::planes(resolution, camera.near(), GUARD_BAND);
        let mut draw = |projected: [ProjectedVertex; 3], corners: [u32; 3], id: u32| {
            draw_triangle(
                projected,
                || corners.map(|v| mesh.position(v)),
                camera,
                &planes,
                |tri| {
                    scan_triangle(tri, resolution, DEFAULT_PATHS, |index, q, covered| {
                        plot(id, index, q, covered)
                    })
                },
            )
        };
        if all_vertices {
            self.vertices.clear();
            self.vertices.extend(
                (0..mesh.vertex_count()).map(|v| project(camera, &planes, mesh.position(v))),
            );
            // The stamps stay: none equals the next lazy render's generation.
            for (t, id) in triangles {
                let corners = mesh.triangle(t);
                draw(corners.map(|v| self.vertices[v as usize]), corners, id);
            }
            return;
        }
        let vertex_count = mesh.vertex_count() as usize;
        if self.stamps.len() != vertex_count || self.generation == u32::MAX {
            self.stamps.clear();
            self.stamps.resize(vertex_count, 0);
            self.generation = 0;
        }
        if self.vertices.len() != vertex_count {
            self.vertices.clear();
            self.vertices
                .resize(vertex_count, ProjectedVertex::default());
        }
        self.generation += 1;
        let generation = self.generation;
        for (t, id) in triangles {
            let corners = mesh.triangle(t);
            let projected = corners.map(|v| {
                let slot = v as usize;
                if self.stamps[slot] != generation {
                    self.stamps[slot] = generation;
                    self.vertices[slot] = project(camera, &planes, mesh.position(v));
                }
                self.vertices[slot]
            });
            draw(projected, corners, id);
        }
    }
}

/// The clip planes every view uses: near plane and guard band of `camera`.
pub(crate) fn view_planes(camera: &Camera) -> [Plane; PLANE_COUNT] {
    clip::planes(camera.resolution(), camera.near(), GUARD_BAND)
}

/// Draws one triangle whose corners `v` were projected with [`project`]: rejects it if all
/// corners are outside one image edge or behind the near plane, clips it if it reaches behind
/// the near plane or beyond the guard band (`positions` gives the world-space corners then),
/// and hands each resulting screen triangle to `scan`. Every sampling path uses this one
/// function, so they all produce the same fragments.
#[inline(always)]
pub(crate) fn draw_triangle(
    v: [ProjectedVertex; 3],
    positions: impl FnOnce() -> [[f32; 3]; 3],
    camera: &Camera,
    planes: &[Plane; PLANE_COUNT],
    mut scan: impl FnMut([ScreenVertex; 3]),
) {
    let [a, b, c] = v;
    if a.outcode & b.outcode & c.outcode & REJECT != 0 {
        return;
    }
    if (a.outcode | b.outcode | c.outcode) & NEEDS_CLIP == 0 {
        scan([a.screen, b.screen, c.screen]);
        return;
    }
    let corners = positions().map(|p| camera.clip(p));
    let clipped = clip::clip_triangle(corners, planes);
    // Corners the clipper kept (it copies them bit for bit) keep the snapped position every
    // other triangle sharing them has; only the new vertices on the planes are snapped here.
    let snap_kept = |c: &[f64; 3]| {
        v.iter()
            .zip(&corners)
            .find(|(p, k)| {
                p.outcode & NEEDS_CLIP == 0 && k.map(f64::to_bits) == c.map(f64::to_bits)
            })
            .map_or_else(|| snap(*c), |(p, _)| p.screen)
    };
    // The clipped polygon is convex: fan it from its first vertex. Fan diagonals are shared
    // exactly, so the fill rule keeps the polygon's interior watertight too.
    if let [first, rest @ ..] = clipped.vertices() {
        let first = snap_kept(first);
        for pair in rest.windows(2) {
            scan([first, snap_kept(&pair[0]), snap_kept(&pair[1])]);
        }
    }
}

/// Transforms `p` and classifies it against the image, near plane and guard band.
#[inline]
pub(crate) fn project(
    camera: &Camera,
    planes: &[Plane; PLANE_COUNT],
    p: [f32; 3],
) -> ProjectedVertex {
    let c = camera.clip(p);
    let [cx, cy, w] = c;
    let edge = camera.resolution() as f64 * w;
    let mut outcode = 0;
    outcode |= if cx < 0.0 { LEFT } else { 0 };
    outcode |= if cx > edge { RIGHT } else { 0 };
    outcode |= if cy < 0.0 { TOP } else { 0 };
    outcode |= if cy > edge { BOTTOM } else { 0 };
    // The same distance function as the clipper, so "inside" means the same to both.
    if clip::distance(&planes[0], &c) < 0.0 {
        outcode |= NEAR;
    } else if planes[1..]
        .iter()
        .any(|plane| clip::distance(plane, &c) < 0.0)
    {
        outcode |= GUARD;
    }
    let screen = if outcode & NEEDS_CLIP == 0 {
        snap32(camera.clip32(p))
    } else {
        ScreenVertex::default()
    };
    ProjectedVertex { screen, outcode }
}

/// Whether every vertex within `radius` of `center` is certainly in front of the near plane
/// and inside the guard band, so that [`project_unclipped`] may replace [`project`] for it:
/// the ball must lie beyond twice the near distance and within half the guard band, margins
/// that dwarf the rounding of the transforms (~1e-15 relative in `f64`, ~1e-7 in the `f32`
/// snapping transform). True for every patch of
/// a sampling view, whose cameras frame the whole model.
pub(crate) fn sphere_needs_no_clip(camera: &Camera, center: [f32; 3], radius: f32) -> bool {
    let margin = GUARD_BAND / 2.0;
    camera.sphere_within(
        center,
        radius,
        2.0 * camera.near(),
        -margin,
        camera.resolution() as f64 + margin,
    )
}

/// [`project`] for a vertex that is known to need no clipping (see [`sphere_needs_no_clip`]):
/// the same transform, outcodes and snapping, without the five plane tests (a third of the
/// work of a projection). The reference for [`ScreenBatch::project`], which production uses.
#[cfg(test)]
pub(crate) fn project_unclipped(camera: &Camera, p: [f32; 3]) -> ProjectedVertex {
    let c = camera.clip(p);
    let [cx, cy, w] = c;
    let edge = camera.resolution() as f64 * w;
    let mut outcode = 0;
    outcode |= if cx < 0.0 { LEFT } else { 0 };
    outcode |= if cx > edge { RIGHT } else { 0 };
    outcode |= if cy < 0.0 { TOP } else { 0 };
    outcode |= if cy > edge { BOTTOM } else { 0 };
    ProjectedVertex {
        screen: snap32(camera.clip32(p)),
        outcode,
    }
}

/// [`snap`] of binary32 clip coordinates ([`Camera::clip32`]): how every vertex that needs no
/// clipping is snapped. Division, scaling, clamp and the round-half-up in binary32, a fixed
/// sequence of IEEE operations (the same bits on every machine), over four lanes at once in
/// `ScreenBatch::project`. `c` must have `w > 0`.
#[inline(always)]
pub(crate) fn snap32(c: [f32; 3]) -> ScreenVertex {
    let inv_w = 1.0 / c[2];
    ScreenVertex {
        x: snap_coordinate32(c[0], inv_w),
        y: snap_coordinate32(c[1], inv_w),
        q: inv_w,
    }
}

/// `floor(v · inv_w · 256 + 0.5)` in binary32, clamped to `±COORD_LIMIT`: truncation then a
/// correction where it rounded up (negative values), which SSE2 does four lanes at a time
/// (`cvttps2dq`, compare, add) where `f32::floor` would be a library call per value.
#[inline(always)]
pub(crate) fn snap_coordinate32(v: f32, inv_w: f32) -> i32 {
    // `max`/`min` rather than `clamp`: a NaN becomes `-COORD_LIMIT32`, as in the lanes.
    #[allow(clippy::manual_clamp)]
    let t = (v * inv_w * SUBPIXEL as f32)
        .max(-COORD_LIMIT32)
        .min(COORD_LIMIT32)
        + 0.5;
    let i = t as i32;
    i - i32::from((i as f32) > t)
}

/// [`COORD_LIMIT`] in binary32 (exact: a power of two).
pub(crate) const COORD_LIMIT32: f32 = COORD_LIMIT as f32;

/// Perspective division and snapping to the sub-pixel grid in `f64`: for the new vertices a
/// clipper makes (every vertex of the mesh goes through [`snap32`]). `c` must have `w > 0`.
#[inline]
fn snap(c: [f64; 3]) -> ScreenVertex {
    let inv_w = 1.0 / c[2];
    ScreenVertex {
        x: snap_coordinate(c[0], inv_w),
        y: snap_coordinate(c[1], inv_w),
        q: inv_w as f32,
    }
}

/// The sub-pixel coordinate of clip coordinate `v` at `1/w = inv_w`: `v · inv_w · 256`
/// clamped to `±COORD_LIMIT` and rounded half up.
#[inline(always)]
pub(crate) fn snap_coordinate(v: f64, inv_w: f64) -> i32 {
    // Round half up as `floor(v + 0.5)`, with the floor done by truncating a value made
    // positive: `f64::round` is a libm call on baseline x86-64 and was 3 % of a view. The
    // shifted value lies in `2^30 ± (2^28 + 1)`, inside `i32`, so truncating to `i32` is
    // the same as truncating to `i64`.
    const OFFSET: f64 = (1u64 << 30) as f64;
    let v = (v * inv_w * SUBPIXEL as f64).clamp(-COORD_LIMIT, COORD_LIMIT);
    ((v + 0.5 + OFFSET) as i32).wrapping_sub(OFFSET as i32)
}

/// One edge function `E(p) = (to − from) × (p − from)` (positive inside a triangle of positive
/// area), its value at the first sample of the bounding box, and its steps per pixel.
struct Edge {
    start: i64,
    step_x: i64,
    step_y: i64,
}

impl Edge {
    /// The edge `from → to`, or `to → from` if `sign` is −1.
    #[inline(always)]
    fn new(from: ScreenVertex, to: ScreenVertex, sample_x: i64, sample_y: i64, sign: i64) -> Edge {
        let (fx, fy) = (from.x as i64, from.y as i64);
        let (ex, ey) = (sign * (to.x as i64 - fx), sign * (to.y as i64 - fy));
        // Top-left rule (y points down, interior on the positive side): a top edge is
        // horizontal with the interior below it, a left edge goes upwards. Samples exactly on
        // other edges are excluded by requiring `E >= 1` there, i.e. biasing `E` by -1.
        // Non-short-circuit operators: as `||` and `&&` this compiled to branches on the
        // edge's direction, a coin toss per edge (a third of a one-pixel triangle's cost).
        let top_left = (ey < 0) | ((ey == 0) & (ex > 0));
        Edge {
            start: ex * (sample_y - fy) - ey * (sample_x - fx) - i64::from(!top_left),
            step_x: -ey * SUBPIXEL,
            step_y: ex * SUBPIXEL,
        }
    }
}

/// Which pixel loop [`scan_triangle`] uses for a bounding box; tests force each one.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ScanPaths {
    /// Bounding boxes of at most 2 × 2 pixels take the unrolled, branch-free path, and those
    /// of one to three columns rows unrolled to their width (`scan_columns`).
    pub(crate) tiny: bool,
    /// Bounding boxes at least this wide solve each row's span instead of testing pixels.
    pub(crate) span_min_width: i64,
}

/// The paths used in production.
pub(crate) const DEFAULT_PATHS: ScanPaths = ScanPaths {
    tiny: true,
    span_min_width: SPAN_MIN_WIDTH,
};

/// Calls `plot(pixel_index, depth, covered)` for the pixels of a `resolution`² image whose
/// centre the triangle may cover, in row-major order; `covered` says whether it does under the
/// top-left rule. Every covered pixel is passed exactly once; uncovered pixels of small
/// bounding boxes are passed with `covered == false` (possibly repeating a pixel) so that the
/// caller can stay branch-free. Either winding; zero area draws nothing.
#[inline(always)]
pub(crate) fn scan_triangle(
    tri: [ScreenVertex; 3],
    resolution: u32,
    paths: ScanPaths,
    plot: impl FnMut(usize, f32, bool),
) {
    scan_triangle_with_area(tri, signed_area(tri), resolution, paths, plot);
}

/// The signed area `(b − a) × (c − a)` of screen triangle `tri` (twice its area, in
/// sub-pixel units squared, y down): its sign is its winding.
#[inline(always)]
pub(crate) fn signed_area(tri: [ScreenVertex; 3]) -> i64 {
    let [a, b, c] = tri.map(|v| (v.x as i64, v.y as i64));
    (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
}

/// [`scan_triangle`] given `tri`'s [`signed_area`], for callers that computed it already
/// (the tiled sampler, to tell front from back faces).
#[inline(always)]
pub(crate) fn scan_triangle_with_area(
    tri: [ScreenVertex; 3],
    signed_area: i64,
    resolution: u32,
    paths: ScanPaths,
    mut plot: impl FnMut(usize, f32, bool),
) {
    let [a, b, c] = tri;
    // Pixels whose centres `p · 256 + 128` lie within the bounding box, clamped to the image.
    let last = resolution as i64 - 1;
    let min_x = a.x.min(b.x).min(c.x) as i64;
    let max_x = a.x.max(b.x).max(c.x) as i64;
    let min_y = a.y.min(b.y).min(c.y) as i64;
    let max_y = a.y.max(b.y).max(c.y) as i64;
    let x0 = ((min_x - HALF_PIXEL + SUBPIXEL - 1) >> SUBPIXEL_BITS).max(0);
    let x1 = ((max_x - HALF_PIXEL) >> SUBPIXEL_BITS).min(last);
    let y0 = ((min_y - HALF_PIXEL + SUBPIXEL - 1) >> SUBPIXEL_BITS).max(0);
    let y1 = ((max_y - HALF_PIXEL) >> SUBPIXEL_BITS).min(last);
    // Many small triangles fall between pixel centres: reject them before any multiplication.
    if x0 > x1 || y0 > y1 {
        return;
    }
    if signed_area == 0 {
        return;
    }
    // Negating every edge function of a clockwise triangle is the same as reversing its
    // edges, so both windings share one path without a vertex swap (a branch that would
    // mispredict on every other triangle of a closed mesh: front and back faces alternate).
    let sign = signed_area.signum();
    let area = signed_area * sign;
    let (sample_x, sample_y) = (x0 * SUBPIXEL + HALF_PIXEL, y0 * SUBPIXEL + HALF_PIXEL);
    // Barycentric weights of b and c are e1 / area and e2 / area.
    let inv_area = 1.0 / area as f32;
    let kb = (b.q - a.q) * inv_area;
    let kc = (c.q - a.q) * inv_area;
    let stride = resolution as usize;
    let (dx, dy) = (x1 - x0, y1 - y0);
    if paths.tiny && dx < 3 && max_x - min_x < LANE_SPAN && max_y - min_y < LANE_SPAN {
        let edges = LaneEdges::new(tri, sample_x, sample_y, sign);
        let depth = |w: [f32; 4]| a.q + w[1] * kb + w[2] * kc;
        scan_small(edges, [x0, y0, dx, dy], stride, depth, &mut plot);
        return;
    }
    let e0 = Edge::new(b, c, sample_x, sample_y, sign);
    let e1 = Edge::new(c, a, sample_x, sample_y, sign);
    let e2 = Edge::new(a, b, sample_x, sample_y, sign);
    let depth = |w1: i64, w2: i64| a.q + w1 as f32 * kb + w2 as f32 * kc;
    if paths.tiny && (dx | dy) == 0 {
        // One pixel centre in the box (most triangles that hold one on meshes finer than
        // the image): one sample, no steps.
        let w = [e0.start, e1.start, e2.start];
        plot(
            y0 as usize * stride + x0 as usize,
            depth(w[1], w[2]),
            (w[0] | w[1] | w[2]) >= 0,
        );
        return;
    }
    if paths.tiny && dx <= 1 && dy <= 1 {
        // Most triangles of a dense mesh: four samples, no loops, no data-dependent
        // branches. A sample beyond a 1-pixel-wide box is outside the triangle or the image;
        // it is plotted as uncovered onto an in-box pixel.
        let (has_x, has_y) = (dx == 1, dy == 1);
        let i00 = y0 as usize * stride + x0 as usize;
        let i10 = i00 + dx as usize;
        let i01 = i00 + dy as usize * stride;
        let i11 = i01 + dx as usize;
        let mut sample = |w: [i64; 3], index: usize, valid: bool| {
            plot(
                index,
                depth(w[1], w[2]),
                ((w[0] | w[1] | w[2]) >= 0) & valid,
            );
        };
        let w00 = [e0.start, e1.start, e2.start];
        let w10 = [w00[0] + e0.step_x, w00[1] + e1.step_x, w00[2] + e2.step_x];
        let w01 = [w00[0] + e0.step_y, w00[1] + e1.step_y, w00[2] + e2.step_y];
        let w11 = [w01[0] + e0.step_x, w01[1] + e1.step_x, w01[2] + e2.step_x];
        sample(w00, i00, true);
        sample(w10, i10, has_x);
        sample(w01, i01, has_y);
        sample(w11, i11, has_x & has_y);
        return;
    }

    if paths.tiny && dx < 3 {
        // One, two or three columns (most triangles of scanned meshes left here): each row
        // takes exactly that many samples, unrolled, with no loop over the row (bunny −3 %;
        // a fixed 4 samples per row, wasting the ones past the box, was +5 %).
        let rows = y0..=y1;
        let row = y0 as usize * stride + x0 as usize;
        let edges = [&e0, &e1, &e2];
        match dx {
            0 => scan_columns::<1>(edges, rows, row, stride, depth, &mut plot),
            1 => scan_columns::<2>(edges, rows, row, stride, depth, &mut plot),
            _ => scan_columns::<3>(edges, rows, row, stride, depth, &mut plot),
        }
        return;
    }

    let width = dx + 1;
    let (mut r0, mut r1, mut r2) = (e0.start, e1.start, e2.start);
    for y in y0..=y1 {
        let row = y as usize * stride + x0 as usize;
        if width < paths.span_min_width {
            let (mut w0, mut w1, mut w2) = (r0, r1, r2);
            for k in 0..width as usize {
                plot(row + k, depth(w1, w2), (w0 | w1 | w2) >= 0);
                w0 += e0.step_x;
                w1 += e1.step_x;
                w2 += e2.step_x;
            }
        } else if let Some((lo, hi)) = covered_span([r0, r1, r2], [&e0, &e1, &e2], width - 1) {
            for k in lo..=hi {
                plot(
                    row + k as usize,
                    depth(r1 + e1.step_x * k, r2 + e2.step_x * k),
                    true,
                );
            }
        }
        r0 += e0.step_y;
        r1 += e1.step_y;
        r2 += e2.step_y;
    }
}

/// Triangles whose corners span less than this (in both axes, in sub-pixel units: 4 pixels)
/// take [`scan_small`]: their edge functions, products of two differences below 1,280, stay
/// below 2^23 at every sample of their box, so `f32` lanes hold them exactly.
const LANE_SPAN: i64 = 4 * SUBPIXEL;

/// The three edge functions of a small triangle (`LANE_SPAN`) in the first three `f32` lanes,
/// the fourth always 0: the same exact integers as [`Edge::new`]'s, set up together.
#[derive(Clone, Copy)]
struct LaneEdges {
    start: f32x4,
    step_x: f32x4,
    step_y: f32x4,
}

impl LaneEdges {
    /// [`Edge::new`] of `b → c`, `c → a` and `a → b` at the sample `(sample_x, sample_y)`,
    /// which must lie within the triangle's bounding box.
    #[inline(always)]
    fn new([a, b, c]: [ScreenVertex; 3], sample_x: i64, sample_y: i64, sign: i64) -> LaneEdges {
        let from_x = i32x4::from([b.x, c.x, a.x, 0]);
        let from_y = i32x4::from([b.y, c.y, a.y, 0]);
        // Differences of snapped coordinates (within ±2^28) fit `i32`, and those of a small
        // triangle's corners and box samples convert to `f32` exactly.
        let sign = f32x4::splat(sign as f32);
        let ex = (i32x4::from([c.x, a.x, b.x, 0]) - from_x).round_float() * sign;
        let ey = (i32x4::from([c.y, a.y, b.y, 0]) - from_y).round_float() * sign;
        let to_sample_x = (i32x4::splat(sample_x as i32) - from_x).round_float();
        let to_sample_y = (i32x4::splat(sample_y as i32) - from_y).round_float();
        let zero = f32x4::splat(0.0);
        // The top-left rule as in `Edge::new`; the fourth lane, no edge, is never biased.
        let top_left = ey.cmp_lt(zero) | (ey.cmp_eq(zero) & ex.cmp_gt(zero));
        let bias = top_left.blend(zero, f32x4::from([1.0, 1.0, 1.0, 0.0]));
        let subpixel = f32x4::splat(SUBPIXEL as f32);
        LaneEdges {
            start: ex * to_sample_y - ey * to_sample_x - bias,
            step_x: -ey * subpixel,
            step_y: ex * subpixel,
        }
    }
}

/// [`scan_triangle`]'s small-box paths on [`LaneEdges`]: the box `[x0, y0, dx, dy]` is at
/// most three pixels wide; `depth` takes the edge values at a sample. The same fragments, in
/// the same order, as the `i64` paths.
#[inline(always)]
fn scan_small(
    edges: LaneEdges,
    [x0, y0, dx, dy]: [i64; 4],
    stride: usize,
    depth: impl Fn([f32; 4]) -> f32,
    plot: &mut impl FnMut(usize, f32, bool),
) {
    let zero = f32x4::splat(0.0);
    let mut sample = |w: f32x4, index: usize, valid: bool| {
        let covered = w.cmp_lt(zero).move_mask() == 0;
        plot(index, depth(w.to_array()), covered & valid);
    };
    let i00 = y0 as usize * stride + x0 as usize;
    if (dx | dy) == 0 {
        sample(edges.start, i00, true);
        return;
    }
    if dx <= 1 && dy <= 1 {
        // Four samples, no loops; a sample beyond a 1-pixel-wide box is plotted as
        // uncovered onto an in-box pixel.
        let (has_x, has_y) = (dx == 1, dy == 1);
        let (i10, i01) = (i00 + dx as usize, i00 + dy as usize * stride);
        let w01 = edges.start + edges.step_y;
        sample(edges.start, i00, true);
        sample(edges.start + edges.step_x, i10, has_x);
        sample(w01, i01, has_y);
        sample(w01 + edges.step_x, i01 + dx as usize, has_x & has_y);
        return;
    }
    match dx {
        0 => lane_columns::<1>(edges, dy, i00, stride, &mut sample),
        1 => lane_columns::<2>(edges, dy, i00, stride, &mut sample),
        _ => lane_columns::<3>(edges, dy, i00, stride, &mut sample),
    }
}

/// The `dy + 1` rows of a box `W` pixels wide whose first pixel is `row`, for
/// [`scan_small`]: `W` samples per row, unrolled.
#[inline(always)]
fn lane_columns<const W: usize>(
    edges: LaneEdges,
    dy: i64,
    mut row: usize,
    stride: usize,
    sample: &mut impl FnMut(f32x4, usize, bool),
) {
    let mut r = edges.start;
    for _ in 0..=dy {
        let mut w = r;
        for k in 0..W {
            sample(w, row + k, true);
            w += edges.step_x;
        }
        r += edges.step_y;
        row += stride;
    }
}

/// The rows `rows` of a bounding box `W` pixels wide whose first pixel is `row`: `W`
/// samples per row from the edges' values at the box's first sample.
#[inline(always)]
fn scan_columns<const W: usize>(
    edges: [&Edge; 3],
    rows: std::ops::RangeInclusive<i64>,
    mut row: usize,
    stride: usize,
    depth: impl Fn(i64, i64) -> f32,
    plot: &mut impl FnMut(usize, f32, bool),
) {
    let [e0, e1, e2] = edges;
    let mut r = [e0.start, e1.start, e2.start];
    for _ in rows {
        let mut w = r;
        for k in 0..W {
            plot(row + k, depth(w[1], w[2]), (w[0] | w[1] | w[2]) >= 0);
            w = [w[0] + e0.step_x, w[1] + e1.step_x, w[2] + e2.step_x];
        }
        r = [r[0] + e0.step_y, r[1] + e1.step_y, r[2] + e2.step_y];
        row += stride;
    }
}

/// The pixels `k` in `0..=last` where every `value + step_x · k >= 0`, as an inclusive range.
#[inline]
fn covered_span(values: [i64; 3], edges: [&Edge; 3], last: i64) -> Option<(i64, i64)> {
    let (mut lo, mut hi) = (0, last);
    for (value, edge) in values.into_iter().zip(edges) {
        let step = edge.step_x;
        if value < 0 {
            if step <= 0 {
                return None;
            }
            lo = lo.max((-value + step - 1) / step);
        } else if step < 0 {
            hi = hi.min(value / -step);
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// How many triangles of `mesh` cover each pixel (no depth test): the watertightness probe.
#[cfg(test)]
pub(crate) fn coverage_counts(mesh: &Mesh, camera: &Camera) -> Vec<u32> {
    let resolution = camera.resolution() as usize;
    let mut counts = vec![0; resolution * resolution];
    let triangles = (0..mesh.triangle_count()).map(|t| (t, t));
    Rasterizer::new().rasterize(mesh, camera, triangles, true, |_, index, _, covered| {
        counts[index] += u32::from(covered)
    });
    counts
}

#[cfg(test)]
mod tests;
