//! `patchvis query`'s camera flags → the reader's [`Frustum`]: an OpenGL-style look-at camera
//! (`--eye`, `--look-at`, `--fov`, `--aspect`, `--near`, `--far`) or a view-projection matrix
//! given as 16 numbers (`--view-proj`, with its `--depth` convention).
//!
//! The look-at camera is the usual right-handed `lookAt` times `perspective` (vertical field of
//! view, the camera looking down its −Z), computed in `f64` and rounded to `f32` once, so the
//! printed matrix is exactly what the reader's plane extraction sees. World up is `+Y`, or `+Z`
//! when the view is within 2.6° of vertical. No far plane by default (an infinite
//! perspective), so only the four sides and the near plane cull.

use super::UsageError;
use patchvis::runtime::{DepthRange, Frustum};

/// A look-at camera of `query`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LookAt {
    /// Eye position, model space.
    pub eye: [f32; 3],
    /// The point looked at.
    pub target: [f32; 3],
    /// Vertical field of view, degrees.
    pub fov_deg: f32,
    /// Width over height.
    pub aspect: f32,
    /// Near-plane distance; `None` is 1/1000 of the eye–target distance.
    pub near: Option<f32>,
    /// Far-plane distance; `None` is no far plane.
    pub far: Option<f32>,
}

/// Above this `|forward · Y|` the camera takes `+Z` as world up (as the sampling cameras do).
const UP_SWITCH_COS: f64 = 0.999;

impl LookAt {
    /// The column-major OpenGL view-projection matrix (`−w ≤ z ≤ w`), or why the camera is
    /// not one.
    pub fn view_projection(&self) -> Result<[f32; 16], UsageError> {
        let usage = |m: String| Err(UsageError(m));
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return usage(format!(
                "--fov {}: expected degrees in (0, 180)",
                self.fov_deg
            ));
        }
        if !(self.aspect > 0.0 && self.aspect.is_finite()) {
            return usage(format!(
                "--aspect {}: expected a positive number",
                self.aspect
            ));
        }
        let eye = self.eye.map(f64::from);
        let to = [0, 1, 2].map(|i| f64::from(self.target[i]) - eye[i]);
        let distance = dot(to, to).sqrt();
        if distance == 0.0 {
            return usage("--look-at: the point looked at is the eye".into());
        }
        let near = self.near.map_or(1e-3 * distance, f64::from);
        if !(near > 0.0 && near.is_finite()) {
            return usage(format!("--near {near}: expected a positive distance"));
        }
        if let Some(far) = self.far
            && !(f64::from(far) > near && far.is_finite())
        {
            return usage(format!(
                "--far {far}: expected a distance beyond --near ({near})"
            ));
        }
        let f = to.map(|c| c / distance);
        let up = if f[1].abs() > UP_SWITCH_COS {
            [0.0, 0.0, 1.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let s = normalize(cross(f, up));
        let u = cross(s, f);
        let view = [
            s[0],
            u[0],
            -f[0],
            0.0,
            s[1],
            u[1],
            -f[1],
            0.0,
            s[2],
            u[2],
            -f[2],
            0.0,
            -dot(s, eye),
            -dot(u, eye),
            dot(f, eye),
            1.0,
        ];
        let g = 1.0 / (f64::from(self.fov_deg).to_radians() / 2.0).tan();
        // Depth row: (far + near)/(near − far), 2·far·near/(near − far); its limit −1, −2·near
        // without a far plane.
        let (c, e) = match self.far.map(f64::from) {
            Some(far) => ((far + near) / (near - far), 2.0 * far * near / (near - far)),
            None => (-1.0, -2.0 * near),
        };
        let projection = [
            g / f64::from(self.aspect),
            0.0,
            0.0,
            0.0,
            0.0,
            g,
            0.0,
            0.0,
            0.0,
            0.0,
            c,
            -1.0,
            0.0,
            0.0,
            e,
            0.0,
        ];
        Ok(multiply(&projection, &view).map(|v| v as f32))
    }

    /// The camera's frustum.
    pub fn frustum(&self) -> Result<Frustum, UsageError> {
        Ok(Frustum::from_view_projection(
            &self.view_projection()?,
            DepthRange::NegativeOneToOne,
        ))
    }
}

/// Column-major `a · b`.
fn multiply(a: &[f64; 16], b: &[f64; 16]) -> [f64; 16] {
    std::array::from_fn(|i| {
        let (row, col) = (i % 4, i / 4);
        (0..4).map(|k| a[4 * k + row] * b[4 * col + k]).sum()
    })
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    a.map(|c| c / l)
}

/// `--view-proj`: 16 comma-separated finite numbers, column-major.
pub fn parse_matrix(s: &str) -> Result<[f32; 16], String> {
    let values = s
        .split(',')
        .map(|t| match t.trim().parse::<f32>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!("expected a finite number, found '{}'", t.trim())),
        })
        .collect::<Result<Vec<f32>, String>>()?;
    <[f32; 16]>::try_from(values.as_slice()).map_err(|_| {
        format!(
            "expected 16 comma-separated numbers (column-major 4×4), found {}",
            values.len()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Clip coordinates of `p` under column-major `m`.
    fn clip(m: &[f32; 16], p: [f32; 3]) -> [f32; 4] {
        std::array::from_fn(|i| m[i] * p[0] + m[4 + i] * p[1] + m[8 + i] * p[2] + m[12 + i])
    }

    #[test]
    fn look_at_maps_the_target_to_the_centre_and_the_near_plane_to_minus_one() {
        let camera = LookAt {
            eye: [1.0, 2.0, 10.0],
            target: [1.0, 2.0, 0.0],
            fov_deg: 90.0,
            aspect: 2.0,
            near: Some(1.0),
            far: Some(100.0),
        };
        let m = camera.view_projection().unwrap();
        let c = clip(&m, [1.0, 2.0, 0.0]);
        assert!(c[0].abs() < 1e-5 && c[1].abs() < 1e-5 && (c[3] - 10.0).abs() < 1e-5);
        let near = clip(&m, [1.0, 2.0, 9.0]);
        assert!((near[2] / near[3] + 1.0).abs() < 1e-5);
        let far = clip(&m, [1.0, 2.0, -90.0]);
        assert!((far[2] / far[3] - 1.0).abs() < 1e-4);
        // 90° vertically: y = ±depth is the top and bottom edge; aspect 2 doubles x.
        let top = clip(&m, [1.0, 7.0, 5.0]);
        assert!((top[1] / top[3] - 1.0).abs() < 1e-5);
        let right = clip(&m, [11.0, 2.0, 5.0]);
        assert!((right[0] / right[3] - 1.0).abs() < 1e-5);
        let f = camera.frustum().unwrap();
        assert!(f.keeps([1.0, 2.0, 0.0], 0.1));
        assert!(!f.keeps([1.0, 2.0, 20.0], 1.0));
        assert!(!f.keeps([30.0, 2.0, 0.0], 1.0));
    }

    #[test]
    fn bad_cameras_and_matrices_are_usage_errors() {
        let ok = LookAt {
            eye: [0.0; 3],
            target: [0.0, 0.0, -1.0],
            fov_deg: 45.0,
            aspect: 1.0,
            near: None,
            far: None,
        };
        assert!(ok.view_projection().is_ok());
        for bad in [
            LookAt {
                fov_deg: 180.0,
                ..ok
            },
            LookAt { aspect: 0.0, ..ok },
            LookAt {
                near: Some(-1.0),
                ..ok
            },
            LookAt {
                far: Some(0.0),
                ..ok
            },
            LookAt {
                target: [0.0; 3],
                ..ok
            },
        ] {
            assert!(bad.view_projection().is_err(), "{bad:?}");
        }
        assert!(parse_matrix("1,2,3").unwrap_err().contains("found 3"));
        assert!(parse_matrix(&["0"; 16].join(",")).is_ok());
        assert!(parse_matrix(&["nan"; 16].join(",")).is_err());
    }
}
