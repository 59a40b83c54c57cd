//! Why the reader refused a file: one small `Copy` enum carrying the values that caused it.
//!
//! Every variant's `Display` is one precise line saying what was found, where, and what the
//! spec (`spec/FORMAT.md`) expects. `std::error::Error` comes with the `std` feature.

use core::fmt;

use super::consts;

/// Why a file was refused. Carries the values that caused it; offsets are absolute byte
/// offsets into the file.
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
    /// The file does not start with the `.pvis` signature.
    BadMagic,
    /// The header's version is not one this reader understands.
    UnsupportedVersion {
        /// The version in the header.
        found: u32,
    },
    /// The header sets flag bits this version does not define.
    UnknownFlags {
        /// The flags in the header.
        flags: u32,
    },
    /// The header's `file_length` is not the length of the data.
    LengthMismatch {
        /// Length the header declares.
        header: u64,
        /// Length of the data.
        actual: u64,
    },
    /// The trailer's CRC-32C does not match the bytes before it.
    ChecksumMismatch {
        /// The CRC in the trailer.
        stored: u32,
        /// The CRC of the data.
        computed: u32,
    },
    /// A required section is absent.
    MissingSection {
        /// Its tag.
        tag: [u8; 4],
    },
    /// A known section appears twice.
    DuplicateSection {
        /// Its tag.
        tag: [u8; 4],
    },
    /// A section is shorter than its fixed header.
    BadSection {
        /// Its tag.
        tag: [u8; 4],
    },
    /// A section's length is not the one its contents determine.
    SectionLength {
        /// Its tag.
        tag: [u8; 4],
        /// Length in the section table.
        length: u64,
        /// Length the contents require.
        expected: u64,
    },
    /// A section does not lie inside `start..end`: after the table or the previous section,
    /// and before the trailer. Catches overlap, wrong order and sections past the end.
    SectionOutOfBounds {
        /// Its tag.
        tag: [u8; 4],
        /// Its offset.
        offset: u64,
        /// Its length.
        length: u64,
        /// First offset it may use.
        start: u64,
        /// Offset it must end at or before.
        end: u64,
    },
    /// A section's offset is not a multiple of 8.
    SectionMisaligned {
        /// Its tag.
        tag: [u8; 4],
        /// Its offset.
        offset: u64,
    },
    /// A count exceeds a resource limit of the spec.
    LimitExceeded {
        /// The quantity.
        what: &'static str,
        /// Its value in the file.
        value: u64,
        /// The largest value allowed.
        limit: u64,
    },
    /// An integer field has a value the spec forbids; `what` names it and the rule.
    Invalid {
        /// The field and the rule it breaks.
        what: &'static str,
        /// Where the field is.
        offset: u64,
        /// Its value.
        value: u64,
    },
    /// A float field has a value the spec forbids (non-finite or out of range).
    InvalidFloat {
        /// The field and the rule it breaks.
        what: &'static str,
        /// Where the field is.
        offset: u64,
        /// Its bits (`f32::from_bits` gives the value; bits keep the enum `Eq`).
        bits: u32,
    },
    /// CAMR's `view_count` is not `4·4^level + 2`.
    ViewCountMismatch {
        /// The level in the file.
        level: u32,
        /// The view count in the file.
        found: u32,
        /// The view count of that level.
        expected: u32,
    },
    /// A patch's triangle range does not continue where the previous one ended, or is empty.
    PatchRange {
        /// The patch.
        patch: u32,
        /// Its first triangle.
        first: u32,
        /// Its triangle count.
        count: u32,
        /// The first triangle it must have (the sum of the previous counts).
        expected_first: u64,
    },
    /// The patch ranges do not add up to PTCH's `triangle_count`.
    TriangleCountMismatch {
        /// `triangle_count` in the PTCH header.
        header: u64,
        /// Sum of the patch counts.
        sum: u64,
    },
    /// VISB uses an encoding this reader does not know.
    UnsupportedEncoding {
        /// The encoding in the file.
        found: u32,
    },
    /// A visibility row sets bits past the last patch.
    PaddingBits {
        /// The view whose row it is.
        view: u32,
        /// Offset of the row's last byte.
        offset: u64,
    },
}

/// A section tag, printed as text when it is printable ASCII and as hex otherwise.
struct Tag([u8; 4]);

impl fmt::Display for Tag {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.iter().all(|b| b.is_ascii_graphic()) {
            for &b in &self.0 {
                write!(f, "{}", b as char)?;
            }
            Ok(())
        } else {
            write!(f, "0x{:08X}", u32::from_be_bytes(self.0))
        }
    }
}

/// Length of the fixed part of a known section, for messages.
fn fixed_len(tag: [u8; 4]) -> u64 {
    match tag {
        consts::TAG_CAMR => consts::CAMR_LEN,
        consts::TAG_PTCH => consts::PTCH_HEADER_LEN,
        consts::TAG_VISB => consts::VISB_HEADER_LEN,
        _ => 0,
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::Truncated { needed, have } => {
                write!(f, "truncated: needed {needed} bytes, have {have}")
            }
            Error::BadMagic => write!(f, "not a .pvis file: bad signature"),
            Error::UnsupportedVersion { found } => write!(
                f,
                "unsupported version {found}: this reader understands version {}",
                consts::VERSION
            ),
            Error::UnknownFlags { flags } => write!(
                f,
                "unknown header flags 0x{:08X}",
                flags & !consts::KNOWN_FLAGS
            ),
            Error::LengthMismatch { header, actual } => write!(
                f,
                "length mismatch: header says {header} bytes, data has {actual}"
            ),
            Error::ChecksumMismatch { stored, computed } => write!(
                f,
                "checksum mismatch: trailer has CRC-32C 0x{stored:08X}, data has 0x{computed:08X}"
            ),
            Error::MissingSection { tag } => write!(f, "missing section {}", Tag(tag)),
            Error::DuplicateSection { tag } => write!(f, "section {} appears twice", Tag(tag)),
            Error::BadSection { tag } => write!(
                f,
                "section {}: shorter than its {}-byte fixed part",
                Tag(tag),
                fixed_len(tag)
            ),
            Error::SectionLength {
                tag,
                length,
                expected,
            } => write!(
                f,
                "section {}: length {length} but its contents need {expected}",
                Tag(tag)
            ),
            Error::SectionOutOfBounds {
                tag,
                offset,
                length,
                start,
                end,
            } => write!(
                f,
                "section {}: bytes {offset}..{offset}+{length} not inside {start}..{end} \
                 (after the table or previous section, before the trailer)",
                Tag(tag)
            ),
            Error::SectionMisaligned { tag, offset } => write!(
                f,
                "section {}: offset {offset} is not a multiple of {}",
                Tag(tag),
                consts::SECTION_ALIGN
            ),
            Error::LimitExceeded { what, value, limit } => {
                write!(f, "{what} {value} exceeds the limit {limit}")
            }
            Error::Invalid {
                what,
                offset,
                value,
            } => write!(f, "{what}: found {value} at byte {offset}"),
            Error::InvalidFloat { what, offset, bits } => {
                write!(
                    f,
                    "{what}: found {} at byte {offset}",
                    super::float_text::FloatText(f32::from_bits(bits))
                )
            }
            Error::ViewCountMismatch {
                level,
                found,
                expected,
            } => write!(
                f,
                "section CAMR: view_count {found} but level {level} has {expected} views"
            ),
            Error::PatchRange {
                patch,
                first,
                count,
                expected_first,
            } => write!(
                f,
                "section PTCH: patch {patch} covers triangles {first}+{count}, \
                 expected a non-empty range starting at {expected_first}"
            ),
            Error::TriangleCountMismatch { header, sum } => write!(
                f,
                "section PTCH: triangle_count {header} but the patches cover {sum}"
            ),
            Error::UnsupportedEncoding { found } => write!(
                f,
                "section VISB: unsupported encoding {found} (encoding {} is read from version 1, \
                 {} from version 2, {} from version 3)",
                consts::ENCODING_RAW,
                consts::ENCODING_HIERARCHICAL,
                consts::ENCODING_TREE,
            ),
            Error::PaddingBits { view, offset } => write!(
                f,
                "section VISB: row of view {view} sets bits past the last patch (byte {offset})"
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for Error {}
