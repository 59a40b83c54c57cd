//! Layout constants of the `.pvis` format, one-to-one with `spec/FORMAT.md`.
//!
//! The writer (`crate::format`) takes every offset, length and limit from here, so reader and
//! writer cannot drift apart. Each constant names the spec section it mirrors.

/// File signature (§ Header): `"PVIS\r\n\x1a\n"`. The CR LF, Ctrl-Z and LF catch text-mode
/// transfers and line-ending conversion, as in PNG.
pub const MAGIC: [u8; 8] = *b"PVIS\r\n\x1a\n";

/// The newest format version this reader understands (§ Versioning). The writer writes it
/// for a file with a far band and the oldest version that holds its contents otherwise.
pub const VERSION: u32 = 6;

/// The oldest version this reader still reads (§ Versioning): version 1 is version 2 restricted
/// to VISB encoding 0.
pub const MIN_VERSION: u32 = 1;

/// Header flag bits this version defines (§ Header): none. Readers reject any other bit.
pub const KNOWN_FLAGS: u32 = 0;

/// Header length in bytes (§ Header).
pub const HEADER_LEN: u64 = 32;

/// Length of one section-table entry in bytes (§ Section table).
pub const SECTION_ENTRY_LEN: u64 = 24;

/// Sections start at offsets that are multiples of this (§ Section table).
pub const SECTION_ALIGN: u64 = 8;

/// Most sections a file may declare (§ Resource limits).
pub const MAX_SECTIONS: u32 = 16;

/// Length of the trailer (the CRC-32C) in bytes (§ Trailer).
pub const TRAILER_LEN: u64 = 4;

/// Tag of the sampling-parameters section (§ CAMR).
pub const TAG_CAMR: [u8; 4] = *b"CAMR";
/// Tag of the patch-table section (§ PTCH).
pub const TAG_PTCH: [u8; 4] = *b"PTCH";
/// Tag of the visibility section (§ VISB).
pub const TAG_VISB: [u8; 4] = *b"VISB";
/// Tag of the sampling-shells section (§ SHEL), meaningful from version 5.
pub const TAG_SHEL: [u8; 4] = *b"SHEL";

/// The first version whose SHEL section a reader must read (§ SHEL, § Versioning); in older
/// files a SHEL-tagged section is an unknown section, ignored.
pub const SHELLS_VERSION: u32 = 5;

/// The first version whose SHEL records may lie beyond the sampling distance (§ SHEL, the far
/// band); before it every record is nearer the model than the sampling sphere.
pub const FAR_BAND_VERSION: u32 = 6;

/// Most shells a SHEL section may hold (§ Resource limits): a query ORs the rows of at most two
/// of them, and the streaming state keeps a path per shell it moves among.
pub const MAX_SHELLS: u32 = 8;

/// Length of the SHEL section's fixed part before the shell records (§ SHEL).
pub const SHEL_HEADER_LEN: u64 = 8;

/// Length of one shell record in SHEL: `distance`, `level`, `length` (§ SHEL).
pub const SHELL_RECORD_LEN: u64 = 16;

/// Exact length of the CAMR section (§ CAMR).
pub const CAMR_LEN: u64 = 44;

/// The sampling-sphere convention of § Sampling sphere, as stored in CAMR.
pub const SPHERE_CONVENTION: u32 = 1;

/// Length of the PTCH section's fixed part before the records (§ PTCH).
pub const PTCH_HEADER_LEN: u64 = 16;

/// Length of one patch record of the full layout (§ PTCH, versions 1–3).
pub const PATCH_RECORD_LEN: u64 = 40;

/// The first version whose PTCH has the compact layout (§ PTCH, version 4).
pub const COMPACT_PTCH_VERSION: u32 = 4;

/// Length of the compact PTCH's fixed part before the block starts (§ PTCH, version 4).
pub const PTCH_COMPACT_HEADER_LEN: u64 = 40;

/// The compact PTCH stores the first triangle of every `PTCH_START_INTERVAL`-th patch, so a
/// range is found in at most `PTCH_START_INTERVAL − 1` additions (§ PTCH, version 4): 4 bytes
/// per 64 patches, under 1% of the table.
pub const PTCH_START_INTERVAL: u32 = 64;

/// Most patches a file may hold (§ Resource limits).
pub const MAX_PATCHES: u32 = 1 << 20;

/// Length of the VISB section's fixed part before the rows (§ VISB).
pub const VISB_HEADER_LEN: u64 = 8;

/// VISB encoding 0: one uncompressed bit row per view (§ VISB, encoding 0).
pub const ENCODING_RAW: u32 = 0;

/// VISB encoding 1: every view's row coded by a binary range coder conditioned on its two
/// parent views (§ VISB, encoding 1). Version 2 only.
pub const ENCODING_HIERARCHICAL: u32 = 1;

/// VISB encoding 2: every view's row coded by a binary range coder whose probabilities come
/// from a context tree over the bit's features (§ VISB, encoding 2). Version 3 only.
pub const ENCODING_TREE: u32 = 2;

/// Contexts per level of encoding 1 (§ Context): 5 bits — the two parents' bits at the patch
/// and at the patch before it, and the view's own previous bit. Measured on the bunny (spec §
/// Rationale): adding the parents' previous bits saves 3% over `(a, b, x−1)`, wider contexts
/// gain under 3% more and cost table space at small patch counts.
pub const CONTEXTS: usize = 32;

/// Probabilities are in units of `1 / 2^PROB_BITS` (§ Range coder).
pub const PROB_BITS: u32 = 12;

/// The range coder renormalises when its range drops below this (§ Range coder).
pub const RANGE_TOP: u32 = 1 << 24;

/// Every `CHECKPOINT_INTERVAL`-th view's record offset is stored (§ VISB, encoding 1): finding a
/// view's code walks at most `CHECKPOINT_INTERVAL − 1` length prefixes. 64 keeps the table at
/// 4 bytes per 64 views (68 bytes at level 4) and the walk well under the cost of one decode.
pub const CHECKPOINT_INTERVAL: u32 = 64;

/// Most bytes a length prefix (unsigned LEB128) may take (§ VISB, encoding 1).
pub const MAX_VARINT_LEN: usize = 4;

/// Longest code a view may have: the decoder reads 4 bytes, then at most 2 per decoded bit
/// (a decision divides the range by at most `2^PROB_BITS`), so longer codes carry bytes no
/// decoder reads (§ VISB, encoding 1).
pub const fn max_code_len(patch_count: u32) -> u64 {
    4 + 2 * patch_count as u64
}

/// Views whose rows a decode of one leaf involves: its 3 corners and 3 more per level — the
/// ancestor closure of a leaf of level `l` has exactly `3 + 3·l` views (checked exhaustively
/// for every leaf up to `MAX_LEVEL` in the tests). Bounds the lock-step decoder.
pub const MAX_LANES: usize = 3 + 3 * crate::sphere::MAX_LEVEL as usize;

/// The finest sphere level a file may use (§ Resource limits); the sphere module's limit.
pub const MAX_LEVEL: u32 = crate::sphere::MAX_LEVEL;

/// Bytes in one stored visibility row: `ceil(patch_count / 8)` (§ VISB).
pub const fn row_bytes(patch_count: u32) -> u64 {
    (patch_count as u64).div_ceil(8)
}
