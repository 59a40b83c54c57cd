//! Which side of each triangle can show: the mesh as solids with openings.
//!
//! Vertices are welded by position and triangles sharing an edge form a component. Each
//! component is an integer 2-chain; its boundary (the edges whose uses do not cancel, weighted
//! by how much they do not) is capped by a cone from a point `O` inside the model's bounds,
//! which makes the chain closed. For a closed chain whose winding number is 0 or 1 everywhere
//! (a solid, however it is wound), a ray from outside the model's bounding sphere first
//! crosses it from outside to inside. So a triangle's back side can show only when the ray
//! first entered through the cap, that is through one of the component's openings:
//!
//! - a component whose boundary is empty (closed) never shows its back faces;
//! - an open one shows them only to a camera that faces some triangle of its cap from the
//!   front. A sheet's cap is the sheet itself, reversed, so its back always may show.
//!
//! The orientation (which side is out) is the sign of the capped chain's volume, so meshes
//! wound inwards, and mirrored parts, are handled per component. The one assumption (winding
//! number 0 or 1) fails only for self-intersecting or inconsistently wound solids; on those a
//! skipped back face that shows is caught by the point-sampled render at the sampled views.
//!
//! Cost: a sort of the 3·n edges (`memory::SOLIDS_BYTES_PER_TRIANGLE` bytes per triangle at
//! the peak) and a union-find over the triangles; what stays is 5 bytes per triangle and the
//! caps.

use crate::ooc::Mesh;
use crate::sampler::camera::{Camera, SphereBounds};
use rayon::prelude::*;

/// The solids of a mesh: per triangle its component and orientation, per component its cap.
pub(crate) struct Solids {
    /// Per input triangle: +1 when its front side faces out of its (capped) component, −1 when
    /// its back side does.
    orientation: Vec<i8>,
    /// Per input triangle: its component.
    component: Vec<u32>,
    /// Per component: +1 when its triangles' front sides face out, −1 when their backs do.
    component_sign: Vec<i8>,
    /// Per component: the first of its boundary loops in `loops` (one more entry at the end).
    loop_start: Vec<u32>,
    /// Boundary loops, each capped by a cone from its centroid.
    loops: Vec<Loop>,
    /// Cap triangles of every loop.
    caps: Vec<Cap>,
}

/// One boundary loop of a component and its cap.
#[derive(Clone, Debug)]
pub(crate) struct Loop {
    /// The cone's apex: the loop's centroid.
    apex: [f64; 3],
    /// Its cap triangles in `Solids::caps`.
    caps: std::ops::Range<usize>,
    /// Corners of a box holding the loop and the apex, so the whole cap.
    corners: [[f64; 3]; 8],
}

/// One triangle of a component's cap.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cap {
    /// Outward normal of the capped solid there (length: twice the triangle's area times the
    /// edge's multiplicity).
    normal: [f64; 3],
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

/// The cameras whose queries may use a view's row, for the facing tests: every point within
/// `radius` of the segment between `ends` (a ball when they coincide). The segment runs along
/// the view's direction over the camera distances the row answers (`SamplingOptions::band`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cell {
    /// The segment's ends.
    pub(crate) ends: [[f64; 3]; 2],
    /// Distance from the segment.
    pub(crate) radius: f64,
}

impl Cell {
    /// The ball of `radius` around `eye`.
    pub(crate) fn ball(eye: [f64; 3], radius: f64) -> Cell {
        Cell {
            ends: [eye, eye],
            radius,
        }
    }

    /// The distinct ends. A half-space holds the cell when it holds the balls around its
    /// ends, since the cell is their convex hull, so every facing test runs on them.
    fn balls(&self) -> &[[f64; 3]] {
        if self.ends[0] == self.ends[1] {
            &self.ends[..1]
        } else {
            &self.ends
        }
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
            .iter()
            .any(|&eye| dot(normal, sub(eye, point)) >= -cell.radius * len)
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
}

impl Solids {
    /// Finds the components, their caps and orientations.
    pub(crate) fn new(mesh: &Mesh) -> Solids {
        let n = mesh.triangle_count() as usize;
        let weld = weld_by_position(mesh);
        // Each directed edge as (min, max) key, triangle, and +1 when it runs min → max.
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
        edges.par_sort_unstable_by_key(|e| (e.0, e.1));
        let mut parent: Vec<u32> = (0..n as u32).collect();
        // Boundary edges: (first triangle, a, b, multiplicity), running a → b.
        let mut boundary: Vec<(u32, u32, u32, i32)> = Vec::new();
        for run in edges.chunk_by(|a, b| a.0 == b.0) {
            let root = find(&mut parent, run[0].1);
            let mut balance = 0;
            for &(_, t, dir) in run {
                balance += dir;
                let r = find(&mut parent, t);
                if r != root {
                    parent[r as usize] = root;
                }
            }
            if balance != 0 {
                let (lo, hi) = ((run[0].0 >> 32) as u32, run[0].0 as u32);
                let (a, b) = if balance > 0 { (lo, hi) } else { (hi, lo) };
                boundary.push((run[0].1, a, b, balance.abs()));
            }
        }
        drop(edges);
        // Number the components in order of their first triangle (deterministic).
        let mut component = vec![u32::MAX; n];
        let mut count = 0u32;
        let mut id_of_root = vec![u32::MAX; n];
        for t in 0..n as u32 {
            let r = find(&mut parent, t) as usize;
            if id_of_root[r] == u32::MAX {
                id_of_root[r] = count;
                count += 1;
            }
            component[t as usize] = id_of_root[r];
        }
        drop(parent);
        drop(id_of_root);
        let components = count as usize;
        let position = |v: u32| mesh.position(v).map(f64::from);
        // Trace the boundary into cycles, one cap (a cone from the cycle's centroid) each.
        boundary.sort_unstable_by_key(|&(t, a, b, _)| (component[t as usize], a, b));
        let mut loop_start = Vec::with_capacity(components + 1);
        let mut loops = Vec::new();
        let mut caps = Vec::new();
        let mut next = 0;
        for c in 0..components {
            loop_start.push(loops.len() as u32);
            let end =
                next + boundary[next..].partition_point(|e| component[e.0 as usize] as usize == c);
            trace_loops(&boundary[next..end], &position, &mut loops, &mut caps);
            next = end;
        }
        loop_start.push(loops.len() as u32);
        drop(boundary);
        // Volume of each capped component (about its first vertex, for precision).
        let mut reference = vec![None; components];
        let mut volume = vec![0f64; components];
        for t in 0..n as u32 {
            let c = component[t as usize] as usize;
            let corners = mesh.triangle(t).map(position);
            let o = *reference[c].get_or_insert(corners[0]);
            let [a, b, d] = corners.map(|p| sub(p, o));
            volume[c] += dot(a, cross(b, d));
        }
        for c in 0..components {
            let o = reference[c].unwrap_or([0.0; 3]);
            for l in &loops[loop_start[c] as usize..loop_start[c + 1] as usize] {
                for cap in &caps[l.caps.clone()] {
                    // det(apex − o, b − o, a − o) through the stored normal (b−apex)×(a−apex).
                    volume[c] += dot(sub(l.apex, o), cap.normal);
                }
            }
        }
        let sign: Vec<i8> = volume
            .iter()
            .map(|&v| if v >= 0.0 { 1 } else { -1 })
            .collect();
        for c in 0..components {
            if sign[c] < 0 {
                for l in &loops[loop_start[c] as usize..loop_start[c + 1] as usize] {
                    for cap in &mut caps[l.caps.clone()] {
                        cap.normal = cap.normal.map(|x| -x);
                    }
                }
            }
        }
        let orientation = component.iter().map(|&c| sign[c as usize]).collect();
        Solids {
            orientation,
            component,
            component_sign: sign,
            loop_start,
            loops,
            caps,
        }
    }

    /// Number of components.
    #[cfg(test)]
    pub(crate) fn component_count(&self) -> usize {
        self.loop_start.len() - 1
    }

    /// Number of closed components (no boundary loop).
    #[cfg(test)]
    pub(crate) fn closed_count(&self) -> usize {
        self.loop_start.windows(2).filter(|w| w[0] == w[1]).count()
    }

    /// Where each component may be looked into from a camera of `cell`: the screen rectangles
    /// in `camera`'s image of its loops whose caps some such camera sees from the front,
    /// widened by `margin` pixels. Component `c`'s are `rects[start[c]..start[c + 1]]`.
    pub(crate) fn openings(
        &self,
        camera: &Camera,
        cell: &Cell,
        margin: usize,
        openings: &mut Openings,
    ) {
        let last = camera.resolution() as usize - 1;
        openings.rects.clear();
        openings.start.clear();
        for w in self.loop_start.windows(2) {
            openings.start.push(openings.rects.len() as u32);
            for l in &self.loops[w[0] as usize..w[1] as usize] {
                if !self.caps[l.caps.clone()]
                    .iter()
                    .any(|cap| may_face(l.apex, cap.normal, cell))
                {
                    continue;
                }
                match camera.hull_bounds(&l.corners) {
                    SphereBounds::Outside => {}
                    SphereBounds::Unbounded => openings.rects.push([0, 0, last, last]),
                    SphereBounds::Rect {
                        rect: [x0, y0, x1, y1],
                        ..
                    } => openings.rects.push([
                        x0.saturating_sub(margin),
                        y0.saturating_sub(margin),
                        (x1 + margin).min(last),
                        (y1 + margin).min(last),
                    ]),
                }
            }
        }
        openings.start.push(openings.rects.len() as u32);
    }

    /// Whether input triangle `t` (corners `tri`, covering the pixel rectangle `pixels`, `[x0,
    /// y0, x1, y1]` inclusive) may show to a camera of `cell`: its outward side faces some
    /// such camera, or it lies behind an opening of its component that one faces
    /// ([`Solids::openings`] of the view).
    pub(crate) fn may_show(
        &self,
        t: u32,
        tri: [[f32; 3]; 3],
        pixels: [usize; 4],
        cell: &Cell,
        openings: &Openings,
    ) -> bool {
        let [a, b, c] = tri.map(|p| p.map(f64::from));
        let normal =
            cross(sub(b, a), sub(c, a)).map(|x| x * f64::from(self.orientation[t as usize]));
        if may_face(a, normal, cell) {
            return true;
        }
        let c = self.component[t as usize] as usize;
        let rects = &openings.rects[openings.start[c] as usize..openings.start[c + 1] as usize];
        rects.iter().any(|r| {
            pixels[0] <= r[2] && r[0] <= pixels[2] && pixels[1] <= r[3] && r[1] <= pixels[3]
        })
    }
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
        let c = c as usize;
        let rects = &openings.rects[openings.start[c] as usize..openings.start[c + 1] as usize];
        if !rects.is_empty() {
            let Some(p) = rect else { return false };
            if rects
                .iter()
                .any(|r| p[0] <= r[2] && r[0] <= p[2] && p[1] <= r[3] && r[1] <= p[3])
            {
                return false;
            }
        }
        // Outward normals lie within the cone around `sign · axis`; the patch's points seen
        // from a ball of the cell lie within `rho` of direction `d`. All back sides show when
        // the angle between them, plus the cone's and the ball's half-angles, stays below 90°
        // (for each ball, and so for the cell, their convex hull).
        let sign = f64::from(self.orientation_of_component(c));
        let axis = axis.map(|x| f64::from(x) * sign);
        cell.balls().iter().all(|&eye| {
            let d = sub(center.map(f64::from), eye);
            let rho = f64::from(radius) + cell.radius;
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

/// A view's openings ([`Solids::openings`]): per component, screen rectangles.
#[derive(Default)]
pub(crate) struct Openings {
    rects: Vec<[usize; 4]>,
    start: Vec<u32>,
}

/// Splits one component's boundary edges (`(triangle, a, b, multiplicity)`, sorted by `a`)
/// into closed loops and caps each with a cone from its centroid, into `loops` and `caps`.
/// The boundary of a triangle set is a cycle (every vertex has as many boundary edges in as
/// out), so following unused edges from a loop's first vertex always leads back to it.
fn trace_loops(
    boundary: &[(u32, u32, u32, i32)],
    position: &impl Fn(u32) -> [f64; 3],
    loops: &mut Vec<Loop>,
    caps: &mut Vec<Cap>,
) {
    let mut edges: Vec<(u32, u32)> = Vec::new();
    for &(_, a, b, m) in boundary {
        for _ in 0..m {
            edges.push((a, b));
        }
    }
    edges.sort_unstable();
    let mut used = vec![false; edges.len()];
    // Per start vertex: the next edge leaving it that may be unused.
    let mut cursor: std::collections::HashMap<u32, usize> = std::collections::HashMap::new();
    let mut vertices = Vec::new();
    for first in 0..edges.len() {
        if used[first] {
            continue;
        }
        vertices.clear();
        let start = edges[first].0;
        let mut e = first;
        loop {
            used[e] = true;
            let (a, b) = edges[e];
            vertices.push(a);
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
                break; // Not reached for a true boundary; the cone still covers the path.
            };
            cursor.insert(b, k + 1);
            e = k;
        }
        let points: Vec<[f64; 3]> = vertices.iter().map(|&v| position(v)).collect();
        let count = points.len() as f64;
        let apex = points
            .iter()
            .fold([0.0; 3], |s, p| [s[0] + p[0], s[1] + p[1], s[2] + p[2]])
            .map(|x| x / count);
        let first_cap = caps.len();
        for (i, &a) in points.iter().enumerate() {
            let b = points[(i + 1) % points.len()];
            caps.push(Cap {
                normal: cross(sub(b, apex), sub(a, apex)),
            });
        }
        let (mut lo, mut hi) = (apex, apex);
        for p in &points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let corners = std::array::from_fn(|i| {
            [
                if i & 1 == 0 { lo[0] } else { hi[0] },
                if i & 2 == 0 { lo[1] } else { hi[1] },
                if i & 4 == 0 { lo[2] } else { hi[2] },
            ]
        });
        loops.push(Loop {
            apex,
            caps: first_cap..caps.len(),
            corners,
        });
    }
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
        let mut openings = Openings::default();
        let cell = Cell::ball(camera.eye(), 0.0);
        solids.openings(camera, &cell, 1, &mut openings);
        (0..mesh.triangle_count())
            .map(|t| {
                // The whole image: whether an opening's rectangle exists decides.
                let last = camera.resolution() as usize - 1;
                let pixels = [0, 0, last, last];
                solids.may_show(t, corners(mesh, t), pixels, &cell, &openings)
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
            solids.openings(&camera, &Cell::ball(camera.eye(), 0.0), 1, &mut o);
            o
        };
        let top: Vec<u32> = (0..24)
            .filter(|&t| {
                let cell = Cell::ball(camera.eye(), 0.0);
                solids.may_show(t, corners(&m, t), [0; 4], &cell, &openings)
            })
            .collect();
        // The +Z face of each cube, and the inner-facing side walls (+X of the first, −X of
        // the second), which the eye between them sees.
        assert_eq!(top, vec![2, 3, 10, 11, 12, 13, 22, 23]);
    }
}
