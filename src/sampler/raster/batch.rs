//! A patch's vertices projected together for the sub-pixel fast path of tiled sampling.
//!
//! Technique: the same transform and snapping as [`super::project`], bit for bit, over a
//! whole patch, four points at a time: the transform in lane arrays the compiler packs into
//! SSE2 `f32` registers, the division and rounding in `wide`'s `f32x4` (safe code).
//! Only patches that need no clipping come here (see [`super::sphere_needs_no_clip`]), so
//! outcodes are not computed: they only reject triangles wholly beyond one image edge early,
//! and such a triangle has no pixel centre in its clamped bounding box, so
//! [`super::scan_triangle`] draws nothing for it either.
//! Cost: per vertex one `f32` transform, a division and two roundings, four lanes at a time.

use super::{COORD_LIMIT32, HALF_PIXEL, SUBPIXEL, SUBPIXEL_BITS, ScreenVertex};
use crate::sampler::camera::Camera;
use crate::sampler::patch_mesh::SECTION_VERTICES;

/// Screen positions of one patch section's vertices: snapped `x`, `y` in sub-pixel units
/// and depth `1/w`, in a table of [`SECTION_VERTICES`] entries, so that a `u16` corner
/// indexes it without a bounds check (one per corner cost a third of the triangle loop on
/// sub-pixel meshes). Entries past the section's vertices hold earlier sections' values.
#[derive(Debug)]
pub(crate) struct ScreenBatch {
    vertices: Box<[ScreenVertex; SECTION_VERTICES]>,
}

impl Default for ScreenBatch {
    fn default() -> ScreenBatch {
        let table = vec![ScreenVertex::default(); SECTION_VERTICES].into_boxed_slice();
        ScreenBatch {
            vertices: table.try_into().expect("the table's length"),
        }
    }
}

/// Points per step of [`ScreenBatch::project`]: four `f32` lanes, one SSE2 register per
/// value (BENCHMARKS.md, "Fifth pass": plain lane arrays left the division and the
/// conversions scalar, `wide`'s `f32x4` does not).
const LANES: usize = 4;

impl ScreenBatch {
    /// Projects `points` (at most [`SECTION_VERTICES`]) into the first entries. Every point
    /// must need no clipping (it lies in a ball [`super::sphere_needs_no_clip`] accepted).
    pub(crate) fn project(&mut self, camera: &Camera, points: &[[f32; 3]]) {
        let out = &mut self.vertices[..points.len()];
        let mut chunks = points.chunks_exact(LANES);
        let mut slots = out.chunks_exact_mut(LANES);
        for (chunk, slot) in (&mut chunks).zip(&mut slots) {
            let lanes: &[[f32; 3]; LANES] = chunk.try_into().expect("exact chunk");
            slot.copy_from_slice(&snap_lanes(camera.clip32_lanes(lanes)));
        }
        let (rest, slot) = (chunks.remainder(), slots.into_remainder());
        if let Some(&last) = rest.last() {
            let lanes: [[f32; 3]; LANES] =
                std::array::from_fn(|i| rest.get(i).copied().unwrap_or(last));
            slot.copy_from_slice(&snap_lanes(camera.clip32_lanes(&lanes))[..rest.len()]);
        }
    }

    /// The screen triangle `tri` (indices into the projected points).
    #[inline(always)]
    pub(crate) fn triangle(&self, tri: [u16; 3]) -> [ScreenVertex; 3] {
        let v = &*self.vertices;
        [v[tri[0] as usize], v[tri[1] as usize], v[tri[2] as usize]]
    }
}

/// `snap32` of four lanes in SSE2 registers (`wide`): the same IEEE operations in the same
/// order as the scalar [`snap_coordinate32`], so the same bits.
#[inline(always)]
fn snap_lanes(c: [[f32; LANES]; 3]) -> [ScreenVertex; LANES] {
    use wide::{CmpGt, f32x4};
    let [cx, cy, w] = c.map(f32x4::from);
    let inv_w = f32x4::splat(1.0) / w;
    let limit = f32x4::splat(COORD_LIMIT32);
    let one = f32x4::splat(1.0);
    let snap = |v: f32x4| -> [i32; LANES] {
        let t = (v * inv_w * f32x4::splat(SUBPIXEL as f32))
            .max(-limit)
            .min(limit)
            + 0.5;
        let i = t.trunc_int();
        // Truncation rounded negative values up: take 1 off there. Every value here is an
        // integer below 2^29, exact in binary32, so this is exactly `floor(t)`.
        let below = i.round_float() - (i.round_float().cmp_gt(t) & one);
        below.trunc_int().to_array()
    };
    let (x, y, q) = (snap(cx), snap(cy), inv_w.to_array());
    std::array::from_fn(|i| ScreenVertex {
        x: x[i],
        y: y[i],
        q: q[i],
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

#[cfg(test)]
mod tests {
    use super::super::snap32;
    use super::*;
    use proptest::prelude::*;

    fn lane_value() -> impl Strategy<Value = f32> {
        prop_oneof![
            -600.0f32..600.0,
            -1e9f32..1e9,
            Just(f32::NAN),
            Just(f32::INFINITY),
            Just(-0.0),
            Just(0.5 / 256.0),
            Just(-0.5 / 256.0),
        ]
    }

    proptest! {
        /// The SSE2 lanes give the scalar snap's bits for any input, NaN and overflow included.
        #[test]
        fn lanes_equal_the_scalar_snap(
            cx in proptest::array::uniform4(lane_value()),
            cy in proptest::array::uniform4(lane_value()),
            w in proptest::array::uniform4(prop_oneof![1e-3f32..1e3, Just(f32::NAN), Just(1e-30)]),
        ) {
            let lanes = snap_lanes([cx, cy, w]);
            for i in 0..LANES {
                let one = snap32([cx[i], cy[i], w[i]]);
                prop_assert_eq!(
                    (lanes[i].x, lanes[i].y, lanes[i].q.to_bits()),
                    (one.x, one.y, one.q.to_bits())
                );
            }
        }
    }
}
