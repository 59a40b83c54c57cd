//! The `.pvis` writer: lays out header, section table, CAMR, PTCH, VISB and the CRC-32C
//! trailer (spec `spec/FORMAT.md`); files are written atomically by [`write_atomic`], re-exported
//! from [`crate::output`].
//!
//! Every offset, length and limit comes from [`crate::runtime::consts`], so writer and reader
//! cannot drift apart; `encode` also runs the reader over its own output. Output is
//! byte-deterministic: the same contents give the same bytes. VISB is written with encoding 2
//! (`tree`: rows range-coded given their parent views, probabilities from a context tree);
//! encodings 0 and 1 on request (`visb`). Sampling shells, when the contents have any, go into
//! a SHEL section (version 5), each shell's rows coded as a VISB body of their own. Cost: a few passes over the visibility matrix plus
//! one CRC and one validation pass over the output. `file.rs` is the other direction: a
//! `.pvis` on disk opened for the reader ([`PvisFile`]).

mod file;
mod patch_order;
mod ptch;
#[cfg(test)]
mod tests;
mod tree;
mod visb;

pub use crate::output::write_atomic;
pub use file::{PvisFile, PvisFileError};
pub use patch_order::{
    MAX_TOUR_WORK, centre_order, covisibility_order, keep_equal_records_in_order,
};
pub use ptch::{
    RecordKey, choose_with as choose_quantisation_with, quantise, record_key, stored_record,
};
pub use tree::encode_tree;
pub use visb::{encode_hierarchical, probabilities};

use crate::runtime::Pvis;
use crate::runtime::consts::*;
use crate::runtime::crc32c::crc32c;
use crate::sphere;
use crate::tiling::Patch;
use crate::visibility::{SamplingParams, VisibilityMatrix};

/// What a bake produced, ready to be encoded.
#[derive(Clone, Copy, Debug)]
pub struct BakeContents<'a> {
    /// Where the sampling cameras were.
    pub sampling: &'a SamplingParams,
    /// Triangles in the (reordered) mesh; the patches' ranges cover exactly these.
    pub triangle_count: u64,
    /// The patches, ranges contiguous in order from triangle 0.
    pub patches: &'a [Patch],
    /// Which patches each view sees: `view_count(level)` rows of `patches.len()` bits.
    pub visibility: &'a VisibilityMatrix,
    /// The sampling shells (spec § SHEL) by decreasing distance: those of the far band
    /// (beyond the sampling distance) first, then those nearer the model; empty for a file
    /// without them.
    pub shells: &'a [ShellRows<'a>],
    /// SHEL's `reach` (spec § SHEL): out to this distance from the centre, an eye between the
    /// sampling sphere and the first far shell is answered by the sampling sphere alone. 0 for
    /// none; otherwise above the sampling distance, with a far shell.
    pub reach: f32,
}

/// The rows of one sampling shell: views on a sphere of radius `distance` around the
/// sampling centre, each recording every patch visible from its eye in any direction.
#[derive(Clone, Copy, Debug)]
pub struct ShellRows<'a> {
    /// Camera distance from the centre: below the previous shell's, not the sampling
    /// distance, and at least the bounding radius.
    pub distance: f32,
    /// Which patches each view of the shell sees: `view_count(level)` rows of
    /// `patches.len()` bits, `level` being the matrix's own.
    pub visibility: &'a VisibilityMatrix,
}

/// The sections this writer emits, in file order; SHEL only for a file with shells.
const SECTIONS: [[u8; 4]; 4] = [TAG_CAMR, TAG_PTCH, TAG_VISB, TAG_SHEL];

/// How the VISB section stores the rows (spec: "VISB — visibility").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VisibilityEncoding {
    /// Encoding 0: every row whole, one bit per patch. For comparisons and simple readers.
    Raw,
    /// Encoding 1: each view range-coded given its two parent views, with a 32-context table
    /// per level. Readable by version-2 readers.
    Table,
    /// Encoding 2: as encoding 1, with probabilities from a context tree over wider features
    /// of the parents' rows (5–9% smaller on the bunny, spec/FORMAT.md). The default.
    Tree,
}

/// How the PTCH section stores the patch records (spec: "PTCH — patch table").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PatchTableLayout {
    /// 40-byte records of `f32` bounds and `u32` ranges: versions 1–3, read by every reader.
    Full,
    /// Version 4: ranges from counts, bounds and cones quantised conservatively relative to
    /// the model's bounds, bit-packed (about 8 bytes a patch on the bunny). The default.
    Compact,
}

/// Encodes `contents` as a `.pvis` file with the default, context-coded payload.
///
/// # Panics
/// As [`encode_with`].
pub fn encode(contents: &BakeContents) -> Vec<u8> {
    encode_with(contents, VisibilityEncoding::Tree)
}

/// Encodes `contents` as a `.pvis` file whose payload uses `encoding`.
///
/// # Panics
/// If the contents break the format's rules — a broken caller contract, as the bake
/// pipeline's own output always satisfies them: ranges not contiguous from 0 or not summing to
/// `triangle_count`, a matrix whose size disagrees with the level or patch count, limits
/// exceeded, non-finite values. The message is the reader's error.
pub fn encode_with(contents: &BakeContents, encoding: VisibilityEncoding) -> Vec<u8> {
    encode_as(contents, encoding, layout_of(encoding))
}

/// [`encode_with`] for contents read from outside the bake (the parts of a sharded bake):
/// patch ranges that break the format, or a file the reader refuses, are the reader's error
/// instead of a panic. The matrices' sizes remain a caller contract.
pub fn try_encode_with(
    contents: &BakeContents,
    encoding: VisibilityEncoding,
) -> Result<Vec<u8>, crate::runtime::Error> {
    try_encode_as(contents, encoding, layout_of(encoding))
}

/// The patch table `encoding` is written with by default.
fn layout_of(encoding: VisibilityEncoding) -> PatchTableLayout {
    match encoding {
        VisibilityEncoding::Tree => PatchTableLayout::Compact,
        // Written for readers of version 2, which know neither the tree nor the compact table.
        VisibilityEncoding::Raw | VisibilityEncoding::Table => PatchTableLayout::Full,
    }
}

/// Encodes `contents` with `encoding` and the patch table `layout`. The file's version is the
/// oldest that has both (§ Versioning): 2 for encodings 0 and 1 with the full table, 3 for
/// encoding 2 with it, 4 with the compact table. Patches whose coordinates are too large for
/// the compact table's grid (near `f32::MAX`) get the full table instead.
///
/// Contents with shells give version 5 (6 with a shell beyond the sampling distance: the far
/// band), whose SHEL section stores each shell's rows with `encoding` (a VISB body per shell,
/// with its own table or tree), and which has the compact table whatever `layout` asks. Where the compact table cannot hold the patches, the shells
/// are left out: the file then answers every eye inside the sampling sphere with
/// `inside_sphere` (draw everything), which is never wrong.
///
/// # Panics
/// As [`encode_with`].
pub fn encode_as(
    contents: &BakeContents,
    encoding: VisibilityEncoding,
    layout: PatchTableLayout,
) -> Vec<u8> {
    try_encode_as(contents, encoding, layout)
        .unwrap_or_else(|error| panic!("encode: the bake contents break the .pvis format: {error}"))
}

/// [`encode_as`], with the reader's error where the contents break the format (see
/// [`try_encode_with`]).
fn try_encode_as(
    contents: &BakeContents,
    encoding: VisibilityEncoding,
    layout: PatchTableLayout,
) -> Result<Vec<u8>, crate::runtime::Error> {
    check_ranges(contents.triangle_count, contents.patches)?;
    let params = contents.sampling;
    let patch_count = contents.patches.len() as u64;
    let views = sphere::view_count(params.level.min(MAX_LEVEL));
    assert_eq!(
        (
            contents.visibility.views(),
            contents.visibility.patches() as u64
        ),
        (views, patch_count),
        "visibility matrix size (views, patches) disagrees with the level and patch table"
    );

    let camr = camr(params, views);
    // Version 5 has the compact table (§ Versioning).
    let layout = match contents.shells.is_empty() {
        true => layout,
        false => PatchTableLayout::Compact,
    };
    let compact = match layout {
        PatchTableLayout::Compact => ptch::compact(contents.triangle_count, contents.patches),
        PatchTableLayout::Full => None,
    };
    // Patches too far out for the compact grid fall back to the full table.
    let layout = match compact {
        Some(_) => PatchTableLayout::Compact,
        None => PatchTableLayout::Full,
    };
    let (ptch, facing_axes) = match compact {
        Some(table) => (table.bytes, table.facing_axes),
        None => (
            ptch::full(contents.triangle_count, contents.patches),
            contents.patches.iter().map(|p| p.cone_axis).collect(),
        ),
    };
    let body = |matrix: &VisibilityMatrix, level: u32| match encoding {
        VisibilityEncoding::Raw => encode_raw(matrix),
        VisibilityEncoding::Table => encode_hierarchical(matrix, level),
        VisibilityEncoding::Tree => encode_tree(matrix, &facing_axes),
    };
    let visb = body(contents.visibility, params.level.min(MAX_LEVEL));
    let shells = match layout {
        PatchTableLayout::Compact => contents.shells,
        PatchTableLayout::Full => &[],
    };
    // A reach needs the far band, which the full table's fallback leaves out.
    let reach = if shells.is_empty() {
        0.0
    } else {
        contents.reach
    };
    let shel = shel(shells, reach, patch_count, &body);
    let bodies: &[&Vec<u8>] = match shel {
        Some(ref shel) => &[&camr, &ptch, &visb, shel],
        None => &[&camr, &ptch, &visb],
    };

    let table_end = HEADER_LEN + SECTION_ENTRY_LEN * bodies.len() as u64;
    let mut offsets = [0u64; SECTIONS.len()];
    let mut end = table_end;
    for (offset, body) in offsets.iter_mut().zip(bodies) {
        *offset = end.next_multiple_of(SECTION_ALIGN);
        end = *offset + body.len() as u64;
    }
    let file_length = end + TRAILER_LEN;

    let mut out = Vec::with_capacity(file_length as usize);
    out.extend_from_slice(&MAGIC);
    // The oldest version that has the encoding and the table, so older readers take what
    // they can read.
    let far_band = shells.iter().any(|s| s.distance > params.distance());
    let version = match (layout, encoding) {
        _ if far_band => FAR_BAND_VERSION,
        _ if bodies.len() == SECTIONS.len() => SHELLS_VERSION,
        (PatchTableLayout::Compact, _) => COMPACT_PTCH_VERSION,
        (PatchTableLayout::Full, VisibilityEncoding::Tree) => 3,
        (PatchTableLayout::Full, _) => 2,
    };
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&KNOWN_FLAGS.to_le_bytes());
    out.extend_from_slice(&file_length.to_le_bytes());
    out.extend_from_slice(&(bodies.len() as u32).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    for ((tag, offset), body) in SECTIONS.iter().zip(offsets).zip(bodies) {
        out.extend_from_slice(tag);
        out.extend_from_slice(&0u32.to_le_bytes());
        out.extend_from_slice(&offset.to_le_bytes());
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    }
    for (offset, body) in offsets.iter().zip(bodies) {
        out.resize(*offset as usize, 0);
        out.extend_from_slice(body);
    }
    let crc = crc32c(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    debug_assert_eq!(out.len() as u64, file_length);

    Pvis::parse(&out)?;
    Ok(out)
}

/// § PTCH's ranges, as the reader checks them: non-empty, contiguous from triangle 0, summing
/// to `triangle_count`. The compact table stores counts alone, so it could not say where a
/// range that breaks them starts.
fn check_ranges(triangle_count: u64, patches: &[Patch]) -> Result<(), crate::runtime::Error> {
    let mut next = 0u64;
    for (patch, p) in (0u32..).zip(patches) {
        if u64::from(p.first) != next || p.count == 0 {
            return Err(crate::runtime::Error::PatchRange {
                patch,
                first: p.first,
                count: p.count,
                expected_first: next,
            });
        }
        next += u64::from(p.count);
    }
    if next != triangle_count {
        return Err(crate::runtime::Error::TriangleCountMismatch {
            header: triangle_count,
            sum: next,
        });
    }
    Ok(())
}

/// § SHEL: the shell count, `reach`, a record per shell (distance, level, payload length) and
/// the payloads, each the VISB body `body` codes for the shell's matrix and level; `None`
/// without shells.
///
/// # Panics
/// If there are more than `MAX_SHELLS` shells or a shell's matrix has a view count of no level
/// or rows of another patch count (broken caller contracts).
fn shel(
    shells: &[ShellRows],
    reach: f32,
    patch_count: u64,
    body: &dyn Fn(&VisibilityMatrix, u32) -> Vec<u8>,
) -> Option<Vec<u8>> {
    if shells.is_empty() {
        return None;
    }
    assert!(
        shells.len() <= MAX_SHELLS as usize,
        "encode: {} sampling shells, at most {MAX_SHELLS}",
        shells.len()
    );
    let payloads: Vec<(u32, Vec<u8>)> = shells
        .iter()
        .map(|shell| {
            let matrix = shell.visibility;
            let level = (0..=MAX_LEVEL).find(|&l| sphere::view_count(l) == matrix.views());
            let level = level.unwrap_or_else(|| {
                panic!(
                    "encode: a sampling shell has {} views, which no sphere level has",
                    matrix.views()
                )
            });
            assert_eq!(
                matrix.patches() as u64,
                patch_count,
                "encode: a sampling shell's rows disagree with the patch count"
            );
            (level, body(matrix, level))
        })
        .collect();
    let mut out = Vec::new();
    out.extend_from_slice(&(shells.len() as u32).to_le_bytes());
    out.extend_from_slice(&reach.to_le_bytes());
    for (shell, (level, payload)) in shells.iter().zip(&payloads) {
        out.extend_from_slice(&shell.distance.to_le_bytes());
        out.extend_from_slice(&level.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    }
    for (_, payload) in &payloads {
        out.extend_from_slice(payload);
    }
    Some(out)
}

/// § CAMR.
fn camr(params: &SamplingParams, views: u32) -> Vec<u8> {
    let mut out = Vec::with_capacity(CAMR_LEN as usize);
    out.extend_from_slice(&params.level.to_le_bytes());
    out.extend_from_slice(&views.to_le_bytes());
    for v in params.center {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&params.radius.to_le_bytes());
    out.extend_from_slice(&params.distance().to_le_bytes());
    out.extend_from_slice(&params.fov_deg.to_le_bytes());
    out.extend_from_slice(&params.resolution.to_le_bytes());
    out.extend_from_slice(&SPHERE_CONVENTION.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    debug_assert_eq!(out.len() as u64, CAMR_LEN);
    out
}

/// § VISB, encoding 0 (what version-1 files hold; kept for tests and comparisons): each row's `u64`
/// words cut into `ceil(P / 8)` little-endian bytes, which is exactly the spec's "bit p is bit p %
/// 8 of byte p / 8".
pub fn encode_raw(matrix: &VisibilityMatrix) -> Vec<u8> {
    let row_len = row_bytes(matrix.patches()) as usize;
    let mut out = Vec::with_capacity(VISB_HEADER_LEN as usize + matrix.views() as usize * row_len);
    out.extend_from_slice(&ENCODING_RAW.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    let tail_bits = matrix.patches() % 8;
    for view in 0..matrix.views() {
        let row_start = out.len();
        for word in matrix.row(view) {
            out.extend_from_slice(&word.to_le_bytes());
        }
        out.truncate(row_start + row_len);
        // The matrix keeps bits past the last patch zero; masking makes the padding rule hold
        // even if it did not.
        if tail_bits != 0
            && let Some(last) = out.last_mut()
        {
            *last &= (1u8 << tail_bits) - 1;
        }
    }
    out
}
