//! Conservative rasterization for `bake --conservative-raster`: a triangle marks every pixel
//! whose square it touches, with the nearest depth it can have inside that pixel.
//!
//! Not what `bake --conservative` does: measured on the bunny (BENCHMARKS.md, "Quality"),
//! this rasterization made view-supersampled bakes *worse* (98.5% instead of
//! 99.5% identical views), because a pixel keeps one winner at the nearest depth a triangle
//! reaches anywhere in it, so widened occluders also hide patches that point sampling sees
//! through a gap; its rows are not a superset of point-sampled rows. The variant that would
//! be a superset (per pixel, the nearest *far* depth of the triangles covering the whole
//! square as occluder; mark every touching triangle in front of it) finds almost no occluder
//! on scanned meshes: the bunny's visible triangles cover ~1.8 pixels each at 512², too small
//! to contain a pixel square, so nearly every touched triangle would be marked. `bake
//! --conservative` point-samples instead, and adds what may show near each view with the
//! probe pass (`tiled/probe.rs`).
//!
//! Point-sampled ID buffers miss patches that show only as sub-pixel slivers (a triangle
//! between pixel centres draws nothing). Here coverage is the exact overlap test of the closed
//! triangle with the closed pixel square (separating axes: the bounding box, then each edge
//! function evaluated at the square's corner deepest inside that edge, `E(centre) +
//! (|ex| + |ey|) · ½ px`, as in Hasselgren, Akenine-Möller & Ohlsson, GPU Gems 2 ch. 42), on
//! the same snapped fixed-point vertices as the point-sampled rasterizer.
//!
//! Depth rule (also stated in docs/benchmarks/sampling.md): the fragment depth is a sound upper
//! bound of `1/w` (nearer is larger) over triangle ∩ pixel: the minimum of (a) the maximum of
//! the affine depth plane over the whole pixel square, `q(centre) + ½ (|∂q/∂x| + |∂q/∂y|)`, and
//! (b) the largest corner depth; evaluated in `f64`, widened by a relative `DEPTH_SLACK` for
//! rounding and rounded up to `f32`. A triangle's fragment is thus never farther than any
//! point of the triangle inside the pixel, so a pixel keeps the triangle that comes nearest
//! anywhere in it. Cost: the bounding box of pixels touched, three edge tests per pixel.

use super::raster::{SUBPIXEL_BITS, ScreenVertex};

const SUBPIXEL: i64 = 1 << SUBPIXEL_BITS;
const HALF_PIXEL: i64 = SUBPIXEL / 2;

/// Relative widening of the depth bound: covers the `f64` rounding of the plane evaluation
/// (~1e-15 relative) with a wide margin while changing no comparison that matters (1e-9 is
/// far below the `f32` resolution of 6e-8).
const DEPTH_SLACK: f64 = 1e-9;

/// Calls `plot(pixel_index, depth, true)` for every pixel of a `resolution`² image whose
/// closed square the closed triangle touches, once each, in row-major order, with the depth
/// bound described above. Either winding; zero area draws nothing.
#[inline]
pub(crate) fn scan_triangle_conservative(
    tri: [ScreenVertex; 3],
    resolution: u32,
    mut plot: impl FnMut(usize, f32, bool),
) {
    let [a, b, c] = tri;
    let last = resolution as i64 - 1;
    let min_x = a.x.min(b.x).min(c.x) as i64;
    let max_x = a.x.max(b.x).max(c.x) as i64;
    let min_y = a.y.min(b.y).min(c.y) as i64;
    let max_y = a.y.max(b.y).max(c.y) as i64;
    // Pixel x's square [x, x + 1] · 256 meets [min, max] iff x · 256 <= max and
    // (x + 1) · 256 >= min.
    let x0 = (((min_x + SUBPIXEL - 1) >> SUBPIXEL_BITS) - 1).max(0);
    let x1 = (max_x >> SUBPIXEL_BITS).min(last);
    let y0 = (((min_y + SUBPIXEL - 1) >> SUBPIXEL_BITS) - 1).max(0);
    let y1 = (max_y >> SUBPIXEL_BITS).min(last);
    if x0 > x1 || y0 > y1 {
        return;
    }
    let (ax, ay) = (a.x as i64, a.y as i64);
    let signed_area = (b.x as i64 - ax) * (c.y as i64 - ay) - (b.y as i64 - ay) * (c.x as i64 - ax);
    if signed_area == 0 {
        return;
    }
    let sign = signed_area.signum();
    let (sample_x, sample_y) = (x0 * SUBPIXEL + HALF_PIXEL, y0 * SUBPIXEL + HALF_PIXEL);
    // Edge functions at the first pixel centre, widened to the square's innermost corner.
    let edge = |from: ScreenVertex, to: ScreenVertex| {
        let (fx, fy) = (from.x as i64, from.y as i64);
        let (ex, ey) = (sign * (to.x as i64 - fx), sign * (to.y as i64 - fy));
        let centre = ex * (sample_y - fy) - ey * (sample_x - fx);
        let widen = (ex.abs() + ey.abs()) * HALF_PIXEL;
        (centre + widen, -ey * SUBPIXEL, ex * SUBPIXEL)
    };
    let edges = [edge(b, c), edge(c, a), edge(a, b)];

    // Depth plane q(x, y) in pixel units, in f64: q = a.q + kb · E1 + kc · E2 where E1, E2
    // are the (unwidened) edge functions of b and c divided by the area.
    let area = (signed_area * sign) as f64;
    let (aq, bq, cq) = (a.q as f64, b.q as f64, c.q as f64);
    let (kb, kc) = ((bq - aq) / area, (cq - aq) / area);
    let centre_e = |from: ScreenVertex, to: ScreenVertex, px: i64, py: i64| {
        let (fx, fy) = (from.x as i64, from.y as i64);
        let (ex, ey) = (sign * (to.x as i64 - fx), sign * (to.y as i64 - fy));
        (ex * (py - fy) - ey * (px - fx)) as f64
    };
    let q0 = aq + kb * centre_e(c, a, sample_x, sample_y) + kc * centre_e(a, b, sample_x, sample_y);
    let step = |from: ScreenVertex, to: ScreenVertex| {
        let (ex, ey) = (sign * (to.x - from.x) as i64, sign * (to.y - from.y) as i64);
        ((-ey * SUBPIXEL) as f64, (ex * SUBPIXEL) as f64)
    };
    let (e1x, e1y) = step(c, a);
    let (e2x, e2y) = step(a, b);
    let (dqdx, dqdy) = (kb * e1x + kc * e2x, kb * e1y + kc * e2y);
    let spread = 0.5 * (dqdx.abs() + dqdy.abs());
    let nearest_corner = aq.max(bq).max(cq);
    let depth = |x: i64, y: i64| {
        let plane = q0 + dqdx * x as f64 + dqdy * y as f64 + spread;
        let bound = plane.min(nearest_corner) * (1.0 + DEPTH_SLACK);
        let rounded = bound as f32;
        if (rounded as f64) < bound {
            rounded.next_up()
        } else {
            rounded
        }
    };

    let stride = resolution as usize;
    let mut rows = edges.map(|(value, _, _)| value);
    for y in y0..=y1 {
        let mut w = rows;
        for x in x0..=x1 {
            if (w[0] | w[1] | w[2]) >= 0 {
                plot(
                    y as usize * stride + x as usize,
                    depth(x - x0, y - y0),
                    true,
                );
            }
            for (w, e) in w.iter_mut().zip(&edges) {
                *w += e.1;
            }
        }
        for (r, e) in rows.iter_mut().zip(&edges) {
            *r += e.2;
        }
    }
}
