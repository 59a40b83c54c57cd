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
use wide::{CmpGt, f32x4, i32x4};

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
    #[cfg(test)]
    pub(crate) fn project(&mut self, camera: &Camera, points: &[[f32; 3]]) {
        self.project_from(camera, points, 0);
    }

    /// Projects `points[start..]` (`points` at most [`SECTION_VERTICES`]) into the same
    /// entries; the ones before `start` keep what they hold. Every point must need no
    /// clipping (it lies in a ball [`super::sphere_needs_no_clip`] accepted).
    pub(crate) fn project_from(&mut self, camera: &Camera, points: &[[f32; 3]], start: usize) {
        let rows = camera.rows32().map(|r| r.map(f32x4::splat));
        let points = &points[start..];
        let out = &mut self.vertices[start..start + points.len()];
        let mut chunks = points.chunks_exact(LANES);
        let mut slots = out.chunks_exact_mut(LANES);
        for (chunk, slot) in (&mut chunks).zip(&mut slots) {
            let lanes: &[[f32; 3]; LANES] = chunk.try_into().expect("exact chunk");
            slot.copy_from_slice(&project_lanes(&rows, lanes));
        }
        let (rest, slot) = (chunks.remainder(), slots.into_remainder());
        if let Some(&last) = rest.last() {
            let lanes: [[f32; 3]; LANES] =
                std::array::from_fn(|i| rest.get(i).copied().unwrap_or(last));
            slot.copy_from_slice(&project_lanes(&rows, &lanes)[..rest.len()]);
        }
    }

    /// The screen triangle `tri` (indices into the projected points).
    #[inline(always)]
    pub(crate) fn triangle(&self, tri: [u16; 3]) -> [ScreenVertex; 3] {
        let v = &*self.vertices;
        [v[tri[0] as usize], v[tri[1] as usize], v[tri[2] as usize]]
    }
}

/// [`Camera::clip32`] then [`super::snap32`] of four points in SSE2 registers (`wide`),
/// `rows` being the camera's binary32 rows splatted: the same IEEE operations in the same
/// order as the scalar code, so the same bits. Written on `f32x4` values throughout: as
/// arrays, the transform was left an out-of-line call, and `wide`'s NaN-careful `max`,
/// `min` and saturating truncation cost a third of the projection where the plain
/// instructions are exact (see `snap`).
#[inline(always)]
fn project_lanes(rows: &[[f32x4; 4]; 3], p: &[[f32; 3]; LANES]) -> [ScreenVertex; LANES] {
    let coordinate = |k: usize| f32x4::from([p[0][k], p[1][k], p[2][k], p[3][k]]);
    let (x, y, z) = (coordinate(0), coordinate(1), coordinate(2));
    snap_lanes(rows.map(|r| r[0] * x + r[1] * y + r[2] * z + r[3]))
}

/// [`super::snap32`] of four clip-space points `[cx, cy, w]`, lane by lane.
#[inline(always)]
fn snap_lanes([cx, cy, w]: [f32x4; 3]) -> [ScreenVertex; LANES] {
    let inv_w = f32x4::splat(1.0) / w;
    let limit = f32x4::splat(COORD_LIMIT32);
    let snap = |v: f32x4| -> [i32; LANES] {
        // `fast_max` is SSE's `maxps(t, −limit)`, which returns its second operand when the
        // first is NaN: exactly `f32::max` with a non-NaN bound. After the clamp every lane
        // is finite and below 2^29, so the plain truncation is exact too.
        let t = (v * inv_w * f32x4::splat(SUBPIXEL as f32))
            .fast_max(-limit)
            .fast_min(limit)
            + 0.5;
        let i = t.fast_trunc_int();
        // Truncation rounded negative values up: take 1 off there (the compare's all-ones
        // lanes are −1 as integers). Every value here is an integer below 2^29, exact in
        // binary32, so this is exactly `floor(t)`.
        let above: i32x4 = mask_as_integers(i.round_float().cmp_gt(t));
        (i + above).to_array()
    };
    let (x, y, q) = (snap(cx), snap(cy), inv_w.to_array());
    std::array::from_fn(|i| ScreenVertex {
        x: x[i],
        y: y[i],
        q: q[i],
    })
}

/// The lanes of a compare mask (all ones or all zeros) as integers (−1 or 0).
#[inline(always)]
fn mask_as_integers(mask: f32x4) -> i32x4 {
    let bits = mask.to_array().map(|m| m.to_bits() as i32);
    i32x4::from(bits)
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
            let lanes = snap_lanes([cx, cy, w].map(f32x4::from));
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
