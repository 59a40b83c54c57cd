//! Sampling: render a patch-ID buffer from every sphere view and record which patches it shows.
//!
//! Meruvia 2002, section 3: each sampling view on the bounding sphere renders the mesh with
//! one id per patch; every id left in the buffer is visible from that view. Files:
//! `camera.rs` (the normative camera convention), `raster.rs` (watertight fixed-point
//! rasterizer), `clip.rs` (near plane and guard band), `id_buffer.rs` (the render target).
//! Cost: one full render per view; views run in parallel (one view per task, a buffer and
//! scratch per worker), and the result does not depend on the number of threads.

mod camera;
mod checkpoint;
mod clip;
mod conservative;
#[cfg(feature = "gpu")]
pub mod gpu;
mod id_buffer;
mod key_buffer;
mod patch_box;
mod patch_graph;
mod patch_mesh;
mod raster;
mod supersample;
#[cfg(test)]
mod test_meshes;
#[cfg(test)]
mod tests;
mod tiled;
#[cfg(test)]
mod tiled_tests;

pub use camera::{Camera, MAX_RESOLUTION, NEAR_FRACTION};
pub use id_buffer::{IdBuffer, NO_PATCH};
pub use raster::{Rasterizer, SUBPIXEL_BITS, render_ids, render_ids_filtered};
pub use supersample::{
    FoldCorners, FoldTargets, MAX_VIEW_SUPERSAMPLE, fold_into, fold_into_with, fold_targets,
    supersample_rows,
};
pub use tiled::{SamplingError, SamplingOptions, sample_tiled};

mod bounding;

pub use bounding::bounding_sphere;

use crate::ooc::Mesh;
use crate::progress::Progress;
use crate::tiling::PatchId;
use rayon::prelude::*;

/// Where the sampling cameras are, shared by every view (see the spec's "Sampling sphere").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplingParams {
    /// Subdivision level of the sphere (views: `sphere::view_count(level)`).
    pub level: u32,
    /// ID buffer width and height in pixels.
    pub resolution: u32,
    /// Full field of view, degrees, of the square image.
    pub fov_deg: f32,
    /// Centre of the bounding sphere the cameras look at.
    pub center: [f32; 3],
    /// Radius of that bounding sphere.
    pub radius: f32,
}

impl SamplingParams {
    /// Camera distance from the centre: `radius / sin(fov / 2)`, so the sphere fits the view.
    pub fn distance(&self) -> f32 {
        self.radius / (self.fov_deg.to_radians() * 0.5).sin()
    }
}

/// Which patches each view sees: one row of `patches` bits per view.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VisibilityMatrix {
    views: u32,
    patches: u32,
    words_per_row: usize,
    bits: Vec<u64>,
}

impl VisibilityMatrix {
    /// An all-zero matrix.
    pub fn new(views: u32, patches: u32) -> Self {
        let words_per_row = (patches as usize).div_ceil(64);
        VisibilityMatrix {
            views,
            patches,
            words_per_row,
            bits: vec![0; words_per_row * views as usize],
        }
    }
    /// Number of views (rows).
    pub fn views(&self) -> u32 {
        self.views
    }
    /// Number of patches (bits per row).
    pub fn patches(&self) -> u32 {
        self.patches
    }
    /// Row of `view`: bit `p % 64` of word `p / 64` is patch `p`; bits past `patches` are zero.
    pub fn row(&self, view: u32) -> &[u64] {
        let start = view as usize * self.words_per_row;
        &self.bits[start..start + self.words_per_row]
    }
    /// Mutable row of `view`.
    pub fn row_mut(&mut self, view: u32) -> &mut [u64] {
        let start = view as usize * self.words_per_row;
        &mut self.bits[start..start + self.words_per_row]
    }
    /// Whether `view` sees `patch`.
    pub fn get(&self, view: u32, patch: PatchId) -> bool {
        self.row(view)[patch as usize / 64] >> (patch % 64) & 1 == 1
    }
    /// Marks `patch` seen from `view`.
    pub fn set(&mut self, view: u32, patch: PatchId) {
        self.row_mut(view)[patch as usize / 64] |= 1 << (patch % 64);
    }

    /// The same visibility with the patches renumbered: patch `i` of the result is patch
    /// `order[i]` of `self` (see [`crate::tiling::Tiling::renumbered`]). O(views × patches).
    ///
    /// Panics (caller contract) if `order` does not have one entry per patch or names a
    /// patch that does not exist.
    pub fn with_patch_order(&self, order: &[PatchId]) -> VisibilityMatrix {
        assert_eq!(order.len(), self.patches as usize, "one entry per patch");
        let mut out = VisibilityMatrix::new(self.views, self.patches);
        let words = self.words_per_row;
        if words == 0 {
            return out;
        }
        out.bits
            .par_chunks_mut(words)
            .zip(self.bits.par_chunks(words))
            .for_each(|(to, from)| {
                for (i, &old) in order.iter().enumerate() {
                    let bit = from[old as usize / 64] >> (old % 64) & 1;
                    to[i / 64] |= bit << (i % 64);
                }
            });
        out
    }
}

/// Renders every view of `params` and returns which patches each one shows.
/// `patch_of[t]` is the patch of input triangle `t`, below `patch_count`.
pub fn sample(
    mesh: &Mesh,
    patch_of: &[PatchId],
    patch_count: u32,
    params: &SamplingParams,
    progress: &dyn Progress,
) -> VisibilityMatrix {
    let directions: Vec<[f32; 3]> = (0..crate::sphere::view_count(params.level))
        .map(crate::sphere::direction)
        .collect();
    sample_directions(mesh, patch_of, patch_count, params, &directions, progress)
}

/// [`sample`] with explicit view directions (unit vectors from the centre towards the eye):
/// row `i` of the result is the view from `directions[i]`. `params.level` is ignored.
pub fn sample_directions(
    mesh: &Mesh,
    patch_of: &[PatchId],
    patch_count: u32,
    params: &SamplingParams,
    directions: &[[f32; 3]],
    progress: &dyn Progress,
) -> VisibilityMatrix {
    assert_eq!(
        patch_of.len(),
        mesh.triangle_count() as usize,
        "patch_of must hold one patch per triangle"
    );
    if let Some(bad) = patch_of.iter().find(|&&p| p >= patch_count) {
        panic!("patch id {bad} is not below patch_count {patch_count}");
    }
    assert!(
        params.radius > 0.0 && params.radius.is_finite(),
        "sampling radius must be positive and finite, got {}",
        params.radius
    );
    let views = u32::try_from(directions.len()).expect("more than 2^32 views");
    let mut matrix = VisibilityMatrix::new(views, patch_count);
    progress.start("sampling", views as u64);
    if matrix.words_per_row > 0 {
        let words_per_row = matrix.words_per_row;
        matrix
            .bits
            .par_chunks_mut(words_per_row)
            .zip(directions.par_iter())
            .for_each_init(
                || (IdBuffer::new(params.resolution), Rasterizer::new()),
                |(buffer, rasterizer), (row, &direction)| {
                    let camera = Camera::sampling(params, direction);
                    buffer.clear();
                    rasterizer.render(mesh, patch_of, &camera, buffer);
                    mark_visible(buffer.ids(), row);
                    progress.inc(1);
                },
            );
    } else {
        progress.inc(views as u64);
    }
    progress.finish();
    matrix
}

/// Sets the bit of every patch id in `ids` (ignoring [`NO_PATCH`]). Neighbouring pixels
/// mostly show the same patch, so runs of one id cost a compare per pixel.
fn mark_visible(ids: &[u32], row: &mut [u64]) {
    let mut previous = NO_PATCH;
    for &id in ids {
        if id != previous {
            previous = id;
            if id != NO_PATCH {
                row[id as usize / 64] |= 1 << (id % 64);
            }
        }
    }
}
