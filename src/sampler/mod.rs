//! Sampling: render a patch-ID buffer from every sphere view and record which patches it shows.

use crate::ooc::Mesh;
use crate::progress::Progress;
use crate::tiling::PatchId;

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
}

/// Renders every view of `params` and returns which patches each one shows.
/// `patch_of[t]` is the patch of input triangle `t`.
pub fn sample(
    mesh: &Mesh,
    patch_of: &[PatchId],
    patch_count: u32,
    params: &SamplingParams,
    progress: &dyn Progress,
) -> VisibilityMatrix {
    let _ = (mesh, patch_of, patch_count, params, progress);
    todo!()
}
