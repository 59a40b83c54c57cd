//! Every direction from an eye in which the model lies: the renders behind eval's ideal
//! culling *without* the frustum (the patches visible from the eye in some direction), as
//! opposed to the ideal with the frustum (the patches the evaluation camera's own full render
//! shows).
//!
//! A `.pvis` answer does not depend on where the camera looks, so the culling of the answer
//! alone compares with what no direction from the eye shows. When the evaluation camera's
//! image already holds the whole mesh ([`frames_whole_mesh`]: every vertex inside the image,
//! in front of the near plane), its full render is that reference and nothing more is drawn;
//! that is every camera at the sampling distance or farther that looks at the centre.
//! Otherwise (a nearer eye, a turned look) [`surround_cameras`] cover the model's bounding
//! sphere as seen from the eye:
//! - one camera looking at the centre whose image the sphere's silhouette just fits, when the
//!   sphere's half-angle `θ = asin(R / d)` is at most 45°;
//! - else the faces of the world-axis-aligned cube map around the eye that can see the sphere
//!   (all six when the eye is inside it): 90° faces, aligned so that they tile every
//!   direction once.
//!
//! Each has the evaluation camera's angular pixel density at the image centre, and its near
//! plane, so that the reference samples directions as finely as the view it is compared with.
//! Cost: the single camera has `(tan θ / tan(fov / 2))²` times the evaluation's pixels (up to
//! 5.8× at 45°); a cube face `1 / tan²(fov / 2)` times (5.8× at the default 45°), three to six
//! faces.

use crate::ooc::Mesh;
use crate::sampler::{Camera, MAX_RESOLUTION};

/// How far (pixels) outside the image a vertex may lie and still count as framed: pixel
/// centres lie half a pixel inside, so a vertex within this margin adds no pixel the image
/// could show (the same margin as the frustum's, `frustum.rs`).
const FRAME_MARGIN_PX: f64 = super::frustum::MARGIN_PX;

/// Relative widening of the bounding sphere the surround must cover: far above the binary32
/// rounding of a stored radius, far below a pixel at any distance the cameras allow.
const RADIUS_SLACK: f64 = 1e-4;

/// Largest half-angle (degrees) of the bounding sphere covered by a single camera; beyond it
/// its image would grow past a cube face's.
const SINGLE_CAMERA_MAX_DEG: f64 = 45.0;

/// Whether every vertex of `mesh`'s triangles projects into `camera`'s image (within a
/// quarter pixel) and lies in front of its near plane: then the camera's full render shows
/// every patch visible from its eye in any direction (a vertex no triangle uses draws
/// nothing). Cost: one projection per triangle corner.
pub fn frames_whole_mesh(camera: &Camera, mesh: &Mesh) -> bool {
    let resolution = f64::from(camera.resolution());
    let (lo, hi) = (-FRAME_MARGIN_PX, resolution + FRAME_MARGIN_PX);
    let near = camera.near();
    (0..mesh.triangle_count()).all(|t| {
        mesh.triangle(t).into_iter().all(|v| {
            let [cx, cy, w] = camera.clip(mesh.position(v));
            w >= near && cx >= lo * w && cx <= hi * w && cy >= lo * w && cy <= hi * w
        })
    })
}

/// The largest image [`surround_cameras`] gives for `camera`: a cube face with `camera`'s
/// pixel density (`resolution / tan(fov / 2)`), at most [`MAX_RESOLUTION`].
pub fn surround_resolution(camera: &Camera) -> u32 {
    density_resolution(camera, 1.0)
}

/// Cameras at `camera`'s eye (rounded to binary32, as the query's eye is) that together see
/// every direction in which the sphere of `radius` around `center` lies (see the module
/// documentation), with `camera`'s pixel density and near plane.
pub fn surround_cameras(camera: &Camera, center: [f32; 3], radius: f32) -> Vec<Camera> {
    let eye = camera.eye().map(|c| c as f32);
    let to_center: [f64; 3] = std::array::from_fn(|k| f64::from(center[k]) - f64::from(eye[k]));
    let d = to_center.iter().map(|c| c * c).sum::<f64>().sqrt();
    let r = f64::from(radius) * (1.0 + RADIUS_SLACK);
    let near = camera.near();
    let outside = d > r && eye != center;
    let theta = if outside { (r / d).asin() } else { 0.0 };
    if outside && theta.to_degrees() <= SINGLE_CAMERA_MAX_DEG {
        let fov = (2.0 * theta.to_degrees()) as f32;
        let resolution = density_resolution(camera, theta.tan());
        return vec![Camera::look_at(eye, center, fov, resolution).with_near(near)];
    }
    // The cube's faces along ±X, ±Y, ±Z. A face sees directions within atan(√2) of its axis
    // (its corners), so it can see the sphere only if its axis lies within θ + atan(√2) of
    // the direction to the centre.
    let reach = theta + std::f64::consts::SQRT_2.atan();
    let resolution = surround_resolution(camera);
    // Far enough that the target differs from the eye in binary32 along exactly one axis.
    let step = (d + r).max(1.0) as f32 * 2.0;
    let mut cameras = Vec::with_capacity(6);
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let sees = !outside || sign as f64 * to_center[axis] / d > reach.cos();
            if !sees {
                continue;
            }
            let mut target = eye;
            target[axis] += sign * step;
            if target == eye {
                // An eye beyond 2^24 units along this axis: no binary32 target ahead of it.
                target[axis] = sign * f32::MAX;
            }
            cameras.push(Camera::look_at(eye, target, 90.0, resolution).with_near(near));
        }
    }
    cameras
}

/// The resolution that gives an image reaching `tan_half` (tangent of its half field of view)
/// `camera`'s pixels per unit of tangent at the image centre, rounded up, at most
/// [`MAX_RESOLUTION`].
fn density_resolution(camera: &Camera, tan_half: f64) -> u32 {
    let camera_tan = (camera.fov_deg().to_radians() * 0.5).tan();
    let pixels = f64::from(camera.resolution()) * tan_half / camera_tan;
    (pixels.ceil() as u32).clamp(1, MAX_RESOLUTION)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether some camera's image holds `p` in front of its near plane.
    fn seen(cameras: &[Camera], p: [f32; 3]) -> bool {
        cameras.iter().any(|c| {
            let [cx, cy, w] = c.clip(p);
            let edge = f64::from(c.resolution()) * w;
            w >= c.near() && (0.0..=edge).contains(&cx) && (0.0..=edge).contains(&cy)
        })
    }

    /// Points on the sphere of `radius` around `center`: a Fibonacci lattice.
    fn sphere_points(center: [f32; 3], radius: f32) -> Vec<[f32; 3]> {
        let n = 2000;
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let phi = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
                let s = (1.0 - z * z).sqrt();
                let d = [s * phi.cos(), s * phi.sin(), z];
                std::array::from_fn(|k| center[k] + radius * d[k] as f32)
            })
            .collect()
    }

    #[test]
    fn the_surround_sees_the_whole_sphere_from_far_near_and_inside() {
        let center = [1.0, -2.0, 0.5];
        let radius = 2.0;
        // Distances over the radius: one camera (2.61: the sampling distance; 1.5), the cube
        // (1.18: 0.45 of the sampling distance; 1.02) and inside (0.5).
        for (k, faces) in [(2.61, 1..=1), (1.5, 1..=1), (1.18, 3..=5), (1.02, 3..=6)]
            .into_iter()
            .chain([(0.5, 6..=6)])
        {
            for dir in [[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.48, -0.6, 0.64]] {
                let eye: [f32; 3] = std::array::from_fn(|i| center[i] + k * radius * dir[i]);
                let camera = Camera::look_at(eye, center, 45.0, 64);
                let cameras = surround_cameras(&camera, center, radius);
                assert!(
                    faces.contains(&cameras.len()),
                    "{k} {dir:?}: {}",
                    cameras.len()
                );
                for p in sphere_points(center, radius) {
                    // Inside, every point; outside, those the eye can see (in front of the
                    // sphere's tangent plane through p).
                    let normal: [f32; 3] = std::array::from_fn(|i| p[i] - center[i]);
                    let facing: f32 = (0..3).map(|i| normal[i] * (eye[i] - p[i])).sum();
                    if k > 1.0 && facing < 0.0 {
                        continue;
                    }
                    assert!(seen(&cameras, p), "{k} {dir:?}: {p:?}");
                }
                // Same density at the image centre: a cube face is 1 / tan(22.5°) = 2.414×
                // the 64 px camera.
                let widest = cameras.iter().map(Camera::resolution).max().unwrap();
                assert!(widest <= surround_resolution(&camera), "{k}");
                if k < 1.4 {
                    assert_eq!(widest, 155);
                }
            }
        }
    }

    #[test]
    fn a_camera_at_the_sampling_distance_frames_the_mesh_a_nearer_one_does_not() {
        // Two triangles spanning a tilted box.
        let mesh = Mesh::from_memory(
            "box",
            vec![
                [0.0, 0.0, 0.0],
                [2.0, 0.5, 0.0],
                [0.0, 1.0, 1.5],
                [1.5, -1.0, 1.0],
            ],
            vec![[0, 1, 2], [1, 3, 2]],
        )
        .unwrap();
        let params = crate::sampler::SamplingParams::for_mesh(&mesh, 0, 64, 45.0);
        let at = |scale: f32| {
            let p = crate::sampler::SamplingParams {
                radius: params.radius * scale,
                ..params
            };
            Camera::sampling(&p, [0.3, 0.5, 0.8])
        };
        assert!(frames_whole_mesh(&at(1.0), &mesh));
        assert!(frames_whole_mesh(&at(1.5), &mesh));
        assert!(!frames_whole_mesh(&at(0.8), &mesh));
        // The surround at the sampling distance is the camera itself, give or take rounding.
        let s = surround_cameras(&at(1.0), params.center, params.radius);
        assert_eq!(s.len(), 1);
        assert!((s[0].fov_deg() - 45.0).abs() < 0.05 && s[0].resolution() == 65);
    }
}
