//! A patch's vertices projected together for the sub-pixel fast path of tiled sampling.
//!
//! Technique: the same transform and snapping as [`super::project`], bit for bit, over a
//! whole patch, four points at a time in lane arrays that the compiler pairs into packed
//! SSE2 `f64` multiplies and adds (the division and rounding stay scalar).
//! Only patches that need no clipping come here (see [`super::sphere_needs_no_clip`]), so
//! outcodes are not computed: they only reject triangles wholly beyond one image edge early,
//! and such a triangle has no pixel centre in its clamped bounding box, so
//! [`super::scan_triangle`] draws nothing for it either.
//! Cost: per vertex one `f64` transform, a division and two roundings.

use super::{HALF_PIXEL, SUBPIXEL_BITS, ScreenVertex, snap_coordinate};
use crate::sampler::camera::Camera;

/// Screen positions of one patch's vertices: snapped `x`, `y` in sub-pixel units and
/// depth `1/w`.
#[derive(Debug, Default)]
pub(crate) struct ScreenBatch {
    vertices: Vec<ScreenVertex>,
}

/// Points per step of [`ScreenBatch::project`]: four `f64` lanes are two SSE2 registers
/// per value. (A plain loop that the compiler vectorized completely, division and a
/// float-only floor included, measured slower; see BENCHMARKS.md, "Third pass".)
const LANES: usize = 4;

impl ScreenBatch {
    /// Projects `points`, replacing the previous contents. Every point must need no clipping
    /// (it lies in a ball [`super::sphere_needs_no_clip`] accepted).
    pub(crate) fn project(&mut self, camera: &Camera, points: &[[f32; 3]]) {
        let out = &mut self.vertices;
        out.clear();
        out.reserve(points.len());
        let mut chunks = points.chunks_exact(LANES);
        for chunk in &mut chunks {
            let lanes: &[[f32; 3]; LANES] = chunk.try_into().expect("exact chunk");
            out.extend_from_slice(&snap_lanes(camera.clip_lanes(lanes)));
        }
        let rest = chunks.remainder();
        if let Some(&last) = rest.last() {
            let lanes: [[f32; 3]; LANES] =
                std::array::from_fn(|i| rest.get(i).copied().unwrap_or(last));
            out.extend_from_slice(&snap_lanes(camera.clip_lanes(&lanes))[..rest.len()]);
        }
    }

    /// The screen triangle `tri` (indices into the projected points).
    #[inline(always)]
    pub(crate) fn triangle(&self, tri: [u32; 3]) -> [ScreenVertex; 3] {
        let v = &self.vertices;
        [v[tri[0] as usize], v[tri[1] as usize], v[tri[2] as usize]]
    }
}

/// `snap` lane by lane.
#[inline(always)]
fn snap_lanes<const N: usize>(c: [[f64; N]; 3]) -> [ScreenVertex; N] {
    let [cx, cy, w] = c;
    let inv_w: [f64; N] = std::array::from_fn(|i| 1.0 / w[i]);
    std::array::from_fn(|i| ScreenVertex {
        x: snap_coordinate(cx[i], inv_w[i]),
        y: snap_coordinate(cy[i], inv_w[i]),
        q: inv_w[i] as f32,
    })
}

/// Whether the bounding box of screen triangle `tri` holds no pixel centre, so that [`super::scan_triangle`] (point sampling) draws nothing for it: a few
/// integer operations and two compares, before any edge setup. Most triangles of a mesh
/// much finer than the image leave here.
#[inline(always)]
pub(crate) fn covers_no_centre(tri: [ScreenVertex; 3]) -> bool {
    const BELOW_HALF: i32 = HALF_PIXEL as i32 - 1;
    const HALF: i32 = HALF_PIXEL as i32;
    // As in `scan_triangle` (centres at `p · 256 + 128`), before clamping to the image;
    // snapped coordinates stay within `±2^28`, so `i32` cannot overflow. (Written on the
    // fields: `array::map` here was left as an out-of-line call and cost 9 % of a view.)
    let [a, b, c] = tri;
    let x0 = (a.x.min(b.x).min(c.x) + BELOW_HALF) >> SUBPIXEL_BITS;
    let x1 = (a.x.max(b.x).max(c.x) - HALF) >> SUBPIXEL_BITS;
    let y0 = (a.y.min(b.y).min(c.y) + BELOW_HALF) >> SUBPIXEL_BITS;
    let y1 = (a.y.max(b.y).max(c.y) - HALF) >> SUBPIXEL_BITS;
    (x0 > x1) | (y0 > y1)
}
