//! Per-patch bounds: area, bounding sphere and normal cone.
//!
//! - Area: the sum of triangle areas in `f64`, summed in input-triangle order.
//! - Bounding sphere: centred on the patch's bounding box, radius the largest distance from that
//!   (rounded) centre to a vertex, padded by [`RADIUS_PAD`] so that every vertex is inside even
//!   when a consumer tests containment in `f32`. Not the minimal sphere (within √3 of it for
//!   thin patches, usually within a few per cent), but exact to compute.
//! - Normal cone, after meshoptimizer's `meshopt_computeClusterBounds`: the axis is the
//!   normalised mean of the unit normals of the non-degenerate triangles, the cosine is the
//!   smallest dot product of the axis with those normals, minus [`CONE_COS_PAD`]. If the axis
//!   has zero length or the cosine is not positive, the cone is "never reject": axis `[0,0,0]`,
//!   cosine `-1`. Triangles with a zero (or non-finite) normal are skipped. The cone has no
//!   apex: it bounds directions only, and a backface test with it must be made against the
//!   bounding sphere (every point of the patch), as the sampler's consumers do.
//!
//! Cost: O(triangles of the patch).

use super::Patch;
use super::aabb::Aabb;
use crate::ooc::Mesh;

/// Relative padding of the bounding-sphere radius, applied to the radius plus the largest
/// centre coordinate (so it also covers `f32` cancellation far from the origin). 2⁻²⁰ is
/// about 16 `f32` ulps: enough for a consumer's `f32` distance test, invisible in culling.
pub(crate) const RADIUS_PAD: f64 = 1.0 / (1u64 << 20) as f64;

/// Subtracted from the cone cosine so that the stored `f32` axis and cosine still contain
/// every normal after rounding (each rounding moves a dot product by about 10⁻⁷).
pub(crate) const CONE_COS_PAD: f64 = 1.0 / (1u64 << 19) as f64;

/// The corners of triangle `t`.
pub(crate) fn corners(mesh: &Mesh, t: u32) -> [[f32; 3]; 3] {
    mesh.triangle(t).map(|v| mesh.position(v))
}

/// The (unnormalised) normal of a triangle in `f64`: its length is twice the area.
pub(crate) fn cross_normal(p: [[f32; 3]; 3]) -> [f64; 3] {
    let d = |i: usize, k: usize| f64::from(p[i][k]) - f64::from(p[0][k]);
    let (u, v) = ([d(1, 0), d(1, 1), d(1, 2)], [d(2, 0), d(2, 1), d(2, 2)]);
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

/// The first triangle of `mesh` whose area is not zero ([`cross_normal`], exact enough for
/// any finite `f32` corners), or `None` when every triangle is degenerate. Stops at the
/// first: on a usual mesh that is triangle 0.
pub(crate) fn first_with_area(mesh: &Mesh) -> Option<u32> {
    (0..mesh.triangle_count()).find(|&t| cross_normal(corners(mesh, t)).iter().any(|&c| c != 0.0))
}

pub(crate) fn length(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// The area of a triangle.
pub(crate) fn triangle_area(p: [[f32; 3]; 3]) -> f64 {
    0.5 * length(cross_normal(p))
}

/// The bounds of the patch made of `triangles` (input indices), with `first`/`count` given,
/// and the squared diagonal of its bounding box (for the compactness measure).
pub(crate) fn patch_bounds(mesh: &Mesh, triangles: &[u32], first: u32) -> (Patch, f64) {
    let mut area = 0.0;
    let mut bbox: Option<Aabb> = None;
    let mut normal_sum = [0.0f64; 3];
    for &t in triangles {
        let p = corners(mesh, t);
        let tb = Aabb::of_triangle(p);
        bbox = Some(bbox.map_or(tb, |b| b.union(&tb)));
        let n = cross_normal(p);
        let len = length(n);
        area += 0.5 * len;
        if len > 0.0 && len.is_finite() {
            for k in 0..3 {
                normal_sum[k] += n[k] / len;
            }
        }
    }
    // Callers pass at least one triangle; an empty patch would still get a valid (point) box.
    let bbox = bbox.unwrap_or(Aabb {
        min: [0.0; 3],
        max: [0.0; 3],
    });
    let (center, radius) = sphere_in(&bbox, triangles.iter().flat_map(|&t| corners(mesh, t)));
    let (cone_axis, cone_cos) = normal_cone(mesh, triangles, normal_sum);
    let patch = Patch {
        first,
        count: triangles.len() as u32,
        area,
        center,
        radius,
        cone_axis,
        cone_cos,
    };
    (patch, bbox.diagonal_squared())
}

/// A bounding sphere of `points` (at least one): centred on their box `bbox` (rounded to
/// `f32`), radius the largest distance from that centre, padded by [`RADIUS_PAD`] and
/// rounded up, so that it holds every point in `f32` as well.
fn sphere_in(bbox: &Aabb, points: impl Iterator<Item = [f32; 3]>) -> ([f32; 3], f32) {
    let center = bbox.center().map(|c| c as f32);
    let c64 = center.map(f64::from);
    let mut max_d2 = 0.0f64;
    for q in points {
        let d2: f64 = (0..3).map(|k| (f64::from(q[k]) - c64[k]).powi(2)).sum();
        max_d2 = max_d2.max(d2);
    }
    let scale = c64.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    let radius = max_d2.sqrt() + (max_d2.sqrt() + scale) * RADIUS_PAD;
    (center, round_up(radius))
}

/// [`sphere_in`] of `points` (at least one) around their own box.
pub(crate) fn bounding_sphere(points: &[[f32; 3]]) -> ([f32; 3], f32) {
    let mut bbox = Aabb {
        min: points[0],
        max: points[0],
    };
    for &q in points {
        bbox.include(q);
    }
    sphere_in(&bbox, points.iter().copied())
}

/// The cone around the normalised `normal_sum` that holds every non-degenerate normal.
fn normal_cone(mesh: &Mesh, triangles: &[u32], normal_sum: [f64; 3]) -> ([f32; 3], f32) {
    const NEVER_REJECT: ([f32; 3], f32) = ([0.0; 3], -1.0);
    let len = length(normal_sum);
    if !(len > 0.0 && len.is_finite()) {
        return NEVER_REJECT;
    }
    // Measure against the axis as stored, so its rounding cannot leave a normal outside.
    let axis = normal_sum.map(|c| (c / len) as f32);
    let a64 = axis.map(f64::from);
    let mut min_dot = f64::INFINITY;
    for &t in triangles {
        let n = cross_normal(corners(mesh, t));
        let l = length(n);
        if l > 0.0 && l.is_finite() {
            min_dot = min_dot.min((a64[0] * n[0] + a64[1] * n[1] + a64[2] * n[2]) / l);
        }
    }
    let cos = min_dot - CONE_COS_PAD;
    if cos > 0.0 {
        // Rounding to `f32` moves the cosine by at most 6·10⁻⁸, well inside the pad.
        (axis, cos as f32)
    } else {
        NEVER_REJECT
    }
}

/// The smallest `f32` not below `x` (for non-negative finite `x`).
fn round_up(x: f64) -> f32 {
    let r = x as f32;
    if f64::from(r) < x {
        f32::from_bits(r.to_bits() + 1)
    } else {
        r
    }
}
