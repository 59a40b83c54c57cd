//! The `.pvis` reader: validates a file once, then answers "which patches can a camera at this
//! position see?" without allocating and without failing.
//!
//! Follows the ttf-parser school: a borrowed `&[u8]`, one `Stream` to read values, checked
//! arithmetic on every offset, validation at [`Pvis::parse`] and infallible accessors after.
//! Query technique: Meruvia 2002 — the eye's direction from the model centre falls in one face
//! of the sampling sphere, and the patches visible from the face's three corner views
//! approximate those visible from the eye. Cost: `parse` is one pass over the file (CRC) plus
//! one over the patch table; a query is one point location (`sphere::locate`, ≤ 4 plane tests
//! per level) plus three rows OR-ed, `3·ceil(P/8)` bytes read.
//!
//! **Invariant:** nothing here allocates or panics on any input; the only panics are `assert!`s
//! on caller contracts (an out-of-range patch index, a too-small scratch buffer).
//! Needs only `core` (and the core-only [`crate::sphere`]). Format: `spec/FORMAT.md`.
#![forbid(unsafe_code)]

pub mod consts;
pub mod crc32c;
mod error;
mod parse;
mod query;
mod stream;

#[cfg(test)]
mod tests;

pub use error::Error;
pub use query::{Patches, TriangleRanges, Visible, ranges};

use stream::Stream;

/// Sampling parameters stored in the file (spec § CAMR).
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

/// One patch record (spec § PTCH): its triangle range in the reordered mesh and its bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchInfo {
    /// First triangle of the patch.
    pub first_triangle: u32,
    /// Number of triangles (at least 1).
    pub triangle_count: u32,
    /// Bounding sphere centre.
    pub center: [f32; 3],
    /// Bounding sphere radius.
    pub radius: f32,
    /// Normal cone axis (unit, or zero when the cone is degenerate).
    pub cone_axis: [f32; 3],
    /// Cosine of the normal cone's half-angle; `-1` means every direction.
    pub cone_cos: f32,
}

/// A validated `.pvis` file.
#[derive(Clone, Copy, Debug)]
pub struct Pvis<'a> {
    bytes: &'a [u8],
    sampling: Sampling,
    patch_count: u32,
    triangle_count: u64,
    /// The PTCH records, `patch_count × PATCH_RECORD_LEN` bytes.
    records: &'a [u8],
    /// The VISB rows, `views × row_bytes` bytes.
    rows: &'a [u8],
    row_bytes: usize,
    visibility_bytes: u64,
}

impl<'a> Pvis<'a> {
    /// Validates `bytes` as a `.pvis` file: every field, every patch record, the padding bits
    /// and the checksum. Afterwards no accessor or query can fail.
    pub fn parse(bytes: &'a [u8]) -> Result<Pvis<'a>, Error> {
        parse::parse(bytes)
    }

    /// The format version of the file.
    pub fn version(&self) -> u32 {
        Stream::new_at(self.bytes, consts::MAGIC.len())
            .read::<u32>()
            .unwrap_or(consts::VERSION)
    }

    /// The sampling parameters the file was baked with.
    pub fn sampling(&self) -> Sampling {
        self.sampling
    }

    /// Number of patches (at least 1).
    pub fn patch_count(&self) -> u32 {
        self.patch_count
    }

    /// Number of triangles the patches cover.
    pub fn triangle_count(&self) -> u64 {
        self.triangle_count
    }

    /// The record of patch `p`.
    ///
    /// # Panics
    /// If `p >= self.patch_count()`.
    pub fn patch(&self, p: u32) -> PatchInfo {
        assert!(
            p < self.patch_count,
            "patch {p} out of range (patch_count {})",
            self.patch_count
        );
        let mut s = Stream::new_at(self.records, p as usize * consts::PATCH_RECORD_LEN as usize);
        // The records were read once at parse, so these reads cannot fail.
        PatchInfo {
            first_triangle: s.read().unwrap_or(0),
            triangle_count: s.read().unwrap_or(0),
            center: s.read().unwrap_or([0.0; 3]),
            radius: s.read().unwrap_or(0.0),
            cone_axis: s.read().unwrap_or([0.0; 3]),
            cone_cos: s.read().unwrap_or(-1.0),
        }
    }

    /// Triangle range `(first, count)` of patch `p`, which must be in range.
    fn range(&self, p: u32) -> (u32, u32) {
        let mut s = Stream::new_at(self.records, p as usize * consts::PATCH_RECORD_LEN as usize);
        (s.read().unwrap_or(0), s.read().unwrap_or(0))
    }

    /// Length of the whole file in bytes.
    pub fn total_bytes(&self) -> u64 {
        self.bytes.len() as u64
    }

    /// Length of the VISB section in bytes.
    pub fn visibility_bytes(&self) -> u64 {
        self.visibility_bytes
    }

    /// `u64` words in one decoded row: `ceil(patch_count / 64)`.
    pub fn row_words(&self) -> usize {
        (self.patch_count as usize).div_ceil(64)
    }

    /// Decodes the row of `view` into `out[..row_words()]`: bit `p % 64` of word `p / 64` is
    /// patch `p`; bits past the last patch are zero.
    ///
    /// # Panics
    /// If `view >= self.sampling().views` or `out.len() < self.row_words()`.
    pub fn view_row(&self, view: u32, out: &mut [u64]) {
        let words = self.row_words();
        assert!(
            out.len() >= words,
            "row buffer holds {} words, {words} needed",
            out.len()
        );
        out[..words].fill(0);
        self.or_row(view, &mut out[..words]);
    }

    /// ORs the row of `view` into `out`.
    fn or_row(&self, view: u32, out: &mut [u64]) {
        assert!(
            view < self.sampling.views,
            "view {view} out of range (views {})",
            self.sampling.views
        );
        let start = view as usize * self.row_bytes;
        let row = self.rows.get(start..start + self.row_bytes).unwrap_or(&[]);
        for (word, chunk) in out.iter_mut().zip(row.chunks(8)) {
            let mut le = [0u8; 8];
            le[..chunk.len()].copy_from_slice(chunk);
            *word |= u64::from_le_bytes(le);
        }
    }

    /// `u64` words of scratch space [`Pvis::query`] needs.
    pub fn scratch_words(&self) -> usize {
        self.row_words()
    }

    /// The patches visible from `eye` (model space), following spec § Query: the OR of the rows
    /// of the three corner views of the sphere face containing `eye − center`. The answer lives
    /// in `scratch`.
    ///
    /// An eye with a non-finite coordinate (or one whose offset from the centre overflows) gets
    /// the conservative answer: every patch, `inside_sphere = true`.
    ///
    /// # Panics
    /// If `scratch.len() < self.scratch_words()`.
    pub fn query<'s>(&self, eye: [f32; 3], scratch: &'s mut [u64]) -> Visible<'s> {
        query::query(self, eye, scratch)
    }

    /// Merged triangle ranges of the patches in `visible`; see [`ranges`].
    pub fn ranges<'v>(&'v self, visible: &'v Visible<'_>) -> TriangleRanges<'v> {
        ranges(self, visible)
    }
}
