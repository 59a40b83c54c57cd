//! Why the reader refused a file: one small `Copy` enum carrying the values that caused it.
//!
//! Every variant's message ([`Error::message`], also its `Display`) is one precise line saying
//! what was found, where, and what the spec (`spec/FORMAT.md`) expects. Its words are a
//! template per kind of error ([`MESSAGE_TEMPLATES`]) with holes for the values
//! ([`Error::parts`]), and what a refused field is and which rule it breaks is a [`Rule`], a
//! one-byte id whose text ([`RULE_TEXTS`]) fills a hole. The message is built with the
//! reader's own small formatter (`message.rs`) rather than `core::fmt`: a build that never
//! prints an error (a microcontroller) carries neither the texts nor a formatter, one that
//! does (the C ABI) carries no `core::fmt`, and one whose host prints the message from the
//! parts (WebAssembly, whose JavaScript holds a generated copy of the templates) carries
//! neither. `std::error::Error` comes with the `std` feature.

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
    /// VISB (or a shell's payload in SHEL) uses an encoding this reader does not know.
    UnsupportedEncoding {
        /// The section: VISB, or SHEL for a shell's payload.
        tag: [u8; 4],
        /// The encoding in the file.
        found: u32,
    },
    /// A visibility row sets bits past the last patch.
    PaddingBits {
        /// The section: VISB, or SHEL for a shell's payload.
        tag: [u8; 4],
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
    /// `SHEL shell_count must be in 1..=8`
    ShellCount,
    /// `SHEL reach must be 0, or finite and above CAMR distance with a shell beyond it`
    ShelReach,
    /// `SHEL distance must be finite, below the previous shell's (CAMR distance for the
    /// first before version 6), not CAMR distance and >= CAMR radius`
    ShellDistance,
    /// `SHEL shell level`
    ShellLevel,
    /// `SHEL payload reserved field must be 0`: [`Rule::VisbReserved`] in a shell's payload.
    ShelPayloadReserved,
    /// `SHEL payload probability must be in 1..4096`
    ShelProbability,
    /// `SHEL payload tree node count must be in 1..=1024`
    ShelTreeNodeCount,
    /// `SHEL payload tree leaf must hold a probability in 1..4096`
    ShelTreeLeaf,
    /// `SHEL payload tree node must test a feature below 23`
    ShelTreeFeature,
    /// `SHEL payload tree node's children must follow it inside the tree`
    ShelTreeChildren,
    /// `SHEL payload tree depth`
    ShelTreeDepth,
    /// `SHEL payload checkpoint must be the offset of its view's record`
    ShelCheckpoint,
    /// `SHEL payload record length must be a LEB128 of at most 4 bytes inside the payload`
    ShelRecordLength,
    /// `SHEL payload record length must be a minimal LEB128`
    ShelRecordLengthMinimal,
    /// `SHEL payload code length`
    ShelCodeLength,
    /// `SHEL payload code must not end in a zero byte`
    ShelCodeEnd,
}

impl Rule {
    /// The words a message prints for this rule.
    pub fn text(self) -> &'static str {
        RULE_TEXTS.get(self as usize).copied().unwrap_or("")
    }

    /// The rule as a shell's payload breaks it: [`Error::in_shell_payload`].
    fn in_shell_payload(self) -> Rule {
        match self {
            Rule::VisbReserved => Rule::ShelPayloadReserved,
            Rule::VisbProbability => Rule::ShelProbability,
            Rule::TreeNodeCount => Rule::ShelTreeNodeCount,
            Rule::TreeLeaf => Rule::ShelTreeLeaf,
            Rule::TreeFeature => Rule::ShelTreeFeature,
            Rule::TreeChildren => Rule::ShelTreeChildren,
            Rule::TreeDepth => Rule::ShelTreeDepth,
            Rule::Checkpoint => Rule::ShelCheckpoint,
            Rule::RecordLength => Rule::ShelRecordLength,
            Rule::RecordLengthMinimal => Rule::ShelRecordLengthMinimal,
            Rule::CodeLength => Rule::ShelCodeLength,
            Rule::CodeEnd => Rule::ShelCodeEnd,
            other => other,
        }
    }
}

impl Error {
    /// Names SHEL in the error of a shell's payload. A payload follows the rules of VISB (spec
    /// § SHEL), and its faults name SHEL, where its bytes lie, as the section's other faults
    /// do.
    pub(crate) fn in_shell_payload(mut self) -> Error {
        if let Error::Invalid { what, .. } | Error::LimitExceeded { what, .. } = &mut self {
            *what = what.in_shell_payload();
        }
        self
    }
}

/// What each [`Rule`] prints, in declaration order (`RULE_TEXTS[rule as usize]`): the `{r}`
/// of [`MESSAGE_TEMPLATES`].
pub const RULE_TEXTS: [&str; 62] = [
    "header section_count must be at least 1",
    "section_count",
    "header reserved field must be 0",
    "section table reserved field must be 0",
    "bytes between sections must be 0",
    "sphere level",
    "CAMR center must be finite",
    "CAMR radius must be finite and > 0",
    "CAMR distance must be finite and >= radius",
    "CAMR fov_deg must be in (0, 180)",
    "CAMR resolution must be at least 1",
    "CAMR sphere_convention must be 1",
    "CAMR reserved field must be 0",
    "PTCH patch_count must be at least 1",
    "patch_count",
    "triangle_count",
    "PTCH reserved field must be 0",
    "PTCH patch center must be finite",
    "PTCH patch radius must be finite and >= 0",
    "PTCH patch cone_axis must be finite",
    "PTCH patch cone_cos must be in [-1, 1]",
    "PTCH origin must be finite",
    "PTCH step must be finite and > 0",
    "PTCH count_bits must be at most 32",
    "PTCH center_bits must be at most 24",
    "PTCH radius_bits must be at most 24",
    "PTCH axis_bits must be in 2..=16",
    "PTCH cos_bits must be in 1..=16",
    "PTCH reserved bytes must be 0",
    "PTCH step must keep origin + (2^center_bits - 1) * step finite",
    "PTCH step must keep (2^radius_bits - 1) * step finite",
    "PTCH block start must equal the sum of the counts before it",
    "PTCH record's axis coordinate must be at most 2^axis_bits - 2",
    "PTCH bits after the last record must be 0",
    "VISB reserved field must be 0",
    "VISB probability must be in 1..4096",
    "VISB tree node count must be in 1..=1024",
    "VISB tree leaf must hold a probability in 1..4096",
    "VISB tree node must test a feature below 23",
    "VISB tree node's children must follow it inside the tree",
    "VISB tree depth",
    "VISB checkpoint must be the offset of its view's record",
    "VISB record length must be a LEB128 of at most 4 bytes inside the section",
    "VISB record length must be a minimal LEB128",
    "VISB code length",
    "VISB code must not end in a zero byte",
    "SHEL shell_count must be in 1..=8",
    "SHEL reach must be 0, or finite and above CAMR distance with a shell beyond it",
    "SHEL distance must be finite, below the previous shell's \
     (CAMR distance for the first before version 6), not CAMR distance and >= CAMR radius",
    "SHEL shell level",
    "SHEL payload reserved field must be 0",
    "SHEL payload probability must be in 1..4096",
    "SHEL payload tree node count must be in 1..=1024",
    "SHEL payload tree leaf must hold a probability in 1..4096",
    "SHEL payload tree node must test a feature below 23",
    "SHEL payload tree node's children must follow it inside the tree",
    "SHEL payload tree depth",
    "SHEL payload checkpoint must be the offset of its view's record",
    "SHEL payload record length must be a LEB128 of at most 4 bytes inside the payload",
    "SHEL payload record length must be a minimal LEB128",
    "SHEL payload code length",
    "SHEL payload code must not end in a zero byte",
];

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
        consts::TAG_SHEL => consts::SHEL_HEADER_LEN,
        _ => 0,
    }
}

/// What a message is made of: the template of the error's kind and the values of its holes.
/// [`Error::message`] fills them in; a host that prints messages itself (the WebAssembly
/// module's JavaScript, through the C ABI's `patchvis_error_parts`) gets these instead, so
/// that the reader it embeds carries neither the texts nor a number formatter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MessageParts {
    /// The error's kind: its index in [`MESSAGE_TEMPLATES`] (the declaration order of
    /// [`Error`]).
    pub kind: u32,
    /// The values of the template's holes, in order; unused ones are 0.
    pub values: [u64; 6],
}

/// The message of each kind of [`Error`], in declaration order, with holes filled in order
/// from [`MessageParts::values`]: `{}` a value in decimal; `{x}` a `u32` as `0x` and eight
/// upper-case hexadecimal digits; `{t}` a section tag given as its big-endian `u32`, as text
/// when its four bytes are printable ASCII and else as `{x}`; `{f}` an `f32` given by its
/// bits, as `Display` writes it (shortest round-trip digits, no exponent; `NaN`, `inf`);
/// `{r}` the text of the [`Rule`] with that index ([`RULE_TEXTS`]). The one source of every
/// message's words: `npm/patchvis.mjs` holds a copy generated from these by a test.
pub const MESSAGE_TEMPLATES: [&str; 20] = [
    "truncated: needed {} bytes, have {}",
    "not a .pvis file: bad signature",
    "unsupported version {}: this reader understands version {}",
    "unknown header flags {x}",
    "length mismatch: header says {} bytes, data has {}",
    "checksum mismatch: trailer has CRC-32C {x}, data has {x}",
    "missing section {t}",
    "section {t} appears twice",
    "section {t}: shorter than its {}-byte fixed part",
    "section {t}: length {} but its contents need {}",
    "section {t}: bytes {}..{}+{} not inside {}..{} \
     (after the table or previous section, before the trailer)",
    "section {t}: offset {} is not a multiple of {}",
    "{r} {} exceeds the limit {}",
    "{r}: found {} at byte {}",
    "{r}: found {f} at byte {}",
    "section CAMR: view_count {} but level {} has {} views",
    "section PTCH: patch {} covers triangles {}+{}, \
     expected a non-empty range starting at {}",
    "section PTCH: triangle_count {} but the patches cover {}",
    "section {t}: unsupported encoding {} \
     (encoding {} is read from version 1, {} from version 2, {} from version 3)",
    "section {t}: row of view {} sets bits past the last patch (byte {})",
];

impl Error {
    /// The one-line message: what was found, where, and what the spec expects. Exactly the
    /// `Display` text, made without `core::fmt`.
    pub fn message(&self) -> Message {
        let mut m = Message::new();
        self.write(&mut m);
        m
    }

    /// The template and values the message is made of (see [`MessageParts`]).
    pub fn parts(&self) -> MessageParts {
        let tag = |t: [u8; 4]| u64::from(u32::from_be_bytes(t));
        let (kind, values): (u32, [u64; 6]) = match *self {
            Error::Truncated { needed, have } => (0, [needed, have, 0, 0, 0, 0]),
            Error::BadMagic => (1, [0, 0, 0, 0, 0, 0]),
            Error::UnsupportedVersion { found } => {
                (2, [found.into(), consts::VERSION.into(), 0, 0, 0, 0])
            }
            Error::UnknownFlags { flags } => {
                (3, [(flags & !consts::KNOWN_FLAGS).into(), 0, 0, 0, 0, 0])
            }
            Error::LengthMismatch { header, actual } => (4, [header, actual, 0, 0, 0, 0]),
            Error::ChecksumMismatch { stored, computed } => {
                (5, [stored.into(), computed.into(), 0, 0, 0, 0])
            }
            Error::MissingSection { tag: t } => (6, [tag(t), 0, 0, 0, 0, 0]),
            Error::DuplicateSection { tag: t } => (7, [tag(t), 0, 0, 0, 0, 0]),
            Error::BadSection { tag: t } => (8, [tag(t), fixed_len(t), 0, 0, 0, 0]),
            Error::SectionLength {
                tag: t,
                length,
                expected,
            } => (9, [tag(t), length, expected, 0, 0, 0]),
            Error::SectionOutOfBounds {
                tag: t,
                offset,
                length,
                start,
                end,
            } => (10, [tag(t), offset, offset, length, start, end]),
            Error::SectionMisaligned { tag: t, offset } => {
                (11, [tag(t), offset, consts::SECTION_ALIGN, 0, 0, 0])
            }
            Error::LimitExceeded { what, value, limit } => {
                (12, [what as u64, value, limit, 0, 0, 0])
            }
            Error::Invalid {
                what,
                offset,
                value,
            } => (13, [what as u64, value, offset, 0, 0, 0]),
            Error::InvalidFloat { what, offset, bits } => {
                (14, [what as u64, bits.into(), offset, 0, 0, 0])
            }
            Error::ViewCountMismatch {
                level,
                found,
                expected,
            } => (15, [found.into(), level.into(), expected.into(), 0, 0, 0]),
            Error::PatchRange {
                patch,
                first,
                count,
                expected_first,
            } => (
                16,
                [
                    patch.into(),
                    first.into(),
                    count.into(),
                    expected_first,
                    0,
                    0,
                ],
            ),
            Error::TriangleCountMismatch { header, sum } => (17, [header, sum, 0, 0, 0, 0]),
            Error::UnsupportedEncoding { tag: t, found } => (
                18,
                [
                    tag(t),
                    found.into(),
                    consts::ENCODING_RAW.into(),
                    consts::ENCODING_HIERARCHICAL.into(),
                    consts::ENCODING_TREE.into(),
                    0,
                ],
            ),
            Error::PaddingBits {
                tag: t,
                view,
                offset,
            } => (19, [tag(t), view.into(), offset, 0, 0, 0]),
        };
        MessageParts { kind, values }
    }

    /// Writes [`Error::message`] into `m`: the kind's template with its holes filled. One
    /// out-of-line function, so the texts and the formatter exist once in a build however
    /// many callers print errors.
    #[inline(never)]
    fn write(&self, m: &mut Message) {
        let parts = self.parts();
        let mut values = parts.values.into_iter();
        let template = MESSAGE_TEMPLATES.get(parts.kind as usize).copied();
        let mut rest = template.unwrap_or("").as_bytes();
        while let Some(open) = rest.iter().position(|&b| b == b'{') {
            let close = rest[open..].iter().position(|&b| b == b'}').unwrap_or(1) + open;
            m.bytes(&rest[..open]);
            let v = values.next().unwrap_or(0);
            match rest.get(open + 1..close) {
                Some(b"x") => m.hex32(v as u32),
                Some(b"t") => m.tag((v as u32).to_be_bytes()),
                Some(b"f") => m.f32(f32::from_bits(v as u32)),
                Some(b"r") => m.text(RULE_TEXTS.get(v as usize).copied().unwrap_or("")),
                _ => m.u64(v),
            };
            rest = rest.get(close + 1..).unwrap_or(&[]);
        }
        m.bytes(rest);
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
