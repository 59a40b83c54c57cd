//! Zero-copy binary little-endian PLY: decide whether the file's own records can serve the
//! mesh, and validate them in one pass.
//!
//! Requirements: vertex records of fixed size with `float` x, y, z anywhere among other scalar
//! properties; face records whose first property is `list uchar int|uint` (the index list) with
//! every count 3, followed only by scalars. Then a face record has a fixed size and
//! `Mesh::triangle` reads three `u32`s at `record + 1`. Cost: one sequential pass over the
//! face count bytes, one over the vertices (finiteness) and one over the indices;
//! about 1 ms for the 1.9 MB bunny.
//!
//! Anything that does not fit returns `None` and the file goes to the converting reader, which
//! also produces the precise error for truncated or malformed files. Bytes after the last
//! element are an error here already: the header's counts are too small for the data.

use super::super::error::{ErrorPosition, Fault, MeshErrorKind};
use super::super::{Layout, four};
use super::binary::BinaryCursor;
use super::header::{Encoding, Header, PropertyType, ScalarType};
use super::{InPlace, Schema};

/// The face list's count byte must say 3 for a record to have the fixed size this path needs.
const TRIANGLE_COUNT_BYTE: u8 = 3;

/// Reads the body in place when its layout allows; `Ok(None)` sends it to the converter.
pub(crate) fn try_read(
    bytes: &[u8],
    header: &Header,
    schema: &Schema,
) -> Result<Option<InPlace>, Fault> {
    if header.encoding != Encoding::BinaryLittleEndian {
        return Ok(None);
    }
    let vertices = &header.elements[schema.vertex];
    let faces = &header.elements[schema.face];
    let Some(vertex_stride) = vertices.fixed_size() else {
        return Ok(None);
    };
    let mut xyz = [0; 3];
    for (slot, &p) in xyz.iter_mut().zip(&schema.xyz) {
        if vertices.properties[p].ty != PropertyType::Scalar(ScalarType::F32) {
            return Ok(None);
        }
        *slot = offset_of(vertices, p);
    }
    let index_list_first = schema.indices == 0
        && matches!(
            faces.properties[0].ty,
            PropertyType::List {
                count: ScalarType::U8,
                item: ScalarType::I32 | ScalarType::U32,
            }
        );
    let rest: Option<usize> = faces.properties[1..]
        .iter()
        .map(|p| match p.ty {
            PropertyType::Scalar(s) => Some(s.size()),
            PropertyType::List { .. } => None,
        })
        .sum();
    let (true, Some(rest)) = (index_list_first, rest) else {
        return Ok(None);
    };
    let face_stride = 1 + 3 * 4 + rest;
    let Ok(triangle_count) = u32::try_from(faces.count) else {
        return Ok(None); // the converter reports the count
    };

    // Find the two elements' offsets, walking whatever precedes them.
    let mut cursor = BinaryCursor::new(bytes, header.body_offset, false);
    let (mut vertex_at, mut face_at) = (None, None);
    // Every element, so that data after the last one (counts that are too small) is found.
    for (i, element) in header.elements.iter().enumerate() {
        let stride = if i == schema.vertex {
            vertex_at = Some(cursor.offset);
            vertex_stride
        } else if i == schema.face {
            face_at = Some(cursor.offset);
            face_stride
        } else {
            if cursor.skip_element(element).is_err() {
                return Ok(None);
            }
            continue;
        };
        let len = usize::try_from(element.count)
            .ok()
            .and_then(|c| c.checked_mul(stride));
        match len.filter(|&n| n <= cursor.remaining()) {
            Some(n) => cursor.offset += n,
            None => return Ok(None),
        }
    }
    let (Some(vertex_at), Some(face_at)) = (vertex_at, face_at) else {
        return Ok(None);
    };
    let vertex_count = schema.vertex_count as usize;
    let face_bytes = &bytes[face_at..face_at + triangle_count as usize * face_stride];
    if face_bytes
        .iter()
        .step_by(face_stride)
        .any(|&c| c != TRIANGLE_COUNT_BYTE)
    {
        return Ok(None);
    }
    // Every record has the size assumed: bytes left over are data the header does not count.
    if cursor.remaining() > 0 {
        let extra = cursor.remaining();
        return Err(super::data_after_elements(
            header,
            schema,
            ErrorPosition::Byte(cursor.offset as u64),
            &format!("{extra} bytes"),
        ));
    }

    let vertex_bytes = &bytes[vertex_at..vertex_at + vertex_count * vertex_stride];
    for (v, record) in vertex_bytes.chunks_exact(vertex_stride).enumerate() {
        let p = xyz.map(|o| f32::from_le_bytes(four(record, o)));
        if !p.iter().all(|c| c.is_finite()) {
            return Err(Fault::at_byte(
                MeshErrorKind::NonFinite,
                vertex_at + v * vertex_stride,
                format!(
                    "vertex {v} is ({}, {}, {}), expected finite coordinates",
                    p[0], p[1], p[2]
                ),
            ));
        }
    }

    let signed = matches!(
        faces.properties[0].ty,
        PropertyType::List {
            item: ScalarType::I32,
            ..
        }
    );
    for (t, record) in face_bytes.chunks_exact(face_stride).enumerate() {
        for k in 0..3 {
            let index = u32::from_le_bytes(four(record, 1 + 4 * k));
            if index >= schema.vertex_count {
                let shown = if signed {
                    i64::from(index as i32)
                } else {
                    i64::from(index)
                };
                return Err(Fault::at_byte(
                    MeshErrorKind::BadIndex,
                    face_at + t * face_stride + 1 + 4 * k,
                    format!(
                        "face {t} has vertex index {shown}, expected < {} vertices",
                        schema.vertex_count
                    ),
                ));
            }
        }
    }

    Ok(Some(InPlace {
        layout: Layout {
            x: vertex_at + xyz[0],
            y: vertex_at + xyz[1],
            z: vertex_at + xyz[2],
            vertex_stride,
            index: face_at + 1,
            face_stride,
        },
        triangle_count,
    }))
}

/// Byte offset of scalar property `p` within a fixed-size record.
fn offset_of(element: &super::header::Element, p: usize) -> usize {
    element.properties[..p]
        .iter()
        .map(|q| match q.ty {
            PropertyType::Scalar(s) => s.size(),
            PropertyType::List { .. } => 0, // not reached: the record has a fixed size
        })
        .sum()
}
