//! Where a bake's sampling cameras are: the sphere level, the image, and the bounding sphere
//! they look at. Plain data, written into the file's CAMR section and read back by eval.

/// Where the sampling cameras are, shared by every view (see the spec's "Sampling sphere").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplingParams {
    /// Subdivision level of the sphere (views: `sphere::view_count(level)`).
    pub level: u32,
    /// ID buffer width and height in pixels.
    pub resolution: u32,
    /// Full field of view, degrees, of the square image.
    pub fov_deg: f32,
    /// Centre of the bounding sphere the cameras look at.
    pub center: [f32; 3],
    /// Radius of that bounding sphere.
    pub radius: f32,
}

impl SamplingParams {
    /// Camera distance from the centre: `radius / sin(fov / 2)`, so the sphere fits the view.
    pub fn distance(&self) -> f32 {
        self.radius / (self.fov_deg.to_radians() * 0.5).sin()
    }
}
