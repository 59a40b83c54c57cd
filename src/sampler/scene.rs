//! What every pass of a bake samples: the mesh and its tiling, with the CPU sampler's set-up
//! built the first time a pass needs it and shared by every pass after.
//!
//! A default bake samples five spheres of views (the sampling sphere, two near shells, two far
//! shells), each in its own pass over the same mesh and tiling. Every pass needs the mesh
//! regrouped by patch (`patch_mesh.rs`), every patch's box (`patch_box.rs`) and the mesh's
//! winding; with the probe its solids (`solid.rs`); with `--dilate` or `--apertures` the patch
//! graph (`patch_graph.rs`). At 20M triangles the first three take 3.7 s on one thread, on a
//! budget that maps the regrouped mesh to a temporary file. None of it depends on the pass
//! (camera distance, level, probe cell), so a [`Scene`] builds each once.
//!
//! Where the regrouped mesh lives (heap or mapped file) is decided by the first pass that
//! builds it, within that pass's sampling share of the memory budget: every pass of a bake has
//! the same share, resolution and threads, and where it lives changes no row.

use super::patch_box::{PatchBox, patch_boxes};
use super::patch_graph::PatchGraph;
use super::patch_mesh::{PatchMesh, Storage};
use super::solid::Solids;
use crate::ooc::Mesh;
use crate::tiling::Tiling;
use rayon::prelude::*;
use std::sync::OnceLock;

/// A mesh and a tiling of it, as every sampling pass of one bake sees them, with the set-up
/// the CPU sampler shares between its passes ([`super::sample_scene`]).
pub struct Scene<'a> {
    mesh: &'a Mesh,
    tiling: &'a Tiling,
    setup: OnceLock<Setup>,
    solids: OnceLock<SceneSolids>,
    graph: OnceLock<PatchGraph>,
}

/// The CPU sampler's per-mesh set-up.
pub(super) struct Setup {
    /// The mesh regrouped by patch.
    pub(super) mesh: PatchMesh,
    /// Every patch's oriented bounding box, the tight bound of the occlusion test.
    pub(super) boxes: Vec<PatchBox>,
    /// [`back_winding`] of the mesh.
    pub(super) back_winding: i64,
    /// A ball holding every patch's bounding ball ([`patch_ball`]).
    pub(super) patch_ball: ([f32; 3], f32),
}

/// The mesh's solids and each patch's component among them, for the probe pass.
pub(super) struct SceneSolids {
    /// The mesh's solids.
    pub(super) solids: Solids,
    /// Per patch: [`Solids::patch_components`].
    pub(super) patch_component: Vec<u32>,
}

impl<'a> Scene<'a> {
    /// The scene of `mesh` tiled by `tiling` (which must be a tiling of `mesh`); nothing is
    /// built until a pass needs it.
    pub fn new(mesh: &'a Mesh, tiling: &'a Tiling) -> Scene<'a> {
        Scene {
            mesh,
            tiling,
            setup: OnceLock::new(),
            solids: OnceLock::new(),
            graph: OnceLock::new(),
        }
    }

    /// The mesh.
    pub fn mesh(&self) -> &'a Mesh {
        self.mesh
    }

    /// The tiling.
    pub fn tiling(&self) -> &'a Tiling {
        self.tiling
    }

    /// The sampler's set-up, built in `storage` on first use. Fails only if a mapped copy's
    /// temporary file cannot be created or written.
    pub(super) fn setup(&self, storage: Storage) -> std::io::Result<&Setup> {
        if let Some(setup) = self.setup.get() {
            return Ok(setup);
        }
        let mesh = PatchMesh::new(self.mesh, self.tiling, storage)?;
        let setup = Setup {
            boxes: patch_boxes(&mesh, self.tiling),
            mesh,
            back_winding: back_winding(self.mesh),
            patch_ball: patch_ball(self.tiling),
        };
        Ok(self.setup.get_or_init(|| setup))
    }

    /// The mesh's solids, built on first use.
    pub(super) fn solids(&self) -> &SceneSolids {
        self.solids.get_or_init(|| {
            let solids = Solids::new(self.mesh);
            let patch_component = solids.patch_components(self.tiling);
            SceneSolids {
                solids,
                patch_component,
            }
        })
    }

    /// The patch graph (`--dilate`, `--apertures`), built on first use.
    pub(super) fn patch_graph(&self) -> &PatchGraph {
        self.graph
            .get_or_init(|| super::marks::patch_graph(self.mesh, self.tiling))
    }
}

/// The screen winding of the triangles that face away from the eye on a consistently wound
/// closed mesh: with outward normals `(b − a) × (c − a)` (positive signed volume) a front
/// face winds counter-clockwise seen from the eye, which the y-down pixel frame turns into a
/// negative signed area, so back faces are positive. Only steers which triangles are drawn
/// first; any answer is correct, a wrong one only slower.
fn back_winding(mesh: &Mesh) -> i64 {
    let volume: f64 = (0..mesh.triangle_count())
        .into_par_iter()
        .map(|t| {
            let p = crate::tiling::corners(mesh, t);
            let (n, a) = (crate::tiling::cross_normal(p), p[0].map(f64::from));
            n[0] * a[0] + n[1] * a[1] + n[2] * a[2]
        })
        .sum();
    if volume < 0.0 { -1 } else { 1 }
}

/// A ball (centre, radius) holding every patch's bounding ball: a camera for which it needs
/// no clipping ([`super::raster::sphere_needs_no_clip`], every sampling view's camera) needs
/// none for any patch, which is then tested once per camera instead of once per patch drawn.
fn patch_ball(tiling: &Tiling) -> ([f32; 3], f32) {
    let Some(first) = tiling.patches.first() else {
        return ([0.0; 3], 0.0);
    };
    let (mut lo, mut hi) = (first.center, first.center);
    for p in &tiling.patches {
        for k in 0..3 {
            lo[k] = lo[k].min(p.center[k]);
            hi[k] = hi[k].max(p.center[k]);
        }
    }
    let center: [f32; 3] = std::array::from_fn(|k| lo[k] + (hi[k] - lo[k]) * 0.5);
    let radius = tiling
        .patches
        .iter()
        .map(|p| {
            let d: f64 = (0..3)
                .map(|k| (f64::from(p.center[k]) - f64::from(center[k])).powi(2))
                .sum();
            d.sqrt() + f64::from(p.radius)
        })
        .fold(0.0, f64::max);
    // Rounded up to the next `f32`: the ball still holds every patch's.
    let r = radius as f32;
    (
        center,
        if f64::from(r) < radius {
            r.next_up()
        } else {
            r
        },
    )
}
