//! The frame a bake tiles and samples in: the mesh's own coordinates, or coordinates
//! relative to its bounds where binary32 cameras cannot handle them.
//!
//! The sampler snaps vertices through a binary32 transform of the coordinates it is given
//! (`sampler::raster`), and the file stores its camera in binary32 (spec, CAMR). In the
//! mesh's own coordinates that works, and gives what bakes have always given bit for bit,
//! while the bounding radius `R` lies in [2⁻⁶⁴, 2⁶⁴] and the centre lies within 2¹⁰·`R` of
//! the origin on every axis: a cube bakes alike from ×1e-37 to ×1e30 and moved to 1e5 (37.9 %
//! of its patches visible per view at level 2, 128 px). Beyond that range the transform's
//! products overflow and its depths lose their bits (×1e34 gave 51 %, ×1e37 13.5 %, ×1e38
//! 4 %), denormals lose theirs (×1e-40: 0 %), and far from the origin the rounding swamps a
//! small model (a triangle at x = 1e30 put the sampling eye on its target). There the bake
//! works on a copy of the mesh moved by its bounding-box centre and scaled by the power of
//! two that brings `R` into [1, 2) ([`Mesh::transformed`], in `f64`, rounded once): tiling
//! and sampling see a well-scaled model, and the file gets the camera and patch records of
//! the original mesh, computed as a bake in its own frame computes them.
//!
//! Refused with one line: a mesh whose bounding radius or camera distance
//! (`R / sin(fov / 2)`) is not a finite binary32 number, which the file could not store.
//! Cost: nothing inside the range; outside it, a pass over the vertices, a copy of the mesh
//! in a temporary file, and the patch records computed again.

use super::BakeError;
use crate::ooc::{Mesh, MeshError, MeshErrorKind};
use crate::sampler::bounding_sphere_f64;
use crate::tiling::{Patch, Tiling, patch_bounds};
use crate::visibility::SamplingParams;
use rayon::prelude::*;

/// Bounding radii (estimated from the bounding box) inside `[2^-LOG2_RADIUS_RANGE,
/// 2^LOG2_RADIUS_RANGE]` are sampled in the mesh's own coordinates: far inside where a unit
/// cube still bakes alike (×1e-37 to ×1e30).
const LOG2_RADIUS_RANGE: i32 = 64;

/// A centre farther from the origin than this many radii (on any axis) is moved to the
/// origin: the transform's rounding there stays below a quarter pixel at 8192 px.
const MAX_CENTRE_IN_RADII: f64 = 1024.0;

/// How the working copy's coordinates follow from the mesh's: `(p - origin) · scale`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Frame {
    origin: [f64; 3],
    scale: f64,
}

impl Frame {
    /// The frame `mesh` is baked in at a field of view of `fov_deg`: `None` for its own
    /// coordinates, or the error that refuses it.
    pub(crate) fn choose(mesh: &Mesh, fov_deg: f32) -> Result<Option<Frame>, BakeError> {
        let b = mesh.bounds();
        let half: [f64; 3] =
            std::array::from_fn(|k| (f64::from(b.max[k]) - f64::from(b.min[k])) * 0.5);
        let centre: [f64; 3] =
            std::array::from_fn(|k| (f64::from(b.max[k]) + f64::from(b.min[k])) * 0.5);
        // Within √3 of the bounding sphere's radius: enough for a range of powers of two.
        let estimate = half.iter().map(|h| h * h).sum::<f64>().sqrt();
        let range = 2f64.powi(-LOG2_RADIUS_RANGE)..=2f64.powi(LOG2_RADIUS_RANGE);
        let near_origin = centre
            .iter()
            .all(|c| c.abs() <= MAX_CENTRE_IN_RADII * estimate);
        if range.contains(&estimate) && near_origin {
            return Ok(None);
        }
        let (center, radius) = bounding_sphere_f64(mesh);
        if radius <= 0.0 {
            // Every vertex at one point: nothing to frame (the bake refuses it as degenerate).
            return Ok(None);
        }
        let params = SamplingParams {
            level: 0,
            resolution: 1,
            fov_deg,
            center,
            radius: round_up(radius),
        };
        if !(params.radius.is_finite() && params.distance().is_finite()) {
            let sin = (f64::from(fov_deg).to_radians() * 0.5).sin();
            return Err(BakeError::Mesh(MeshError::whole(
                mesh.path(),
                MeshErrorKind::OutOfRange,
                format!(
                    "the model's bounding sphere (radius {radius:.3e}) puts the sampling cameras \
                     {:.3e} from its centre, past the largest binary32 number ({:.3e}) a .pvis \
                     stores; scale the model to a radius below {:.3e} (at --fov {fov_deg})",
                    radius / sin,
                    f32::MAX,
                    f64::from(f32::MAX) * sin
                ),
            )));
        }
        Ok(Some(Frame {
            origin: center.map(f64::from),
            scale: 2f64.powi(-(radius.log2().floor() as i32)),
        }))
    }

    /// `mesh` in this frame.
    pub(crate) fn apply(&self, mesh: &Mesh) -> Result<Mesh, BakeError> {
        Ok(mesh.transformed(self.origin, self.scale)?)
    }

    /// The file's camera for `mesh` (the original): `params` (sampled in this frame) with
    /// the original's bounding sphere, as a bake in its own frame would store it.
    pub(crate) fn world_params(mesh: &Mesh, params: SamplingParams) -> SamplingParams {
        let (center, radius) = bounding_sphere_f64(mesh);
        SamplingParams {
            center,
            radius: round_up(radius),
            ..params
        }
    }

    /// `tiling` (made in this frame) with every patch's area, bounding sphere and normal
    /// cone computed from `mesh` (the original), as a tiling of it would compute them.
    pub(crate) fn world_tiling(mesh: &Mesh, mut tiling: Tiling) -> Tiling {
        tiling.patches = Frame::world_patches(mesh, &tiling);
        tiling
    }

    /// The patch records of [`Frame::world_tiling`] alone.
    pub(crate) fn world_patches(mesh: &Mesh, tiling: &Tiling) -> Vec<Patch> {
        let order: &[u32] = &tiling.order;
        tiling
            .patches
            .par_iter()
            .map(|p| {
                let range = p.first as usize..(p.first + p.count) as usize;
                patch_bounds(mesh, &order[range], p.first).0
            })
            .collect()
    }
}

/// The smallest `f32` not below `x` (infinity past the largest).
fn round_up(x: f64) -> f32 {
    let r = x as f32;
    if f64::from(r) < x { r.next_up() } else { r }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube(scale: f64, offset: f64) -> Mesh {
        let positions = (0..8)
            .map(|i| {
                std::array::from_fn(|k| ((f64::from(i >> k & 1) - 0.5) * scale + offset) as f32)
            })
            .collect();
        let triangles = vec![[0, 1, 2], [1, 3, 2], [4, 6, 5], [5, 6, 7]];
        Mesh::from_memory("cube", positions, triangles).unwrap()
    }

    #[test]
    fn ordinary_meshes_keep_their_frame() {
        for (scale, offset) in [(1.0, 0.0), (1e-15, 0.0), (1e15, 0.0), (1.0, 500.0)] {
            assert_eq!(Frame::choose(&cube(scale, offset), 45.0).unwrap(), None);
        }
    }

    #[test]
    fn extreme_meshes_are_moved_and_scaled_to_a_unit_radius() {
        for (scale, offset) in [(1e37, 0.0), (1e-40, 0.0), (1.0, 1e4), (1e25, 1e30)] {
            let mesh = cube(scale, offset);
            let frame = Frame::choose(&mesh, 45.0)
                .unwrap()
                .expect("a frame of its own");
            let local = frame.apply(&mesh).unwrap();
            let (center, radius) = bounding_sphere_f64(&local);
            assert!((1.0..2.0).contains(&radius), "{scale} {offset}: {radius}");
            assert!(center.iter().all(|c| c.abs() < 1e-6), "{center:?}");
            // The file's camera is the original's.
            let params = Frame::world_params(&mesh, SamplingParams::for_mesh(&local, 2, 64, 45.0));
            assert!(params.radius.is_finite() && params.distance().is_finite());
            assert_eq!(params.center, crate::sampler::bounding_sphere(&mesh).0);
        }
    }

    #[test]
    fn a_camera_past_f32_is_refused() {
        let err = Frame::choose(&cube(4e38, 0.0), 45.0)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("binary32") && err.contains("scale the model"),
            "{err}"
        );
        // Radius 1.7e38 fits, but a camera at 4.5e38 does not.
        assert!(Frame::choose(&cube(2e38, 0.0), 45.0).is_err());
    }
}
