//! Why the reader refused a file: one small `Copy` enum carrying the values that caused it.
//!
//! Every variant's message ([`Error::message`], also its `Display`) is one precise line saying
//! what was found, where, and what the spec (`spec/FORMAT.md`) expects. The message is built
//! with the reader's own small formatter (`message.rs`) rather than `core::fmt`, and what a
//! refused field is and which rule it breaks is a [`Rule`], a one-byte id whose text is only
//! looked up when a message is made: a build that never prints an error (a microcontroller)
//! carries neither the texts nor a formatter, and one that does (WebAssembly) carries no
//! `core::fmt`. `std::error::Error` comes with the `std` feature.

use core::fmt;

use super::consts;
use super::message::Message;

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
        what: Rule,
        /// Its value in the file.
        value: u64,
        /// The largest value allowed.
        limit: u64,
    },
    /// An integer field has a value the spec forbids; `what` names it and the rule.
    Invalid {
        /// The field and the rule it breaks.
        what: Rule,
        /// Where the field is.
        offset: u64,
        /// Its value.
        value: u64,
    },
    /// A float field has a value the spec forbids (non-finite or out of range).
    InvalidFloat {
        /// The field and the rule it breaks.
        what: Rule,
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

/// What a refused value is: the field and the rule it breaks ([`Error::Invalid`],
/// [`Error::InvalidFloat`]) or the quantity over a limit ([`Error::LimitExceeded`]). Its
/// [`Rule::text`] is what the message prints.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Rule {
    /// `header section_count must be at least 1`
    HeaderSectionCount,
    /// `section_count`
    SectionCount,
    /// `header reserved field must be 0`
    HeaderReserved,
    /// `section table reserved field must be 0`
    TableReserved,
    /// `bytes between sections must be 0`
    Gap,
    /// `sphere level`
    SphereLevel,
    /// `CAMR center must be finite`
    CamrCenter,
    /// `CAMR radius must be finite and > 0`
    CamrRadius,
    /// `CAMR distance must be finite and >= radius`
    CamrDistance,
    /// `CAMR fov_deg must be in (0, 180)`
    CamrFov,
    /// `CAMR resolution must be at least 1`
    CamrResolution,
    /// `CAMR sphere_convention must be 1`
    CamrConvention,
    /// `CAMR reserved field must be 0`
    CamrReserved,
    /// `PTCH patch_count must be at least 1`
    PatchCount,
    /// `patch_count`
    PatchCountLimit,
    /// `triangle_count`
    TriangleCount,
    /// `PTCH reserved field must be 0`
    PtchReserved,
    /// `PTCH patch center must be finite`
    PatchCenter,
    /// `PTCH patch radius must be finite and >= 0`
    PatchRadius,
    /// `PTCH patch cone_axis must be finite`
    PatchConeAxis,
    /// `PTCH patch cone_cos must be in [-1, 1]`
    PatchConeCos,
    /// `PTCH origin must be finite`
    Origin,
    /// `PTCH step must be finite and > 0`
    Step,
    /// `PTCH count_bits must be at most 32`
    CountBits,
    /// `PTCH center_bits must be at most 24`
    CenterBits,
    /// `PTCH radius_bits must be at most 24`
    RadiusBits,
    /// `PTCH axis_bits must be in 2..=16`
    AxisBits,
    /// `PTCH cos_bits must be in 1..=16`
    CosBits,
    /// `PTCH reserved bytes must be 0`
    PtchReservedBytes,
    /// `PTCH step must keep origin + (2^center_bits - 1) * step finite`
    StepCenterRange,
    /// `PTCH step must keep (2^radius_bits - 1) * step finite`
    StepRadiusRange,
    /// `PTCH block start must equal the sum of the counts before it`
    BlockStart,
    /// `PTCH record's axis coordinate must be at most 2^axis_bits - 2`
    RecordAxis,
    /// `PTCH bits after the last record must be 0`
    RecordPadding,
    /// `VISB reserved field must be 0`
    VisbReserved,
    /// `VISB probability must be in 1..4096`
    VisbProbability,
    /// `VISB tree node count must be in 1..=1024`
    TreeNodeCount,
    /// `VISB tree leaf must hold a probability in 1..4096`
    TreeLeaf,
    /// `VISB tree node must test a feature below 23`
    TreeFeature,
    /// `VISB tree node's children must follow it inside the tree`
    TreeChildren,
    /// `VISB tree depth`
    TreeDepth,
    /// `VISB checkpoint must be the offset of its view's record`
    Checkpoint,
    /// `VISB record length must be a LEB128 of at most 4 bytes inside the section`
    RecordLength,
    /// `VISB record length must be a minimal LEB128`
    RecordLengthMinimal,
    /// `VISB code length`
    CodeLength,
    /// `VISB code must not end in a zero byte`
    CodeEnd,
}

impl Rule {
    /// The words a message prints for this rule.
    pub fn text(self) -> &'static str {
        match self {
            Rule::HeaderSectionCount => "header section_count must be at least 1",
            Rule::SectionCount => "section_count",
            Rule::HeaderReserved => "header reserved field must be 0",
            Rule::TableReserved => "section table reserved field must be 0",
            Rule::Gap => "bytes between sections must be 0",
            Rule::SphereLevel => "sphere level",
            Rule::CamrCenter => "CAMR center must be finite",
            Rule::CamrRadius => "CAMR radius must be finite and > 0",
            Rule::CamrDistance => "CAMR distance must be finite and >= radius",
            Rule::CamrFov => "CAMR fov_deg must be in (0, 180)",
            Rule::CamrResolution => "CAMR resolution must be at least 1",
            Rule::CamrConvention => "CAMR sphere_convention must be 1",
            Rule::CamrReserved => "CAMR reserved field must be 0",
            Rule::PatchCount => "PTCH patch_count must be at least 1",
            Rule::PatchCountLimit => "patch_count",
            Rule::TriangleCount => "triangle_count",
            Rule::PtchReserved => "PTCH reserved field must be 0",
            Rule::PatchCenter => "PTCH patch center must be finite",
            Rule::PatchRadius => "PTCH patch radius must be finite and >= 0",
            Rule::PatchConeAxis => "PTCH patch cone_axis must be finite",
            Rule::PatchConeCos => "PTCH patch cone_cos must be in [-1, 1]",
            Rule::Origin => "PTCH origin must be finite",
            Rule::Step => "PTCH step must be finite and > 0",
            Rule::CountBits => "PTCH count_bits must be at most 32",
            Rule::CenterBits => "PTCH center_bits must be at most 24",
            Rule::RadiusBits => "PTCH radius_bits must be at most 24",
            Rule::AxisBits => "PTCH axis_bits must be in 2..=16",
            Rule::CosBits => "PTCH cos_bits must be in 1..=16",
            Rule::PtchReservedBytes => "PTCH reserved bytes must be 0",
            Rule::StepCenterRange => {
                "PTCH step must keep origin + (2^center_bits - 1) * step finite"
            }
            Rule::StepRadiusRange => "PTCH step must keep (2^radius_bits - 1) * step finite",
            Rule::BlockStart => "PTCH block start must equal the sum of the counts before it",
            Rule::RecordAxis => "PTCH record's axis coordinate must be at most 2^axis_bits - 2",
            Rule::RecordPadding => "PTCH bits after the last record must be 0",
            Rule::VisbReserved => "VISB reserved field must be 0",
            Rule::VisbProbability => "VISB probability must be in 1..4096",
            Rule::TreeNodeCount => "VISB tree node count must be in 1..=1024",
            Rule::TreeLeaf => "VISB tree leaf must hold a probability in 1..4096",
            Rule::TreeFeature => "VISB tree node must test a feature below 23",
            Rule::TreeChildren => "VISB tree node's children must follow it inside the tree",
            Rule::TreeDepth => "VISB tree depth",
            Rule::Checkpoint => "VISB checkpoint must be the offset of its view's record",
            Rule::RecordLength => {
                "VISB record length must be a LEB128 of at most 4 bytes inside the section"
            }
            Rule::RecordLengthMinimal => "VISB record length must be a minimal LEB128",
            Rule::CodeLength => "VISB code length",
            Rule::CodeEnd => "VISB code must not end in a zero byte",
        }
    }
}

impl fmt::Display for Rule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.text())
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

impl Error {
    /// The one-line message: what was found, where, and what the spec expects. Exactly the
    /// `Display` text, made without `core::fmt`.
    pub fn message(&self) -> Message {
        let mut m = Message::new();
        self.write(&mut m);
        m
    }

    /// Writes [`Error::message`] into `m`. One out-of-line function, so the message texts and
    /// the formatter exist once in a build however many callers print errors.
    #[inline(never)]
    fn write(&self, m: &mut Message) {
        match *self {
            Error::Truncated { needed, have } => {
                m.text("truncated: needed ")
                    .u64(needed)
                    .text(" bytes, have ")
                    .u64(have);
            }
            Error::BadMagic => {
                m.text("not a .pvis file: bad signature");
            }
            Error::UnsupportedVersion { found } => {
                m.text("unsupported version ")
                    .u64(found.into())
                    .text(": this reader understands version ")
                    .u64(consts::VERSION.into());
            }
            Error::UnknownFlags { flags } => {
                m.text("unknown header flags ")
                    .hex32(flags & !consts::KNOWN_FLAGS);
            }
            Error::LengthMismatch { header, actual } => {
                m.text("length mismatch: header says ")
                    .u64(header)
                    .text(" bytes, data has ")
                    .u64(actual);
            }
            Error::ChecksumMismatch { stored, computed } => {
                m.text("checksum mismatch: trailer has CRC-32C ")
                    .hex32(stored)
                    .text(", data has ")
                    .hex32(computed);
            }
            Error::MissingSection { tag } => {
                m.text("missing section ").tag(tag);
            }
            Error::DuplicateSection { tag } => {
                m.text("section ").tag(tag).text(" appears twice");
            }
            Error::BadSection { tag } => {
                m.text("section ")
                    .tag(tag)
                    .text(": shorter than its ")
                    .u64(fixed_len(tag))
                    .text("-byte fixed part");
            }
            Error::SectionLength {
                tag,
                length,
                expected,
            } => {
                m.text("section ")
                    .tag(tag)
                    .text(": length ")
                    .u64(length)
                    .text(" but its contents need ")
                    .u64(expected);
            }
            Error::SectionOutOfBounds {
                tag,
                offset,
                length,
                start,
                end,
            } => {
                m.text("section ")
                    .tag(tag)
                    .text(": bytes ")
                    .u64(offset)
                    .text("..")
                    .u64(offset)
                    .text("+")
                    .u64(length)
                    .text(" not inside ")
                    .u64(start)
                    .text("..")
                    .u64(end)
                    .text(" (after the table or previous section, before the trailer)");
            }
            Error::SectionMisaligned { tag, offset } => {
                m.text("section ")
                    .tag(tag)
                    .text(": offset ")
                    .u64(offset)
                    .text(" is not a multiple of ")
                    .u64(consts::SECTION_ALIGN);
            }
            Error::LimitExceeded { what, value, limit } => {
                m.text(what.text())
                    .text(" ")
                    .u64(value)
                    .text(" exceeds the limit ")
                    .u64(limit);
            }
            Error::Invalid {
                what,
                offset,
                value,
            } => {
                m.text(what.text())
                    .text(": found ")
                    .u64(value)
                    .text(" at byte ")
                    .u64(offset);
            }
            Error::InvalidFloat { what, offset, bits } => {
                m.text(what.text())
                    .text(": found ")
                    .f32(f32::from_bits(bits))
                    .text(" at byte ")
                    .u64(offset);
            }
            Error::ViewCountMismatch {
                level,
                found,
                expected,
            } => {
                m.text("section CAMR: view_count ")
                    .u64(found.into())
                    .text(" but level ")
                    .u64(level.into())
                    .text(" has ")
                    .u64(expected.into())
                    .text(" views");
            }
            Error::PatchRange {
                patch,
                first,
                count,
                expected_first,
            } => {
                m.text("section PTCH: patch ")
                    .u64(patch.into())
                    .text(" covers triangles ")
                    .u64(first.into())
                    .text("+")
                    .u64(count.into())
                    .text(", expected a non-empty range starting at ")
                    .u64(expected_first);
            }
            Error::TriangleCountMismatch { header, sum } => {
                m.text("section PTCH: triangle_count ")
                    .u64(header)
                    .text(" but the patches cover ")
                    .u64(sum);
            }
            Error::UnsupportedEncoding { found } => {
                m.text("section VISB: unsupported encoding ")
                    .u64(found.into())
                    .text(" (encoding ")
                    .u64(consts::ENCODING_RAW.into())
                    .text(" is read from version 1, ")
                    .u64(consts::ENCODING_HIERARCHICAL.into())
                    .text(" from version 2, ")
                    .u64(consts::ENCODING_TREE.into())
                    .text(" from version 3)");
            }
            Error::PaddingBits { view, offset } => {
                m.text("section VISB: row of view ")
                    .u64(view.into())
                    .text(" sets bits past the last patch (byte ")
                    .u64(offset)
                    .text(")");
            }
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.message().as_str())
    }
}

#[cfg(feature = "std")]
impl std::error::Error for Error {}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::format;

    /// The longest messages fit a `Message` whole, and read as `core::fmt` would write them.
    #[test]
    fn the_longest_messages_fit() {
        let big = u64::MAX;
        let bounds = Error::SectionOutOfBounds {
            tag: [0xFF, 0, b'A', 2],
            offset: big,
            length: big,
            start: big,
            end: big,
        };
        let expected = format!(
            "section 0xFF004102: bytes {big}..{big}+{big} not inside {big}..{big} \
             (after the table or previous section, before the trailer)"
        );
        assert_eq!(bounds.message().as_str(), expected);
        for bits in [1, 0x8000_0001, 0xFF7F_FFFF, 0x0080_0001, 0x3E4C_CCCD] {
            let what = Rule::StepCenterRange;
            let e = Error::InvalidFloat {
                what,
                offset: big,
                bits,
            };
            let v = f32::from_bits(bits);
            assert_eq!(
                e.message().as_str(),
                format!("{}: found {v} at byte {big}", what.text())
            );
        }
        let invalid = Error::Invalid {
            what: Rule::RecordLength,
            offset: big,
            value: big,
        };
        assert_eq!(
            invalid.message().as_str(),
            format!("{}: found {big} at byte {big}", Rule::RecordLength.text())
        );
        for e in [bounds, invalid] {
            assert!(e.message().as_bytes().len() < Message::CAPACITY);
        }
    }
}
