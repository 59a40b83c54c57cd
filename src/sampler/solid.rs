//! Which side of each triangle can show: the mesh as solids with openings.
//!
//! Vertices are welded by position and triangles sharing an edge form a component. Each
//! component is an integer 2-chain; its boundary (the edges whose uses do not cancel, weighted
//! by how much they do not) is traced into loops, and each loop is capped, which makes the
//! chain closed. For a closed chain whose winding number is 0 or 1 everywhere (a solid,
//! however it is wound), a ray from outside the model's bounding sphere first crosses it from
//! outside to inside. So a triangle's back side can show only when the ray first entered
//! through the cap, that is through one of the component's openings:
//!
//! - a component whose boundary is empty (closed) never shows its back faces;
//! - an open one shows them only to a camera that faces some triangle of its cap from the
//!   front, and only behind a point of that cap that the camera sees. A view finds those
//!   points for the cameras of its cell as the cap pixels in front of its shrunk depths,
//!   widened by a margin of the shrink's pixels ([`Solids::openings`]).
//!
//! Any 2-chain with the loop as boundary is a valid cap; the tighter it hugs the opening, the
//! fewer back faces lie behind it. A loop is capped by its least-area triangulation, which
//! spans a hole by the hole and an open seam (a wing whose skins part along the trailing
//! edge) by a thin strip along it; a cone from the centroid would fan across the whole part.
//! Loops longer than [`SMALL_CAP_LOOP`] take that cone, since the triangulation costs `O(n³)`,
//! and so do all loops once the mesh's triangulations have used [`CAP_WORK_FIXED`] and its
//! per-triangle share.
//!
//! A sheet's cap is about the sheet itself, reversed, so its back may show from its back side.
//! A component whose capped volume is nil (a flat card, a lone triangle, a folded strip that
//! is its own least-area cap) is taken as such a sheet outright: either side may show, and it
//! keeps no caps, which would cost every view a pass over them for nothing.
//!
//! The orientation (which side is out) is the sign of the capped chain's volume, so meshes
//! wound inwards, and mirrored parts, are handled per component. The one assumption (winding
//! number 0 or 1) fails only for self-intersecting or inconsistently wound solids; on those a
//! skipped back face that shows is caught by the point-sampled render at the sampled views.
//!
//! Cost: a sort of the 3·n edges (`memory::SOLIDS_BYTES_PER_TRIANGLE` bytes per triangle at
//! the peak) and a union-find over the triangles; what stays is 5 bytes per triangle and the
//! caps of the components that are not sheets (36 bytes a cap triangle, 16 a loop, 24 an open
//! component).

use crate::ooc::Mesh;
use crate::sampler::camera::Camera;
use crate::sampler::conservative::scan_triangle_conservative;
use crate::sampler::key_buffer::DepthBuffer;
use crate::sampler::raster::{draw_triangle, project, view_planes};
use rayon::prelude::*;

/// The solids of a mesh: per triangle its component and orientation, per component its cap.
pub(crate) struct Solids {
    /// Per input triangle: +1 when its front side faces out of its (capped) component, −1 when
    /// its back side does, 0 on a sheet.
    orientation: Vec<i8>,
    /// Per input triangle: its component. The open components (those with boundary loops)
    /// come first, so that a view's openings walk only them; then the closed ones and the
    /// sheets. Each group is in order of the components' first triangles.
    component: Vec<u32>,
    /// Per component: +1 when its triangles' front sides face out, −1 when their backs do, 0
    /// for a sheet, either of whose sides may show.
    component_sign: Vec<i8>,
    /// Per open component: the first of its boundary loops in `loops` (one more entry at the
    /// end).
    loop_start: Vec<u32>,
    /// Boundary loops and their caps.
    loops: Vec<Loop>,
    /// Cap triangles of every loop.
    caps: Vec<Cap>,
}

/// One boundary loop of a component and its cap.
#[derive(Clone, Debug)]
pub(crate) struct Loop {
    /// Its cap triangles in `Solids::caps`.
    caps: std::ops::Range<usize>,
}

/// One triangle of a component's cap.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cap {
    /// Its corners, wound so that the capped chain is closed.
    corners: [[f32; 3]; 3],
}

impl Cap {
    /// The normal of its winding (length: twice its area), in `f64` from the `f32` corners.
    /// Times the component's sign, it points out of the capped solid.
    fn normal(&self) -> [f64; 3] {
        let [a, b, c] = self.corners.map(widen);
        cross(sub(b, a), sub(c, a))
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(u: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

fn dot(u: [f64; 3], v: [f64; 3]) -> f64 {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

fn widen(p: [f32; 3]) -> [f64; 3] {
    p.map(f64::from)
}

/// The cameras whose queries may use a view's row, for the facing tests: the convex hull of
/// a ball around each of `ends` (one ball when they coincide). Along a band of camera
/// distances (`SamplingOptions::band`) the ends lie on the view's direction at the band's
/// nearest and farthest distance, each ball's radius the cell's angle times its distance: a
/// truncated cone holding every camera within that angle of the direction, at any distance
/// of the band.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cell {
    /// The balls' centres.
    pub(crate) ends: [[f64; 3]; 2],
    /// The balls' radii.
    pub(crate) radii: [f64; 2],
}

impl Cell {
    /// The ball of `radius` around `eye`.
    pub(crate) fn ball(eye: [f64; 3], radius: f64) -> Cell {
        Cell {
            ends: [eye, eye],
            radii: [radius; 2],
        }
    }

    /// The distinct balls, as (centre, radius). A half-space holds the cell when it holds
    /// them, since the cell is their convex hull, so every facing test runs on them.
    fn balls(&self) -> impl Iterator<Item = ([f64; 3], f64)> + '_ {
        let count = if self.ends[0] == self.ends[1] && self.radii[0] == self.radii[1] {
            1
        } else {
            2
        };
        self.ends.iter().copied().zip(self.radii).take(count)
    }
}

/// Whether a plane through `point` with normal `normal` (not unit) is seen from its front by
/// some point of `cell`.
pub(crate) fn may_face(point: [f64; 3], normal: [f64; 3], cell: &Cell) -> bool {
    let len = dot(normal, normal).sqrt();
    // A degenerate triangle has no side: treat it as facing.
    len.is_nan()
        || len == 0.0
        || cell
            .balls()
            .any(|(eye, r)| dot(normal, sub(eye, point)) >= -r * len)
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
}

/// Each directed edge of the mesh, its vertices welded by position: the `(min, max)` vertex
/// key, the triangle, and +1 when it runs min → max. Sorted by key, then triangle.
fn directed_edges(mesh: &Mesh) -> Vec<(u64, u32, i32)> {
    let n = mesh.triangle_count() as usize;
    let weld = weld_by_position(mesh);
    let mut edges: Vec<(u64, u32, i32)> = Vec::with_capacity(3 * n);
    for t in 0..n as u32 {
        let c = mesh.triangle(t).map(|v| weld[v as usize]);
        for (a, b) in [(c[0], c[1]), (c[1], c[2]), (c[2], c[0])] {
            if a != b {
                let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
                edges.push((key, t, if a < b { 1 } else { -1 }));
            }
        }
    }
    drop(weld);
    edges.par_sort_unstable_by_key(|e| (e.0, e.1));
    edges
}

/// Joins the triangles of each of the sorted `edges` in a union-find over the `n` triangles
/// (whose parents are returned) and keeps the boundary edges, in place and in key order:
/// `(a << 32 | b, first triangle, multiplicity)`, running a → b.
fn join_edges(mut edges: Vec<(u64, u32, i32)>, n: usize) -> (Vec<(u64, u32, i32)>, Vec<u32>) {
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut kept = 0;
    let mut run = 0;
    while run < edges.len() {
        let (key, first, _) = edges[run];
        let root = find(&mut parent, first);
        let mut balance = 0;
        let mut end = run;
        while end < edges.len() && edges[end].0 == key {
            balance += edges[end].2;
            let r = find(&mut parent, edges[end].1);
            if r != root {
                parent[r as usize] = root;
            }
            end += 1;
        }
        if balance != 0 {
            let (lo, hi) = (key >> 32, key & u64::from(u32::MAX));
            let (a, b) = if balance > 0 { (lo, hi) } else { (hi, lo) };
            edges[kept] = ((a << 32) | b, first, balance.abs());
            kept += 1;
        }
        run = end;
    }
    edges.truncate(kept);
    edges.shrink_to_fit();
    (edges, parent)
}
/// Numbers the components of the union-find `parent` in order of their first triangle
/// (deterministic): per triangle its component, and per component its first triangle.
fn number_components(mut parent: Vec<u32>) -> (Vec<u32>, Vec<u32>) {
    let n = parent.len();
    let mut component = vec![u32::MAX; n];
    let mut first_triangle = Vec::new();
    let mut id_of_root = vec![u32::MAX; n];
    for t in 0..n as u32 {
        let r = find(&mut parent, t) as usize;
        if id_of_root[r] == u32::MAX {
            id_of_root[r] = first_triangle.len() as u32;
            first_triangle.push(t);
        }
        component[t as usize] = id_of_root[r];
    }
    drop(parent);
    drop(id_of_root);
    first_triangle.shrink_to_fit();
    (component, first_triangle)
}

/// The point component `c`'s volume is taken about, for precision: the first vertex of its
/// first triangle.
fn reference(mesh: &Mesh, first_triangle: &[u32], c: usize) -> [f64; 3] {
    widen(mesh.position(mesh.triangle(first_triangle[c])[0]))
}

/// Six times the volume of each component's triangles about its [`reference`]; each cap adds
/// its own ([`cap_components`]).
fn component_volumes(mesh: &Mesh, component: &[u32], first_triangle: &[u32]) -> Vec<f64> {
    let mut volume = vec![0f64; first_triangle.len()];
    for t in 0..mesh.triangle_count() {
        let c = component[t as usize] as usize;
        let o = reference(mesh, first_triangle, c);
        let [a, b, d] = mesh.triangle(t).map(|v| sub(widen(mesh.position(v)), o));
        volume[c] += dot(a, cross(b, d));
    }
    volume
}

/// Every component's boundary loops and caps, and its sign.
struct Capped {
    /// Per component, the first of its loops in `loops` (one more entry at the end).
    loop_start: Vec<u32>,
    /// Per component: +1 or −1 as its capped volume is positive or negative, 0 for a sheet.
    sign: Vec<i8>,
    loops: Vec<Loop>,
    caps: Vec<Cap>,
}

/// Traces each component's `boundary` into loops and caps them, and signs each component by
/// its capped `volume`. A component whose capped volume is nil next to its size is a sheet (a
/// card, a lone triangle): its cap lies on it, so either side may show wherever the sheet
/// does. Sign 0 says so, and it keeps no loops, so a mesh of cards needs no room for their
/// caps.
fn cap_components(
    mesh: &Mesh,
    mut boundary: Vec<(u64, u32, i32)>,
    component: &[u32],
    first_triangle: &[u32],
    mut volume: Vec<f64>,
) -> Capped {
    let n = component.len();
    let components = first_triangle.len();
    let position = |v: u32| widen(mesh.position(v));
    boundary.sort_unstable_by_key(|&(key, t, _)| (component[t as usize], key));
    let mut loop_start = Vec::with_capacity(components + 1);
    let mut sign = Vec::with_capacity(components);
    let mut loops = Vec::new();
    let mut caps: Vec<Cap> = Vec::new();
    let mut work = CAP_WORK_FIXED + CAP_WORK_PER_TRIANGLE * n as u64;
    let mut next = 0;
    for (c, volume) in volume.iter_mut().enumerate() {
        let (first_loop, first_cap) = (loops.len(), caps.len());
        loop_start.push(first_loop as u32);
        let end =
            next + boundary[next..].partition_point(|e| component[e.1 as usize] as usize == c);
        trace_loops(
            &boundary[next..end],
            &position,
            &mut work,
            &mut loops,
            &mut caps,
        );
        next = end;
        let o = reference(mesh, first_triangle, c);
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for cap in &caps[first_cap..] {
            // det(p − o, q − o, r − o) through the normal (q − p) × (r − p).
            *volume += dot(sub(widen(cap.corners[0]), o), cap.normal());
            for p in cap.corners.map(widen) {
                lo = std::array::from_fn(|k| lo[k].min(p[k]));
                hi = std::array::from_fn(|k| hi[k].max(p[k]));
            }
        }
        let size = sub(hi, lo);
        if loops.len() > first_loop && volume.abs() <= FLAT_VOLUME * dot(size, size).powf(1.5) {
            loops.truncate(first_loop);
            caps.truncate(first_cap);
            sign.push(0);
        } else {
            sign.push(if *volume >= 0.0 { 1 } else { -1 });
        }
    }
    loop_start.push(loops.len() as u32);
    Capped {
        loop_start,
        sign,
        loops,
        caps,
    }
}

/// Renumbers the components so that the open ones (those with loops) come first, then the
/// closed ones and the sheets, each group in its former order: rewrites `component` and
/// returns the renumbered components' signs and the open components' first loops (one more
/// entry at the end). Their loops are already in that order.
fn open_first(loop_start: Vec<u32>, sign: Vec<i8>, component: &mut [u32]) -> (Vec<i8>, Vec<u32>) {
    let components = sign.len();
    let open_count = loop_start.windows(2).filter(|w| w[1] > w[0]).count();
    let mut rank = Vec::with_capacity(components);
    let (mut next_open, mut next_other) = (0u32, open_count as u32);
    for w in loop_start.windows(2) {
        let next = if w[1] > w[0] {
            &mut next_open
        } else {
            &mut next_other
        };
        rank.push(*next);
        *next += 1;
    }
    let mut component_sign = vec![0i8; components];
    for (c, &r) in rank.iter().enumerate() {
        component_sign[r as usize] = sign[c];
    }
    drop(sign);
    for c in component.iter_mut() {
        *c = rank[*c as usize];
    }
    drop(rank);
    let mut open_start: Vec<u32> = loop_start
        .windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| w[0])
        .collect();
    open_start.push(loop_start[components]);
    (component_sign, open_start)
}

impl Solids {
    /// Finds the components, their caps and orientations.
    pub(crate) fn new(mesh: &Mesh) -> Solids {
        let n = mesh.triangle_count() as usize;
        let (boundary, parent) = join_edges(directed_edges(mesh), n);
        let (mut component, first_triangle) = number_components(parent);
        let volume = component_volumes(mesh, &component, &first_triangle);
        let Capped {
            loop_start,
            sign,
            mut loops,
            mut caps,
        } = cap_components(mesh, boundary, &component, &first_triangle, volume);
        drop(first_triangle);
        loops.shrink_to_fit();
        caps.shrink_to_fit();
        let (component_sign, open_start) = open_first(loop_start, sign, &mut component);
        let orientation = component
            .iter()
            .map(|&c| component_sign[c as usize])
            .collect();
        Solids {
            orientation,
            component,
            component_sign,
            loop_start: open_start,
            loops,
            caps,
        }
    }

    /// Number of components.
    #[cfg(test)]
    pub(crate) fn component_count(&self) -> usize {
        self.component_sign.len()
    }

    /// Number of closed components (no boundary loop).
    #[cfg(test)]
    pub(crate) fn closed_count(&self) -> usize {
        self.component_sign.len() + 1 - self.loop_start.len()
    }

    /// Where each component may be looked into from a camera of `cell`: the pixels of
    /// `camera`'s image where a cap triangle that some such camera sees from the front, drawn
    /// conservatively, lies in front of `guard` (the view's shrunk occluders), kept per loop as
    /// each pixel's distance from them over a rectangle. A back face is in the opening within
    /// `margin` pixels of them ([`Openings::covers`]).
    ///
    /// A ray that shows a back face entered the capped solid through a cap point between the
    /// eye and that face, and nothing occludes that point either. So the cap point shows to
    /// the camera, and whatever shows to a camera of the cell is in front of `guard`: the
    /// assumption the whole probe rests on. A cap hidden behind the model (an open end pushed
    /// into another part, the inside of a wing open along its trailing edge) opens nothing.
    /// From this view's eye the cap point and the back face behind it lie apart by the
    /// parallax between them; as for every occluder's edge in the probe, the margin covers
    /// what comes out by up to the shrink (the probe passes its radius plus one pixel), and
    /// the finer views around the view find what comes out by more. Widening each opening by
    /// the whole parallax the cell allows culled 0.6–2.3 points less on the bunny and the
    /// airplane, for one view of 300 more identical in some of their bakes (a 1-pixel miss;
    /// docs/benchmarks/quality-zoo.md, "Openings as tight as the shrink").
    pub(crate) fn openings(
        &self,
        camera: &Camera,
        cell: &Cell,
        margin: usize,
        guard: &DepthBuffer,
        openings: &mut Openings,
    ) {
        let resolution = camera.resolution();
        let n = resolution as usize;
        let planes = view_planes(camera);
        let pixel_of = |i: u32| (i as usize % n, i as usize / n);
        openings.clear();
        openings.margin = margin;
        let Openings {
            start,
            loops,
            distance,
            pixels,
            ..
        } = openings;
        for (c, w) in self.loop_start.windows(2).enumerate() {
            let sign = self.component_sign[c];
            start.push(loops.len() as u32);
            for l in &self.loops[w[0] as usize..w[1] as usize] {
                pixels.clear();
                for cap in &self.caps[l.caps.clone()] {
                    let outward = cap.normal().map(|x| x * f64::from(sign));
                    if !may_face(widen(cap.corners[0]), outward, cell) {
                        continue;
                    }
                    let projected = cap.corners.map(|p| project(camera, &planes, p));
                    draw_triangle(
                        projected,
                        || cap.corners,
                        camera,
                        &planes,
                        |st| {
                            // Wholly behind the shrunk occluders (most caps of a hole
                            // under the model): no pixel to scan for.
                            if guard.triangle_hidden(st, true) {
                                return;
                            }
                            scan_triangle_conservative(st, resolution, |index, q, _| {
                                if q.to_bits() > guard.depth_bits(index) {
                                    pixels.push(index as u32);
                                }
                            });
                        },
                    );
                }
                if pixels.is_empty() {
                    continue;
                }
                // The loop's pixels, widened by `margin` each way: its rectangle.
                let (mut x0, mut y0, mut x1, mut y1) = (n, n, 0, 0);
                for &i in pixels.iter() {
                    let (x, y) = pixel_of(i);
                    (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
                }
                let widen_by_margin =
                    |lo: usize, hi: usize| (lo.saturating_sub(margin), (hi + margin).min(n - 1));
                let ((x0, x1), (y0, y1)) = (widen_by_margin(x0, x1), widen_by_margin(y0, y1));
                let (width, height) = (x1 + 1 - x0, y1 + 1 - y0);
                // Every pixel of the rectangle lies within `margin` of the loop's, or the
                // view's grids would pass their bound: the whole rectangle (a superset).
                let first = if margin >= width.max(height)
                    || distance.len() + width * height > n * n / GRID_PIXELS_PER_CELL
                {
                    WHOLE_RECT
                } else {
                    let first = distance.len();
                    distance.resize(first + width * height, FAR_PIXELS);
                    let grid = &mut distance[first..];
                    for &i in pixels.iter() {
                        let (x, y) = pixel_of(i);
                        grid[(y - y0) * width + (x - x0)] = 0;
                    }
                    chessboard_distances(grid, width);
                    first
                };
                loops.push(LoopOpening {
                    rect: [x0, y0, x1, y1],
                    width,
                    first,
                });
            }
        }
        start.push(loops.len() as u32);
    }

    /// Which side of input triangle `t` (corners `tri`) may show to a camera of `cell`.
    pub(crate) fn side(&self, t: u32, tri: [[f32; 3]; 3], cell: &Cell) -> Side {
        let orientation = self.orientation[t as usize];
        let [a, b, c] = tri.map(|p| p.map(f64::from));
        let normal = cross(sub(b, a), sub(c, a)).map(|x| x * f64::from(orientation));
        if orientation == 0 || may_face(a, normal, cell) {
            Side::Outward
        } else {
            Side::Inward(self.component[t as usize])
        }
    }
}

/// Which side of a triangle may show to a camera of a cell ([`Solids::side`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Side {
    /// Its outward side faces some camera: it may show anywhere.
    Outward,
    /// Only its inward side faces the cell: it may show only through an opening of its
    /// component ([`Openings::covers`]).
    Inward(u32),
}

impl Solids {
    /// Per patch of `tiling`: the component all its triangles lie on, or `u32::MAX` when they
    /// lie on several.
    pub(crate) fn patch_components(&self, tiling: &crate::tiling::Tiling) -> Vec<u32> {
        tiling
            .patches
            .iter()
            .map(|patch| {
                let range = patch.first as usize..(patch.first + patch.count) as usize;
                let mut ts = tiling.order[range]
                    .iter()
                    .map(|&t| self.component[t as usize]);
                let first = ts.next().unwrap_or(u32::MAX);
                if ts.all(|c| c == first) {
                    first
                } else {
                    u32::MAX
                }
            })
            .collect()
    }

    /// Whether every triangle of a patch on component `c` (bounding sphere `center`,
    /// `radius`; geometric normals within the cone `axis`, `cos`) faces away from every
    /// camera of `cell`, and none lies behind an opening of `c` one of them faces (`rect`:
    /// the patch's screen rectangle, `[x0, y0, x1, y1]`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn patch_hidden_side(
        &self,
        c: u32,
        center: [f32; 3],
        radius: f32,
        axis: [f32; 3],
        cos: f32,
        rect: Option<[usize; 4]>,
        cell: &Cell,
        openings: &Openings,
    ) -> bool {
        if c == u32::MAX || cos <= 0.0 {
            return false;
        }
        if openings.any(c) {
            let Some(p) = rect else { return false };
            if openings.meets(c, p) {
                return false;
            }
        }
        let c = c as usize;
        if self.orientation_of_component(c) == 0 {
            return false; // A sheet: either side may show.
        }
        // Outward normals lie within the cone around `sign · axis`; the patch's points seen
        // from a ball of the cell lie within `rho` of direction `d`. All back sides show when
        // the angle between them, plus the cone's and the ball's half-angles, stays below 90°
        // (for each ball, and so for the cell, their convex hull).
        let sign = f64::from(self.orientation_of_component(c));
        let axis = axis.map(|x| f64::from(x) * sign);
        cell.balls().all(|(eye, r)| {
            let d = sub(center.map(f64::from), eye);
            let rho = f64::from(radius) + r;
            let len = dot(d, d).sqrt();
            if len.is_nan() || len <= rho {
                return false;
            }
            let angle = (dot(d, axis) / len).clamp(-1.0, 1.0).acos();
            let spread = (rho / len).asin() + f64::from(cos).clamp(-1.0, 1.0).acos();
            angle + spread < std::f64::consts::FRAC_PI_2 - 1e-6
        })
    }

    fn orientation_of_component(&self, c: usize) -> i8 {
        self.component_sign[c]
    }
}

/// Distances at or past this many pixels are stored as this.
const FAR_PIXELS: u8 = u8::MAX;

/// A view's loops keep distance grids of at most one cell (a byte) per this many pixels of
/// the image (64 KiB at 512²); past it, and where a loop's margin spans its whole rectangle,
/// a loop's opening is its rectangle ([`WHOLE_RECT`]). Many open parts seen at once (a near
/// view of a model of open shells) so cost bounded memory.
const GRID_PIXELS_PER_CELL: usize = 4;

/// `LoopOpening::first` of an opening that is its whole rectangle.
const WHOLE_RECT: usize = usize::MAX;

/// Replaces each cell of the row-major grid `width` cells wide by its chessboard distance
/// (in cells) to the nearest cell holding 0, at most [`FAR_PIXELS`]: the two raster passes
/// over the eight neighbours, which give that distance exactly. Each pass takes a row's
/// three neighbours in the row before it first, a loop over the whole row that the compiler
/// turns into SIMD, and then its neighbour along the row, one cell after the other.
fn chessboard_distances(grid: &mut [u8], width: usize) {
    if width == 0 {
        return;
    }
    let height = grid.len() / width;
    for y in 0..height {
        let (before, rest) = grid.split_at_mut(y * width);
        let row = &mut rest[..width];
        if y > 0 {
            from_row(row, &before[(y - 1) * width..]);
        }
        for x in 1..width {
            row[x] = row[x].min(row[x - 1].saturating_add(1));
        }
    }
    for y in (0..height).rev() {
        let (row, after) = grid[y * width..].split_at_mut(width);
        if y + 1 < height {
            from_row(row, &after[..width]);
        }
        for x in (0..width - 1).rev() {
            row[x] = row[x].min(row[x + 1].saturating_add(1));
        }
    }
}

/// Lowers each cell of `row` to one more than the least of its three neighbours in `other`,
/// the grid row above or below it (as long).
fn from_row(row: &mut [u8], other: &[u8]) {
    let w = row.len();
    let step = |r: &mut u8, d: u8| *r = (*r).min(d.saturating_add(1));
    if w == 1 {
        step(&mut row[0], other[0]);
        return;
    }
    step(&mut row[0], other[0].min(other[1]));
    step(&mut row[w - 1], other[w - 2].min(other[w - 1]));
    for (r, ((&a, &b), &c)) in row[1..w - 1]
        .iter_mut()
        .zip(other.iter().zip(&other[1..]).zip(&other[2..]))
    {
        step(r, a.min(b).min(c));
    }
}

/// A view's openings ([`Solids::openings`]): per component, the pixels of its loops' caps
/// that may show, as distance grids.
#[derive(Default)]
pub(crate) struct Openings {
    /// Per open component `c`: its loops are `loops[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    loops: Vec<LoopOpening>,
    /// Every loop's pixel distances.
    distance: Vec<u8>,
    /// The cap pixels of the loop being built.
    pixels: Vec<u32>,
    /// How many pixels from a cap pixel that shows a back face may show.
    margin: usize,
}

/// One loop's opening in a view: a rectangle of pixels and their distances from the cap's.
struct LoopOpening {
    /// `[x0, y0, x1, y1]`, inclusive: every pixel the opening may hold.
    rect: [usize; 4],
    /// Pixels per row of the rectangle.
    width: usize,
    /// The rectangle's first pixel's distance in `Openings::distance`, or [`WHOLE_RECT`].
    first: usize,
}

impl Openings {
    fn clear(&mut self) {
        self.start.clear();
        self.loops.clear();
        self.distance.clear();
    }

    /// The openings of `component`'s loops: none for a closed component or a sheet, which
    /// are numbered after the open ones.
    fn of(&self, component: u32) -> &[LoopOpening] {
        let c = component as usize;
        match (self.start.get(c), self.start.get(c + 1)) {
            (Some(&first), Some(&end)) => &self.loops[first as usize..end as usize],
            _ => &[],
        }
    }

    /// Whether a back face of `component` at pixel `(x, y)` may show through an opening:
    /// whether it lies within the margin of a cap pixel that shows ([`Solids::openings`]).
    pub(crate) fn covers(&self, component: u32, x: usize, y: usize) -> bool {
        self.of(component).iter().any(|l| {
            let [x0, y0, x1, y1] = l.rect;
            if x < x0 || x > x1 || y < y0 || y > y1 {
                return false;
            }
            // Exact below FAR_PIXELS; at it, the margin is as large or the rectangle held it.
            l.first == WHOLE_RECT
                || usize::from(self.distance[l.first + (y - y0) * l.width + (x - x0)])
                    <= self.margin
        })
    }

    /// Whether `component` has an opening whose rectangle meets the pixel rectangle `rect`
    /// (`[x0, y0, x1, y1]`, inclusive).
    pub(crate) fn meets(&self, component: u32, rect: [usize; 4]) -> bool {
        self.of(component).iter().any(|l| {
            let r = l.rect;
            rect[0] <= r[2] && r[0] <= rect[2] && rect[1] <= r[3] && r[1] <= rect[3]
        })
    }

    /// Whether `component` has any opening.
    pub(crate) fn any(&self, component: u32) -> bool {
        !self.of(component).is_empty()
    }
}

/// Splits one component's boundary edges (`(a << 32 | b, triangle, multiplicity)`, sorted)
/// into closed loops and caps each ([`cap_loop`], drawing on `work`), into `loops` and
/// `caps`. The boundary of a triangle set is a cycle (every vertex has as many boundary edges
/// in as out), so following unused edges from a loop's first vertex always leads back to it.
fn trace_loops(
    boundary: &[(u64, u32, i32)],
    position: &impl Fn(u32) -> [f64; 3],
    work: &mut u64,
    loops: &mut Vec<Loop>,
    caps: &mut Vec<Cap>,
) {
    let mut edges: Vec<(u32, u32)> = Vec::new();
    for &(key, _, m) in boundary {
        for _ in 0..m {
            edges.push(((key >> 32) as u32, key as u32));
        }
    }
    edges.sort_unstable();
    let mut used = vec![false; edges.len()];
    // Per start vertex: the next edge leaving it that may be unused.
    let mut cursor: std::collections::HashMap<u32, usize> = std::collections::HashMap::new();
    let mut points = Vec::new();
    for first in 0..edges.len() {
        if used[first] {
            continue;
        }
        points.clear();
        let start = edges[first].0;
        let mut e = first;
        loop {
            used[e] = true;
            let (a, b) = edges[e];
            points.push(position(a));
            if b == start {
                break;
            }
            let from = *cursor
                .entry(b)
                .or_insert_with(|| edges.partition_point(|&(x, _)| x < b));
            let Some(k) = (from..edges.len())
                .take_while(|&k| edges[k].0 == b)
                .find(|&k| !used[k])
            else {
                break; // Not reached for a true boundary; the cap still closes the path.
            };
            cursor.insert(b, k + 1);
            e = k;
        }
        let first_cap = caps.len();
        cap_loop(&points, work, caps);
        loops.push(Loop {
            caps: first_cap..caps.len(),
        });
    }
}

/// A capped component is a sheet ([`Solids::new`]) when six times its volume is at most this
/// much of the cube of its caps' bounding box's diagonal (a sheet's boundary spans it): flat
/// to `f32` rounding, with room.
const FLAT_VOLUME: f64 = 1e-6;

/// Caps the loop through `points` (see the module documentation), into `caps`.
fn cap_loop(points: &[[f64; 3]], work: &mut u64, caps: &mut Vec<Cap>) {
    // Each triangle `[i, k, j]` runs with the loop; its cap triangle runs against it, so
    // that the cap's boundary cancels the component's. Loop points are mesh positions, exact
    // in `f32`; a cone's apex is rounded.
    let mut push = |corners: [[f64; 3]; 3]| {
        caps.push(Cap {
            corners: corners.map(|p| p.map(|x| x as f32)),
        })
    };
    let n = points.len() as u64;
    let cost = n * n * n / 6;
    if points.len() <= SMALL_CAP_LOOP && cost <= *work {
        *work -= cost;
        for [i, k, j] in least_area_triangulation(points) {
            push([points[i], points[j], points[k]]);
        }
    } else {
        let count = points.len() as f64;
        let apex = points
            .iter()
            .fold([0.0; 3], |s, p| [s[0] + p[0], s[1] + p[1], s[2] + p[2]])
            .map(|x| x / count);
        for (i, &a) in points.iter().enumerate() {
            push([apex, points[(i + 1) % points.len()], a]);
        }
    }
}

/// Loops of up to this many vertices are capped by their least-area triangulation (`O(n³)`
/// time, `O(n²)` memory: 2.8 million area terms and 0.5 MiB at the bound), longer ones by
/// the cone from their centroid.
const SMALL_CAP_LOOP: usize = 256;

/// The least-area triangulations of a mesh together evaluate at most `CAP_WORK_FIXED +
/// CAP_WORK_PER_TRIANGLE · n` area terms (`n³ / 6` a loop of `n` vertices; about 3 ns each),
/// in loop order; loops past it take the cone. A mesh of many long open loops (a hundred
/// thousand open tubes of 256 sides would take hours) so costs at most about 0.2 s and 0.8 µs
/// a triangle; the zoo's loops (at most 90 vertices) use a few thousandths of it.
const CAP_WORK_FIXED: u64 = 1 << 26;
/// See [`CAP_WORK_FIXED`].
const CAP_WORK_PER_TRIANGLE: u64 = 256;

/// The triangulation of the closed polygon `points` (in 3D, not necessarily planar) with the
/// least total area, as triangles `[i, k, j]`, `i < k < j`, running with the polygon. Dynamic
/// programming over the sub-polygons `i..=j` (Barequet & Sharir 1995); ties go to the
/// smallest `k`, so the result is deterministic.
fn least_area_triangulation(points: &[[f64; 3]]) -> Vec<[usize; 3]> {
    let n = points.len();
    if n < 3 {
        return Vec::new();
    }
    let area = |i: usize, k: usize, j: usize| {
        let c = cross(sub(points[k], points[i]), sub(points[j], points[i]));
        dot(c, c).sqrt()
    };
    // cost[i * n + j]: least area of the polygon i, i + 1, …, j; best: its apex over i → j.
    let mut cost = vec![0f64; n * n];
    let mut best = vec![0u32; n * n];
    for span in 2..n {
        for i in 0..n - span {
            let j = i + span;
            let (mut least, mut arg) = (f64::INFINITY, i + 1);
            for k in i + 1..j {
                let c = cost[i * n + k] + cost[k * n + j] + area(i, k, j);
                if c < least {
                    (least, arg) = (c, k);
                }
            }
            cost[i * n + j] = least;
            best[i * n + j] = arg as u32;
        }
    }
    let mut triangles = Vec::with_capacity(n - 2);
    let mut stack = vec![(0, n - 1)];
    while let Some((i, j)) = stack.pop() {
        if j - i < 2 {
            continue;
        }
        let k = best[i * n + j] as usize;
        triangles.push([i, k, j]);
        stack.push((i, k));
        stack.push((k, j));
    }
    triangles
}

/// Per vertex, the smallest vertex index at the same position.
fn weld_by_position(mesh: &Mesh) -> Vec<u32> {
    let vertices = mesh.vertex_count();
    let mut by_position: Vec<([u32; 3], u32)> = (0..vertices)
        .into_par_iter()
        .map(|v| (mesh.position(v).map(f32::to_bits), v))
        .collect();
    by_position.par_sort_unstable();
    let mut weld = vec![0u32; vertices as usize];
    let mut first = 0;
    for (i, &(p, v)) in by_position.iter().enumerate() {
        if p != by_position[first].0 {
            first = i;
        }
        weld[v as usize] = by_position[first].1;
    }
    weld
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_band_reaching_far_out_is_a_cone_not_a_cylinder() {
        // The cameras within 0.03 rad of +z, from 1 to 256 units out: a plane at the origin
        // facing -z is seen from none of them, nor one turned 3° past the side; one turned 1°
        // towards them is.
        let phi = 0.03;
        let band = [1.0, 256.0];
        let cone = Cell {
            ends: band.map(|t| [0.0, 0.0, t]),
            radii: band.map(|t| phi * t),
        };
        let (back, side) = ([0.0, 0.0, -1.0], [1.0, 0.0, 0.02f64.sin()]);
        assert!(!may_face([0.0; 3], back, &cone));
        assert!(may_face([0.0; 3], side, &cone));
        assert!(!may_face([0.0; 3], [1.0, 0.0, -0.05f64.sin()], &cone));
        // A cylinder of the far end's radius wraps around the origin: everything faces it.
        let cylinder = Cell {
            radii: [phi * 256.0; 2],
            ..cone
        };
        assert!(may_face([0.0; 3], back, &cylinder));
        // Conservative: any plane some camera of the band sees from its front (cameras on
        // the cone's rim and axis, at distances across the band) faces the cell.
        let mut rng = crate::test_kit::rng::Rng::new(7);
        for _ in 0..2000 {
            let n = [0; 3].map(|_| rng.unit() * 2.0 - 1.0);
            let p = [0; 3].map(|_| rng.unit() * 0.5 - 0.25);
            let seen = [1.0, 1.5, 3.0, 40.0, 256.0].iter().any(|&t| {
                (0..16).any(|k| {
                    let a = k as f64 * std::f64::consts::TAU / 16.0;
                    let eye = [
                        t * phi.sin() * a.cos(),
                        t * phi.sin() * a.sin(),
                        t * phi.cos(),
                    ];
                    dot(n, sub(eye, p)) > 0.0
                })
            });
            assert!(!seen || may_face(p, n, &cone), "{n:?} {p:?}");
        }
    }

    /// Corners of the unit cube.
    fn corner(i: u32) -> [f32; 3] {
        [(i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2 & 1) as f32]
    }

    /// The unit cube's faces wound outwards, each as two triangles, in the order −X, +X, −Y,
    /// +Y, −Z, +Z.
    fn cube_faces() -> Vec<[[u32; 3]; 2]> {
        vec![
            [[0, 4, 6], [0, 6, 2]],
            [[1, 3, 7], [1, 7, 5]],
            [[0, 1, 5], [0, 5, 4]],
            [[2, 6, 7], [2, 7, 3]],
            [[0, 2, 3], [0, 3, 1]],
            [[4, 5, 7], [4, 7, 6]],
        ]
    }

    fn mesh(faces: &[[[u32; 3]; 2]], flip: bool) -> Mesh {
        let triangles = faces
            .iter()
            .flatten()
            .map(|&[a, b, c]| if flip { [a, c, b] } else { [a, b, c] })
            .collect();
        Mesh::from_memory("cube", (0..8).map(corner).collect(), triangles).unwrap()
    }

    fn corners(mesh: &Mesh, t: u32) -> [[f32; 3]; 3] {
        mesh.triangle(t).map(|v| mesh.position(v))
    }

    /// An eye far along `direction` from the cube's centre, looking at it.
    fn camera(direction: [f32; 3]) -> Camera {
        let eye = direction.map(|d| 0.5 + 10.0 * d);
        Camera::look_at(eye, [0.5; 3], 45.0, 64)
    }

    /// Which triangles of `mesh` may show to `camera`'s eye (cell 0), each taken to cover the
    /// whole image.
    fn shown(solids: &Solids, mesh: &Mesh, camera: &Camera) -> Vec<bool> {
        shown_behind(solids, mesh, camera, &DepthBuffer::new(camera.resolution()))
    }

    /// [`shown`] with the occluders `guard`.
    fn shown_behind(
        solids: &Solids,
        mesh: &Mesh,
        camera: &Camera,
        guard: &DepthBuffer,
    ) -> Vec<bool> {
        let mut openings = Openings::default();
        let cell = Cell::ball(camera.eye(), 0.0);
        solids.openings(camera, &cell, 1, guard, &mut openings);
        (0..mesh.triangle_count())
            .map(|t| match solids.side(t, corners(mesh, t), &cell) {
                Side::Outward => true,
                // Whether the component has an opening anywhere in the image decides.
                Side::Inward(c) => openings.any(c),
            })
            .collect()
    }

    #[test]
    fn a_closed_cube_shows_its_outer_side_however_it_is_wound() {
        for flip in [false, true] {
            let m = mesh(&cube_faces(), flip);
            let solids = Solids::new(&m);
            assert_eq!((solids.component_count(), solids.closed_count()), (1, 1));
            // From +Z only the +Z face (triangles 10 and 11) faces the eye.
            let shown = shown(&solids, &m, &camera([0.0, 0.0, 1.0]));
            let expect: Vec<bool> = (0..12).map(|t| t >= 10).collect();
            assert_eq!(shown, expect, "flip {flip}");
        }
    }

    #[test]
    fn an_open_box_shows_its_inside_only_through_the_opening() {
        // The cube without its +Z face: a box open at the top.
        let faces = cube_faces()[..5].to_vec();
        for flip in [false, true] {
            let m = mesh(&faces, flip);
            let solids = Solids::new(&m);
            assert_eq!((solids.component_count(), solids.closed_count()), (1, 0));
            // From above, every inner side shows through the opening.
            assert!(
                shown(&solids, &m, &camera([0.0, 0.0, 1.0]))
                    .iter()
                    .all(|&s| s)
            );
            // From below, only the bottom's outer side: the opening faces away.
            let below = shown(&solids, &m, &camera([0.0, 0.0, -1.0]));
            let expect: Vec<bool> = (0..10).map(|t| t >= 8).collect();
            assert_eq!(below, expect, "flip {flip}");
        }
    }

    #[test]
    fn a_sheet_shows_both_sides() {
        let faces = cube_faces()[5..].to_vec();
        let m = mesh(&faces, false);
        let solids = Solids::new(&m);
        for d in [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]] {
            assert!(shown(&solids, &m, &camera(d)).iter().all(|&s| s), "{d:?}");
        }
        // Flat: taken as a sheet outright, with no caps to pass over.
        assert_eq!(solids.component_sign, [0]);
        assert!(solids.loops.is_empty() && solids.caps.is_empty());
        // Two faces meeting at an edge are their own least-area cap: a sheet too.
        let faces = cube_faces();
        let bent = Solids::new(&mesh(&[faces[0], faces[2]], false));
        assert_eq!(bent.component_sign, [0]);
        // An open box's cap is its lid, which encloses a volume: a solid with an opening.
        let open = Solids::new(&mesh(&faces[..5], false));
        assert_eq!(open.component_sign, [1]);
        assert_eq!((open.loops.len(), open.caps.len()), (1, 2));
    }

    #[test]
    fn separate_parts_get_their_own_orientation() {
        // Two cubes, the second wound inwards and moved along x: each is its own solid.
        let mut positions: Vec<[f32; 3]> = (0..8).map(corner).collect();
        positions.extend((0..8).map(|i| {
            let p = corner(i);
            [p[0] + 3.0, p[1], p[2]]
        }));
        let mut triangles: Vec<[u32; 3]> = cube_faces().into_iter().flatten().collect();
        triangles.extend(
            cube_faces()
                .into_iter()
                .flatten()
                .map(|[a, b, c]| [a + 8, c + 8, b + 8]),
        );
        let m = Mesh::from_memory("cubes", positions, triangles).unwrap();
        let solids = Solids::new(&m);
        assert_eq!((solids.component_count(), solids.closed_count()), (2, 2));
        let eye = [1.75, 0.5, 10.0];
        let camera = Camera::look_at(eye.map(|x| x as f32), [1.75, 0.5, 0.5], 45.0, 64);
        let openings = {
            let mut o = Openings::default();
            let nothing = DepthBuffer::new(camera.resolution());
            let cell = Cell::ball(camera.eye(), 0.0);
            solids.openings(&camera, &cell, 1, &nothing, &mut o);
            o
        };
        let top: Vec<u32> = (0..24)
            .filter(|&t| {
                let cell = Cell::ball(camera.eye(), 0.0);
                match solids.side(t, corners(&m, t), &cell) {
                    Side::Outward => true,
                    Side::Inward(c) => openings.any(c),
                }
            })
            .collect();
        // The +Z face of each cube, and the inner-facing side walls (+X of the first, −X of
        // the second), which the eye between them sees.
        assert_eq!(top, vec![2, 3, 10, 11, 12, 13, 22, 23]);
    }

    #[test]
    fn a_cap_behind_an_occluder_opens_nothing() {
        // The box open at the top, seen from above behind a wall nearer than its rim.
        let m = mesh(&cube_faces()[..5], false);
        let solids = Solids::new(&m);
        let camera = camera([0.0, 0.0, 1.0]);
        let mut guard = DepthBuffer::new(camera.resolution());
        let n = camera.resolution() as usize;
        let near = 1.0 / 5.0; // 1/w at 5 units from the eye, the box's top at 9.5
        for i in 0..n * n {
            guard.set(i, near);
        }
        // Every side the eye faces is inward: all show through the open top, and none
        // behind the wall.
        assert!(shown(&solids, &m, &camera).iter().all(|&s| s));
        assert!(
            shown_behind(&solids, &m, &camera, &guard)
                .iter()
                .all(|&s| !s)
        );
    }

    #[test]
    fn openings_cover_only_where_the_cap_shows() {
        // The box open at the top, from above: its inside shows through the top's pixels
        // (widened by the margin), not elsewhere in the image.
        let m = mesh(&cube_faces()[..5], false);
        let solids = Solids::new(&m);
        let camera = camera([0.0, 0.0, 1.0]);
        let cell = Cell::ball(camera.eye(), 0.0);
        let mut openings = Openings::default();
        let guard = DepthBuffer::new(camera.resolution());
        solids.openings(&camera, &cell, 1, &guard, &mut openings);
        let centre = camera.project([0.5, 0.5, 1.0]).unwrap().map(|x| x as usize);
        assert!(openings.covers(0, centre[0], centre[1]));
        assert!(!openings.covers(0, 0, 0));
    }

    #[test]
    fn openings_reach_exactly_the_margin_past_the_cap() {
        // Along the row through the open top's centre, the covered pixels run `margin`
        // further each way than the cap's own (margin 0), and no further.
        let m = mesh(&cube_faces()[..5], false);
        let solids = Solids::new(&m);
        let camera = camera([0.0, 0.0, 1.0]);
        let cell = Cell::ball(camera.eye(), 0.0);
        let guard = DepthBuffer::new(camera.resolution());
        let n = camera.resolution() as usize;
        let y = camera.project([0.5, 0.5, 1.0]).unwrap()[1] as usize;
        let covered_span = |margin: usize| {
            let mut openings = Openings::default();
            solids.openings(&camera, &cell, margin, &guard, &mut openings);
            let covered: Vec<usize> = (0..n).filter(|&x| openings.covers(0, x, y)).collect();
            // One run of pixels.
            assert_eq!(covered.len(), covered[covered.len() - 1] - covered[0] + 1);
            (covered[0], covered[covered.len() - 1])
        };
        let (lo, hi) = covered_span(0);
        assert!(lo >= 3 && hi + 3 < n, "the cap lies inside the image");
        for margin in [1, 3] {
            assert_eq!(
                covered_span(margin),
                (lo - margin, hi + margin),
                "margin {margin}"
            );
        }
    }

    #[test]
    fn least_area_caps_span_their_loops() {
        // A planar convex hexagon: n − 2 triangles, its area exactly, every side used once.
        let hexagon: Vec<[f64; 3]> = (0..6)
            .map(|i| {
                let a = i as f64 * std::f64::consts::PI / 3.0;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let triangles = least_area_triangulation(&hexagon);
        assert_eq!(triangles.len(), 4);
        let area: f64 = triangles
            .iter()
            .map(|&[i, k, j]| {
                let c = cross(sub(hexagon[k], hexagon[i]), sub(hexagon[j], hexagon[i]));
                dot(c, c).sqrt() / 2.0
            })
            .sum();
        assert!((area - 1.5 * 3f64.sqrt()).abs() < 1e-12, "{area}");
        let mut sides = std::collections::HashSet::new();
        for [i, k, j] in triangles {
            assert!(i < k && k < j);
            for (a, b) in [(i, k), (k, j), (i, j)] {
                if b == a + 1 || (a, b) == (0, 5) {
                    assert!(sides.insert((a, b)), "side {a}-{b} twice");
                }
            }
        }
        assert_eq!(sides.len(), 6);

        // Two rails 0.01 apart (a wing's open trailing edge): a thin strip, where the cone
        // from the centroid would fan across the whole loop.
        let rails: Vec<[f64; 3]> = (0..10)
            .map(|i| [i as f64, 0.0, 0.0])
            .chain((0..10).rev().map(|i| [i as f64, 0.01, 0.0]))
            .collect();
        let area: f64 = least_area_triangulation(&rails)
            .iter()
            .map(|&[i, k, j]| {
                let c = cross(sub(rails[k], rails[i]), sub(rails[j], rails[i]));
                dot(c, c).sqrt() / 2.0
            })
            .sum();
        assert!((area - 0.09).abs() < 1e-9, "{area}");
    }

    #[test]
    fn cap_work_runs_out_into_cones() {
        let ring: Vec<[f64; 3]> = (0..12)
            .map(|i| {
                let a = f64::from(i) * std::f64::consts::TAU / 12.0;
                [a.cos(), a.sin(), 0.1 * (3.0 * a).sin()]
            })
            .collect();
        let (mut caps, mut work) = (Vec::new(), 12 * 12 * 12 / 6);
        cap_loop(&ring, &mut work, &mut caps);
        assert_eq!((caps.len(), work), (10, 0), "least area: n − 2 triangles");
        caps.clear();
        cap_loop(&ring, &mut work, &mut caps);
        assert_eq!(caps.len(), 12, "no work left: the cone");
    }

    proptest::proptest! {
        /// The chessboard distances are the brute-force ones.
        #[test]
        fn chessboard_distances_are_exact(
            cells in proptest::collection::vec(proptest::bool::weighted(0.05), 1..400),
            width in 1usize..30,
        ) {
            let height = cells.len() / width;
            proptest::prop_assume!(height > 0);
            let cells = &cells[..width * height];
            let mut grid: Vec<u8> =
                cells.iter().map(|&zero| if zero { 0 } else { FAR_PIXELS }).collect();
            chessboard_distances(&mut grid, width);
            for (i, &d) in grid.iter().enumerate() {
                let (x, y) = (i % width, i / width);
                let brute = (0..cells.len())
                    .filter(|&j| cells[j])
                    .map(|j| x.abs_diff(j % width).max(y.abs_diff(j / width)))
                    .min()
                    .map_or(FAR_PIXELS, |d| d.min(usize::from(FAR_PIXELS)) as u8);
                proptest::prop_assert_eq!(d, brute, "cell ({}, {})", x, y);
            }
        }
    }
}
