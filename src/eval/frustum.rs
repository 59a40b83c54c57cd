//! The view frustum of an evaluation camera, for the culling figures "with the frustum": the
//! reader's [`Frustum`] whose planes hold every point the rasterizer can draw, so that the
//! frustum only ever drops patches that draw no pixel.
//!
//! The rasterizer draws a point only where its clip coordinates `(cx, cy, w)`
//! ([`Camera::clip`]) fall in the image (`0 ≤ cx/w ≤ resolution`, likewise `cy`, pixel centres
//! half a pixel inside) and in front of the near plane (`w ≥ near`); there is no far plane. The
//! planes here are those bounds widened by [`MARGIN_PX`] a side and the near plane moved to
//! half its depth, in binary64, then rounded to binary32: the widening is thousands of times
//! the planes' rounding and the binary32 snapping of vertices. Cost: a few dozen flops.

use crate::runtime::Frustum;
use crate::sampler::Camera;

/// How far (pixels) each side plane lies outside the image: far more than rounding, far less
/// than a pixel, so the figures are the frustum's and not the margin's.
pub(super) const MARGIN_PX: f64 = 0.25;

/// The frustum of everything `camera` can draw, slightly widened (see the module
/// documentation); a plane `[0, 0, 0, 1]` stands for the absent far plane.
pub fn camera_frustum(camera: &Camera) -> Frustum {
    let (r, u, f, eye) = (camera.right(), camera.up(), camera.forward(), camera.eye());
    let res = f64::from(camera.resolution());
    let half = res * 0.5;
    let scale = half / (camera.fov_deg().to_radians() * 0.5).tan();
    // `w = f·(p − eye)`, `cx = scale·r·(p − eye) + half·w`, `cy = half·w − scale·u·(p − eye)`.
    let side = |a: f64, b: [f64; 3]| -> [f64; 3] { std::array::from_fn(|k| a * f[k] + b[k]) };
    let sr = r.map(|c| scale * c);
    let su = u.map(|c| scale * c);
    let (lo, hi) = (half + MARGIN_PX, res + MARGIN_PX - half);
    let normals = [
        side(lo, sr),             // cx + m·w ≥ 0
        side(hi, sr.map(|c| -c)), // (res + m)·w − cx ≥ 0
        side(lo, su.map(|c| -c)), // cy + m·w ≥ 0
        side(hi, su),             // (res + m)·w − cy ≥ 0
        f,                        // w − near / 2 ≥ 0
    ];
    let offsets = [0.0, 0.0, 0.0, 0.0, -0.5 * camera.near()];
    let mut planes = [[0.0, 0.0, 0.0, 1.0f32]; 6];
    for (plane, (n, o)) in planes.iter_mut().zip(normals.iter().zip(offsets)) {
        let d = o - (n[0] * eye[0] + n[1] * eye[1] + n[2] * eye[2]);
        *plane = [n[0] as f32, n[1] as f32, n[2] as f32, d as f32];
    }
    Frustum::from_planes(planes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_frustum_holds_the_image_and_nothing_far_beside_it() {
        let camera = Camera::look_at([0.0, 0.0, 10.0], [0.0; 3], 60.0, 64);
        let f = camera_frustum(&camera);
        // The target, and points just inside each image edge at depth 10.
        let edge = 10.0 * (30f32).to_radians().tan();
        assert!(f.keeps([0.0; 3], 0.0));
        for p in [
            [0.99 * edge, 0.0, 0.0],
            [-0.99 * edge, 0.0, 0.0],
            [0.0, 0.99 * edge, 0.0],
        ] {
            assert!(f.keeps(p, 0.0), "{p:?}");
        }
        for (p, reach) in [
            ([1.05 * edge, 0.0, 0.0], 0.2 * edge),
            ([0.0, -1.05 * edge, 0.0], 0.2 * edge),
            // Behind the eye; a sphere reaching half a unit in front of it is kept.
            ([0.0, 0.0, 12.0], 2.5),
        ] {
            assert!(!f.keeps(p, 0.0), "{p:?}");
            assert!(f.keeps(p, reach), "{p:?}");
        }
        // No far plane.
        assert!(f.keeps([0.0, 0.0, -1e6], 0.0));
    }
}
