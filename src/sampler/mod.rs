//! Sampling: render a patch-ID buffer from every sphere view and record which patches it shows.
//!
//! Meruvia 2002, section 3: each sampling view on the bounding sphere renders the mesh with
//! one id per patch; every id left in the buffer is visible from that view. Files:
//! `camera.rs` (the normative camera convention), `raster.rs` (watertight fixed-point
//! rasterizer), `clip.rs` (near plane and guard band), `id_buffer.rs` (the render target).
//! Cost: one full render per view; views run in parallel (one view per task, a buffer and
//! scratch per worker), and the result does not depend on the number of threads.
//!
//! Near views (`SamplingOptions::shell`, for the sampling shells of format version 5): a
//! view's eye lies on a sphere of radius `r` (`R <= r`) around the centre, in the view's
//! direction, and its row holds every patch visible from the eye in any direction: the OR of
//! one camera's row, or of five cube faces' rows when the bounding sphere is wider than 90°
//! from there (`near.rs` states the convention). [`sample_near`] is their brute-force
//! reference, as [`sample`] is the sampling views'.

mod camera;
mod checkpoint;
mod clip;
mod conservative;
mod finer;
#[cfg(feature = "gpu")]
pub mod gpu;
mod id_buffer;
mod key_buffer;
mod marks;
mod near;
mod patch_box;
mod patch_graph;
mod patch_mesh;
mod raster;
mod saturate;
mod scene;
mod solid;
mod supersample;
#[cfg(test)]
mod tests;
mod tiled;

pub use camera::{Camera, MAX_RESOLUTION, NEAR_FRACTION};
/// The checkpoint file's bytes without a mesh, for the `checkpoint` fuzz target.
#[doc(hidden)]
pub use checkpoint::{decode as decode_checkpoint, encode as encode_checkpoint};
pub use finer::{FinerViews, PassViews, Seeds};
pub use id_buffer::{IdBuffer, NO_PATCH};
pub use near::{MAX_NEAR_CAMERAS, NearCameras, near_camera_count, near_cameras};
pub use raster::{Rasterizer, SUBPIXEL_BITS, render_ids, render_ids_filtered};
pub use saturate::saturate;
pub use scene::Scene;
pub use supersample::{
    FoldCorners, FoldTargets, MAX_VIEW_SUPERSAMPLE, cover_fold, fold_into, fold_into_with,
    fold_targets, fold_views, split_fold, split_fold_views, supersample_rows,
};
pub use tiled::{
    SamplingError, SamplingOptions, probe_reach, rendered_view_count, sample_scene,
    sample_scene_split, sample_tiled, sample_tiled_split,
};

mod bounding;

pub use crate::visibility::{SamplingParams, VisibilityMatrix};
pub use bounding::bounding_sphere;
pub(crate) use bounding::bounding_sphere_f64;

use crate::ooc::Mesh;
use crate::progress::Progress;
use crate::tiling::PatchId;
use rayon::prelude::*;

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
    check_patch_of(mesh, patch_of, patch_count);
    assert!(
        params.radius > 0.0 && params.radius.is_finite(),
        "sampling radius must be positive and finite, got {}",
        params.radius
    );
    let views = u32::try_from(directions.len()).expect("more than 2^32 views");
    let mut matrix = VisibilityMatrix::new(views, patch_count);
    progress.start("sampling", views as u64);
    if matrix.words_per_row() > 0 {
        let words_per_row = matrix.words_per_row();
        matrix
            .words_mut()
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

/// Renders every near view of `params` on the shell at `distance` from `params.center` (see
/// `SamplingOptions::shell`) and returns which patches each one shows in any direction: every
/// triangle drawn into an ID buffer per camera ([`near_cameras`]), the OR of their ids. The
/// reference [`sample_tiled`] with `shell: Some(distance)` and default options equals.
///
/// Panics (caller contract) as [`sample`] does, and unless `distance` is finite and at least
/// `params.radius`.
pub fn sample_near(
    mesh: &Mesh,
    patch_of: &[PatchId],
    patch_count: u32,
    params: &SamplingParams,
    distance: f32,
    progress: &dyn Progress,
) -> VisibilityMatrix {
    check_patch_of(mesh, patch_of, patch_count);
    // Checks `params.radius` and `distance`.
    near_camera_count(params, distance);
    let views = crate::sphere::view_count(params.level);
    let mut matrix = VisibilityMatrix::new(views, patch_count);
    progress.start("sampling", u64::from(views));
    if matrix.words_per_row() > 0 {
        let words_per_row = matrix.words_per_row();
        matrix
            .words_mut()
            .par_chunks_mut(words_per_row)
            .enumerate()
            .for_each_init(
                || (IdBuffer::new(params.resolution), Rasterizer::new()),
                |(buffer, rasterizer), (view, row)| {
                    for camera in
                        near_cameras(params, crate::sphere::direction(view as u32), distance).iter()
                    {
                        buffer.clear();
                        rasterizer.render(mesh, patch_of, camera, buffer);
                        mark_visible(buffer.ids(), row);
                    }
                    progress.inc(1);
                },
            );
    } else {
        progress.inc(u64::from(views));
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

/// The caller contract of the brute-force samplers: one patch per triangle, each below
/// `patch_count`.
fn check_patch_of(mesh: &Mesh, patch_of: &[PatchId], patch_count: u32) {
    assert_eq!(
        patch_of.len(),
        mesh.triangle_count() as usize,
        "patch_of must hold one patch per triangle"
    );
    if let Some(bad) = patch_of.iter().find(|&&p| p >= patch_count) {
        panic!("patch id {bad} is not below patch_count {patch_count}");
    }
}
