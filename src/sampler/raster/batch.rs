//! A patch's vertices projected together for the sub-pixel fast path of tiled sampling.
//!
//! Technique: the same transform and snapping as [`super::project`], bit for bit, over a
//! whole patch, four points at a time: each coordinate's four lanes one plain load from the
//! regrouped mesh's blocks (`patch_mesh::PointBlock`), the transform, division and rounding
//! in `wide`'s `f32x4` (SSE2, safe code); eight at a time in AVX2 registers where the CPU
//! has them (`wide8`, chosen at run time; same operations, same bits). The blocks are
//! streamed from memory (a view reads every patch it draws), so they are prefetched a
//! little ahead of use.
//! Only patches that need no clipping come here (see [`super::sphere_needs_no_clip`]), so
//! outcodes are not computed: they only reject triangles wholly beyond one image edge early,
//! and such a triangle has no pixel centre in its clamped bounding box, so
//! [`super::scan_triangle`] draws nothing for it either.
//! Beside each snapped vertex goes its centre code (`codes_hold_no_centre`), from which the
//! triangle loop tells sub-pixel triangles that hold no pixel centre (at 6.4M triangles 93 %
//! of those looped) without reading their coordinates.
//! Cost: per vertex one `f32` transform, a division and two roundings, four or eight lanes at
//! a time.

use super::{COORD_LIMIT32, HALF_PIXEL, SUBPIXEL, SUBPIXEL_BITS, ScreenVertex};
use crate::sampler::camera::Camera;
use crate::sampler::patch_mesh::{PointBlock, SECTION_VERTICES};
use wide::{CmpEq, CmpGt, f32x4, i32x4};

/// Screen positions of one patch section's vertices: snapped `x`, `y` in sub-pixel units
/// and depth `1/w`, in a table of [`SECTION_VERTICES`] entries, so that a `u16` corner
/// indexes it without a bounds check (one per corner cost a third of the triangle loop on
/// sub-pixel meshes). Entries past the section's vertices hold earlier sections' values.
/// Beside each vertex sits its centre code ([`codes_hold_no_centre`]), which is all that the
/// sub-pixel test of a triangle reads. Each value has a table of its own, so that four lanes
/// of the projection go out in one store per value (as `ScreenVertex` records they took a
/// dozen stores and shuffles per four vertices, a tenth of the projection); only the
/// triangles that hold a pixel centre gather their corners' values.
#[derive(Debug)]
pub(crate) struct ScreenBatch {
    xs: Box<[i32; SECTION_VERTICES]>,
    ys: Box<[i32; SECTION_VERTICES]>,
    qs: Box<[f32; SECTION_VERTICES]>,
    codes: Box<[u64; SECTION_VERTICES]>,
    /// Whether the CPU has AVX2, so that the projection takes eight points at a time.
    avx2: bool,
}

/// A zeroed table of [`SECTION_VERTICES`] values, allocated on the heap directly.
fn table<T: Copy + Default + std::fmt::Debug>() -> Box<[T; SECTION_VERTICES]> {
    let values = vec![T::default(); SECTION_VERTICES].into_boxed_slice();
    values.try_into().expect("the table's length")
}

impl Default for ScreenBatch {
    fn default() -> ScreenBatch {
        ScreenBatch {
            xs: table(),
            ys: table(),
            qs: table(),
            codes: table(),
            avx2: has_avx2(),
        }
    }
}

/// How many blocks (48 bytes each) ahead of the projection its vertex blocks are
/// prefetched. Without it the loads of the blocks were a quarter of the projection's time
/// (memory latency: the hardware prefetcher starts late on runs of a few kB). Tuned at 6.4M
/// triangles, level 4, 512²: 16 was −6 % against none; 8, 16 and 32 within noise of each
/// other, 32 best in both rounds (docs/benchmarks/sampling.md, "Tenth pass").
const BLOCKS_AHEAD: usize = 32;

/// Asks the CPU to bring the cache line holding `items[at]` into its caches, ahead of use;
/// does nothing if there is no such item or off x86-64. A prefetch never faults, so the
/// address need not be valid.
#[inline(always)]
pub(crate) fn prefetch<T>(items: &[T], at: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: SSE is part of every x86-64 CPU, and a prefetch reads nothing the program
        // sees and never faults, whatever the address (`wrapping_add` makes it without UB).
        unsafe { _mm_prefetch::<_MM_HINT_T0>(items.as_ptr().wrapping_add(at).cast()) };
    }
}

/// Whether this CPU has AVX2 (always false off x86-64).
pub(crate) fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Points per step of [`ScreenBatch::project`]: four `f32` lanes, one SSE2 register per
/// value (docs/benchmarks/sampling.md, "Fifth pass": plain lane arrays left the division and the
/// conversions scalar, `wide`'s `f32x4` does not).
const LANES: usize = 4;

impl ScreenBatch {
    /// Projects `points` (at most [`SECTION_VERTICES`]) into the first entries. Every point
    /// must need no clipping (it lies in a ball [`super::sphere_needs_no_clip`] accepted).
    #[cfg(test)]
    pub(crate) fn project(&mut self, camera: &Camera, points: &[[f32; 3]]) {
        let blocks = crate::sampler::patch_mesh::to_blocks(points);
        self.project_from(camera, &blocks, 0, points.len());
    }

    /// The same table projecting four points at a time on every CPU (tests compare it with
    /// the eight-lane projection).
    #[cfg(test)]
    pub(crate) fn four_lanes(self) -> ScreenBatch {
        ScreenBatch {
            avx2: false,
            ..self
        }
    }

    /// Projects the points `start..end` of `blocks` (at most [`SECTION_VERTICES`] points)
    /// into the same entries, whole blocks at a time (the other points of a block land on
    /// their own entries, with the values they would get anyway); the entries before its
    /// first block keep what they hold. Every point must need no clipping (it lies in a ball
    /// [`super::sphere_needs_no_clip`] accepted).
    #[inline(always)]
    pub(crate) fn project_from(
        &mut self,
        camera: &Camera,
        blocks: &[PointBlock],
        start: usize,
        end: usize,
    ) {
        let rows = camera.rows32();
        let blocks = &blocks[start / LANES..end.div_ceil(LANES).min(blocks.len())];
        let first = start / LANES * LANES;
        let range = first..first + blocks.len() * LANES;
        let entries = Entries {
            xs: &mut self.xs[range.clone()],
            ys: &mut self.ys[range.clone()],
            qs: &mut self.qs[range.clone()],
            codes: &mut self.codes[range],
        };
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // Pairs of blocks eight points at a time, an odd last block four at a time.
            let pairs = blocks.len() / 2 * 2;
            let (head, tail) = entries.split_at(pairs * LANES);
            // SAFETY: `avx2` is set only where the CPU has AVX2 (`Default`).
            unsafe { wide8::project_blocks(&rows, &blocks[..pairs], head) };
            project_blocks(&rows, &blocks[pairs..], tail);
            return;
        }
        project_blocks(&rows, blocks, entries);
    }

    /// The screen triangle `tri` (indices into the projected points).
    #[inline(always)]
    pub(crate) fn triangle(&self, tri: [u16; 3]) -> [ScreenVertex; 3] {
        tri.map(|i| ScreenVertex {
            x: self.xs[i as usize],
            y: self.ys[i as usize],
            q: self.qs[i as usize],
        })
    }

    /// The snapped screen rectangle `[min_x, max_x, min_y, max_y]` and the largest depth of
    /// the projected points `range` (a depth that is NaN is passed over: a fragment
    /// interpolated from it is never drawn).
    pub(crate) fn extent(&self, range: std::ops::Range<usize>) -> ([i32; 4], f32) {
        let (xs, ys) = (&self.xs[range.clone()], &self.ys[range.clone()]);
        let bounds = |v: &[i32]| {
            let lo = v.iter().copied().fold(i32::MAX, i32::min);
            (lo, v.iter().copied().fold(i32::MIN, i32::max))
        };
        let ((min_x, max_x), (min_y, max_y)) = (bounds(xs), bounds(ys));
        let q = self.qs[range]
            .iter()
            .copied()
            .fold(f32::NEG_INFINITY, f32::max);
        ([min_x, max_x, min_y, max_y], q)
    }

    /// The farthest depth (smallest `1/w`) of the vertices in `range`.
    pub(crate) fn q_far(&self, range: std::ops::Range<usize>) -> f32 {
        self.qs[range].iter().copied().fold(f32::INFINITY, f32::min)
    }

    /// Whether the bounding box of the screen triangle `tri` holds no pixel centre, from its
    /// corners' codes alone ([`codes_hold_no_centre`]).
    #[inline(always)]
    pub(crate) fn holds_no_centre(&self, tri: [u16; 3]) -> bool {
        let c = &*self.codes;
        codes_hold_no_centre([c[tri[0] as usize], c[tri[1] as usize], c[tri[2] as usize]])
    }

    /// The position in `triangles` of the first one at or after `from` whose bounding box
    /// holds a pixel centre ([`Self::holds_no_centre`]), or `triangles.len()`. A loop of its
    /// own, with nothing but the test in it: written inside the drawing loop, the test
    /// shared its registers with the drawing and reloaded its pointers from the stack on
    /// every triangle, though on meshes much finer than the image 93 % of them only pass
    /// through the test.
    #[inline(always)]
    pub(crate) fn next_holding_centre(&self, triangles: &[[u16; 3]], from: usize) -> usize {
        let c = &*self.codes;
        triangles[from.min(triangles.len())..]
            .iter()
            .position(|t| {
                !codes_hold_no_centre([c[t[0] as usize], c[t[1] as usize], c[t[2] as usize]])
            })
            .map_or(triangles.len(), |k| from + k)
    }

    /// Writes to the front of `kept` the positions in `triangles` (at most `N`, a power of
    /// two) of those whose bounding box holds a pixel centre, and returns how many there
    /// are: branch-free, every triangle's position is written and the count advances only
    /// past those that hold one (for meshes where that is a coin toss, see `tiled.rs`).
    #[inline(always)]
    pub(crate) fn keep_holding_centre<const N: usize>(
        &self,
        triangles: &[[u16; 3]],
        kept: &mut [u32; N],
    ) -> usize {
        const { assert!(N.is_power_of_two()) };
        let c = &*self.codes;
        let mut count = 0;
        for (i, t) in triangles.iter().take(N).enumerate() {
            // `count <= i < N`: the mask only spares the bounds check.
            kept[count & (N - 1)] = i as u32;
            let codes = [c[t[0] as usize], c[t[1] as usize], c[t[2] as usize]];
            count += usize::from(!codes_hold_no_centre(codes));
        }
        count
    }
}

/// Consecutive entries of a [`ScreenBatch`]'s tables, one slice per value, all as long.
pub(super) struct Entries<'a> {
    xs: &'a mut [i32],
    ys: &'a mut [i32],
    qs: &'a mut [f32],
    codes: &'a mut [u64],
}

impl<'a> Entries<'a> {
    /// The first `mid` entries and the rest.
    fn split_at(self, mid: usize) -> (Entries<'a>, Entries<'a>) {
        let (xs, xs_rest) = self.xs.split_at_mut(mid);
        let (ys, ys_rest) = self.ys.split_at_mut(mid);
        let (qs, qs_rest) = self.qs.split_at_mut(mid);
        let (codes, codes_rest) = self.codes.split_at_mut(mid);
        let rest = Entries {
            xs: xs_rest,
            ys: ys_rest,
            qs: qs_rest,
            codes: codes_rest,
        };
        (Entries { xs, ys, qs, codes }, rest)
    }
}

/// Projects `blocks` with the camera rows `rows` ([`Camera::rows32`]) into `out` (four
/// entries per block), four points at a time: [`transform_lanes`], then [`snap_lanes`].
#[inline(always)]
fn project_blocks(rows: &[[f32; 4]; 3], blocks: &[PointBlock], out: Entries) {
    let rows = rows.map(|r| r.map(f32x4::splat));
    let Entries { xs, ys, qs, codes } = out;
    let out = xs
        .chunks_exact_mut(LANES)
        .zip(ys.chunks_exact_mut(LANES))
        .zip(qs.chunks_exact_mut(LANES))
        .zip(codes.chunks_exact_mut(LANES));
    for (k, (block, (((xs, ys), qs), codes))) in blocks.iter().zip(out).enumerate() {
        prefetch(blocks, k + BLOCKS_AHEAD);
        let lanes = |k: usize| {
            f32x4::from(<[f32; LANES]>::try_from(&block[4 * k..][..4]).expect("a block's lane"))
        };
        let ((x, y, q), code) = snap_lanes(transform_lanes(&rows, [lanes(0), lanes(1), lanes(2)]));
        xs.copy_from_slice(&x);
        ys.copy_from_slice(&y);
        qs.copy_from_slice(&q);
        codes.copy_from_slice(&code);
    }
}

/// A vertex's centre code, scalar: the reference for the lanes of
/// `ScreenBatch::project_from`, which compute it (see [`codes_hold_no_centre`]).
#[cfg(test)]
pub(crate) fn centre_code(x: i32, y: i32) -> u64 {
    let field = |v: i32| {
        let t = v - HALF_PIXEL as i32;
        let on_centre = t & (SUBPIXEL as i32 - 1) == 0;
        ((t >> SUBPIXEL_BITS) * 2 + i32::from(on_centre)) as u32
    };
    u64::from(field(x)) | u64::from(field(y)) << 32
}

/// The low bit of both fields of a centre code: the corner lies on a centre.
const ON_CENTRE: u64 = 1 | 1 << 32;

/// Whether the bounding box of three snapped corners holds no pixel centre, from their
/// centre codes: one 32-bit field per axis (`x` low, `y` high) holding `2 f + e`, where
/// `f = floor((v − 128) / 256)` is the column (row) of the last centre at or before the
/// coordinate `v` and `e` is 1 if `v` lies exactly on it. The box holds no centre column
/// exactly when every corner has the same `f` and none lies on its centre (the lowest corner
/// would be that centre): when their `x` fields are equal and even. Snapped coordinates lie
/// within `±2^28`, so `2 f + e` lies within `±2^21` and never wraps onto another field
/// value. Two exclusive-ors, three ors and two compares, where the same test on the
/// coordinates (`covers_no_centre`, its reference in the tests) reads 6 values and takes 8
/// minima and maxima.
#[inline(always)]
pub(crate) fn codes_hold_no_centre([a, b, c]: [u64; 3]) -> bool {
    let differ = (a ^ b) | (a ^ c) | (a & ON_CENTRE);
    (differ as u32 == 0) | (differ >> 32 == 0)
}

/// [`Camera::clip32`] of four points given by their coordinate lanes `[x, y, z]`, `rows`
/// being the camera's binary32 rows splatted: the same IEEE operations in the same order as
/// the scalar code, so the same bits (then [`snap_lanes`]). Written on `f32x4` values
/// throughout: as arrays, the transform was left an out-of-line call, and `wide`'s
/// NaN-careful `max`, `min` and saturating truncation cost a third of the projection where
/// the plain instructions are exact (see `snap`).
#[inline(always)]
fn transform_lanes(rows: &[[f32x4; 4]; 3], [x, y, z]: [f32x4; 3]) -> [f32x4; 3] {
    rows.map(|r| r[0] * x + r[1] * y + r[2] * z + r[3])
}

/// [`super::snap32`] of four clip-space points `[cx, cy, w]`, lane by lane, and their centre
/// codes ([`codes_hold_no_centre`]).
#[inline(always)]
fn snap_lanes([cx, cy, w]: [f32x4; 3]) -> (ScreenLanes, [u64; LANES]) {
    let inv_w = f32x4::splat(1.0) / w;
    let limit = f32x4::splat(COORD_LIMIT32);
    let snap = |v: f32x4| -> i32x4 {
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
        i + above
    };
    // The centre codes' fields, lane by lane: the compare's all-ones lanes are −1.
    let field = |v: i32x4| -> [i32; LANES] {
        let t = v - i32x4::splat(HALF_PIXEL as i32);
        let on_centre = (t & i32x4::splat(SUBPIXEL as i32 - 1)).cmp_eq(i32x4::splat(0));
        let column: i32x4 = t >> SUBPIXEL_BITS as i32;
        let doubled: i32x4 = column << 1;
        (doubled - on_centre).to_array()
    };
    let (x, y) = (snap(cx), snap(cy));
    let (fx, fy) = (field(x), field(y));
    let codes = std::array::from_fn(|i| u64::from(fx[i] as u32) | u64::from(fy[i] as u32) << 32);
    ((x.to_array(), y.to_array(), inv_w.to_array()), codes)
}

/// Four snapped points: `x`, `y` and `q`, a lane each.
type ScreenLanes = ([i32; LANES], [i32; LANES], [f32; LANES]);

/// The lanes of a compare mask (all ones or all zeros) as integers (−1 or 0).
#[inline(always)]
fn mask_as_integers(mask: f32x4) -> i32x4 {
    let bits = mask.to_array().map(|m| m.to_bits() as i32);
    i32x4::from(bits)
}

/// Whether the bounding box of screen triangle `tri` holds no pixel centre, so that
/// [`super::scan_triangle`] (point sampling) draws nothing for it. The reference for
/// [`codes_hold_no_centre`], which the sampler uses: this reads every corner's `x` and `y`
/// and takes their minima and maxima.
#[cfg(test)]
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

/// The projection eight points at a time, on CPUs with AVX2 (found at run time: the build
/// stays portable x86-64). The same IEEE operations in the same order as [`transform_lanes`]
/// and [`snap_lanes`], on 256-bit registers, so the same bits on every CPU (no fused
/// multiply-add: it would round once where they round twice). Where projection is a quarter
/// of sampling (6.4M triangles) four lanes took about 26 cycles per four points, bound by
/// instruction count; eight lanes halve that (6.4M −7 %, docs/benchmarks/sampling.md,
/// "Tenth pass").
#[cfg(target_arch = "x86_64")]
mod wide8 {
    use super::super::{COORD_LIMIT32, HALF_PIXEL, SUBPIXEL, SUBPIXEL_BITS};
    use super::{BLOCKS_AHEAD, Entries};
    use crate::sampler::patch_mesh::PointBlock;
    use std::arch::x86_64::*;

    /// [`super::project_blocks`] of an even number of `blocks`, eight points (two blocks)
    /// at a time.
    #[target_feature(enable = "avx2")]
    pub(super) fn project_blocks(rows: &[[f32; 4]; 3], blocks: &[PointBlock], out: Entries) {
        let Entries { xs, ys, qs, codes } = out;
        // Written out: `array::map` here was left an out-of-line call.
        let splat = |r: [f32; 4]| {
            let v = _mm256_set1_ps;
            [v(r[0]), v(r[1]), v(r[2]), v(r[3])]
        };
        let rows = [splat(rows[0]), splat(rows[1]), splat(rows[2])];
        let one = _mm256_set1_ps(1.0);
        let scale = _mm256_set1_ps(SUBPIXEL as f32);
        let limit = _mm256_set1_ps(COORD_LIMIT32);
        let neg_limit = _mm256_set1_ps(-COORD_LIMIT32);
        let half = _mm256_set1_ps(0.5);
        let half_pixel = _mm256_set1_epi32(HALF_PIXEL as i32);
        let fraction = _mm256_set1_epi32(SUBPIXEL as i32 - 1);
        let zero = _mm256_setzero_si256();
        let out = xs
            .chunks_exact_mut(8)
            .zip(ys.chunks_exact_mut(8))
            .zip(qs.chunks_exact_mut(8))
            .zip(codes.chunks_exact_mut(8));
        for (k, (pair, (((xs, ys), qs), codes))) in blocks.chunks_exact(2).zip(out).enumerate() {
            super::prefetch(blocks, 2 * k + BLOCKS_AHEAD);
            let lane = |k: usize| {
                let lo: [f32; 4] = pair[0][4 * k..][..4].try_into().expect("a lane");
                let hi: [f32; 4] = pair[1][4 * k..][..4].try_into().expect("a lane");
                _mm256_set_m128(bytemuck::cast(hi), bytemuck::cast(lo))
            };
            let (x, y, z) = (lane(0), lane(1), lane(2));
            // `r[0] * x + r[1] * y + r[2] * z + r[3]`, in that order, as `transform_lanes`.
            let transform = |r: &[__m256; 4]| {
                let t = _mm256_add_ps(_mm256_mul_ps(r[0], x), _mm256_mul_ps(r[1], y));
                _mm256_add_ps(_mm256_add_ps(t, _mm256_mul_ps(r[2], z)), r[3])
            };
            let clip = [
                transform(&rows[0]),
                transform(&rows[1]),
                transform(&rows[2]),
            ];
            let inv_w = _mm256_div_ps(one, clip[2]);
            let snap = |v: __m256| {
                let t = _mm256_mul_ps(_mm256_mul_ps(v, inv_w), scale);
                let t = _mm256_add_ps(_mm256_min_ps(_mm256_max_ps(t, neg_limit), limit), half);
                let i = _mm256_cvttps_epi32(t);
                let above = _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_cvtepi32_ps(i), t);
                _mm256_add_epi32(i, _mm256_castps_si256(above))
            };
            let field = |v: __m256i| {
                let t = _mm256_sub_epi32(v, half_pixel);
                let on_centre = _mm256_cmpeq_epi32(_mm256_and_si256(t, fraction), zero);
                let column = _mm256_srai_epi32::<{ SUBPIXEL_BITS as i32 }>(t);
                _mm256_sub_epi32(_mm256_slli_epi32::<1>(column), on_centre)
            };
            let (sx, sy) = (snap(clip[0]), snap(clip[1]));
            let (fx, fy) = (field(sx), field(sy));
            let (low, high) = (_mm256_unpacklo_epi32(fx, fy), _mm256_unpackhi_epi32(fx, fy));
            let first: [u64; 4] = bytemuck::cast(_mm256_permute2x128_si256::<0x20>(low, high));
            let second: [u64; 4] = bytemuck::cast(_mm256_permute2x128_si256::<0x31>(low, high));
            xs.copy_from_slice(&bytemuck::cast::<_, [i32; 8]>(sx));
            ys.copy_from_slice(&bytemuck::cast::<_, [i32; 8]>(sy));
            qs.copy_from_slice(&bytemuck::cast::<_, [f32; 8]>(inv_w));
            codes[..4].copy_from_slice(&first);
            codes[4..].copy_from_slice(&second);
        }
    }
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
        /// Eight lanes (AVX2, where the CPU has it) give four lanes' bits for any camera rows
        /// and points, NaN, infinities and overflow included.
        #[test]
        fn eight_lanes_equal_four_lanes(
            rows in proptest::array::uniform3(proptest::array::uniform4(lane_value())),
            points in proptest::collection::vec(proptest::array::uniform3(lane_value()), 1..40),
        ) {
            let blocks = crate::sampler::patch_mesh::to_blocks(&points);
            let blocks = &blocks[..blocks.len() / 2 * 2];
            let n = blocks.len() * LANES;
            let tables = || (vec![0; n], vec![0; n], vec![0.0; n], vec![0; n]);
            let (mut four, mut eight) = (tables(), tables());
            type Tables = (Vec<i32>, Vec<i32>, Vec<f32>, Vec<u64>);
            fn entries(t: &mut Tables) -> Entries<'_> {
                let (xs, ys, qs, codes) = t;
                Entries { xs, ys, qs, codes }
            }
            project_blocks(&rows, blocks, entries(&mut four));
            if !has_avx2() {
                return Ok(());
            }
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the CPU has AVX2 (tested above).
            unsafe { wide8::project_blocks(&rows, blocks, entries(&mut eight)) };
            // A NaN depth's sign and payload are not defined (the compiler may swap the
            // operands of an addition, and x86 passes on the first NaN operand); every NaN
            // depth draws nothing, so any NaN is as good as another.
            let bits = |q: &[f32]| {
                let bits = |v: &f32| if v.is_nan() { u32::MAX } else { v.to_bits() };
                q.iter().map(bits).collect::<Vec<_>>()
            };
            prop_assert_eq!(&four.0, &eight.0);
            prop_assert_eq!(&four.1, &eight.1);
            prop_assert_eq!(bits(&four.2), bits(&eight.2));
            prop_assert_eq!(&four.3, &eight.3);
        }

        /// The SSE2 lanes give the scalar snap's bits for any input, NaN and overflow included.
        #[test]
        fn lanes_equal_the_scalar_snap(
            cx in proptest::array::uniform4(lane_value()),
            cy in proptest::array::uniform4(lane_value()),
            w in proptest::array::uniform4(prop_oneof![1e-3f32..1e3, Just(f32::NAN), Just(1e-30)]),
        ) {
            let ((x, y, q), codes) = snap_lanes([cx, cy, w].map(f32x4::from));
            for i in 0..LANES {
                let one = snap32([cx[i], cy[i], w[i]]);
                prop_assert_eq!(
                    (x[i], y[i], q[i].to_bits()),
                    (one.x, one.y, one.q.to_bits())
                );
                prop_assert_eq!(codes[i], centre_code(one.x, one.y));
            }
        }
    }
}
