//! The probe's apertures: where a view looks through a gap a few pixels wide between parts
//! (a hole in a sheet, the slit between two parts), a camera elsewhere in the view's cell sees
//! through the gap what lies behind it, shifted by parallax, which the probe's one-pixel
//! shrink does not reach. A fragment at depth `1/q` seen past a rim at depth `1/a` moves by
//! `s · ρ · (a − q)` pixels for a camera `ρ` aside (`s` the camera's pixels per unit at depth
//! 1, depths as `1/w`), so every fragment within that distance of a gap, behind its rim, may
//! show from the cell: the bound of a cell of radius `ρ` around the eye, blocking ignored.
//!
//! An aperture pixel has, within `width` pixels on both sides along its row or its column, a
//! rim: a pixel nearer than it by at least one pixel's parallax whose patch is not its own nor
//! an edge neighbour of it (a fold of one surface is no gap), or it is empty. Its value is the
//! nearer rim's `1/a`. The values spread by a cone of slope `1 / (s ρ)` a pixel, in two
//! chamfer passes over the 8-neighbourhood, whose Chebyshev steps reach at least as far as
//! the Euclidean bound: `reveal[x] = max over apertures h of (a_h − |x − h| / (s ρ))`, and a
//! fragment `(x, q)` may show through an aperture when `q < reveal[x]`.
//!
//! Asked for with `--apertures PX`: with `--conservative` at 2 pixels, the FM1 box (a
//! sheet-metal box with holes) keeps 98.7–100 % identical views at every distance against
//! 95.3–99.3 %, for 8–13 points of culling; assemblies whose parts meet at gaps everywhere
//! lose 7–25 points (the exposed engine and the cycloidal drive, docs/benchmarks/far-cameras.md,
//! "Apertures"), so no preset opens them.

use crate::sampler::key_buffer::{TILE, patch_slot};
use crate::sampler::patch_graph::PatchGraph;

/// One view's apertures.
#[derive(Default)]
pub(super) struct Apertures {
    n: usize,
    /// Per pixel: fragments farther than this (a smaller `1/w`) may show; 0 where none.
    reveal: Vec<f32>,
    /// Per tile of [`TILE`]² pixels: the largest `reveal` in it.
    tiles: Vec<f32>,
    /// Whether any pixel has a non-zero `reveal`.
    any: bool,
    /// The inclusive rectangle `[x0, y0, x1, y1]` holding every non-zero `reveal`.
    written: [usize; 4],
    /// Scratch: the image's depths while finding apertures, then the values to spread.
    values: Vec<f32>,
    /// Scratch of the spread: each wedge of the cone, and their maximum.
    wedge: Vec<f32>,
    cone: Vec<f32>,
    /// Scratch: per pixel of a line, the nearest depth within the width before and after.
    before: Vec<f32>,
    after: Vec<f32>,
}

impl Apertures {
    /// Finds the apertures of the view whose keys are `keys` (`n`² pixels, `patch_count`
    /// patches, edge neighbours in `graph`), gaps at most `width` pixels wide, and spreads
    /// them with cone slope `slope` (`1 / (s ρ)`).
    pub(super) fn build(
        &mut self,
        keys: &[u64],
        n: usize,
        width: usize,
        slope: f32,
        graph: Option<&PatchGraph>,
        patch_count: u32,
    ) {
        if self.any {
            // Only the last view's written rectangle holds values.
            let [x0, y0, x1, y1] = self.written;
            for y in y0..=y1 {
                self.reveal[y * self.n + x0..=y * self.n + x1].fill(0.0);
            }
            self.tiles.fill(0.0);
            self.any = false;
        }
        // No buffers without apertures: the default's probe runs this after every view.
        if width == 0 || slope.is_nan() || slope <= 0.0 {
            return;
        }
        let tiles_per_row = n.div_ceil(TILE);
        if self.n != n {
            self.n = n;
            self.reveal = vec![0.0; n * n];
            self.tiles = vec![0.0; tiles_per_row * tiles_per_row];
        }
        let values = &mut self.values;
        values.clear();
        values.extend(keys.iter().map(|&k| f32::from_bits((k >> 32) as u32)));
        let depth = &values[..];
        let pc = patch_count as usize;
        // Whether the patches of pixels `i` and `j` are one surface (the same patch or
        // patches sharing an edge): a fold of it, not a gap.
        let joined = |i: usize, j: usize| {
            let (a, b) = (
                patch_slot(keys[i], patch_count),
                patch_slot(keys[j], patch_count),
            );
            a < pc
                && b < pc
                && (a == b
                    || graph
                        .is_some_and(|g| g.neighbours(a as u32).binary_search(&(b as u32)).is_ok()))
        };
        // The value of the pixel at `i` of a line whose pixel `j` is `base + j · step`: the
        // nearer rim if it has one within `width` on both sides, else 0. (A line's empty ends
        // hold no rim, so a pixel outside its first and last fragment is no aperture.)
        let aperture = |i: usize, base: usize, step: usize| {
            let p = base + i * step;
            let need = depth[p] + slope;
            let rim = |j: usize| {
                let d = depth[base + j * step];
                if d >= need && !joined(p, base + j * step) {
                    d
                } else {
                    0.0
                }
            };
            let left = (i.saturating_sub(width)..i).map(rim).fold(0.0f32, f32::max);
            if left < need {
                return 0.0;
            }
            let right = (i + 1..=(i + width).min(n - 1))
                .map(rim)
                .fold(0.0f32, f32::max);
            if right < need { 0.0 } else { left.max(right) }
        };
        let reveal = &mut self.reveal;
        let mut bounds = [usize::MAX, usize::MAX, 0, 0];
        let mut top = 0.0f32;
        let mut found = |p: usize, a: f32| {
            if a > reveal[p] {
                reveal[p] = a;
                top = top.max(a);
                let (x, y) = (p % n, p / n);
                bounds = [
                    bounds[0].min(x),
                    bounds[1].min(y),
                    bounds[2].max(x),
                    bounds[3].max(y),
                ];
            }
        };
        deep_steps(
            depth,
            n,
            width,
            slope,
            [&mut self.before, &mut self.after],
            |i, base, stride| {
                let a = aperture(i, base, stride);
                if a > 0.0 {
                    found(base + i * stride, a);
                }
            },
        );
        self.any = top > 0.0;
        if !self.any {
            return;
        }
        // The cone's reach: a value `a` reaches `a / slope` pixels.
        let reach = (top / slope).ceil() as usize + 1;
        let [x0, y0, x1, y1] = [
            bounds[0].saturating_sub(reach),
            bounds[1].saturating_sub(reach),
            (bounds[2] + reach).min(n - 1),
            (bounds[3] + reach).min(n - 1),
        ];
        self.written = [x0, y0, x1, y1];
        spread(
            reveal,
            n,
            self.written,
            slope,
            [&mut self.values, &mut self.wedge, &mut self.cone],
        );
        for y in y0..=y1 {
            for x in x0..=x1 {
                let t = (y / TILE) * tiles_per_row + x / TILE;
                self.tiles[t] = self.tiles[t].max(reveal[y * n + x]);
            }
        }
    }

    /// Whether some pixel of the inclusive rectangle `[x0, y0, x1, y1]` may reveal a fragment
    /// at depth `q_far` (`1/w`) or nearer ([`Self::reveals`]): what lies wholly in front of
    /// every aperture's cone there (its farthest depth `q_far`) never shows through one.
    pub(super) fn may_reveal(&self, rect: [usize; 4], q_far: f32) -> bool {
        if !self.any {
            return false;
        }
        let tiles_per_row = self.n.div_ceil(TILE);
        let last = tiles_per_row - 1;
        for ty in (rect[1] / TILE).min(last)..=(rect[3] / TILE).min(last) {
            for tx in (rect[0] / TILE).min(last)..=(rect[2] / TILE).min(last) {
                if q_far < self.tiles[ty * tiles_per_row + tx] {
                    return true;
                }
            }
        }
        false
    }

    /// Whether a fragment at pixel `index`, depth `q`, may show through an aperture.
    #[inline]
    pub(super) fn reveals(&self, index: usize, q: f32) -> bool {
        self.any && q < self.reveal[index]
    }

    /// Whether anything is revealed at all.
    pub(super) fn any(&self) -> bool {
        self.any
    }
}

/// Calls `visit(i, base, stride)` for each pixel `base + i · stride` of a row (`stride` 1) or
/// a column (`stride` `n`) of the `n`² depths `depth` that has, within `width` pixels on both
/// sides along that line, a depth at least `slope` nearer than its own: the only pixels that
/// may be apertures, found by depth alone before any patch is looked up. A line at a time:
/// the nearest depth within the width before and after each pixel, the rows first, then the
/// columns a row of them at a time (the image is stored by rows). `lines`: scratch.
fn deep_steps(
    depth: &[f32],
    n: usize,
    width: usize,
    slope: f32,
    lines: [&mut Vec<f32>; 2],
    mut visit: impl FnMut(usize, usize, usize),
) {
    let [before, after] = lines;
    let reach = width.min(n - 1);
    let row = |y: usize| &depth[y * n..][..n];
    for pass in 0..2 {
        for y in 0..n {
            if pass == 0 && row(y).iter().all(|&d| d == 0.0) {
                continue;
            }
            before.clear();
            before.resize(n, 0.0);
            after.clear();
            after.resize(n, 0.0);
            for k in 1..=reach {
                if pass == 0 {
                    for (b, &d) in before[k..].iter_mut().zip(row(y)) {
                        *b = max(*b, d);
                    }
                    for (a, &d) in after.iter_mut().zip(&row(y)[k..]) {
                        *a = max(*a, d);
                    }
                    continue;
                }
                if let Some(other) = y.checked_sub(k) {
                    for (b, &d) in before.iter_mut().zip(row(other)) {
                        *b = max(*b, d);
                    }
                }
                if y + k < n {
                    for (a, &d) in after.iter_mut().zip(row(y + k)) {
                        *a = max(*a, d);
                    }
                }
            }
            for (x, &d) in row(y).iter().enumerate() {
                let need = d + slope;
                if before[x] >= need && after[x] >= need {
                    if pass == 0 {
                        visit(x, y * n, 1);
                    } else {
                        visit(y, x, n);
                    }
                }
            }
        }
    }
}

/// Spreads each value of `reveal` (`n` pixels a row) by a cone of `slope` a pixel within the
/// inclusive rectangle `[x0, y0, x1, y1]`: each pixel becomes the largest `v − slope · d` over
/// the pixels of the rectangle, `v` their value and `d` their Chebyshev distance, `slope`
/// subtracted once a step. The cone is four wedges, each swept one row (or column) at a time
/// from the one before, its three neighbours there one step away: down, up, right, left.
/// Within a row (or column) no pixel waits for another. `scratch`: three buffers.
fn spread(reveal: &mut [f32], n: usize, rect: [usize; 4], slope: f32, scratch: [&mut Vec<f32>; 3]) {
    let [x0, y0, x1, y1] = rect;
    let w = x1 - x0 + 1;
    let [values, wedge, cone] = scratch;
    values.clear();
    for y in y0..=y1 {
        values.extend_from_slice(&reveal[y * n + x0..=y * n + x1]);
    }
    cone.clear();
    cone.extend_from_slice(values);
    sweep_rows(cone, w, slope, true);
    let others: [(Sweep, bool); 3] = [
        (sweep_rows, false),
        (sweep_columns, true),
        (sweep_columns, false),
    ];
    for (sweep, forward) in others {
        wedge.clear();
        wedge.extend_from_slice(values);
        sweep(wedge, w, slope, forward);
        for (c, &v) in cone.iter_mut().zip(wedge.iter()) {
            *c = max(*c, v);
        }
    }
    for (y, row) in (y0..=y1).zip(cone.chunks_exact(w)) {
        reveal[y * n + x0..=y * n + x1].copy_from_slice(row);
    }
}

/// The larger of `a` and `b`, neither NaN: one `maxss` (`f32::max` also handles NaN, which
/// keeps the loops here from vectorizing).
#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// A wedge's sweep: [`sweep_rows`] or [`sweep_columns`].
type Sweep = fn(&mut [f32], usize, f32, bool);

/// One wedge of [`spread`] over `buf` (`w` wide): each row, in order (`forward`) or in
/// reverse, takes the largest of its value and its three neighbours' in the row before less
/// `slope`.
fn sweep_rows(buf: &mut [f32], w: usize, slope: f32, forward: bool) {
    let h = buf.len() / w;
    for k in 1..h {
        let (before, row) = if forward {
            let (head, tail) = buf.split_at_mut(k * w);
            (&head[(k - 1) * w..], &mut tail[..w])
        } else {
            let (head, tail) = buf.split_at_mut((h - k) * w);
            (&tail[..w], &mut head[(h - k - 1) * w..])
        };
        row[0] = max(row[0], max(before[0], before[w.min(2) - 1]) - slope);
        if w > 1 {
            row[w - 1] = max(row[w - 1], max(before[w - 2], before[w - 1]) - slope);
        }
        for (r, b) in row[1..w.max(2) - 1].iter_mut().zip(before.windows(3)) {
            *r = max(*r, max(max(b[0], b[1]), b[2]) - slope);
        }
    }
}

/// [`sweep_rows`] along the columns: each column, left to right (`forward`) or right to left,
/// from the column before.
fn sweep_columns(buf: &mut [f32], w: usize, slope: f32, forward: bool) {
    let h = buf.len() / w;
    for k in 1..w {
        let (from, to) = if forward {
            (k - 1, k)
        } else {
            (w - k, w - k - 1)
        };
        for y in 0..h {
            let (lo, hi) = (y.saturating_sub(1), (y + 1).min(h - 1));
            let m = max(
                max(buf[lo * w + from], buf[y * w + from]),
                buf[hi * w + from],
            );
            buf[y * w + to] = max(buf[y * w + to], m - slope);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::key_buffer::low_half;
    use proptest::prelude::*;

    const N: usize = 32;
    const PATCHES: u32 = 4;

    /// A key of `patch` at depth `q`.
    fn key(patch: u32, q: f32) -> u64 {
        (u64::from(q.to_bits()) << 32) | u64::from(low_half(patch, PATCHES))
    }

    /// Keys of an image whose columns `x` show `column(x)` (patch and depth) on every row.
    fn columns(column: impl Fn(usize) -> Option<(u32, f32)>) -> Vec<u64> {
        let mut keys = vec![0; N * N];
        for y in 0..N {
            for x in 0..N {
                if let Some((p, q)) = column(x) {
                    keys[y * N + x] = key(p, q);
                }
            }
        }
        keys
    }

    /// Two parts (patches 0 and 1) at depth `1/1`, with a slit of `gap` columns from
    /// column 15 through which patch 2 shows at depth `1/0.2`.
    fn slit(gap: usize) -> Vec<u64> {
        columns(|x| {
            Some(match x {
                _ if x < 15 => (0, 1.0),
                _ if x < 15 + gap => (2, 0.2),
                _ => (1, 1.0),
            })
        })
    }

    #[test]
    fn a_slit_between_two_parts_reveals_what_lies_deep_behind_it_within_the_cone() {
        let mut a = Apertures::default();
        a.build(&slit(1), N, 2, 0.1, None, PATCHES);
        assert!(a.any());
        let at = |x: usize| 16 * N + x;
        // On the slit: anything behind the rim.
        assert!(a.reveals(at(15), 0.99));
        assert!(!a.reveals(at(15), 1.0));
        // Five pixels away, what lies behind `1/0.5`; nine away, behind `1/0.1`.
        assert!(a.reveals(at(20), 0.49) && !a.reveals(at(20), 0.51));
        assert!(a.reveals(at(6), 0.09) && !a.reveals(at(6), 0.11));
        // Eleven away the cone has ended.
        assert!(!a.reveals(at(26), 0.0001));
        // Diagonally as far as along the row (the Chebyshev step).
        assert!(a.reveals(11 * N + 20, 0.49));
        assert!(a.may_reveal([20, 10, 20, 10], 0.0));
        // Nothing nearer than the rim shows anywhere.
        assert!(!a.may_reveal([0, 0, N - 1, N - 1], 1.0));
        assert!(a.may_reveal([15, 16, 15, 16], 0.99) && !a.may_reveal([26, 16, 26, 16], 0.2));
    }

    #[test]
    fn a_fold_a_wide_gap_and_a_shallow_step_are_no_apertures() {
        let mut a = Apertures::default();
        // One surface: the slit's patch is the parts'.
        let fold = columns(|x| Some(if x == 15 { (0, 0.2) } else { (0, 1.0) }));
        a.build(&fold, N, 2, 0.1, None, PATCHES);
        assert!(!a.any());
        // Five columns wide: no pixel of it has a rim within 2 pixels on both sides.
        a.build(&slit(5), N, 2, 0.1, None, PATCHES);
        assert!(!a.any());
        // Three wide: its middle column has.
        a.build(&slit(3), N, 2, 0.1, None, PATCHES);
        assert!(a.any() && a.reveals(16 * N + 16, 0.5) && !a.reveals(16 * N + 26, 0.1));
        // Behind by less than one pixel's parallax.
        let shallow = columns(|x| {
            Some(if x == 15 {
                (2, 0.95)
            } else {
                (x as u32 % 2, 1.0)
            })
        });
        a.build(&shallow, N, 2, 0.1, None, PATCHES);
        assert!(!a.any());
        // Apertures of the view before are gone.
        a.build(&slit(1), N, 2, 0.1, None, PATCHES);
        a.build(&slit(5), N, 2, 0.1, None, PATCHES);
        assert!(
            !a.any() && !a.reveals(16 * N + 15, 0.0) && !a.may_reveal([0, 0, N - 1, N - 1], 0.0)
        );
    }

    #[test]
    fn an_empty_gap_is_an_aperture_and_an_open_edge_is_not() {
        let mut a = Apertures::default();
        let hole = columns(|x| (x != 15).then_some((x as u32 / 16, 1.0)));
        a.build(&hole, N, 2, 0.1, None, PATCHES);
        assert!(a.any() && a.reveals(16 * N + 18, 0.5));
        let edge = columns(|x| (x < 15).then_some((0, 1.0)));
        a.build(&edge, N, 2, 0.1, None, PATCHES);
        assert!(!a.any());
    }

    proptest! {
        #[test]
        fn the_spread_is_the_largest_value_less_a_slope_a_chebyshev_step(
            values in proptest::collection::vec(
                prop_oneof![3 => Just(0.0f32), 1 => 0.0f32..2.0], 12 * 12),
            slope in 0.05f32..1.0,
        ) {
            let n = 12;
            let mut reveal = values.clone();
            let mut scratch = [Vec::new(), Vec::new(), Vec::new()];
            let [a, b, c] = &mut scratch;
            spread(&mut reveal, n, [0, 0, n - 1, n - 1], slope, [a, b, c]);
            for y in 0..n {
                for x in 0..n {
                    let mut want = 0.0f32;
                    for (i, &v) in values.iter().enumerate() {
                        let d = (i % n).abs_diff(x).max((i / n).abs_diff(y));
                        want = want.max((0..d).fold(v, |v, _| v - slope));
                    }
                    prop_assert_eq!(reveal[y * n + x], want);
                }
            }
        }
    }
}
