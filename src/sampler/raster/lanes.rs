//! The small-triangle paths of [`super::scan_triangle`]: a bounding box at most four pixels
//! wide is scanned a whole row at a time, four samples in one SIMD register (a 2 × 2 box all
//! at once), and only the covered samples are plotted.
//!
//! Technique: the same edge functions and depth plane as the pixel walk (Pineda 1988), one
//! sample per lane, with the `wide` crate's safe 4-lane types (SSE2 on x86-64, NEON on
//! AArch64, plain arrays elsewhere; no `unsafe` here): per row three integer ORs, one sign
//! mask (`movmskps`), two `i32 → f32` converts, two multiplies and two adds for the depths,
//! then a loop over the mask's set bits. The walk spends about twenty scalar operations on
//! every sample of the box, covered or not; most triangles of a scanned mesh at sampling
//! resolutions cover two to six pixels of a box of four to twelve.
//! Exactness: the caller sends only triangles whose corners span at most
//! [`NARROW_MAX_EXTENT`] sub-pixel units in x and y, so every edge function value at a lane
//! fits in `i32` (bound below), and `i32 → f32` rounds the same integer exactly as the walk's
//! `i64 → f32` does; depth is `a.q + w1 · kb + w2 · kc` in `f32`, evaluated in that order
//! without fused multiply-adds, as there. So the fragments are bit-identical to the walk's
//! (`raster/tests.rs` checks it on random triangles).
//! Cost per triangle: about 25 operations to set up the lanes, 15 per box row and 10 per
//! covered sample (measured: BENCHMARKS.md, "Sampling (issue 7)", "Fourth pass").

use wide::{f32x4, i32x4};

/// Widest bounding box (pixels) that takes this path: one 4-lane register per row.
pub(super) const NARROW_MAX_WIDTH: i64 = 4;

/// Largest corner spread (max − min, sub-pixel units, in x and in y) of a triangle that may
/// take this path: 64 pixels. Edge vectors are then at most 2^14 in each coordinate, and a
/// lane lies at most 2^14 + 3 · 256 from any corner (lanes past the box's right edge
/// included), so `|E| <= 2 · 2^14 · (2^14 + 768) + 1 < 2^30` at every lane: no `i32`
/// overflow.
pub(super) const NARROW_MAX_EXTENT: i64 = 1 << 14;

/// One edge function in `i32`: its value at the box's first sample and its steps per pixel.
#[derive(Clone, Copy, Debug)]
pub(super) struct LaneEdge {
    pub(super) start: i32,
    pub(super) step_x: i32,
    pub(super) step_y: i32,
}

impl LaneEdge {
    /// The edge's values at the first four samples of the box's first row.
    #[inline(always)]
    fn first_row(self) -> i32x4 {
        let s = self.step_x;
        i32x4::from([
            self.start,
            self.start + s,
            self.start + 2 * s,
            self.start + 3 * s,
        ])
    }
}

/// The depth plane `a.q + w1 · kb + w2 · kc` of [`super::scan_triangle`].
#[derive(Clone, Copy, Debug)]
pub(super) struct DepthPlane {
    pub(super) aq: f32,
    pub(super) kb: f32,
    pub(super) kc: f32,
}

/// [`scan_narrow`] for a box of at most 2 × 2 pixels (`two_columns`, `two_rows`: whether it
/// has a second column, a second row), all four samples in one register: lanes are the
/// pixels `(0, 0), (1, 0), (0, 1), (1, 1)` of the box.
#[inline(always)]
pub(super) fn scan_quad(
    edges: [LaneEdge; 3],
    depth: DepthPlane,
    two_columns: bool,
    two_rows: bool,
    first: usize,
    stride: usize,
    mut plot: impl FnMut(usize, f32, bool),
) {
    let quad = |e: LaneEdge| {
        let (x, y) = (e.start + e.step_x, e.start + e.step_y);
        i32x4::from([e.start, x, y, x + e.step_y])
    };
    let [w0, w1, w2] = edges.map(quad);
    let (x, y) = (u32::from(two_columns), u32::from(two_rows));
    let in_box = 1 | x << 1 | y << 2 | (x & y) << 3;
    let mut covered = !((w0 | w1 | w2).move_mask() as u32) & in_box;
    let q = (f32x4::splat(depth.aq)
        + w1.round_float() * f32x4::splat(depth.kb)
        + w2.round_float() * f32x4::splat(depth.kc))
    .to_array();
    while covered != 0 {
        let lane = covered.trailing_zeros() as usize;
        plot(first + (lane & 1) + (lane >> 1) * stride, q[lane], true);
        covered &= covered - 1;
    }
}

/// Calls `plot(index, depth, true)` once for every covered sample of the box of `width`
/// (1 to 4) by `height` pixels whose first pixel has index `first` in an image of row length
/// `stride`, row by row. `edges` are the triangle's edge functions `w0, w1, w2` (biased for
/// the fill rule, non-negative inside) at the box's first sample.
#[inline(always)]
pub(super) fn scan_narrow(
    edges: [LaneEdge; 3],
    depth: DepthPlane,
    width: usize,
    height: usize,
    first: usize,
    stride: usize,
    mut plot: impl FnMut(usize, f32, bool),
) {
    let [e0, e1, e2] = edges;
    let (mut w0, mut w1, mut w2) = (e0.first_row(), e1.first_row(), e2.first_row());
    let steps = [e0, e1, e2].map(|e| i32x4::splat(e.step_y));
    let (aq, kb, kc) = (
        f32x4::splat(depth.aq),
        f32x4::splat(depth.kb),
        f32x4::splat(depth.kc),
    );
    // Lanes past the box's right edge are outside the triangle or the image.
    let in_box = (1u32 << width) - 1;
    let mut row = first;
    for _ in 0..height {
        // A sample is covered when no edge function is negative, i.e. no sign bit is set.
        let mut covered = !((w0 | w1 | w2).move_mask() as u32) & in_box;
        let q = (aq + w1.round_float() * kb + w2.round_float() * kc).to_array();
        while covered != 0 {
            let lane = covered.trailing_zeros() as usize;
            plot(row + lane, q[lane], true);
            covered &= covered - 1;
        }
        w0 += steps[0];
        w1 += steps[1];
        w2 += steps[2];
        row += stride;
    }
}
