//! The `.pvis` reader: validates a file once, then answers "which patches can a camera at this
//! position see?" without allocating and without failing.
//!
//! Needs only `core` (and the core-only [`crate::sphere`]). Format: `spec/FORMAT.md`.

/// Why a file was refused. Carries the values that caused it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error {
    /// The data ends before `needed` bytes; only `have` are there.
    Truncated {
        /// Bytes needed.
        needed: u64,
        /// Bytes present.
        have: u64,
    },
}

/// Sampling parameters stored in the file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampling {
    /// Sphere subdivision level.
    pub level: u32,
    /// Number of views (`sphere::view_count(level)`).
    pub views: u32,
    /// Centre of the bounding sphere.
    pub center: [f32; 3],
    /// Radius of the bounding sphere.
    pub radius: f32,
    /// Camera distance from the centre.
    pub distance: f32,
    /// Full field of view, degrees.
    pub fov_deg: f32,
    /// ID-buffer resolution, pixels per side.
    pub resolution: u32,
}

/// A validated `.pvis` file.
#[derive(Clone, Copy, Debug)]
pub struct Pvis<'a> {
    bytes: &'a [u8],
}

impl<'a> Pvis<'a> {
    /// Validates `bytes` as a `.pvis` file.
    pub fn parse(bytes: &'a [u8]) -> Result<Pvis<'a>, Error> {
        let _ = bytes;
        todo!()
    }
}
