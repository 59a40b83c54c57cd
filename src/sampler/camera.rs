//! Pinhole cameras for ID-buffer rendering: the sampling views on the bounding sphere and
//! general look-at cameras, and the world → homogeneous clip transform the rasterizer uses.
//!
//! Convention (normative; the spec's "Sampling cameras" section mirrors it):
//! - Sampling view `v` with unit direction `d = sphere::direction(v)`: eye
//!   `center + d · distance`, `distance = radius / sin(fov / 2)` evaluated in binary32
//!   ([`SamplingParams::distance`], the value the file stores), looking at `center`, so the
//!   bounding sphere's silhouette touches the image edges.
//! - Look-at basis: forward `f = normalize(target − eye)`; world up `+Y`, or `+Z` when
//!   `|f · Y| > 0.999`; right `r = normalize(f × up)`; up `u = r × f`.
//! - Symmetric perspective, square `resolution`² image, full field of view `fov` both ways.
//!   Pixel `(x, y)`: `x` grows along `r`, `y` grows downwards (row 0 is the top, along `+u`);
//!   pixel centres are at `(x + 0.5, y + 0.5)`.
//! - Near plane at `w = near` (view-space depth along `f`); by default
//!   `near = NEAR_FRACTION · |target − eye|`. No far plane.
//!
//! Setup and projection run in `f64` so that eyes far from the origin (scans in survey
//! coordinates) keep their precision; rasterization then works in fixed point.
//! Cost: setup is a few dozen flops; transforming a point is 3 subtractions and 9 multiply-adds.

use super::SamplingParams;

/// Largest image width/height, for baking and evaluating alike: one ID buffer per thread is
/// `resolution² × 8` bytes (512 MiB here). The fixed-point rasterizer would hold to 2^15
/// (see `raster.rs`).
pub const MAX_RESOLUTION: u32 = 1 << 13;

/// Default near-plane distance as a fraction of the eye–target distance. Small enough that a
/// sampling camera never clips the model for any field of view below ~175°, large enough that
/// `1/w` stays far from `f32` overflow.
pub const NEAR_FRACTION: f64 = 1e-3;

/// Above this `|forward · Y|` the camera takes `+Z` as world up, since `+Y` would give an
/// ill-conditioned right vector.
const UP_SWITCH_COS: f64 = 0.999;

/// A perspective camera producing a square image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    eye: [f64; 3],
    right: [f64; 3],
    up: [f64; 3],
    forward: [f64; 3],
    fov_deg: f64,
    resolution: u32,
    near: f64,
    /// `resolution / 2`.
    half: f64,
    /// `resolution / 2 / tan(fov / 2)`: pixels per unit of `x / w`.
    scale: f64,
    /// [`Camera::clip`] as three binary32 rows `[a₀, a₁, a₂, b]` (`c = a · p + b`), rounded
    /// from the binary64 transform once per camera: the transform vertices are snapped with.
    rows32: [[f32; 4]; 3],
}

impl Camera {
    /// A camera at `eye` looking at `target` with full field of view `fov_deg` (degrees) and a
    /// `resolution`² image; near plane `NEAR_FRACTION · |target − eye|`.
    ///
    /// Panics (caller contract) unless the inputs are finite, `eye != target`,
    /// `0 < fov_deg < 180` and `1 <= resolution <= MAX_RESOLUTION`.
    pub fn look_at(eye: [f32; 3], target: [f32; 3], fov_deg: f32, resolution: u32) -> Camera {
        Camera::look_at_f64(widen(eye), widen(target), fov_deg as f64, resolution)
    }

    /// The camera of a sampling view looking along `-direction` at `params.center` from
    /// `params.center + direction · distance` (direction need not be normalised).
    pub fn sampling(params: &SamplingParams, direction: [f32; 3]) -> Camera {
        let d = normalize(widen(direction));
        // The binary32 distance, because that is the value the file stores (spec § CAMR).
        let distance = params.distance() as f64;
        let center = widen(params.center);
        let eye = [
            center[0] + d[0] * distance,
            center[1] + d[1] * distance,
            center[2] + d[2] * distance,
        ];
        Camera::look_at_f64(eye, center, params.fov_deg as f64, params.resolution)
    }

    /// The camera of sampling view `view`: [`Camera::sampling`] with `sphere::direction(view)`.
    pub fn sampling_view(params: &SamplingParams, view: crate::sphere::ViewIndex) -> Camera {
        Camera::sampling(params, crate::sphere::direction(view))
    }

    /// The same camera with the near plane at view-space depth `near` (> 0).
    pub fn with_near(self, near: f64) -> Camera {
        assert!(
            near > 0.0 && near.is_finite(),
            "near plane must be > 0, got {near}"
        );
        Camera { near, ..self }
    }

    /// [`Camera::look_at`] in binary64.
    pub(crate) fn look_at_f64(
        eye: [f64; 3],
        target: [f64; 3],
        fov_deg: f64,
        resolution: u32,
    ) -> Camera {
        assert!(
            eye.iter().chain(&target).all(|c| c.is_finite()),
            "camera eye {eye:?} and target {target:?} must be finite"
        );
        let to_target = sub(target, eye);
        let distance = dot(to_target, to_target).sqrt();
        assert!(distance > 0.0, "camera eye and target coincide at {eye:?}");
        let forward = scale3(to_target, 1.0 / distance);
        let world_up = if forward[1].abs() > UP_SWITCH_COS {
            [0.0, 0.0, 1.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let right = normalize(cross(forward, world_up));
        let up = cross(right, forward);
        Camera::from_basis(
            eye,
            [right, up, forward],
            fov_deg,
            resolution,
            NEAR_FRACTION * distance,
        )
    }

    /// A camera at `eye` with the orthonormal basis `[right, up, forward]` (`right = forward ×
    /// up`), full field of view `fov_deg`, a `resolution`² image and the near plane at
    /// view-space depth `near`: [`Camera::look_at`]'s camera once its basis is chosen, and the
    /// turned faces of a near view's cube map (`near.rs`).
    pub(super) fn from_basis(
        eye: [f64; 3],
        [right, up, forward]: [[f64; 3]; 3],
        fov_deg: f64,
        resolution: u32,
        near: f64,
    ) -> Camera {
        assert!(
            fov_deg > 0.0 && fov_deg < 180.0,
            "field of view must be in (0, 180) degrees, got {fov_deg}"
        );
        assert!(
            (1..=MAX_RESOLUTION).contains(&resolution),
            "resolution must be in 1..={MAX_RESOLUTION}, got {resolution}"
        );
        assert!(
            near > 0.0 && near.is_finite(),
            "near plane must be > 0, got {near}"
        );
        let half = resolution as f64 * 0.5;
        let scale = half / (fov_deg.to_radians() * 0.5).tan();
        let axes = [
            std::array::from_fn(|k| scale * right[k] + half * forward[k]),
            std::array::from_fn(|k| half * forward[k] - scale * up[k]),
            forward,
        ];
        let rows32 = axes.map(|a: [f64; 3]| {
            let b = -dot(a, eye);
            [a[0] as f32, a[1] as f32, a[2] as f32, b as f32]
        });
        Camera {
            eye,
            right,
            up,
            forward,
            fov_deg,
            resolution,
            near,
            half,
            scale,
            rows32,
        }
    }

    /// About how many pixels one world unit spans at the view depth of `p` (along
    /// [`Camera::forward`]; `p` must lie in front of the eye).
    pub(crate) fn pixels_per_unit_at(&self, p: [f32; 3]) -> f64 {
        self.scale / dot(sub(widen(p), self.eye), self.forward)
    }

    /// Pixels one world unit spans at view depth 1.
    pub(crate) fn scale(&self) -> f64 {
        self.scale
    }

    /// Image width and height in pixels.
    pub fn resolution(&self) -> u32 {
        self.resolution
    }
    /// Full field of view in degrees.
    pub fn fov_deg(&self) -> f64 {
        self.fov_deg
    }
    /// Eye position.
    pub fn eye(&self) -> [f64; 3] {
        self.eye
    }
    /// Unit viewing direction `f`.
    pub fn forward(&self) -> [f64; 3] {
        self.forward
    }
    /// Unit right vector `r` (image `x` grows along it).
    pub fn right(&self) -> [f64; 3] {
        self.right
    }
    /// Unit up vector `u` (image `y` grows against it).
    pub fn up(&self) -> [f64; 3] {
        self.up
    }
    /// View-space depth of the near plane.
    pub fn near(&self) -> f64 {
        self.near
    }

    /// Homogeneous clip coordinates `[cx, cy, w]` of `p`: `w` is the view-space depth along
    /// `f`, and the pixel position is `(cx / w, cy / w)`. Affine in `p`, so clipping can
    /// interpolate these coordinates linearly.
    #[inline]
    pub fn clip(&self, p: [f32; 3]) -> [f64; 3] {
        let d = sub(widen(p), self.eye);
        let x = dot(d, self.right);
        let y = dot(d, self.up);
        let w = dot(d, self.forward);
        [
            self.scale * x + self.half * w,
            self.half * w - self.scale * y,
            w,
        ]
    }

    /// [`Camera::clip`] in binary32, the transform vertices are snapped with: `a · p + b` per
    /// row of the rounded transform, summed in a fixed order (`((a₀p₀ + a₁p₁) + a₂p₂) + b`;
    /// Rust never fuses a multiply and an add), so every caller gets the same bits. Accurate
    /// to ~10⁻⁵ pixel for sampling views, far below the 1/256-pixel snapping grid; only its
    /// determinism matters for watertightness (a shared vertex snaps once, the same way).
    #[inline(always)]
    pub(crate) fn clip32(&self, p: [f32; 3]) -> [f32; 3] {
        self.rows32
            .map(|r| r[0] * p[0] + r[1] * p[1] + r[2] * p[2] + r[3])
    }

    /// The rows of [`Camera::clip32`]'s transform: `cx`, `cy`, `w` = `row · [p, 1]`.
    #[inline(always)]
    pub(crate) fn rows32(&self) -> [[f32; 4]; 3] {
        self.rows32
    }

    /// Pixel coordinates of `p`, or `None` if it is nearer than the near plane.
    pub fn project(&self, p: [f32; 3]) -> Option<[f64; 2]> {
        let [cx, cy, w] = self.clip(p);
        (w >= self.near).then(|| [cx / w, cy / w])
    }
}

/// Where a sphere can appear in a view (see [`Camera::sphere_bounds`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum SphereBounds {
    /// The sphere reaches the near plane (or behind the eye): no useful bound.
    Unbounded,
    /// The sphere covers no pixel of the image.
    Outside,
    /// Every pixel the sphere's contents can touch lies in the inclusive rectangle
    /// `[x0, y0, x1, y1]`, and no point inside is nearer than depth `nearest` (`1/w`).
    Rect { rect: [usize; 4], nearest: f64 },
}

/// Pixels added on each side of a sphere's projected box: one for conservative
/// rasterization (which touches the pixel a vertex lies in and its neighbour on a pixel
/// boundary) and one for the snapping of vertices to 1/256 pixel.
const SPHERE_RECT_MARGIN: f64 = 2.0;

/// Relative widening of a sphere's nearest depth: interpolated `f32` depths can exceed the
/// largest corner depth by a few ulps (1e-7 relative); 1e-4 is a wide margin.
const SPHERE_DEPTH_SLACK: f64 = 1e-4;

impl Camera {
    /// A conservative screen rectangle and nearest depth of the ball of `radius` around
    /// `center`: the view-space box around the ball projects inside the rectangle because
    /// `x / w` over a box with `w > 0` is extremal at its corners.
    pub(crate) fn sphere_bounds(&self, center: [f32; 3], radius: f32) -> SphereBounds {
        let d = sub(widen(center), self.eye);
        let r = radius as f64;
        let (x, y, w) = (dot(d, self.right), dot(d, self.up), dot(d, self.forward));
        let (w_near, w_far) = (w - r, w + r);
        if w_near <= self.near {
            return if self.ball_beyond_edges(x, y, w, r) {
                SphereBounds::Outside
            } else {
                SphereBounds::Unbounded
            };
        }
        let lo_hi = |c: f64| {
            let ratios = [
                (c - r) / w_near,
                (c - r) / w_far,
                (c + r) / w_near,
                (c + r) / w_far,
            ];
            let lo = ratios.iter().copied().fold(f64::MAX, f64::min);
            let hi = ratios.iter().copied().fold(f64::MIN, f64::max);
            (lo, hi)
        };
        let (x_lo, x_hi) = lo_hi(x);
        let (y_lo, y_hi) = lo_hi(y);
        self.screen_rect(x_lo, x_hi, y_lo, y_hi, w_near)
    }
}

impl Camera {
    /// Where the convex hull of `corners` (a patch's bounding box) can appear: like
    /// [`Camera::sphere_bounds`], from the corners' projections. When every corner lies
    /// beyond the near plane the hull's image is the convex hull of the projected corners,
    /// so their rectangle (widened by the same margin for snapping) holds every pixel, and
    /// view depth is linear, so no point is nearer than the nearest corner.
    pub(crate) fn hull_bounds(&self, corners: &[[f64; 3]]) -> SphereBounds {
        let (mut x_lo, mut x_hi, mut y_lo, mut y_hi) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        let mut w_near = f64::MAX;
        for &c in corners {
            let d = sub(c, self.eye);
            let (x, y, w) = (dot(d, self.right), dot(d, self.up), dot(d, self.forward));
            if w <= self.near || w.is_nan() {
                return if self.hull_beyond_edges(corners) {
                    SphereBounds::Outside
                } else {
                    SphereBounds::Unbounded
                };
            }
            let (x, y) = (x / w, y / w);
            x_lo = x_lo.min(x);
            x_hi = x_hi.max(x);
            y_lo = y_lo.min(y);
            y_hi = y_hi.max(y);
            w_near = w_near.min(w);
        }
        self.screen_rect(x_lo, x_hi, y_lo, y_hi, w_near)
    }

    /// The tangent of the half-angle of the image widened by [`SPHERE_RECT_MARGIN`] pixels on
    /// each side: a point `(x, y, w)` of view space can touch a pixel only if `|x|, |y| <= t ·
    /// w`.
    fn widened_tangent(&self) -> f64 {
        (self.half + SPHERE_RECT_MARGIN) / self.scale
    }

    /// Whether the ball of radius `r` around view-space `(x, y, w)` covers no pixel although
    /// it reaches the near plane: it lies wholly behind the eye (`w < 0`), or wholly outside
    /// one of the four planes through the eye and the widened image's edges, so that no ray
    /// from the eye through the image meets it. Only the turned faces of a near view's cube
    /// map (`near.rs`) see patches behind or beside them.
    fn ball_beyond_edges(&self, x: f64, y: f64, w: f64, r: f64) -> bool {
        let t = self.widened_tangent();
        // The planes' normals `(±1, 0, t)` and `(0, ±1, t)` have this length; a relative
        // slack keeps rounding on the safe side.
        // A NaN coordinate makes every comparison false: it proves nothing.
        let slack = 1e-9 * (x.abs() + y.abs() + w.abs() + r);
        let reach = r * (1.0 + t * t).sqrt() + slack;
        w + r < -slack || [x, -x, y, -y].iter().any(|&c| c + t * w < -reach)
    }

    /// [`Camera::ball_beyond_edges`] for the convex hull of `corners`: every corner lies behind
    /// the eye, or outside the same widened edge plane.
    fn hull_beyond_edges(&self, corners: &[[f64; 3]]) -> bool {
        let t = self.widened_tangent();
        let mut outside = [true; 5];
        for &c in corners {
            let d = sub(c, self.eye);
            let (x, y, w) = (dot(d, self.right), dot(d, self.up), dot(d, self.forward));
            let slack = 1e-9 * (x.abs() + y.abs() + w.abs());
            // A NaN coordinate makes every comparison false: it proves nothing.
            let beyond = [
                w < -slack,
                x + t * w < -slack,
                -x + t * w < -slack,
                y + t * w < -slack,
                -y + t * w < -slack,
            ];
            for (o, b) in outside.iter_mut().zip(beyond) {
                *o &= b;
            }
        }
        !corners.is_empty() && outside.iter().any(|&o| o)
    }

    /// The bounds of contents whose `x / w` spans `[x_lo, x_hi]`, `y / w` spans `[y_lo,
    /// y_hi]` and whose nearest view depth is `w_near`.
    fn screen_rect(&self, x_lo: f64, x_hi: f64, y_lo: f64, y_hi: f64, w_near: f64) -> SphereBounds {
        let x0 = self.half + self.scale * x_lo - SPHERE_RECT_MARGIN;
        let x1 = self.half + self.scale * x_hi + SPHERE_RECT_MARGIN;
        // Image y grows downwards, against `up`.
        let y0 = self.half - self.scale * y_hi - SPHERE_RECT_MARGIN;
        let y1 = self.half - self.scale * y_lo + SPHERE_RECT_MARGIN;
        let last = (self.resolution - 1) as f64;
        if x1 < 0.0 || y1 < 0.0 || x0 > last || y0 > last {
            return SphereBounds::Outside;
        }
        // Truncation is the floor of a clamped (non-negative) value, and needs no call to
        // libm's `floor` (baseline x86-64 has no rounding instruction).
        let clamp = |v: f64| v.clamp(0.0, last) as usize;
        SphereBounds::Rect {
            rect: [clamp(x0), clamp(y0), clamp(x1), clamp(y1)],
            nearest: (1.0 + SPHERE_DEPTH_SLACK) / w_near,
        }
    }

    /// Whether every point of the ball of `radius` around `center` has view depth `w >=
    /// min_w` and projects into the pixel square `[lo, hi]²` (bounds as in
    /// [`Camera::sphere_bounds`]; callers leave a wide margin for rounding).
    pub(crate) fn sphere_within(
        &self,
        center: [f32; 3],
        radius: f32,
        min_w: f64,
        lo: f64,
        hi: f64,
    ) -> bool {
        let d = sub(widen(center), self.eye);
        let r = radius as f64;
        let (x, y, w) = (dot(d, self.right), dot(d, self.up), dot(d, self.forward));
        let (w_near, w_far) = (w - r, w + r);
        if !(w_near >= min_w && min_w > 0.0) {
            return false;
        }
        // Pixel coordinates are `half ± scale · c / w`, extremal at the box corners.
        let within = |c: f64| {
            [
                (c - r) / w_near,
                (c - r) / w_far,
                (c + r) / w_near,
                (c + r) / w_far,
            ]
            .iter()
            .all(|t| {
                let (a, b) = (self.half + self.scale * t, self.half - self.scale * t);
                a >= lo && a <= hi && b >= lo && b <= hi
            })
        };
        within(x) && within(y)
    }
}

pub(super) fn widen(p: [f32; 3]) -> [f64; 3] {
    [p[0] as f64, p[1] as f64, p[2] as f64]
}
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(super) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn scale3(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub(super) fn normalize(a: [f64; 3]) -> [f64; 3] {
    let len = dot(a, a).sqrt();
    assert!(len > 0.0, "cannot normalise the zero vector");
    scale3(a, 1.0 / len)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_kit::rng::Rng;

    fn params(center: [f32; 3], radius: f32) -> SamplingParams {
        SamplingParams {
            level: 0,
            resolution: 128,
            fov_deg: 50.0,
            center,
            radius,
        }
    }

    const DIRECTIONS: [[f32; 3]; 9] = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [0.577, 0.577, 0.577],
        [0.3, -0.2, 0.9],
        [0.001, 1.0, 0.0],
    ];

    #[test]
    fn sampling_camera_projects_the_centre_to_the_image_centre() {
        let p = params([10.0, -3.0, 250.0], 2.5);
        for dir in DIRECTIONS {
            let camera = Camera::sampling(&p, dir);
            let [x, y] = camera.project(p.center).unwrap();
            assert!(
                (x - 64.0).abs() < 1e-9 && (y - 64.0).abs() < 1e-9,
                "{dir:?}: {x} {y}"
            );
            let eye_distance = dot(sub(camera.eye(), widen(p.center)), camera.forward()).abs();
            assert!((eye_distance - p.distance() as f64).abs() < 1e-9);
        }
    }

    #[test]
    fn bounding_sphere_touches_but_does_not_leave_the_image() {
        let p = params([1.0, 2.0, 3.0], 4.0);
        for dir in DIRECTIONS {
            let camera = Camera::sampling(&p, dir);
            let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
            // The silhouette's extreme points lie on the great circles in the (r, f) and
            // (u, f) planes.
            for axis in [camera.right(), camera.up()] {
                for k in 0..100_000 {
                    let a = k as f64 / 100_000.0 * std::f64::consts::TAU;
                    let (s, c) = a.sin_cos();
                    let q: [f32; 3] = std::array::from_fn(|i| {
                        (p.center[i] as f64 + 4.0 * (c * axis[i] + s * camera.forward()[i])) as f32
                    });
                    let xy = camera.project(q).unwrap();
                    for i in 0..2 {
                        lo[i] = lo[i].min(xy[i]);
                        hi[i] = hi[i].max(xy[i]);
                    }
                }
            }
            for i in 0..2 {
                assert!(lo[i] > -0.01 && lo[i] < 0.01, "{dir:?} {lo:?}");
                assert!(hi[i] < 128.01 && hi[i] > 127.99, "{dir:?} {hi:?}");
            }
        }
    }

    #[test]
    fn clip32_stays_near_clip() {
        let p = params([10.0, -3.0, 250.0], 2.5);
        let points: [[f32; 3]; 4] = [
            [10.3, -2.1, 251.7],
            [9.0, -4.9, 248.1],
            [1e-7, 0.0, -3.0],
            [11.9, -3.3, 250.0],
        ];
        for dir in DIRECTIONS {
            let camera = Camera::sampling(&p, dir);
            for (i, &q) in points.iter().enumerate() {
                let c32 = camera.clip32(q);
                let c64 = camera.clip(q);
                // The pixel position agrees with the binary64 transform to far below the
                // snapping grid (1/256 pixel) for points near the model.
                if i != 2 {
                    for k in 0..2 {
                        let d = c32[k] as f64 / c32[2] as f64 - c64[k] / c64[2];
                        assert!(d.abs() < 1e-3, "{dir:?} {i} {k}: {d}");
                    }
                }
            }
        }
    }

    #[test]
    fn up_vector_switches_to_z_near_the_poles() {
        let down = Camera::look_at([0.0, 5.0, 0.0], [0.0, 0.0, 0.0], 60.0, 16);
        assert_eq!(down.forward(), [0.0, -1.0, 0.0]);
        assert_eq!(down.right(), [-1.0, 0.0, 0.0]);
        assert_eq!(down.up(), [0.0, 0.0, 1.0]);
        let up = Camera::look_at([0.0, -5.0, 0.0], [0.0, 0.0, 0.0], 60.0, 16);
        assert_eq!(up.right(), [1.0, 0.0, 0.0]);
        assert_eq!(up.up(), [0.0, 0.0, 1.0]);
        // Just outside the switch cone +Y is still world up.
        let tilted = Camera::look_at([0.05, 1.0, 0.0], [0.0, 0.0, 0.0], 60.0, 16);
        assert!(tilted.forward()[1].abs() < UP_SWITCH_COS);
        assert!(tilted.up()[1] > 0.0 && tilted.right()[2].abs() > 0.99);
    }

    #[test]
    fn image_axes_follow_right_and_down() {
        // Looking down -Z from +Z: right is +X, up is +Y, so +X is right and +Y is the top.
        let camera = Camera::look_at([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 90.0, 100);
        assert_eq!(camera.right(), [1.0, 0.0, 0.0]);
        assert_eq!(camera.up(), [0.0, 1.0, 0.0]);
        let [x, y] = camera.project([1.0, 1.0, 0.0]).unwrap();
        assert!(
            (x - 60.0).abs() < 1e-9 && (y - 40.0).abs() < 1e-9,
            "{x} {y}"
        );
        assert_eq!(camera.project([0.0, 0.0, 5.0]), None);
        assert!((camera.near() - 5e-3).abs() < 1e-12);
    }

    #[test]
    fn hull_bounds_hold_every_point_of_the_hull() {
        let p = params([10.0, -3.0, 250.0], 2.5);
        // A thin tilted box near the centre, and points spread through it.
        let corners: [[f64; 3]; 8] = std::array::from_fn(|i| {
            let s = |k: usize| if i >> k & 1 == 1 { 1.0 } else { -1.0 };
            [
                10.0 + 1.5 * s(0) + 0.2 * s(2),
                -3.0 + 0.7 * s(1),
                250.0 + 0.3 * s(0) + 0.05 * s(2),
            ]
        });
        let mut rng = Rng::new(7);
        let mut unit = || rng.unit();
        for dir in DIRECTIONS {
            let camera = Camera::sampling(&p, dir);
            let SphereBounds::Rect { rect, nearest } = camera.hull_bounds(&corners) else {
                panic!("{dir:?}: a box inside the sampling sphere has a rectangle");
            };
            for _ in 0..500 {
                let weights: [f64; 8] = std::array::from_fn(|_| unit());
                let total: f64 = weights.iter().sum();
                let mut q = [0.0; 3];
                for (w, c) in weights.iter().zip(&corners) {
                    for k in 0..3 {
                        q[k] += w / total * c[k];
                    }
                }
                let q32 = q.map(|c| c as f32);
                let [cx, cy, w] = camera.clip(q32);
                let (x, y) = (cx / w, cy / w);
                assert!(
                    x >= rect[0] as f64 && x <= rect[2] as f64 + 1.0,
                    "{dir:?} x {x} {rect:?}"
                );
                assert!(
                    y >= rect[1] as f64 && y <= rect[3] as f64 + 1.0,
                    "{dir:?} y {y} {rect:?}"
                );
                assert!(1.0 / w <= nearest, "{dir:?} depth");
            }
        }
        // Reaching behind the near plane: no bound; wholly beside the image: outside.
        let camera = Camera::sampling(&p, [0.0, 0.0, 1.0]);
        let eye = camera.eye();
        let around_eye = corners.map(|c| {
            [
                c[0] - 10.0 + eye[0],
                c[1] + 3.0 + eye[1],
                c[2] - 250.0 + eye[2],
            ]
        });
        assert_eq!(camera.hull_bounds(&around_eye), SphereBounds::Unbounded);
        let beside = corners.map(|c| [c[0] + 500.0, c[1], c[2]]);
        assert_eq!(camera.hull_bounds(&beside), SphereBounds::Outside);
    }
}
