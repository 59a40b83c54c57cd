//! The PLY header: a small line-based parser that keeps line numbers for its errors.
//!
//! Follows Greg Turk's PLY description (1994) as the common exporters write it: `ply`, one
//! `format ascii|binary_little_endian|binary_big_endian 1.0` line, `comment`/`obj_info` lines,
//! `element <name> <count>` each followed by its `property <type> <name>` or
//! `property list <count type> <item type> <name>` lines, then `end_header`. CRLF line endings
//! and trailing blanks are accepted. Free text before the first `element` is tolerated as a
//! comment, because old Blender exporters wrote their banner without the `comment` keyword.
//!
//! Hand-written rather than `ply-rs`: that crate reads bodies into per-element hash maps (far
//! too slow and large for multi-million-triangle meshes) and its errors carry no line numbers
//! or byte offsets. Cost: linear in the header's length, a few hundred bytes.

use super::super::error::{Fault, MeshErrorKind, snippet};

/// How the body is encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Encoding {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

/// A PLY scalar type; the names and aliases of the PLY description.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ScalarType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl ScalarType {
    fn parse(name: &str) -> Option<ScalarType> {
        Some(match name {
            "char" | "int8" => ScalarType::I8,
            "uchar" | "uint8" => ScalarType::U8,
            "short" | "int16" => ScalarType::I16,
            "ushort" | "uint16" => ScalarType::U16,
            "int" | "int32" => ScalarType::I32,
            "uint" | "uint32" => ScalarType::U32,
            "float" | "float32" => ScalarType::F32,
            "double" | "float64" => ScalarType::F64,
            _ => return None,
        })
    }

    /// Size in bytes in a binary body.
    pub(crate) fn size(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }

    pub(crate) fn is_integer(self) -> bool {
        !matches!(self, ScalarType::F32 | ScalarType::F64)
    }

    /// The canonical PLY name, for messages.
    pub(crate) fn name(self) -> &'static str {
        match self {
            ScalarType::I8 => "char",
            ScalarType::U8 => "uchar",
            ScalarType::I16 => "short",
            ScalarType::U16 => "ushort",
            ScalarType::I32 => "int",
            ScalarType::U32 => "uint",
            ScalarType::F32 => "float",
            ScalarType::F64 => "double",
        }
    }

    /// The inclusive range of an integer type, for checking ASCII values.
    pub(crate) fn integer_range(self) -> (i64, i64) {
        match self {
            ScalarType::I8 => (i8::MIN.into(), i8::MAX.into()),
            ScalarType::U8 => (0, u8::MAX.into()),
            ScalarType::I16 => (i16::MIN.into(), i16::MAX.into()),
            ScalarType::U16 => (0, u16::MAX.into()),
            ScalarType::I32 => (i32::MIN.into(), i32::MAX.into()),
            ScalarType::U32 => (0, u32::MAX.into()),
            ScalarType::F32 | ScalarType::F64 => (i64::MIN, i64::MAX),
        }
    }
}

/// A property's type: one scalar, or a list with a count and items.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PropertyType {
    Scalar(ScalarType),
    List { count: ScalarType, item: ScalarType },
}

/// One `property` line.
#[derive(Clone, Debug)]
pub(crate) struct Property {
    pub(crate) name: String,
    pub(crate) ty: PropertyType,
}

/// One `element` line and its properties.
#[derive(Clone, Debug)]
pub(crate) struct Element {
    pub(crate) name: String,
    pub(crate) count: u64,
    pub(crate) properties: Vec<Property>,
    /// Line of the `element` keyword, for errors about the element as a whole.
    pub(crate) line: u64,
}

impl Element {
    /// Bytes per record in a binary body, when no property is a list.
    pub(crate) fn fixed_size(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p.ty {
                PropertyType::Scalar(s) => Some(s.size()),
                PropertyType::List { .. } => None,
            })
            .sum()
    }

    /// Index of the first property called `name`.
    pub(crate) fn property(&self, name: &str) -> Option<usize> {
        self.properties.iter().position(|p| p.name == name)
    }
}

/// A parsed header.
#[derive(Clone, Debug)]
pub(crate) struct Header {
    pub(crate) encoding: Encoding,
    pub(crate) elements: Vec<Element>,
    /// Byte offset of the body (just past the `end_header` line's newline).
    pub(crate) body_offset: usize,
    /// Line number of the body's first line (ASCII bodies).
    pub(crate) body_line: u64,
}

/// Parses the header at the start of `bytes`.
pub(crate) fn parse(bytes: &[u8]) -> Result<Header, Fault> {
    use MeshErrorKind::{BadHeader, UnsupportedFormat};
    // Checked before looking for line ends, so a large non-PLY file fails at once.
    let first_end = bytes
        .iter()
        .take(16)
        .position(|&b| b == b'\n')
        .unwrap_or(bytes.len().min(16));
    if trim_line(&bytes[..first_end]) != b"ply" {
        return Err(Fault::at_line(
            BadHeader,
            1,
            format!(
                "expected 'ply' (a PLY file), found '{}'",
                snippet(&bytes[..bytes.len().min(40)])
            ),
        ));
    }

    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut offset = 0;
    let mut line_number = 0u64;
    loop {
        line_number += 1;
        let Some(len) = bytes[offset..].iter().position(|&b| b == b'\n') else {
            return Err(Fault::at_line(
                BadHeader,
                line_number,
                "the file ends inside the header, expected 'end_header'",
            ));
        };
        let raw = &bytes[offset..offset + len];
        offset += len + 1;
        if line_number == 1 {
            continue; // `ply`, checked above
        }
        let text = String::from_utf8_lossy(trim_line(raw));
        let words: Vec<&str> = text.split_ascii_whitespace().collect();
        let bad = |expected: &str| {
            Fault::at_line(
                BadHeader,
                line_number,
                format!("expected {expected}, found '{}'", snippet(raw)),
            )
        };
        match words.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                if encoding.is_some() {
                    return Err(bad("a single 'format' line"));
                }
                let [_, name, version] = words[..] else {
                    return Err(bad("'format <encoding> 1.0'"));
                };
                encoding = Some(match name {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::BinaryLittleEndian,
                    "binary_big_endian" => Encoding::BinaryBigEndian,
                    _ => {
                        return Err(Fault::at_line(
                            UnsupportedFormat,
                            line_number,
                            format!(
                                "unsupported format '{}', expected ascii, \
                                 binary_little_endian or binary_big_endian",
                                snippet(name.as_bytes())
                            ),
                        ));
                    }
                });
                if version != "1.0" {
                    return Err(Fault::at_line(
                        UnsupportedFormat,
                        line_number,
                        format!(
                            "unsupported PLY version '{}', expected 1.0",
                            snippet(version.as_bytes())
                        ),
                    ));
                }
            }
            Some("element") => {
                let [_, name, count] = words[..] else {
                    return Err(bad("'element <name> <count>'"));
                };
                let Ok(count) = count.parse::<u64>() else {
                    return Err(bad("'element <name> <count>' with a non-negative count"));
                };
                if elements.iter().any(|e| e.name == name) {
                    return Err(bad("each element name once"));
                }
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                    line: line_number,
                });
            }
            Some("property") => {
                let Some(element) = elements.last_mut() else {
                    return Err(bad("'element <name> <count>' before the first 'property'"));
                };
                let ty = match words[..] {
                    [_, "list", count, item, _] => {
                        let count = scalar_type(count, line_number)?;
                        let item = scalar_type(item, line_number)?;
                        if !count.is_integer() {
                            return Err(bad("an integer list count type"));
                        }
                        PropertyType::List { count, item }
                    }
                    [_, ty, _] if ty != "list" => {
                        PropertyType::Scalar(scalar_type(ty, line_number)?)
                    }
                    _ => {
                        return Err(bad(
                            "'property <type> <name>' or 'property list <count type> <item type> <name>'",
                        ));
                    }
                };
                let name = words[words.len() - 1].to_string();
                element.properties.push(Property { name, ty });
            }
            Some("end_header") => break,
            // Free text before the first element: see the module header.
            Some(_) if elements.is_empty() => {}
            Some(_) => {
                return Err(bad("'property <type> <name>', 'element' or 'end_header'"));
            }
        }
    }
    let Some(encoding) = encoding else {
        return Err(Fault::at_line(
            BadHeader,
            line_number,
            "expected a 'format' line before 'end_header'",
        ));
    };
    Ok(Header {
        encoding,
        elements,
        body_offset: offset,
        body_line: line_number + 1,
    })
}

fn scalar_type(name: &str, line: u64) -> Result<ScalarType, Fault> {
    ScalarType::parse(name).ok_or_else(|| {
        Fault::at_line(
            MeshErrorKind::BadHeader,
            line,
            format!(
                "unknown type '{}', expected char, uchar, short, ushort, int, uint, float, \
                 double or an alias (int8 … float64)",
                snippet(name.as_bytes())
            ),
        )
    })
}

/// A header line without its `\r` (CRLF files) and surrounding blanks.
fn trim_line(line: &[u8]) -> &[u8] {
    line.trim_ascii()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_types_aliases_and_crlf() {
        let text = b"ply\r\nformat binary_big_endian 1.0\r\ncomment hi\r\nobj_info x\r\n\
            element vertex 3\r\nproperty float64 x\r\nproperty int8 y\r\nproperty ushort z\r\n\
            element face 1\r\nproperty list int16 uint32 vertex_index\r\nend_header\r\nBODY";
        let h = parse(text).unwrap();
        assert_eq!(h.encoding, Encoding::BinaryBigEndian);
        assert_eq!(&text[h.body_offset..], b"BODY");
        assert_eq!(h.body_line, 12);
        assert_eq!(h.elements.len(), 2);
        assert_eq!(h.elements[0].fixed_size(), Some(8 + 1 + 2));
        assert_eq!(
            h.elements[1].properties[0].ty,
            PropertyType::List {
                count: ScalarType::I16,
                item: ScalarType::U32
            }
        );
        assert_eq!(h.elements[1].fixed_size(), None);
    }

    #[test]
    fn misspelt_keyword_names_the_line() {
        let text = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\npropertee float y\nend_header\n";
        let err = parse(text).unwrap_err();
        assert_eq!(err.kind, MeshErrorKind::BadHeader);
        assert_eq!(
            err.position,
            Some(super::super::super::error::ErrorPosition::Line(5))
        );
        assert!(
            err.message.contains("found 'propertee float y'"),
            "{}",
            err.message
        );
    }

    #[test]
    fn unsupported_format_and_missing_end() {
        let err = parse(b"ply\nformat binary_middle_endian 1.0\nend_header\n").unwrap_err();
        assert_eq!(err.kind, MeshErrorKind::UnsupportedFormat);
        let err = parse(b"ply\nformat ascii 1.0\nelement vertex 1\n").unwrap_err();
        assert_eq!(err.kind, MeshErrorKind::BadHeader);
        assert!(err.message.contains("end_header"));
        let err = parse(b"PK\x03\x04garbage").unwrap_err();
        assert_eq!(err.kind, MeshErrorKind::BadHeader);
    }
}
