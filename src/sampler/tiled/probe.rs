//! The probe pass of `--conservative`: after a view is rendered, every patch it did not show
//! is drawn again, with conservative rasterization, against the view's occluders shrunk by
//! `radius` pixels (each pixel takes the farthest depth within `radius`), and added when a
//! fragment of it lies in front. It finds what point sampling misses: parts thinner than a
//! pixel, and parts about to come out from behind an occluder's edge as the camera moves
//! within the sphere faces whose queries use this view's row.
//!
//! Shrinking occluders also uncovers the back faces behind every silhouette, which would cost
//! most of the culling; so a triangle is drawn only if some camera of the view's cell may see
//! its visible side: its outward side anywhere, its back only near the pixels of an opening
//! of its component, within `radius + 1` pixels of where its cap lies in front of the shrunk
//! occluders (`sampler/solid.rs`).
//! Whole patches that face away from the cell and lie behind no opening are passed over by
//! their normal cone; the triangles of a patch left are tested cluster by cluster, each
//! cluster first as a whole by the screen extent of its vertices. Where the pass's fold keeps
//! from a finer view only what its fold targets lack (`SamplingOptions::folds_into`), a view
//! one level finer than the stored one does not test the patches its parents, which are
//! those targets, already hold.
//!
//! The cell holds every camera whose query may use the view's row: the directions within
//! [`CELL_PER_EDGE`] `· edge` of the view's, `edge` the largest angle between a view of the
//! pass and a view seeding it (an edge of the sampled level; with centroid finer views, a
//! corner's distance from its face's centroid, `finer.rs`), at the pass's distance, or, with
//! `SamplingOptions::band = [near, far]`, at any distance from `near` to `far`. With `φ =
//! CELL_PER_EDGE · edge`, it is taken as the convex hull of the ball of radius `φ · near` around
//! `center + d · near` and that of radius `φ · far` around `center + d · far`, `d` the view's
//! direction: a truncated cone holding the ball of radius `φ · t` around `center + d · t` for
//! every `t` between, and so every camera at angle at most `φ` and distance `t` (which lies
//! within `2 t sin(φ / 2) <= t φ` of `center + d · t`). A cylinder of the far ball's radius
//! would wrap around the model when the band reaches far beyond it (a far shell's), and let
//! every back face show. Without a band, the ball of radius `φ · distance` around the eye.
//! Every camera of a near view's cube map is probed, each against its own shrunk occluders.

use super::aperture::Apertures;
use super::{FEW_TRIANGLES, ViewContext, WorkerScratch, hidden, project_up_to, valid_bits};
use crate::runtime::Patches;
use crate::sampler::SamplingOptions;
use crate::sampler::camera::{Camera, SphereBounds};
use crate::sampler::conservative::scan_triangle_conservative;
use crate::sampler::finer::PassViews;
use crate::sampler::key_buffer::{DepthBuffer, extent_of};
use crate::sampler::raster::{
    SUBPIXEL_BITS, ScreenVertex, draw_triangle, project, sphere_needs_no_clip, view_planes,
};
use crate::sampler::scene::SceneSolids;
use crate::sampler::solid::{Cell, Openings, Side, Solids};
use crate::visibility::SamplingParams;

/// How the probe pass runs.
pub(super) struct Probe<'a> {
    /// Pixels the occluders are shrunk by.
    radius: usize,
    /// `edge` of the module documentation, in radians: the cell's angle over [`CELL_PER_EDGE`].
    edge: f64,
    /// The pass's camera distance.
    distance: f64,
    /// The band's camera distances `[near, far]` (holding `distance`), if the pass has one.
    band: Option<[f64; 2]>,
    /// The sampling centre.
    center: [f64; 3],
    /// The mesh's solids, for the facing test.
    solids: &'a Solids,
    /// Per patch: [`crate::sampler::solid::Solids::patch_components`].
    patch_component: &'a [u32],
    /// Widest gap taken as an aperture, in pixels (0: none).
    aperture_width: usize,
}

/// One worker's probe buffers.
pub(super) struct ProbeScratch {
    guard: DepthBuffer,
    ring: Vec<u32>,
    openings: Openings,
    /// The patches the view did not show, one bit each.
    unseen: Vec<u64>,
    apertures: Apertures,
}

impl ProbeScratch {
    pub(super) fn new(resolution: u32) -> ProbeScratch {
        ProbeScratch {
            guard: DepthBuffer::new(resolution),
            ring: Vec::new(),
            openings: Default::default(),
            unseen: Vec::new(),
            apertures: Apertures::default(),
        }
    }
}

/// The cell's radius in `edge`s (see the module documentation). A query from a sphere face
/// joins the rows of its corners, which hold its finer views' rows, and every point of a face
/// lies within `1/√3 ≈ 0.577 · edge` of one of them (`PassViews::max_seed_angle`); 0.6
/// leaves a margin.
pub(super) const CELL_PER_EDGE: f64 = 0.6;

/// How far out, in units of the pass's camera distance, the probe cells of a pass laid out as
/// `pass` (without a band) hold every camera whose query uses their rows: a camera at angle
/// `θ` from a view's direction and distance `x` lies in the view's ball, of radius `φ` around
/// the unit eye, while `x² − 2x cos θ + 1 ≤ φ²`. With `θ = edge / √3`, the farthest any
/// direction lies from a view of the pass, and `φ = CELL_PER_EDGE · edge`, every camera out to
/// `cos θ + √(φ² − sin² θ)` does (1.0115 for the default's finest pass). SHEL's `reach`
/// (`Plan::sampling_reach`).
pub fn probe_reach(pass: &PassViews) -> f64 {
    let edge = pass.max_seed_angle();
    let theta = edge / 3f64.sqrt();
    let phi = CELL_PER_EDGE * edge;
    theta.cos() + (phi * phi - theta.sin().powi(2)).max(0.0).sqrt()
}

impl<'a> Probe<'a> {
    /// The probe of a pass sampling `params` (its views laid out as `pass`) with `options` (its
    /// shell and band), occluders shrunk by `radius` pixels, over the mesh's `solids`.
    pub(super) fn new(
        radius: u32,
        params: &SamplingParams,
        pass: &PassViews,
        options: &SamplingOptions,
        solids: &'a SceneSolids,
    ) -> Probe<'a> {
        let distance = f64::from(options.shell.unwrap_or_else(|| params.distance()));
        Probe {
            radius: radius as usize,
            edge: pass.max_seed_angle(),
            distance,
            band: options
                .band
                .map(|[near, far]| [f64::from(near).min(distance), f64::from(far).max(distance)]),
            center: params.center.map(f64::from),
            solids: &solids.solids,
            patch_component: &solids.patch_component,
            aperture_width: options.apertures as usize,
        }
    }

    /// The cell's radius at camera distance `t`.
    fn radius_at(&self, t: f64) -> f64 {
        CELL_PER_EDGE * t * self.edge
    }

    /// The cell of the view with unit direction `d` (binary64) and eye `eye`.
    pub(super) fn cell(&self, d: [f64; 3], eye: [f64; 3]) -> Cell {
        match self.band {
            None => Cell::ball(eye, self.radius_at(self.distance)),
            Some(band) => Cell {
                ends: band.map(|t| std::array::from_fn(|k| self.center[k] + d[k] * t)),
                radii: band.map(|t| self.radius_at(t)),
            },
        }
    }
}

impl ViewContext<'_> {
    /// Builds the shrunk occluders of the view just rendered (before resolving empties it).
    pub(super) fn probe_prepare(&self, camera: &Camera, scratch: &mut WorkerScratch) {
        if let (Some(probe), Some(ps)) = (&self.probe, &mut scratch.probe) {
            ps.guard
                .shrink_from(&scratch.view.keys, probe.radius, &mut ps.ring);
            // The cell's radius at the eye's distance, also for a band (`aperture.rs`).
            let rho = probe.radius_at(probe.distance);
            let slope = (1.0 / (camera.scale() * rho)) as f32;
            let n = camera.resolution() as usize;
            ps.apertures.build(
                scratch.view.keys.keys(),
                n,
                probe.aperture_width,
                slope,
                self.marks.graph(),
                self.mesh.patch_count() as u32,
            );
        }
    }

    /// Adds to `row` the patches the probe finds from `camera`, for the cameras of `cell`,
    /// among those neither `row` nor `known` (rows the fold holds already) holds.
    pub(super) fn probe_row(
        &self,
        camera: &Camera,
        cell: &Cell,
        known: Option<&[&[u64]]>,
        scratch: &mut WorkerScratch,
        row: &mut [u64],
    ) {
        let (Some(probe), Some(ps)) = (&self.probe, &mut scratch.probe) else {
            return;
        };
        probe
            .solids
            .openings(camera, cell, probe.radius + 1, &ps.guard, &mut ps.openings);
        let guard = &ps.guard;
        // The render of this camera tested its clipping for every patch at once.
        let no_clip = scratch.view.no_clip;
        let screen = &mut scratch.draw.screen;
        let projected = &mut scratch.draw.projected;
        let patch_count = self.mesh.patch_count();
        let n = camera.resolution() as usize;
        // Whether screen triangle `st` of input triangle `t` (corners `world`) has a
        // fragment in front of the shrunk occluders where some camera of the cell may see
        // it: anywhere for its outward side, through an opening of its component for its
        // inward side.
        let openings = &ps.openings;
        let aps = &ps.apertures;
        let last = n as i32 - 1;
        // The pixels around a snapped screen extent `[min_x, max_x, min_y, max_y]`.
        let rect_of = |e: [i32; 4]| {
            let c = |v: i32, d: i32| ((v >> SUBPIXEL_BITS) + d).clamp(0, last) as usize;
            [c(e[0], -1), c(e[2], -1), c(e[1], 1), c(e[3], 1)]
        };
        // The screen test first: it rejects most triangles of a hidden patch, and costs less
        // than the facing test's look-ups by triangle and square root (a 1,000,000-triangle
        // bunny grid's default bake: 0.87× the CPU time with this order, BENCHMARKS.md).
        let in_front = |t: u32, world: [[f32; 3]; 3], st: [ScreenVertex; 3]| {
            // A fragment is never farther than the triangle's farthest corner (`conservative.rs`).
            let q_far = st[0].q.min(st[1].q).min(st[2].q);
            if guard.triangle_hidden(st, true) && !aps.may_reveal(rect_of(extent_of(st)), q_far) {
                return false;
            }
            let side = probe.solids.side(t, world, cell);
            if let Side::Inward(c) = side
                && !openings.any(c)
            {
                return false;
            }
            let mut hit = false;
            scan_triangle_conservative(st, n as u32, |index, q, _| {
                hit |= (q.to_bits() > guard.depth_bits(index) || aps.reveals(index, q))
                    && match side {
                        Side::Outward => true,
                        Side::Inward(c) => openings.covers(c, index % n, index / n),
                    };
            });
            hit
        };
        unseen_of(&mut ps.unseen, row, known, patch_count);
        for p in Patches::of_bits(&ps.unseen) {
            let p = p as usize;
            let patch = &self.tiling.patches[p];
            let bounds = camera.sphere_bounds(patch.center, patch.radius);
            let rect = match bounds {
                SphereBounds::Rect { rect, .. } => Some(rect),
                _ => None,
            };
            let open = aps.any() && rect.is_none_or(|r| aps.may_reveal(r, 0.0));
            if probe.solids.patch_hidden_side(
                probe.patch_component[p],
                patch.center,
                patch.radius,
                patch.cone_axis,
                patch.cone_cos,
                rect,
                cell,
                openings,
            ) || (!open
                && (hidden(bounds, guard)
                    || (patch.count > FEW_TRIANGLES
                        && hidden(camera.hull_bounds(&self.boxes[p].corners()), guard))))
            {
                continue;
            }
            let mut found = false;
            let mut k = patch.first as usize;
            if no_clip || sphere_needs_no_clip(camera, patch.center, patch.radius) {
                // Cluster by cluster, each first by the extent of the vertices holding its
                // corners, projected only as far as the clusters tested so far use them (a
                // hidden patch's clusters mostly lie wholly behind the shrunk occluders).
                'sections: for section in self.mesh.sections(p) {
                    let mut projected_to = 0;
                    for (c, cluster) in section.clusters.iter().enumerate() {
                        let run = section.run(c);
                        let vertex_end = cluster.vertex_end as usize;
                        project_up_to(screen, camera, &section, &mut projected_to, vertex_end);
                        let (extent, q_max) = screen.extent(cluster.vertices());
                        if guard.extent_hidden(extent, q_max, true)
                            && !(open
                                && aps
                                    .may_reveal(rect_of(extent), screen.q_far(cluster.vertices())))
                        {
                            k += run.len();
                            continue;
                        }
                        for &tri in run {
                            let t = self.tiling.order[k];
                            k += 1;
                            let world = tri.map(|i| section.vertices.get(usize::from(i)));
                            if in_front(t, world, screen.triangle(tri)) {
                                found = true;
                                break 'sections;
                            }
                        }
                    }
                }
            } else if self.options.shell.is_some() {
                // A near view's cube faces cut through patches: the clip path, as the
                // render draws them.
                let planes = view_planes(camera);
                'clipped: for section in self.mesh.sections(p) {
                    let vertices = section.vertices;
                    projected.clear();
                    projected.extend(vertices.iter().map(|v| project(camera, &planes, v)));
                    for tri in section.triangles {
                        let t = self.tiling.order[k];
                        k += 1;
                        let world = tri.map(|i| vertices.get(usize::from(i)));
                        draw_triangle(
                            tri.map(|i| projected[usize::from(i)]),
                            || world,
                            camera,
                            &planes,
                            |st| found = found || in_front(t, world, st),
                        );
                        if found {
                            break 'clipped;
                        }
                    }
                }
            } else {
                // A sampling view's patches never reach the near plane or the guard band:
                // kept whole rather than drawn.
                found = true;
            }
            if found {
                row[p / 64] |= 1 << (p % 64);
            }
        }
    }
}

/// Into `unseen`, the patches (of `patch_count`) neither `row` nor any of `known` holds.
fn unseen_of(unseen: &mut Vec<u64>, row: &[u64], known: Option<&[&[u64]]>, patch_count: usize) {
    unseen.clear();
    unseen.extend(
        row.iter()
            .enumerate()
            .map(|(w, r)| !r & valid_bits(w, patch_count)),
    );
    for r in known.into_iter().flatten() {
        for (u, &k) in unseen.iter_mut().zip(r.iter()) {
            *u &= !k;
        }
    }
}
