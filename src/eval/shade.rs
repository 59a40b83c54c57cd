//! Pictures from triangle-ID buffers: each pixel shaded by its triangle's face normal with a
//! headlight (Lambert), so that the model is recognisable, and a difference picture with the
//! missed pixels in red.
//!
//! The light shines along the camera's viewing direction; `|n · f|` makes the shading
//! independent of the triangles' winding, which scanned meshes do not keep consistent.
//! Cost: one dot product per pixel, plus a face normal where the picture is drawn (computed
//! from the mesh on demand, so a huge mesh needs no normal array).

use crate::ooc::Mesh;
use crate::sampler::NO_PATCH;

/// An 8-bit RGB image, rows from the top.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width · height · 3` bytes, `R G B` per pixel.
    pub pixels: Vec<u8>,
}

impl RgbImage {
    /// The images side by side, left to right, on one canvas as tall as the tallest.
    pub fn side_by_side(images: &[&RgbImage]) -> RgbImage {
        let width: u32 = images.iter().map(|i| i.width).sum();
        let height = images.iter().map(|i| i.height).max().unwrap_or(0);
        let mut pixels = vec![0u8; width as usize * height as usize * 3];
        let mut x0 = 0usize;
        for image in images {
            let w = image.width as usize;
            for y in 0..image.height as usize {
                let src = &image.pixels[y * w * 3..(y + 1) * w * 3];
                let start = (y * width as usize + x0) * 3;
                pixels[start..start + w * 3].copy_from_slice(src);
            }
            x0 += w;
        }
        RgbImage {
            width,
            height,
            pixels,
        }
    }
}

/// Share of the light that reaches surfaces facing away from the headlight, so that grazing
/// surfaces stay visible against the background.
const AMBIENT: f32 = 0.2;
/// Surface colour (a light clay), multiplied by the light intensity.
const ALBEDO: [f32; 3] = [235.0, 225.0, 205.0];
/// Colour of pixels no triangle covers.
pub const BACKGROUND: [u8; 3] = [32, 36, 44];
/// Colour of missed pixels in the difference picture.
pub const MISSED: [u8; 3] = [255, 0, 0];
/// Brightness of the unchanged pixels in the difference picture, so that the red stands out.
const DIFF_DIM: f32 = 0.35;

/// Unit face normal of triangle `t` of `mesh` (zero for a degenerate one).
pub fn face_normal(mesh: &Mesh, t: u32) -> [f32; 3] {
    let [a, b, c] = mesh.triangle(t).map(|v| mesh.position(v));
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if len > 0.0 && len.is_finite() {
        [n[0] / len, n[1] / len, n[2] / len]
    } else {
        [0.0; 3]
    }
}

/// Shades triangle-ID pixels: `normal` gives an id's face normal, `light` is the unit
/// viewing direction.
#[derive(Clone, Copy)]
pub struct Shader<'a> {
    normal: &'a dyn Fn(u32) -> [f32; 3],
    light: [f32; 3],
}

impl<'a> Shader<'a> {
    /// A headlight shader for a camera looking along `forward`, with `normal(id)` the unit
    /// face normal of the triangle with id `id`.
    pub fn new(normal: &'a dyn Fn(u32) -> [f32; 3], forward: [f64; 3]) -> Shader<'a> {
        Shader {
            normal,
            light: forward.map(|c| c as f32),
        }
    }

    /// Colour of a pixel showing triangle `id` ([`NO_PATCH`] for none).
    #[inline]
    pub fn colour(&self, id: u32) -> [u8; 3] {
        if id == NO_PATCH {
            return BACKGROUND;
        }
        let n = (self.normal)(id);
        let lambert = (n[0] * self.light[0] + n[1] * self.light[1] + n[2] * self.light[2]).abs();
        let intensity = AMBIENT + (1.0 - AMBIENT) * lambert.min(1.0);
        ALBEDO.map(|c| (c * intensity).round() as u8)
    }

    /// The shaded picture of a `resolution`² triangle-ID buffer.
    pub fn image(&self, ids: &[u32], resolution: u32) -> RgbImage {
        RgbImage {
            width: resolution,
            height: resolution,
            pixels: ids.iter().flat_map(|&id| self.colour(id)).collect(),
        }
    }

    /// The difference picture: `full` dimmed, and red where `reconstruction` differs.
    pub fn difference(&self, full: &[u32], reconstruction: &[u32], resolution: u32) -> RgbImage {
        assert_eq!(full.len(), reconstruction.len(), "buffers differ in size");
        RgbImage {
            width: resolution,
            height: resolution,
            pixels: full
                .iter()
                .zip(reconstruction)
                .flat_map(|(&a, &b)| {
                    if a == b {
                        self.colour(a).map(|c| (f32::from(c) * DIFF_DIM) as u8)
                    } else {
                        MISSED
                    }
                })
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headlight_shading_ignores_winding_and_keeps_grazing_faces_visible() {
        let normals = [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]];
        let normal = |id: u32| normals[id as usize];
        let shader = Shader::new(&normal, [0.0, 0.0, -1.0]);
        assert_eq!(shader.colour(0), ALBEDO.map(|c| c as u8));
        assert_eq!(shader.colour(1), shader.colour(0));
        let grazing = shader.colour(2);
        assert_eq!(grazing, ALBEDO.map(|c| (c * AMBIENT).round() as u8));
        assert_ne!(grazing, BACKGROUND);
        assert_eq!(shader.colour(NO_PATCH), BACKGROUND);
    }

    #[test]
    fn difference_marks_exactly_the_changed_pixels() {
        let normal = |_: u32| [0.0, 0.0, 1.0];
        let shader = Shader::new(&normal, [0.0, 0.0, 1.0]);
        let full = [0, 1, NO_PATCH, 1];
        let rec = [0, NO_PATCH, NO_PATCH, 0];
        let diff = shader.difference(&full, &rec, 2);
        let red: Vec<bool> = diff.pixels.chunks(3).map(|p| p == MISSED).collect();
        assert_eq!(red, [false, true, false, true]);
        let image = shader.image(&full, 2);
        let both = RgbImage::side_by_side(&[&image, &diff]);
        assert_eq!((both.width, both.height), (4, 2));
        assert_eq!(&both.pixels[0..6], &image.pixels[0..6]);
        assert_eq!(&both.pixels[12..18], &image.pixels[6..12]);
        assert_eq!(&both.pixels[9..12], MISSED);
    }
}
