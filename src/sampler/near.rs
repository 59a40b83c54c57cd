//! Near views: the cameras of a view on a sampling shell ([`super::SamplingOptions::shell`]),
//! whose row holds every patch visible from its eye in any direction.
//!
//! Convention (normative; the spec's informative "Cameras" section cites it). A near view `v`
//! of a shell at distance `r` (binary32, `R <= r` where `R = params.radius`) has its eye at
//! `center + d · r` with `d = sphere::direction(v)` normalised, evaluated in binary64 as for
//! the sampling views ([`Camera::sampling`]). With `θ = asin(R / r)` (binary64, from the
//! binary32 values), its cameras are:
//! - `θ <= 45°`: one camera looking at `center` ([`Camera::look_at`]'s basis) with full field
//!   of view `2θ`: the bounding sphere's silhouette touches the image edges, as it does for
//!   the sampling views, whose distance is `R / sin(fov / 2)`;
//! - `θ > 45°`: a cube map turned to face the centre, five faces of 90°. The front face looks
//!   at `center` (basis `right r`, `up u`, `forward f` as [`Camera::look_at`] chooses it); the
//!   four side faces share the eye and have `[forward, up]` = `[r, u]`, `[−r, u]`, `[u, −f]`,
//!   `[−u, f]`, in that order, and `right = forward × up`. The back face is left out: every
//!   direction from the eye towards the bounding sphere makes an angle of at most `θ <= 90°`
//!   with `f`, so none lies in the back face's region (where `−f` is the nearest axis).
//!
//! Every camera has `params.resolution`² pixels and its near plane at `NEAR_FRACTION · r`.
//! The view's row is the OR of its cameras' rows, each resolved as a sampling view's is
//! (`min_pixels`, conservative rasterization, `--dilate` from the shared eye, the
//! always-visible patches, and the probe pass per camera). Cost: one render per camera, so up
//! to five times a sampling view's pixels.

use super::SamplingParams;
use super::camera::{Camera, NEAR_FRACTION, widen};

/// Most cameras a near view renders: the front and four side faces of its cube map.
pub const MAX_NEAR_CAMERAS: usize = 5;

/// Largest half-angle (`asin(R / r)`, radians) a near view covers with a single camera; past
/// it a single frustum would grow wider than a cube face, whose pixels stretch least.
const SINGLE_CAMERA_MAX_HALF_ANGLE: f64 = std::f64::consts::FRAC_PI_4;

/// The cameras of one near view: one, or a cube map's five faces (see the module
/// documentation). Dereferences to the slice of cameras.
#[derive(Clone, Copy, Debug)]
pub struct NearCameras {
    cameras: [Camera; MAX_NEAR_CAMERAS],
    count: usize,
}

impl std::ops::Deref for NearCameras {
    type Target = [Camera];
    fn deref(&self) -> &[Camera] {
        &self.cameras[..self.count]
    }
}

/// How many cameras each near view of a shell at `distance` renders: 1 or 5.
///
/// Panics (caller contract) as [`near_cameras`].
pub fn near_camera_count(params: &SamplingParams, distance: f32) -> usize {
    if half_angle(params, distance) <= SINGLE_CAMERA_MAX_HALF_ANGLE {
        1
    } else {
        MAX_NEAR_CAMERAS
    }
}

/// The cameras of the near view whose eye lies in `direction` (from `params.center`; a sphere
/// vertex's, `sphere::direction`, or a finer view's, `finer.rs`) on a shell at `distance`.
///
/// Panics (caller contract) unless `distance` is finite and at least `params.radius`, and
/// `params.radius` is positive and finite.
pub fn near_cameras(params: &SamplingParams, direction: [f32; 3], distance: f32) -> NearCameras {
    let theta = half_angle(params, distance);
    let d = super::camera::normalize(widen(direction));
    let center = widen(params.center);
    let r = f64::from(distance);
    let eye = [
        center[0] + d[0] * r,
        center[1] + d[1] * r,
        center[2] + d[2] * r,
    ];
    let resolution = params.resolution;
    if theta <= SINGLE_CAMERA_MAX_HALF_ANGLE {
        let camera = Camera::look_at_f64(eye, center, 2.0 * theta.to_degrees(), resolution);
        return NearCameras {
            cameras: [camera; MAX_NEAR_CAMERAS],
            count: 1,
        };
    }
    let front = Camera::look_at_f64(eye, center, 90.0, resolution);
    let (rt, u, f) = (front.right(), front.up(), front.forward());
    let neg = |a: [f64; 3]| a.map(|x| -x);
    let near = NEAR_FRACTION * r;
    let face = |forward: [f64; 3], up: [f64; 3]| {
        let right = super::camera::cross(forward, up);
        Camera::from_basis(eye, [right, up, forward], 90.0, resolution, near)
    };
    NearCameras {
        cameras: [
            front.with_near(near),
            face(rt, u),
            face(neg(rt), u),
            face(u, neg(f)),
            face(neg(u), f),
        ],
        count: MAX_NEAR_CAMERAS,
    }
}

/// `asin(R / r)`: the half-angle the bounding sphere subtends from a near view's eye.
fn half_angle(params: &SamplingParams, distance: f32) -> f64 {
    assert!(
        params.radius > 0.0 && params.radius.is_finite(),
        "sampling radius must be positive and finite, got {}",
        params.radius
    );
    assert!(
        distance.is_finite() && distance >= params.radius,
        "a shell's distance must be finite and at least the bounding radius {}, got {distance}",
        params.radius
    );
    libm::asin(f64::from(params.radius) / f64::from(distance))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::camera::dot;

    fn params() -> SamplingParams {
        SamplingParams {
            level: 2,
            resolution: 64,
            fov_deg: 45.0,
            center: [3.0, -1.0, 20.0],
            radius: 2.0,
        }
    }

    /// A direction of the unit sphere from a pair of angles.
    fn unit(a: f64, b: f64) -> [f64; 3] {
        [a.cos() * b.cos(), a.sin() * b.cos(), b.sin()]
    }

    /// Whether `camera` shows direction `dir` from its eye inside its image (pixel centres
    /// within the square, with `inset` pixels to spare).
    fn shows(camera: &Camera, dir: [f64; 3], inset: f64) -> bool {
        let (x, y, w) = (
            dot(dir, camera.right()),
            dot(dir, camera.up()),
            dot(dir, camera.forward()),
        );
        let half = f64::from(camera.resolution()) / 2.0;
        let k = half / (camera.fov_deg().to_radians() / 2.0).tan();
        w > 0.0 && (k * x / w).abs() <= half - inset && (k * y / w).abs() <= half - inset
    }

    #[test]
    fn the_cameras_cover_the_bounding_sphere_from_the_eye() {
        let p = params();
        for (factor, count) in [(1.0, 5), (1.1, 5), (1.4, 5), (1.5, 1), (2.0, 1), (2.6, 1)] {
            let r = p.radius * factor;
            assert_eq!(near_camera_count(&p, r), count, "{factor}");
            for view in 0..crate::sphere::view_count(p.level) {
                let cameras = near_cameras(&p, crate::sphere::direction(view), r);
                assert_eq!(cameras.len(), count);
                let eye = cameras[0].eye();
                let to_center: [f64; 3] = std::array::from_fn(|k| f64::from(p.center[k]) - eye[k]);
                let dist = dot(to_center, to_center).sqrt();
                assert!((dist - f64::from(r)).abs() < 1e-9 * dist, "{factor} {view}");
                for c in cameras.iter() {
                    assert_eq!(c.eye(), eye);
                    assert!((c.near() - NEAR_FRACTION * f64::from(r)).abs() < 1e-12);
                    let [rt, u, f] = [c.right(), c.up(), c.forward()];
                    for (a, b) in [(rt, u), (u, f), (f, rt)] {
                        assert!(dot(a, b).abs() < 1e-12);
                    }
                    let rf = super::super::camera::cross(f, u);
                    assert!(
                        (0..3).all(|k| (rf[k] - rt[k]).abs() < 1e-12),
                        "right = f × u"
                    );
                }
                // Every direction towards the bounding sphere shows in some camera; with one
                // camera, the sphere's silhouette touches the image edges.
                let axis = to_center.map(|x| x / dist);
                let sin = f64::from(p.radius) / dist;
                for i in 0..400 {
                    let dir = unit(i as f64 * 0.61, (i as f64 * 0.37).sin() * 1.5);
                    let towards = dot(dir, axis) >= (1.0 - sin * sin).sqrt() + 1e-9;
                    if towards {
                        // A direction on the edge between two faces may round out of both.
                        assert!(cameras.iter().any(|c| shows(c, dir, -1e-6)), "{factor} {i}");
                    }
                }
                if count == 1 {
                    // The silhouette touches the middle of each image edge.
                    let c = &cameras[0];
                    let theta = (f64::from(p.radius) / dist).asin();
                    for side in [c.right(), c.up(), c.right().map(|x| -x)] {
                        for (angle, shown) in [(theta - 1e-6, true), (theta + 1e-6, false)] {
                            let (s, co) = angle.sin_cos();
                            let dir = std::array::from_fn(|k| co * axis[k] + s * side[k]);
                            assert_eq!(shows(c, dir, 0.0), shown, "{factor} {angle}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn the_cube_faces_tile_without_overlap() {
        let p = params();
        let cameras = near_cameras(&p, crate::sphere::direction(7), p.radius * 1.1);
        let mut seen = 0;
        for i in 0..2000 {
            let dir = unit(i as f64 * 0.913, (i as f64 * 0.29).sin() * 1.55);
            let faces = cameras.iter().filter(|c| shows(c, dir, 1e-6)).count();
            assert!(faces <= 1, "{i}: in {faces} faces");
            seen += faces;
        }
        // Five of the six faces: about 5/6 of all directions.
        assert!((1500..1850).contains(&seen), "{seen}");
    }

    #[test]
    #[should_panic(expected = "at least the bounding radius")]
    fn a_shell_inside_the_bounding_sphere_is_a_caller_error() {
        near_cameras(&params(), crate::sphere::direction(0), 1.9);
    }
}
