//! A patch's vertices projected together for the sub-pixel fast path of tiled sampling.
//!
//! Technique: the same transform and snapping as [`super::project`], bit for bit, over a
//! whole patch in structure-of-arrays form (x, y and depth in three arrays), written as one
//! plain loop that the compiler turns into packed SSE2 `f64` arithmetic (two vertices per
//! instruction; the float-to-integer step is `floor_positive`, which has a packed form).
//! The triangle loop then reads only the x and y arrays for its bounding-box test, and the
//! depths only for triangles that cover a pixel centre: on meshes much finer than the image
//! most do not.
//! Only patches that need no clipping come here (see [`super::sphere_needs_no_clip`]), so
//! outcodes are not computed: they only reject triangles wholly beyond one image edge early,
//! and such a triangle has no pixel centre in its clamped bounding box, so
//! [`super::scan_triangle`] draws nothing for it either.
//! Cost: per vertex one `f64` transform, a division and two roundings, at about half the
//! instructions of the one-vertex path.

use super::{HALF_PIXEL, SUBPIXEL_BITS, ScreenVertex, snap_coordinate};
use crate::sampler::camera::Camera;

/// Screen positions of one patch's vertices: snapped `x`, `y` in sub-pixel units and
/// depth `1/w`, one array each.
#[derive(Debug, Default)]
pub(crate) struct ScreenBatch {
    x: Vec<i32>,
    y: Vec<i32>,
    q: Vec<f32>,
}

impl ScreenBatch {
    /// Projects `points`, replacing the previous contents. Every point must need no clipping
    /// (it lies in a ball [`super::sphere_needs_no_clip`] accepted).
    pub(crate) fn project(&mut self, camera: &Camera, points: &[[f32; 3]]) {
        let n = points.len();
        for v in [&mut self.x, &mut self.y] {
            v.clear();
            v.resize(n, 0);
        }
        self.q.clear();
        self.q.resize(n, 0.0);
        let outputs = self.x.iter_mut().zip(&mut self.y).zip(&mut self.q);
        for (&p, ((x, y), q)) in points.iter().zip(outputs) {
            let [cx, cy, w] = camera.clip(p);
            let inv_w = 1.0 / w;
            *x = snap_coordinate(cx, inv_w);
            *y = snap_coordinate(cy, inv_w);
            *q = inv_w as f32;
        }
    }

    /// The snapped corners `(x, y)` of triangle `tri` (indices into the projected points).
    #[inline(always)]
    pub(crate) fn corners(&self, tri: [u32; 3]) -> ([i32; 3], [i32; 3]) {
        let (a, b, c) = (tri[0] as usize, tri[1] as usize, tri[2] as usize);
        let (x, y) = (&self.x, &self.y);
        ([x[a], x[b], x[c]], [y[a], y[b], y[c]])
    }

    /// The screen triangle `tri` whose corners [`ScreenBatch::corners`] returned `xy`.
    #[inline(always)]
    pub(crate) fn triangle(&self, tri: [u32; 3], xy: ([i32; 3], [i32; 3])) -> [ScreenVertex; 3] {
        let ((x, y), q) = (xy, &self.q);
        let vertex = |k: usize| ScreenVertex {
            x: x[k],
            y: y[k],
            q: q[tri[k] as usize],
        };
        [vertex(0), vertex(1), vertex(2)]
    }
}

/// Whether the bounding box of the triangle with snapped corners `x`, `y` holds no pixel
/// centre, so that [`super::scan_triangle`] (point sampling) draws nothing for it: a few
/// integer operations and two compares, before any edge setup. Most triangles of a mesh
/// much finer than the image leave here.
#[inline(always)]
pub(crate) fn covers_no_centre(x: [i32; 3], y: [i32; 3]) -> bool {
    const BELOW_HALF: i32 = HALF_PIXEL as i32 - 1;
    const HALF: i32 = HALF_PIXEL as i32;
    // As in `scan_triangle` (centres at `p · 256 + 128`), before clamping to the image;
    // snapped coordinates stay within `±2^28`, so `i32` cannot overflow.
    let x0 = (x[0].min(x[1]).min(x[2]) + BELOW_HALF) >> SUBPIXEL_BITS;
    let x1 = (x[0].max(x[1]).max(x[2]) - HALF) >> SUBPIXEL_BITS;
    let y0 = (y[0].min(y[1]).min(y[2]) + BELOW_HALF) >> SUBPIXEL_BITS;
    let y1 = (y[0].max(y[1]).max(y[2]) - HALF) >> SUBPIXEL_BITS;
    (x0 > x1) | (y0 > y1)
}
