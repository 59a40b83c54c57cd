//! The `.pvis` reader: validates a file once, then answers "which patches can a camera at this
//! position see?" without allocating and without failing.
//!
//! Follows the ttf-parser school: a borrowed `&[u8]`, one `Stream` to read values, checked
//! arithmetic on every offset, validation at [`Pvis::parse`] and infallible accessors after. Query
//! technique: Meruvia 2002 — the eye's direction from the model centre falls in one face of the
//! sampling sphere, and the patches visible from the face's three corner views approximate those
//! visible from the eye. Rows are stored raw (VISB encoding 0) or range-coded along the sphere
//! hierarchy (`visb`, `coder`), with probabilities from a context table per level (encoding 1) or
//! from a context tree stored in the file (encoding 2, `model`). A version-5 file adds sampling
//! shells (`shells`, spec § SHEL): views on nearer spheres, so an eye inside the sampling sphere
//! is answered from the rows of the two shells around it. Cost: `parse` is one pass over the
//! file (CRC) plus one over the patch table and the VISB records; three query modes trade memory
//! for time — [`Pvis::query`] (one row of scratch, decodes the leaf's `3 + 3·level` ancestor views
//! in lock step), [`Streaming`] (`4 + 3·level` rows, decodes only where the path to the leaf
//! changed) and [`Expanded`] (every row decoded once and every leaf's answer stored; `O(level)` a
//! query).
//!
//! Without feature `shells` this is a far-only reader (spec § SHEL, far-only readers): it skips
//! SHEL's contents and answers every eye from the sampling sphere, `inside_sphere` nearer than
//! it, for devices too small for the shells' 2.9 KB of code. The WebAssembly module and the
//! Cortex-M4F firmware keep the shells.
//!
//! ```
//! use patchvis::runtime::Pvis;
//!
//! # let bytes: &[u8] = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"),
//! #     "/tests/conformance/valid/023-v6-level2-three-far-two-near-mixed-encodings.pvis"));
//! let pvis = Pvis::parse(bytes)?; // validates everything once; no query can fail afterwards
//! let mut scratch = vec![0u64; pvis.scratch_words()]; // or any caller-owned memory
//! let visible = pvis.query([10.0, 10.0, -10.0], &mut scratch);
//! assert!(!visible.inside_sphere);
//! assert_eq!((visible.band, visible.shells), (1, [0, 1])); // between far shells 768 and 12
//! for (first, count) in pvis.ranges(&visible) {
//!     assert!(count > 0); // draw triangles first..first + count of the --mesh-out mesh
//! }
//!
//! // A moving camera: the streaming reader decodes only where the leaf changed.
//! let mut state = vec![0u64; pvis.scratch_bound()];
//! let mut frames = pvis.streaming(&mut state);
//! assert_eq!(frames.query([10.0, 10.0, -10.0]).count(), visible.count());
//! # Ok::<(), patchvis::runtime::Error>(())
//! ```
//!
//! **Invariant:** nothing here allocates or panics on any input; the only panics are `assert!`s
//! on caller contracts (an out-of-range patch index, a too-small scratch buffer).
//! Needs only `core` (and the core-only [`crate::sphere`]). Format: `spec/FORMAT.md`.
#![forbid(unsafe_code)]

mod coder;
pub mod consts;
pub mod crc32c;
mod error;
mod exact;
mod expanded;
mod fields;
mod float_text;
mod frustum;
mod message;
pub(crate) mod model;
mod parse;
mod ptch;
mod query;
mod shells;
mod stream;
mod streaming;
mod visb;

#[cfg(test)]
mod tests;

#[cfg(all(test, feature = "bake"))]
mod shell_tests;

#[cfg(feature = "bake")]
pub(crate) use coder::context;
pub use error::{Error, MESSAGE_TEMPLATES, MessageParts, RULE_TEXTS, Rule};
pub use expanded::Expanded;
pub use frustum::{DepthRange, Frustum};
pub use message::Message;
pub use ptch::{Quantisation, Record, unit_axis};
pub use query::{Patches, TriangleRanges, Visible, ranges, ranges_of_bits};
pub use streaming::Streaming;

use stream::Stream;
use visb::{Model, Visb};

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

/// One shell of a file (spec § SHEL): the sampling sphere (CAMR, VISB) or a SHEL record.
/// Shells are numbered `0..=K` by decreasing distance, the sampling sphere at
/// [`Pvis::sampling_shell`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shell {
    /// Camera distance from the centre (CAMR's for the sampling sphere).
    pub distance: f32,
    /// Sphere subdivision level of the shell's views.
    pub level: u32,
    /// Number of views (`sphere::view_count(level)`).
    pub views: u32,
    /// The VISB encoding of the shell's rows.
    pub encoding: u32,
    /// Bytes of the shell's rows: the VISB section, or the shell's payload in SHEL.
    pub bytes: u64,
}

/// A validated `.pvis` file.
#[derive(Clone, Copy, Debug)]
pub struct Pvis<'a> {
    bytes: &'a [u8],
    sampling: Sampling,
    patch_count: u32,
    triangle_count: u64,
    /// The PTCH records.
    patches: ptch::PatchTable<'a>,
    /// The VISB payload.
    visb: Visb<'a>,
    /// The SHEL section (none before version 5).
    shells: shells::Shells<'a>,
    visibility_bytes: u64,
    patch_table_bytes: u64,
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
        self.patches.info(p)
    }

    /// How the file's patch records are quantised: `Some` for version 4's compact table,
    /// `None` for the `f32` records of versions 1–3 (spec § PTCH).
    pub fn quantisation(&self) -> Option<Quantisation> {
        match self.patches {
            ptch::PatchTable::Full(_) => None,
            ptch::PatchTable::Compact { quantisation, .. } => Some(quantisation),
        }
    }

    /// Length of the PTCH section (the patch table) in bytes.
    pub fn patch_table_bytes(&self) -> u64 {
        self.patch_table_bytes
    }

    /// Triangle range `(first, count)` of patch `p`, which must be in range, given the range
    /// `(q, first, count)` of an earlier patch when the caller walks in order.
    fn range_after(&self, known: Option<(u32, u32, u32)>, p: u32) -> (u32, u32) {
        self.patches.range_after(known, p)
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

    /// The VISB encoding of the file: [`consts::ENCODING_RAW`],
    /// [`consts::ENCODING_HIERARCHICAL`] or [`consts::ENCODING_TREE`].
    pub fn encoding(&self) -> u32 {
        encoding_of(&self.visb)
    }

    /// `K`: the sampling shells besides the sampling sphere (spec § SHEL); 0 for a file without
    /// SHEL (every file of version ≤ 4), and for every file in a far-only reader (built without
    /// feature `shells`: spec § SHEL, far-only readers), which answers from the sampling sphere
    /// alone.
    pub fn shell_count(&self) -> u32 {
        self.shells.count()
    }

    /// `J`: the shell number of the sampling sphere. The file's shells `0..=shell_count()` are
    /// numbered by decreasing distance; the `J` shells before the sampling sphere lie beyond
    /// the sampling distance (the far band, version 6), those after it nearer the model. 0 for
    /// a file without a far band and in a far-only reader.
    pub fn sampling_shell(&self) -> u32 {
        self.shells.sampling()
    }

    /// SHEL's `reach` (spec § SHEL): an eye between the sampling sphere and the first far shell
    /// (band [`Pvis::sampling_shell`]) nearer the centre than this is answered by the sampling
    /// sphere alone. 0 where there is none: without a far band, where the file stores none, and
    /// in a far-only reader.
    pub fn sampling_reach(&self) -> f32 {
        if self.shells.sampling() > 0 {
            self.shells.reach
        } else {
            0.0
        }
    }

    /// Length of the SHEL section in bytes (0 without one).
    pub fn shells_bytes(&self) -> u64 {
        self.shells.section_bytes()
    }

    /// Shell `s` (`0..=shell_count()`, outermost first): [`Pvis::sampling_shell`] is the
    /// sampling sphere, the others the SHEL records.
    ///
    /// # Panics
    /// If `s > self.shell_count()`.
    pub fn shell(&self, s: u32) -> Shell {
        assert!(
            s <= self.shells.count(),
            "shell {s} out of range (shell_count {})",
            self.shells.count()
        );
        let level = self.shell_level(s);
        let (distance, bytes) = if s == self.shells.sampling() {
            (self.sampling.distance, self.visibility_bytes)
        } else {
            let k = self.shells.record(s);
            (self.shells.distance(k), self.shells.payload_length(k))
        };
        Shell {
            distance,
            level,
            views: crate::sphere::view_count(level),
            encoding: encoding_of(&self.visb_of(s)),
            bytes,
        }
    }

    /// Sphere level of shell `s` (which must be `≤ shell_count()`).
    fn shell_level(&self, s: u32) -> u32 {
        // A far-only reader has shell 0 only, the sampling sphere.
        if s == self.shells.sampling() || !cfg!(feature = "shells") {
            return self.sampling.level;
        }
        self.shells
            .level(self.shells.record(s))
            .min(consts::MAX_LEVEL)
    }

    /// The rows of shell `s` (which must be `≤ shell_count()`): VISB's, or a shell's payload
    /// opened again as parse read it ([`Visb::at`]), without walking its records.
    fn visb_of(&self, s: u32) -> Visb<'a> {
        if s == self.shells.sampling() || !cfg!(feature = "shells") {
            return self.visb;
        }
        let payload = self.shells.payload(self.shells.record(s));
        let body = self
            .bytes
            .get(fields::at(payload.offset)..fields::at(payload.offset + payload.length))
            .unwrap_or(&[]);
        Visb::at(body, self.shell_level(s), self.patch_count, self.patches)
    }
}

/// The encoding of a VISB body.
fn encoding_of(visb: &Visb<'_>) -> u32 {
    match *visb {
        Visb::Raw { .. } => consts::ENCODING_RAW,
        Visb::Hierarchical {
            model: Model::Table(_),
            ..
        } => consts::ENCODING_HIERARCHICAL,
        Visb::Hierarchical {
            model: Model::Tree { .. },
            ..
        } => consts::ENCODING_TREE,
    }
}

impl<'a> Pvis<'a> {
    /// Decodes the row of `view` into `out[..row_words()]`: bit `p % 64` of word `p / 64` is
    /// patch `p`; bits past the last patch are zero.
    ///
    /// For encoding 1 this decodes the view together with its `≤ 3 + 3·level` ancestors in
    /// lock step (O(level · P) work, no scratch); use [`Pvis::expand`] to decode all views.
    ///
    /// # Panics
    /// If `view >= self.sampling().views` or `out.len() < self.row_words()`.
    pub fn view_row(&self, view: u32, out: &mut [u64]) {
        self.shell_view_row(self.sampling_shell(), view, out);
    }

    /// [`Pvis::view_row`] for a view of shell `s` ([`Pvis::sampling_shell`] is the sampling
    /// sphere).
    ///
    /// # Panics
    /// If `s > self.shell_count()`, `view >= self.shell(s).views` or
    /// `out.len() < self.row_words()`.
    pub fn shell_view_row(&self, s: u32, view: u32, out: &mut [u64]) {
        let words = self.row_words();
        assert!(
            out.len() >= words,
            "row buffer holds {} words, {words} needed",
            out.len()
        );
        assert!(
            s <= self.shells.count(),
            "shell {s} out of range (shell_count {})",
            self.shells.count()
        );
        out[..words].fill(0);
        self.or_shell_rows(s, &[view], &mut out[..words]);
    }

    /// ORs the rows of `views` (one view, or the corners of a leaf) of shell `s` into `out`.
    fn or_shell_rows(&self, s: u32, views: &[u32], out: &mut [u64]) {
        let count = crate::sphere::view_count(self.shell_level(s));
        for &view in views {
            assert!(view < count, "view {view} out of range (views {count})");
        }
        let visb = self.visb_of(s);
        match visb {
            Visb::Raw { rows, row_bytes } => {
                for &view in views {
                    or_raw_row(rows, row_bytes, view, out);
                }
            }
            Visb::Hierarchical { .. } => {
                visb.or_rows_lockstep(views, out, self.patch_count);
            }
        }
    }

    /// Decodes the row of `view` of the rows `visb` (a shell's, [`Pvis::visb_of`]), at lattice
    /// point `point`, into `out` given its parents' decoded rows (`None` for a level-0 view;
    /// ignored for encoding 0, which reads the row directly).
    fn decode_row(
        &self,
        visb: &Visb<'a>,
        view: u32,
        point: crate::sphere::LatticePoint,
        parent_rows: Option<(&[u64], &[u64])>,
        out: &mut [u64],
        cache: &mut model::TreeCache<'_>,
    ) {
        match *visb {
            // Not through `or_shell_rows`: a build that only streams (the WebAssembly reader)
            // then carries no lock-step decoder.
            Visb::Raw { rows, row_bytes } => {
                out.fill(0);
                or_raw_row(rows, row_bytes, view, out);
            }
            Visb::Hierarchical { .. } => {
                visb.decode_row(view, point, parent_rows, out, self.patch_count, cache)
            }
        }
    }

    /// `u64` words of scratch space [`Pvis::query`] needs: one row.
    pub fn scratch_words(&self) -> usize {
        self.row_words()
    }

    /// `u64` words of scratch a [`Streaming`] query state needs: the answer row, then for each
    /// of its `min(K + 1, 3)` paths (one per shell it moves among: `K` is
    /// [`Pvis::shell_count`]) `3 + 3·L` rows, the 3 corners of the root face and 3 edge
    /// midpoints per level, `L` the finest level of the file's shells; plus, where a shell
    /// uses VISB encoding 2, a 32 KiB cache of context-tree lookups. Without shells: `4 + 3·level`
    /// rows, as in version 4.
    pub fn scratch_bound(&self) -> usize {
        streaming::rows(self) * self.row_words() + self.tree_cache_words()
    }

    /// The finest level of the file's shells (the sampling sphere's included).
    fn max_level(&self) -> u32 {
        self.sampling.level.max(self.shells.max_level)
    }

    /// Words of tree cache the streaming state keeps: [`model::TREE_CACHE_WORDS`] where a shell
    /// uses encoding 2, none otherwise.
    fn tree_cache_words(&self) -> usize {
        let tree = self.shells.tree
            || matches!(
                self.visb,
                Visb::Hierarchical {
                    model: Model::Tree { .. },
                    ..
                }
            );
        if tree { model::TREE_CACHE_WORDS } else { 0 }
    }

    /// `u64` words of the table [`Pvis::expand`] fills: the answer row; every view's row of
    /// every shell (the sampling sphere and the SHEL shells); 5 words per inner face of the
    /// sphere hierarchy down to the finest shell level (its 3 split planes); a 32,768-word
    /// (256 KiB) grid of where point location starts (8 octants × 128² cells × 2 bytes); for
    /// each shell, 1.5 words per leaf face of its level (its 3 corner views) and one row per
    /// leaf face (its answer); then the patch bounds of [`Expanded::query_in_frustum`]: 2 words
    /// per patch and per block of 64 patches (a bounding sphere), and 2 more.
    pub fn expanded_bound(&self) -> usize {
        expanded::words(self)
    }

    /// A streaming query state over `scratch` (at least [`Pvis::scratch_bound`] words): decodes
    /// only the rows along the path to the eye's leaf and keeps them, so a camera that stays in
    /// its leaf costs one point location and a move to a nearby leaf decodes a few rows.
    ///
    /// # Panics
    /// If `scratch.len() < self.scratch_bound()`.
    pub fn streaming<'s>(&self, scratch: &'s mut [u64]) -> Streaming<'a, 's> {
        Streaming::new(*self, scratch)
    }

    /// Decodes every view once into `table` (at least [`Pvis::expanded_bound`] words) and
    /// precomputes the point-location planes and every leaf's answer, for queries in
    /// `O(level)` that return a borrowed row.
    ///
    /// # Panics
    /// If `table.len() < self.expanded_bound()`.
    pub fn expand<'t>(&self, table: &'t mut [u64]) -> Expanded<'a, 't> {
        Expanded::new(*self, table)
    }

    /// Whether patch `p` faces away from `eye` entirely, by its normal cone — meshoptimizer's
    /// cluster cone test with the bounding sphere (`meshopt_Bounds`): with `c`, `r` the
    /// patch's bounding sphere, `axis`, `cos` its normal cone and
    /// `cutoff = sqrt(1 − cos²)`, the patch is back-facing iff
    /// `cos > 0` and `dot(c − eye, axis) > cutoff · |c − eye| + r`. A renderer may skip such
    /// patches in addition to the visibility answer; the test is conservative.
    ///
    /// # Panics
    /// If `p >= self.patch_count()`.
    pub fn backfacing(&self, p: u32, eye: [f32; 3]) -> bool {
        let info = self.patch(p);
        if info.cone_cos <= 0.0 {
            return false;
        }
        let cutoff = crate::sphere::sqrtf(1.0 - info.cone_cos * info.cone_cos);
        let v = [
            info.center[0] - eye[0],
            info.center[1] - eye[1],
            info.center[2] - eye[2],
        ];
        let len = crate::sphere::sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        let d = v[0] * info.cone_axis[0] + v[1] * info.cone_axis[1] + v[2] * info.cone_axis[2];
        d > cutoff * len + info.radius
    }

    /// The patches visible from `eye` (model space), following spec § Query: the OR of the rows
    /// of the three corner views of the sphere face containing `eye − center`, on the one or
    /// two shells of the eye's band ([`Visible::band`]; a file without shells has only the
    /// sampling sphere). The answer lives in `scratch`: each shell's leaf is decoded in lock
    /// step into it, after its payload's record lengths are walked once.
    ///
    /// An eye with a non-finite coordinate (or one whose offset from the centre overflows) gets
    /// the conservative answer: every patch, `inside_sphere = true`.
    ///
    /// # Panics
    /// If `scratch.len() < self.scratch_words()`.
    pub fn query<'s>(&self, eye: [f32; 3], scratch: &'s mut [u64]) -> Visible<'s> {
        query::query(self, eye, scratch)
    }

    /// [`Pvis::query`]'s answer without the patches whose bounding spheres lie wholly outside
    /// `frustum` (spec § Frustum culling): what to draw, in `scratch`. Costs one record decode
    /// and sphere test per visible patch more than `query`.
    ///
    /// # Panics
    /// If `scratch.len() < self.scratch_words()`.
    pub fn query_in_frustum<'s>(
        &self,
        eye: [f32; 3],
        frustum: &Frustum,
        scratch: &'s mut [u64],
    ) -> Visible<'s> {
        let place = query::query(self, eye, scratch).place();
        let row = &mut scratch[..self.row_words()];
        frustum.cull(self, row);
        query::visible(self, place, row)
    }

    /// Merged triangle ranges of the patches in `visible`; see [`ranges`].
    pub fn ranges<'v>(&'v self, visible: &'v Visible<'_>) -> TriangleRanges<'v> {
        ranges(self, visible)
    }
}

/// ORs the stored row of `view` (encoding 0: `row_bytes` bytes a view in `rows`) into `out`.
fn or_raw_row(rows: &[u8], row_bytes: usize, view: u32, out: &mut [u64]) {
    let start = view as usize * row_bytes;
    let row = rows.get(start..start + row_bytes).unwrap_or(&[]);
    for (word, chunk) in out.iter_mut().zip(row.chunks(8)) {
        let mut le = [0u8; 8];
        le[..chunk.len()].copy_from_slice(chunk);
        *word |= u64::from_le_bytes(le);
    }
}
