//! Which patches share a mesh edge, and whether a patch can face a viewpoint: what
//! `--dilate` needs to mark the edge neighbours of visible patches that face the view (the
//! ID-bitfield paper's hole-filling heuristic).
//!
//! Adjacency comes from sorting every triangle edge by its (smaller, larger) vertex pair, as
//! `tiling/adjacency.rs` does for triangles; two patches are neighbours if some edge has
//! triangles of both. Facing uses the patch's normal cone and bounding sphere (no apex): the
//! patch may face eye `e` unless every normal in the cone points more than 90° away from every
//! direction from the sphere towards `e`.
//! Cost: O(n log n) for n triangles, 16 bytes per triangle edge while building; the graph holds
//! 4 bytes per neighbour pair direction.

use crate::ooc::Mesh;
use crate::tiling::{Patch, PatchId};
use rayon::prelude::*;

/// Patch adjacency in compressed-row form.
#[derive(Debug)]
pub(crate) struct PatchGraph {
    start: Vec<usize>,
    neighbours: Vec<PatchId>,
}

impl PatchGraph {
    /// The edge adjacency of the patches `patch_of` assigns to `mesh`'s triangles.
    pub(crate) fn new(mesh: &Mesh, patch_of: &[PatchId], patch_count: u32) -> PatchGraph {
        let mut edges: Vec<(u64, PatchId)> = (0..mesh.triangle_count())
            .into_par_iter()
            .flat_map_iter(|t| {
                let [a, b, c] = mesh.triangle(t);
                let patch = patch_of[t as usize];
                [(a, b), (b, c), (c, a)].into_iter().map(move |(u, v)| {
                    let key = (u64::from(u.min(v)) << 32) | u64::from(u.max(v));
                    (key, patch)
                })
            })
            .collect();
        edges.par_sort_unstable();
        edges.dedup();
        let mut pairs: Vec<(PatchId, PatchId)> = Vec::new();
        for run in edges.chunk_by(|x, y| x.0 == y.0) {
            for (i, &(_, p)) in run.iter().enumerate() {
                for &(_, q) in &run[i + 1..] {
                    pairs.extend([(p, q), (q, p)]);
                }
            }
        }
        pairs.par_sort_unstable();
        pairs.dedup();
        let mut start = vec![0; patch_count as usize + 1];
        for &(p, _) in &pairs {
            start[p as usize + 1] += 1;
        }
        for i in 0..patch_count as usize {
            start[i + 1] += start[i];
        }
        PatchGraph {
            start,
            neighbours: pairs.into_iter().map(|(_, q)| q).collect(),
        }
    }

    /// The patches sharing an edge with `p`, ascending.
    pub(crate) fn neighbours(&self, p: PatchId) -> &[PatchId] {
        &self.neighbours[self.start[p as usize]..self.start[p as usize + 1]]
    }
}

/// Whether some surface point of `patch` may face `eye` (normal within 90° of the direction
/// to the eye), judged from its bounding sphere and normal cone; errs towards `true`.
pub(crate) fn may_face(patch: &Patch, eye: [f64; 3]) -> bool {
    let axis = patch.cone_axis.map(f64::from);
    let axis_len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    if patch.cone_cos <= -1.0 || axis_len == 0.0 {
        return true;
    }
    let v: [f64; 3] = std::array::from_fn(|k| eye[k] - f64::from(patch.center[k]));
    let dist = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let r = f64::from(patch.radius);
    if dist <= r {
        return true;
    }
    let cos_theta = (axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2]) / (axis_len * dist);
    let theta = cos_theta.clamp(-1.0, 1.0).acos();
    let cone = f64::from(patch.cone_cos).clamp(-1.0, 1.0).acos();
    let spread = (r / dist).asin();
    theta - cone - spread < std::f64::consts::FRAC_PI_2
}

/// Whether every point of `patch` faces away from `eye`: [`may_face`] turned round, by the
/// same bound (angle to the eye beyond 90° plus the cone's half-angle plus the sphere's
/// angular radius) written without trigonometry, for the sampler's per-view steering of
/// hundreds of patches. Rounding may tip it either way at the boundary, so it only steers,
/// never decides a result.
pub(crate) fn faces_away(patch: &Patch, eye: [f64; 3]) -> bool {
    let cos_a = f64::from(patch.cone_cos);
    if cos_a <= 0.0 {
        return false;
    }
    let v: [f64; 3] = std::array::from_fn(|k| eye[k] - f64::from(patch.center[k]));
    let d2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    let r = f64::from(patch.radius);
    if d2 <= r * r {
        return false;
    }
    // With the half-angle α and the angular radius β (sin β = r / d): θ > 90° + α + β holds
    // when α + β ≤ 90° and cos θ < −sin(α + β) = −(sin α · cos β + cos α · sin β); the axis is
    // a unit vector, so `d · cos θ` is its dot product with `v`.
    let r_cos_b = (d2 - r * r).sqrt();
    let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
    let axis = patch.cone_axis.map(f64::from);
    let along = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2];
    cos_a * r_cos_b >= sin_a * r && along < -(sin_a * r_cos_b + cos_a * r)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn patch(cone_axis: [f32; 3], cone_cos: f32) -> Patch {
        Patch {
            first: 0,
            count: 1,
            area: 1.0,
            center: [0.0; 3],
            radius: 0.1,
            cone_axis,
            cone_cos,
        }
    }

    #[test]
    fn faces_away_agrees_with_may_face_away_from_the_boundary() {
        let mut rng = crate::test_kit::rng::Rng::new(12345);
        let mut next = || f64::from(rng.signed());
        for _ in 0..20_000 {
            let axis = [next(), next(), next()];
            let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
            let cos = next() as f32;
            let mut p = patch(axis.map(|a| (a / len) as f32), cos);
            p.radius = (next().abs() * 0.5) as f32;
            let eye = [next() * 4.0, next() * 4.0, next() * 4.0];
            let away = faces_away(&p, eye);
            // Either says the opposite of the other only where rounding could tip it.
            assert!(
                !(away && may_face(&p, eye)) || margin(&p, eye) < 1e-9,
                "{p:?} {eye:?}"
            );
            if !away && !may_face(&p, eye) {
                assert!(margin(&p, eye) < 1e-9, "{p:?} {eye:?}");
            }
        }
    }

    /// How far `eye` is from the boundary of [`may_face`]'s test, in radians.
    fn margin(p: &Patch, eye: [f64; 3]) -> f64 {
        let v: [f64; 3] = std::array::from_fn(|k| eye[k] - f64::from(p.center[k]));
        let d = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let a = p.cone_axis.map(f64::from);
        let theta = ((a[0] * v[0] + a[1] * v[1] + a[2] * v[2]) / d)
            .clamp(-1.0, 1.0)
            .acos();
        let cone = f64::from(p.cone_cos).acos();
        let spread = (f64::from(p.radius) / d).min(1.0).asin();
        (theta - cone - spread - std::f64::consts::FRAC_PI_2).abs()
    }

    #[test]
    fn a_flat_patch_faces_its_front_side_only() {
        let p = patch([0.0, 0.0, 1.0], 1.0);
        assert!(may_face(&p, [0.0, 0.0, 5.0]));
        assert!(may_face(&p, [5.0, 0.0, 0.01]));
        assert!(!may_face(&p, [0.0, 0.0, -5.0]));
        assert!(!may_face(&p, [5.0, 0.0, -1.0]));
        assert!(may_face(&patch([0.0; 3], 1.0), [0.0, 0.0, -5.0]));
        assert!(may_face(&patch([0.0, 0.0, 1.0], -1.0), [0.0, 0.0, -5.0]));
    }

    #[test]
    fn patches_sharing_an_edge_are_neighbours() {
        // A strip of four triangles in patches 0, 0, 1, 2 plus a lone triangle in patch 3.
        let positions = (0..8).map(|i| [i as f32, (i % 2) as f32, 0.0]).collect();
        let triangles = vec![[0, 1, 2], [1, 3, 2], [2, 3, 4], [3, 5, 4], [6, 7, 5]];
        let mesh = Mesh::from_memory("strip", positions, triangles).unwrap();
        let graph = PatchGraph::new(&mesh, &[0, 0, 1, 2, 3], 4);
        assert_eq!(graph.neighbours(0), &[1]);
        assert_eq!(graph.neighbours(1), &[0, 2]);
        assert_eq!(graph.neighbours(2), &[1]);
        assert_eq!(graph.neighbours(3), &[] as &[u32]);
    }
}
