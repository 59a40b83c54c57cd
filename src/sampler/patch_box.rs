//! Oriented bounding boxes of patches: the tiled sampler's tight occlusion bound.
//!
//! A patch that no parent view saw is drawn only if its bounds may reach a pixel in front of
//! what the occlusion tiles hold. Its bounding sphere is a poor bound there: a patch is a
//! nearly flat piece of surface, and its sphere reaches out by its radius in every
//! direction, past silhouettes onto empty pixels and in front of the surface that hides the
//! patch. On the 1.6M-triangle subdivided bunny most patches that pass the sphere test turn
//! out hidden (all their triangles looped over for nothing), and exact per-pixel depths
//! instead of 8×8 tiles let nearly as many through: the bound, not the tile size, is what
//! fails (counted in docs/benchmarks/sampling.md).
//!
//! Technique: one axis of the box is the patch's normal-cone axis (the thin direction of a
//! surface piece), the other two the principal directions of its vertices in the tangent
//! plane (closed-form 2 × 2 eigenvectors), extents from the vertices in `f64` and widened so
//! that every vertex is inside despite rounding. A patch with a degenerate cone gets an
//! axis-aligned box. In a view, the eight corners are projected; when all lie in front of
//! the near plane, the patch's pixels lie inside the corners' screen rectangle (perspective
//! maps a convex box in front of the eye into the convex hull of its projected corners) and
//! no point of it is nearer than its nearest corner (depth is linear in the box).
//! Cost: one pass over each patch's vertices when sampling starts; 8 projections per test.

use super::camera::{cross, dot, normalize};
use super::patch_mesh::PatchMesh;
use crate::tiling::Tiling;
use rayon::prelude::*;

/// An oriented box: `center + Σ s_k · axes[k]` for `s_k ∈ [−1, 1]` (axes scaled by the half
/// extents).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PatchBox {
    center: [f64; 3],
    axes: [[f64; 3]; 3],
}

/// Relative widening of every half extent (of the patch's size plus its distance from the
/// origin): the `f64` dot products that measure the extents round by ~1e-16 relative, so
/// 1e-9 keeps every vertex strictly inside while costing nothing measurable in tightness.
const EXTENT_SLACK: f64 = 1e-9;

impl PatchBox {
    /// The box around `points` with one axis along `normal` (any length; a zero vector gives
    /// an axis-aligned box). `points` must not be empty.
    pub(crate) fn around(points: &[[f32; 3]], normal: [f32; 3]) -> PatchBox {
        let axes = box_axes(points, normal.map(f64::from));
        let mut lo = [f64::MAX; 3];
        let mut hi = [f64::MIN; 3];
        let mut reach = 0.0f64;
        for p in points {
            let p = p.map(f64::from);
            reach = reach.max(dot(p, p).sqrt());
            for k in 0..3 {
                let s = dot(p, axes[k]);
                lo[k] = lo[k].min(s);
                hi[k] = hi[k].max(s);
            }
        }
        let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let slack = EXTENT_SLACK * (size + reach) + f64::MIN_POSITIVE;
        let mut center = [0.0; 3];
        let mut scaled = [[0.0; 3]; 3];
        for k in 0..3 {
            let mid = 0.5 * (lo[k] + hi[k]);
            let half = 0.5 * (hi[k] - lo[k]) + slack;
            for i in 0..3 {
                center[i] += mid * axes[k][i];
                scaled[k][i] = half * axes[k][i];
            }
        }
        PatchBox {
            center,
            axes: scaled,
        }
    }

    /// The eight corners.
    pub(crate) fn corners(&self) -> [[f64; 3]; 8] {
        std::array::from_fn(|i| {
            let mut c = self.center;
            for (k, axis) in self.axes.iter().enumerate() {
                let s = if i >> k & 1 == 1 { 1.0 } else { -1.0 };
                for j in 0..3 {
                    c[j] += s * axis[j];
                }
            }
            c
        })
    }
}

/// The boxes of every patch of `tiling`, from its vertices in `mesh`, in parallel.
pub(crate) fn patch_boxes(mesh: &PatchMesh, tiling: &Tiling) -> Vec<PatchBox> {
    (0..mesh.patch_count())
        .into_par_iter()
        .map(|p| {
            let points: Vec<[f32; 3]> = mesh.vertices(p).collect();
            PatchBox::around(&points, tiling.patches[p].cone_axis)
        })
        .collect()
}

/// Orthonormal axes: `normal` (normalised) and the principal directions of `points` in the
/// plane across it; the world axes if `normal` is zero.
fn box_axes(points: &[[f32; 3]], normal: [f64; 3]) -> [[f64; 3]; 3] {
    let length = dot(normal, normal).sqrt();
    if !(length > 0.0 && length.is_finite()) {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let n = normal.map(|c| c / length);
    // Any tangent: across the world axis least aligned with the normal.
    let least = (0..3)
        .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[least] = 1.0;
    let t1 = normalize(cross(n, e));
    let t2 = cross(n, t1);
    // Second moments of the tangent coordinates about their mean.
    let count = points.len() as f64;
    let (mut su, mut sv, mut suu, mut svv, mut suv) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in points {
        let p = p.map(f64::from);
        let (u, v) = (dot(p, t1), dot(p, t2));
        su += u;
        sv += v;
        suu += u * u;
        svv += v * v;
        suv += u * v;
    }
    let (mu, mv) = (su / count, sv / count);
    let cuu = suu / count - mu * mu;
    let cvv = svv / count - mv * mv;
    let cuv = suv / count - mu * mv;
    let angle = 0.5 * (2.0 * cuv).atan2(cuu - cvv);
    let (sin, cos) = angle.sin_cos();
    let major = normalize([
        cos * t1[0] + sin * t2[0],
        cos * t1[1] + sin * t2[1],
        cos * t1[2] + sin * t2[2],
    ]);
    let minor = cross(n, major);
    [major, minor, n]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Whether `p` is inside `b` (its coordinates along the box axes within the extents).
    fn contains(b: &PatchBox, p: [f32; 3]) -> bool {
        let d = [
            p[0] as f64 - b.center[0],
            p[1] as f64 - b.center[1],
            p[2] as f64 - b.center[2],
        ];
        b.axes.iter().all(|a| dot(d, *a).abs() <= dot(*a, *a))
    }

    #[test]
    fn a_flat_patch_gets_a_thin_box_along_its_normal() {
        // A 4 × 1 rectangle in the plane z = 3, rotated 30° about z.
        let (s, c) = (30f32.to_radians().sin(), 30f32.to_radians().cos());
        let points: Vec<[f32; 3]> = [[0.0, 0.0], [4.0, 0.0], [4.0, 1.0], [0.0, 1.0], [2.0, 0.5]]
            .iter()
            .map(|&[x, y]| [c * x - s * y, s * x + c * y, 3.0])
            .collect();
        let b = PatchBox::around(&points, [0.0, 0.0, 2.0]);
        let half = b.axes.map(|a| dot(a, a).sqrt());
        assert!((half[0] - 2.0).abs() < 1e-5, "{half:?}");
        assert!((half[1] - 0.5).abs() < 1e-5, "{half:?}");
        assert!(half[2] < 1e-6, "{half:?}");
        assert!(points.iter().all(|&p| contains(&b, p)));
    }

    #[test]
    fn a_degenerate_cone_gets_an_axis_aligned_box() {
        let points = [[1.0, 2.0, 3.0], [-1.0, 0.0, 5.0]];
        let b = PatchBox::around(&points, [0.0; 3]);
        assert_eq!(b.axes[0][1], 0.0);
        assert!(points.iter().all(|&p| contains(&b, p)));
    }

    proptest! {
        /// Every vertex lies in its box, whatever the normal and however far from the origin.
        #[test]
        fn every_point_is_inside(
            points in proptest::collection::vec(proptest::array::uniform3(-1e3f32..1e3), 1..40),
            offset in proptest::array::uniform3(-1e5f32..1e5),
            normal in proptest::array::uniform3(-1f32..1.0),
        ) {
            let points: Vec<[f32; 3]> = points
                .iter()
                .map(|p| [p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]])
                .collect();
            let b = PatchBox::around(&points, normal);
            for &p in &points {
                prop_assert!(contains(&b, p), "{p:?} outside {b:?}");
            }
            for corner in b.corners() {
                prop_assert!(corner.iter().all(|c| c.is_finite()));
            }
        }
    }
}
