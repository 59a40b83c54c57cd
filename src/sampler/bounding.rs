//! The bounding sphere the sampling cameras frame (spec: "Sampling sphere").
//!
//! Centre: the centre of the axis-aligned bounding box of the vertices the triangles use,
//! rounded to f32. Radius: the largest distance from that f32 centre to any of them, computed
//! in f64 and rounded up to the next f32, so every vertex a triangle uses is inside. A vertex
//! no triangle uses, which real exports carry, decides nothing. Deterministic (a maximum is
//! exact, so any split of the pass gives the same bits), one pass over the triangles; not the
//! minimal sphere (Ritter's or Welzl's would be up to ~15% tighter on elongated models, at the
//! price of a convention that is harder to reproduce in other readers).

use super::SamplingParams;
use crate::ooc::Mesh;
use rayon::prelude::*;

/// Triangles per task of the radius pass.
const BATCH: usize = 1 << 16;

/// Radius used when every vertex is at one point, so the camera distance stays positive.
const POINT_MESH_RADIUS: f32 = 1.0;

/// Centre and radius of the bounding sphere of the vertices `mesh`'s triangles use, by the
/// convention above.
/// A radius past the largest `f32` (coordinates near ±3.4e38) also becomes
/// `POINT_MESH_RADIUS`: the bake refuses such meshes first (`bake::frame`).
pub fn bounding_sphere(mesh: &Mesh) -> ([f32; 3], f32) {
    let (center, r) = bounding_sphere_f64(mesh);
    let mut radius = r as f32;
    if f64::from(radius) < r {
        radius = radius.next_up();
    }
    if radius <= 0.0 || !radius.is_finite() {
        radius = POINT_MESH_RADIUS;
    }
    (center, radius)
}

/// The centre of [`bounding_sphere`] and its radius before rounding to `f32` (finite for any
/// finite vertices).
pub(crate) fn bounding_sphere_f64(mesh: &Mesh) -> ([f32; 3], f64) {
    let b = mesh.bounds();
    let center: [f32; 3] =
        std::array::from_fn(|k| ((f64::from(b.min[k]) + f64::from(b.max[k])) * 0.5) as f32);
    let d2 = |v: u32| -> f64 {
        let p = mesh.position(v);
        (0..3)
            .map(|k| (f64::from(p[k]) - f64::from(center[k])).powi(2))
            .sum()
    };
    let max_sq = (0..mesh.triangle_count())
        .into_par_iter()
        .with_min_len(BATCH)
        .map(|t| mesh.triangle(t).map(d2).into_iter().fold(0.0f64, f64::max))
        .reduce(|| 0.0, f64::max);
    (center, max_sq.sqrt())
}

impl SamplingParams {
    /// Sampling parameters framing `mesh`'s bounding sphere ([`bounding_sphere`]).
    pub fn for_mesh(mesh: &Mesh, level: u32, resolution: u32, fov_deg: f32) -> SamplingParams {
        let (center, radius) = bounding_sphere(mesh);
        SamplingParams {
            level,
            resolution,
            fov_deg,
            center,
            radius,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_vertex_is_inside_and_the_centre_is_the_box_centre() {
        let positions = vec![
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.1, 3.0, -1.0],
            [1.0, 0.5, 1.0],
        ];
        let mesh = Mesh::from_memory("t", positions.clone(), vec![[0, 1, 2], [1, 2, 3]]).unwrap();
        let (c, r) = bounding_sphere(&mesh);
        assert_eq!(c, [1.0, 1.5, 0.0]);
        for p in positions {
            let d: f32 = (0..3).map(|k| (p[k] - c[k]).powi(2)).sum::<f32>().sqrt();
            assert!(d <= r);
        }
    }

    #[test]
    fn a_vertex_no_triangle_uses_is_left_out() {
        let positions = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let without = Mesh::from_memory("t", positions.clone(), vec![[0, 1, 2]]).unwrap();
        for stray in [[1e6, 0.0, 0.0], [-3e38, 1e30, 0.0]] {
            let mut with = positions.clone();
            with.insert(1, stray);
            let with = Mesh::from_memory("t", with, vec![[0, 2, 3]]).unwrap();
            assert_eq!(with.bounds(), without.bounds());
            assert_eq!(bounding_sphere(&with), bounding_sphere(&without));
            assert_eq!(
                bounding_sphere_f64(&with).1.to_bits(),
                bounding_sphere_f64(&without).1.to_bits()
            );
        }
    }

    #[test]
    fn a_point_mesh_gets_a_positive_radius() {
        let mesh = Mesh::from_memory("t", vec![[1.0, 1.0, 1.0]; 3], vec![[0, 1, 2]]).unwrap();
        assert_eq!(bounding_sphere(&mesh), ([1.0, 1.0, 1.0], POINT_MESH_RADIUS));
    }
}
