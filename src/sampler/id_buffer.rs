//! The ID buffer: one patch id and one depth per pixel, the render target of the sampler.
//!
//! Depth is stored as `1/w` (reciprocal view-space depth along the camera's forward axis),
//! which is affine in screen space and so interpolates exactly across a triangle. Larger means
//! nearer; a cleared pixel holds `0.0`, i.e. infinitely far. Cost: 8 bytes per pixel; clearing
//! is two `memset`-like fills.

/// The id of a pixel no triangle covers.
pub const NO_PATCH: u32 = u32::MAX;

/// A square buffer of patch ids with a depth value per pixel. Pixel `(x, y)` is at index
/// `y * resolution + x`; row 0 is the top of the image.
#[derive(Clone, Debug)]
pub struct IdBuffer {
    resolution: u32,
    ids: Vec<u32>,
    depth: Vec<f32>,
}

impl IdBuffer {
    /// A cleared buffer of `resolution`² pixels.
    pub fn new(resolution: u32) -> IdBuffer {
        let pixels = resolution as usize * resolution as usize;
        IdBuffer {
            resolution,
            ids: vec![NO_PATCH; pixels],
            depth: vec![0.0; pixels],
        }
    }

    /// Resets every pixel to [`NO_PATCH`] at infinite depth.
    pub fn clear(&mut self) {
        self.ids.fill(NO_PATCH);
        self.depth.fill(0.0);
    }

    /// Width and height in pixels.
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// The patch id of every pixel, row by row from the top ([`NO_PATCH`] where empty).
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }

    /// The reciprocal view-space depth `1/w` of every pixel (0 where empty; larger is nearer).
    pub fn depth(&self) -> &[f32] {
        &self.depth
    }

    /// Depth test and write: the fragment `(id, q)` replaces pixel `index` only if `covered`,
    /// `q > 0`, and it is strictly nearer or as near with a smaller patch id. That makes the
    /// buffer independent of the order fragments arrive in (the tiled sampler's packed keys,
    /// `key_buffer.rs`, keep the same fragment), and on equal depth the pixel's patch is
    /// the same whichever of the tied triangles came first.
    /// Branch-free: the rasterizer calls it for every pixel of a small triangle's bounding box,
    /// where a branch on coverage would mispredict about half the time.
    #[inline(always)]
    pub(crate) fn plot(&mut self, index: usize, q: f32, id: u32, covered: bool) {
        let stored = self.depth[index];
        let id_stored = self.ids[index];
        let wins = covered & (q > 0.0) & ((q > stored) | ((q == stored) & (id < id_stored)));
        self.depth[index] = if wins { q } else { stored };
        self.ids[index] = if wins { id } else { id_stored };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_and_clear_leave_every_pixel_empty() {
        let mut buffer = IdBuffer::new(3);
        assert_eq!(buffer.ids(), &[NO_PATCH; 9]);
        buffer.plot(4, 0.5, 7, true);
        buffer.plot(3, 0.5, 7, false);
        assert_eq!(buffer.ids()[3], NO_PATCH);
        assert_eq!(buffer.ids()[4], 7);
        buffer.clear();
        assert_eq!(buffer.ids(), &[NO_PATCH; 9]);
        assert_eq!(buffer.depth(), &[0.0; 9]);
    }

    #[test]
    fn equal_depth_keeps_the_smaller_patch_in_any_order() {
        for order in [[1, 2], [2, 1]] {
            let mut buffer = IdBuffer::new(1);
            for id in order {
                buffer.plot(0, 0.5, id, true);
            }
            assert_eq!(buffer.ids(), &[1]);
            buffer.plot(0, 0.6, 3, true);
            assert_eq!(buffer.ids(), &[3]);
            buffer.plot(0, 0.6, 4, true);
            buffer.plot(0, 0.0, 0, true);
            buffer.plot(0, f32::NAN, 0, true);
            assert_eq!(buffer.ids(), &[3]);
        }
    }
}
