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
        let depth = |i: usize| f32::from_bits((keys[i] >> 32) as u32);
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
        let reveal = &mut self.reveal;
        // Along rows, then along columns; only between a line's first and last fragment,
        // the columns only within the rows' extent of fragments.
        let mut bounds = [usize::MAX, usize::MAX, 0, 0];
        let mut top = 0.0f32;
        let mut extent = [n, n, 0, 0]; // Columns and rows holding fragments, half-open.
        for pass in 0..2 {
            let (lines, across) = if pass == 0 {
                (0..n, 0..n)
            } else {
                (extent[0]..extent[2], extent[1]..extent[3])
            };
            for line in lines {
                let at = |i: usize| {
                    if pass == 0 {
                        line * n + i
                    } else {
                        i * n + line
                    }
                };
                let (mut first, mut last) = (usize::MAX, 0);
                for i in across.clone() {
                    if depth(at(i)) > 0.0 {
                        first = first.min(i);
                        last = i;
                    }
                }
                if first == usize::MAX {
                    continue;
                }
                if pass == 0 {
                    extent = [
                        extent[0].min(first),
                        extent[1].min(line),
                        extent[2].max(last + 1),
                        extent[3].max(line + 1),
                    ];
                }
                if first >= last {
                    continue;
                }
                for i in first + 1..last {
                    let q = depth(at(i));
                    let need = q + slope;
                    let lo = i.saturating_sub(width).max(first);
                    let hi = (i + width).min(last);
                    let p = at(i);
                    let rim = |j: usize| {
                        let d = depth(at(j));
                        if d >= need && !joined(p, at(j)) {
                            d
                        } else {
                            0.0
                        }
                    };
                    let left = (lo..i).map(rim).fold(0.0f32, f32::max);
                    if left < need {
                        continue;
                    }
                    let right = (i + 1..=hi).map(rim).fold(0.0f32, f32::max);
                    if right < need {
                        continue;
                    }
                    let a = left.max(right);
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
                        self.any = true;
                    }
                }
            }
        }
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
        spread(reveal, n, self.written, slope);
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

/// Spreads each value of `reveal` (`n` pixels a row) by a cone of `slope` a pixel within the
/// inclusive rectangle `[x0, y0, x1, y1]`: each pixel becomes the largest `v − slope · d` over
/// the pixels of the rectangle, `v` their value and `d` their Chebyshev distance (two chamfer
/// passes over the 8-neighbourhood, exact for that metric).
fn spread(reveal: &mut [f32], n: usize, rect: [usize; 4], slope: f32) {
    let [x0, y0, x1, y1] = rect;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let mut r = reveal[y * n + x];
            if x > x0 {
                r = r.max(reveal[y * n + x - 1] - slope);
            }
            if y > y0 {
                for xx in x.saturating_sub(1).max(x0)..=(x + 1).min(x1) {
                    r = r.max(reveal[(y - 1) * n + xx] - slope);
                }
            }
            reveal[y * n + x] = r;
        }
    }
    for y in (y0..=y1).rev() {
        for x in (x0..=x1).rev() {
            let mut r = reveal[y * n + x];
            if x < x1 {
                r = r.max(reveal[y * n + x + 1] - slope);
            }
            if y < y1 {
                for xx in x.saturating_sub(1).max(x0)..=(x + 1).min(x1) {
                    r = r.max(reveal[(y + 1) * n + xx] - slope);
                }
            }
            reveal[y * n + x] = r;
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
        fn the_spread_is_the_largest_value_less_its_chebyshev_distance(
            values in proptest::collection::vec(
                prop_oneof![3 => Just(0.0f32), 1 => 0.0f32..2.0], 12 * 12),
            slope in 0.05f32..1.0,
        ) {
            let n = 12;
            let mut reveal = values.clone();
            spread(&mut reveal, n, [0, 0, n - 1, n - 1], slope);
            for y in 0..n {
                for x in 0..n {
                    let mut want = 0.0f32;
                    for (i, &v) in values.iter().enumerate() {
                        let d = (i % n).abs_diff(x).max((i / n).abs_diff(y));
                        want = want.max(v - slope * d as f32);
                    }
                    prop_assert!((reveal[y * n + x] - want).abs() <= 1e-5 * (1.0 + want));
                }
            }
        }
    }
}
