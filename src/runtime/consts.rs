//! Layout constants of the `.pvis` format, one-to-one with `spec/FORMAT.md`.
//!
//! The writer (`crate::format`) takes every offset, length and limit from here, so reader and
//! writer cannot drift apart. Each constant names the spec section it mirrors.

/// File signature (§ Header): `"PVIS\r\n\x1a\n"`. The CR LF, Ctrl-Z and LF catch text-mode
/// transfers and line-ending conversion, as in PNG.
pub const MAGIC: [u8; 8] = *b"PVIS\r\n\x1a\n";

/// The format version this reader understands (§ Versioning).
pub const VERSION: u32 = 1;

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

/// Exact length of the CAMR section (§ CAMR).
pub const CAMR_LEN: u64 = 44;

/// The sampling-sphere convention of § Sampling sphere, as stored in CAMR.
pub const SPHERE_CONVENTION: u32 = 1;

/// Length of the PTCH section's fixed part before the records (§ PTCH).
pub const PTCH_HEADER_LEN: u64 = 16;

/// Length of one patch record (§ PTCH).
pub const PATCH_RECORD_LEN: u64 = 40;

/// Most patches a file may hold (§ Resource limits).
pub const MAX_PATCHES: u32 = 1 << 20;

/// Length of the VISB section's fixed part before the rows (§ VISB).
pub const VISB_HEADER_LEN: u64 = 8;

/// VISB encoding 0: one uncompressed bit row per view (§ VISB).
pub const ENCODING_RAW: u32 = 0;

/// The finest sphere level a file may use (§ Resource limits); the sphere module's limit.
pub const MAX_LEVEL: u32 = crate::sphere::MAX_LEVEL;

/// Bytes in one stored visibility row: `ceil(patch_count / 8)` (§ VISB).
pub const fn row_bytes(patch_count: u32) -> u64 {
    (patch_count as u64).div_ceil(8)
}
