//! Converting PLY reader: any encoding, any scalar types, any property order, polygons.
//!
//! Streams once through the body, element by element, keeping only `x, y, z` (as `f32`) and
//! the face index lists (fan-triangulated into `u32` triples: `(i0, ik, ik+1)`), which go
//! straight into the conversion cache ([`CacheWriter`]); everything else is read and dropped.
//! Nothing grows with the mesh: the only buffer is one polygon's index list. Cost: one pass;
//! ASCII is dominated by number parsing (`super::super::text`), binary by the per-value
//! byte-order match.

use super::super::Bounds;
use super::super::cache::CacheWriter;
use super::super::error::{ErrorPosition, Fault, MeshErrorKind};
use super::super::text::{integer, is_blank, parse_f32, parse_f64};
use super::binary::BinaryCursor;
use super::header::{Element, Encoding, Header, PropertyType, ScalarType};
use super::{BoundsBuilder, Schema};

/// One source of body values: ASCII tokens or binary bytes.
trait Values {
    /// The next scalar of type `ty`, exact in an `f64`.
    fn scalar(&mut self, ty: ScalarType) -> Result<f64, Fault>;
    /// A list count (an integer, checked non-negative).
    fn list_count(&mut self, ty: ScalarType) -> Result<u64, Fault>;
    /// Skips `count` values of `ty`.
    fn skip(&mut self, count: u64, ty: ScalarType) -> Result<(), Fault>;
    /// Skips a whole element.
    fn skip_element(&mut self, element: &Element) -> Result<(), Fault>;
    /// Where the next value starts (ASCII: skips blanks first to find its line).
    fn position(&mut self) -> ErrorPosition;
    /// Checks up front that a fixed-size element fits, for a clearer truncation message.
    fn check_fits(&self, element: &Element) -> Result<(), Fault>;
    /// After the last element: where the data that remain start and what they are, or `None`
    /// when nothing but blanks (ASCII) or nothing at all (binary) is left.
    fn leftover(&mut self) -> Option<(ErrorPosition, String)>;
}

impl Values for BinaryCursor<'_> {
    fn scalar(&mut self, ty: ScalarType) -> Result<f64, Fault> {
        BinaryCursor::scalar(self, ty)
    }
    fn list_count(&mut self, ty: ScalarType) -> Result<u64, Fault> {
        BinaryCursor::list_count(self, ty)
    }
    fn skip(&mut self, count: u64, ty: ScalarType) -> Result<(), Fault> {
        BinaryCursor::skip(self, count, ty)
    }
    fn skip_element(&mut self, element: &Element) -> Result<(), Fault> {
        BinaryCursor::skip_element(self, element)
    }
    fn position(&mut self) -> ErrorPosition {
        ErrorPosition::Byte(self.offset as u64)
    }
    fn leftover(&mut self) -> Option<(ErrorPosition, String)> {
        let extra = self.remaining();
        (extra > 0).then(|| (self.position(), format!("{extra} bytes")))
    }
    fn check_fits(&self, element: &Element) -> Result<(), Fault> {
        match element.fixed_size() {
            Some(size) if u128::from(element.count) * size as u128 > self.remaining() as u128 => {
                Err(self.element_truncated(element, size))
            }
            _ => Ok(()),
        }
    }
}

/// ASCII body: whitespace-separated tokens, line numbers kept for errors.
struct AsciiTokens<'a> {
    bytes: &'a [u8],
    offset: usize,
    line: u64,
}

impl<'a> AsciiTokens<'a> {
    #[inline]
    fn skip_blanks(&mut self) {
        while let Some(&b) = self.bytes.get(self.offset) {
            if !is_blank(b) {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.offset += 1;
        }
    }

    #[inline]
    fn next_token(&mut self, ty: ScalarType) -> Result<&'a [u8], Fault> {
        self.skip_blanks();
        let start = self.offset;
        let rest = &self.bytes[start..];
        let len = rest.iter().position(|&b| is_blank(b)).unwrap_or(rest.len());
        if len == 0 {
            return Err(Fault::at_line(
                MeshErrorKind::Truncated,
                self.line,
                format!("the file ends here, expected a {} value", ty.name()),
            ));
        }
        self.offset += len;
        Ok(&rest[..len])
    }
}

impl Values for AsciiTokens<'_> {
    #[inline]
    fn scalar(&mut self, ty: ScalarType) -> Result<f64, Fault> {
        let token = self.next_token(ty)?;
        let value = if ty.is_integer() {
            let (lo, hi) = ty.integer_range();
            integer(token)
                .filter(|v| (lo..=hi).contains(v))
                .map(|v| v as f64)
        } else if ty == ScalarType::F32 {
            // Parsed as f32 directly: going through f64 could round twice.
            parse_f32(token).map(f64::from)
        } else {
            parse_f64(token)
        };
        value.ok_or_else(|| {
            Fault::at_line(
                MeshErrorKind::BadValue,
                self.line,
                format!(
                    "expected a {} value, found '{}'",
                    ty.name(),
                    super::super::error::snippet(token)
                ),
            )
        })
    }
    fn list_count(&mut self, ty: ScalarType) -> Result<u64, Fault> {
        let count = self.scalar(ty)?;
        if count < 0.0 {
            return Err(Fault::at_line(
                MeshErrorKind::BadValue,
                self.line,
                format!("list count {count}, expected a non-negative count"),
            ));
        }
        Ok(count as u64)
    }
    fn skip(&mut self, count: u64, ty: ScalarType) -> Result<(), Fault> {
        for _ in 0..count {
            self.scalar(ty)?;
        }
        Ok(())
    }
    fn skip_element(&mut self, element: &Element) -> Result<(), Fault> {
        if element.properties.is_empty() {
            // Records without properties take no tokens; do not spin through a huge count.
            return Ok(());
        }
        for _ in 0..element.count {
            for p in &element.properties {
                match p.ty {
                    PropertyType::Scalar(s) => self.skip(1, s)?,
                    PropertyType::List { count, item } => {
                        let n = self.list_count(count)?;
                        self.skip(n, item)?;
                    }
                }
            }
        }
        Ok(())
    }
    fn position(&mut self) -> ErrorPosition {
        self.skip_blanks();
        ErrorPosition::Line(self.line)
    }
    fn check_fits(&self, _: &Element) -> Result<(), Fault> {
        Ok(())
    }
    fn leftover(&mut self) -> Option<(ErrorPosition, String)> {
        self.skip_blanks();
        let rest = &self.bytes[self.offset..];
        if rest.is_empty() {
            return None;
        }
        let line = &rest[..memchr::memchr(b'\n', rest).unwrap_or(rest.len())];
        let text = super::super::error::snippet(line.trim_ascii());
        Some((ErrorPosition::Line(self.line), format!("'{text}'")))
    }
}

/// Converts the whole body into `sink`; returns the bounds of the vertices.
pub(crate) fn read(
    bytes: &[u8],
    header: &Header,
    schema: &Schema,
    sink: &mut CacheWriter,
) -> Result<Bounds, Fault> {
    match header.encoding {
        Encoding::Ascii => run(
            &mut AsciiTokens {
                bytes,
                offset: header.body_offset,
                line: header.body_line,
            },
            header,
            schema,
            sink,
        ),
        Encoding::BinaryLittleEndian => run(
            &mut BinaryCursor::new(bytes, header.body_offset, false),
            header,
            schema,
            sink,
        ),
        Encoding::BinaryBigEndian => run(
            &mut BinaryCursor::new(bytes, header.body_offset, true),
            header,
            schema,
            sink,
        ),
    }
}

/// Reads the scalar properties `wanted` (indices into the vertex element) of every vertex,
/// in file order, and hands each vertex's values to `visit`: what `--mesh-out` keeps of a
/// PLY's vertices beside `x, y, z` (`super::super::attributes`). Stops after the vertices.
pub(crate) fn vertex_scalars(
    bytes: &[u8],
    header: &Header,
    schema: &Schema,
    wanted: &[usize],
    visit: &mut dyn FnMut(&[f64]) -> Result<(), Fault>,
) -> Result<(), Fault> {
    match header.encoding {
        Encoding::Ascii => scalars_of(
            &mut AsciiTokens {
                bytes,
                offset: header.body_offset,
                line: header.body_line,
            },
            header,
            schema,
            wanted,
            visit,
        ),
        Encoding::BinaryLittleEndian => scalars_of(
            &mut BinaryCursor::new(bytes, header.body_offset, false),
            header,
            schema,
            wanted,
            visit,
        ),
        Encoding::BinaryBigEndian => scalars_of(
            &mut BinaryCursor::new(bytes, header.body_offset, true),
            header,
            schema,
            wanted,
            visit,
        ),
    }
}

fn scalars_of(
    values: &mut impl Values,
    header: &Header,
    schema: &Schema,
    wanted: &[usize],
    visit: &mut dyn FnMut(&[f64]) -> Result<(), Fault>,
) -> Result<(), Fault> {
    let mut row = vec![0f64; wanted.len()];
    for element in &header.elements[..schema.vertex] {
        values.skip_element(element)?;
    }
    let element = &header.elements[schema.vertex];
    for _ in 0..element.count {
        for (i, property) in element.properties.iter().enumerate() {
            match property.ty {
                PropertyType::Scalar(s) => {
                    let value = values.scalar(s)?;
                    if let Some(k) = wanted.iter().position(|&w| w == i) {
                        row[k] = value;
                    }
                }
                PropertyType::List { count, item } => {
                    let n = values.list_count(count)?;
                    values.skip(n, item)?;
                }
            }
        }
        visit(&row)?;
    }
    Ok(())
}

fn run(
    values: &mut impl Values,
    header: &Header,
    schema: &Schema,
    sink: &mut CacheWriter,
) -> Result<Bounds, Fault> {
    let mut bounds = BoundsBuilder::new();
    // Every element, also those after the vertices and faces, so that data after the last
    // one (counts that are too small) is found rather than silently dropped.
    for (i, element) in header.elements.iter().enumerate() {
        values.check_fits(element)?;
        if i == schema.vertex {
            read_vertices(values, element, schema, sink, &mut bounds)?;
        } else if i == schema.face {
            read_faces(values, element, schema, sink)?;
        } else {
            values.skip_element(element)?;
        }
    }
    if let Some((at, found)) = values.leftover() {
        return Err(super::data_after_elements(header, schema, at, &found));
    }
    Ok(bounds.finish())
}

fn read_vertices(
    values: &mut impl Values,
    element: &Element,
    schema: &Schema,
    sink: &mut CacheWriter,
    bounds: &mut BoundsBuilder,
) -> Result<(), Fault> {
    for v in 0..element.count {
        let at = values.position();
        let mut p = [0f32; 3];
        for (i, property) in element.properties.iter().enumerate() {
            match property.ty {
                PropertyType::Scalar(s) => {
                    let value = values.scalar(s)?;
                    if let Some(k) = schema.xyz.iter().position(|&x| x == i) {
                        p[k] = value as f32;
                    }
                }
                PropertyType::List { count, item } => {
                    let n = values.list_count(count)?;
                    values.skip(n, item)?;
                }
            }
        }
        if !p.iter().all(|c| c.is_finite()) {
            return Err(Fault::new(
                MeshErrorKind::NonFinite,
                Some(at),
                format!(
                    "vertex {v} is ({}, {}, {}) as float, expected finite coordinates",
                    p[0], p[1], p[2]
                ),
            ));
        }
        bounds.add(p);
        sink.vertex(p).map_err(Fault::cache)?;
    }
    Ok(())
}

fn read_faces(
    values: &mut impl Values,
    element: &Element,
    schema: &Schema,
    sink: &mut CacheWriter,
) -> Result<(), Fault> {
    let mut polygon: Vec<u32> = Vec::new();
    for f in 0..element.count {
        for (i, property) in element.properties.iter().enumerate() {
            let PropertyType::List { count, item } = property.ty else {
                if let PropertyType::Scalar(s) = property.ty {
                    values.scalar(s)?;
                }
                continue;
            };
            let at = values.position();
            let n = values.list_count(count)?;
            if i != schema.indices {
                values.skip(n, item)?;
                continue;
            }
            if n < 3 {
                return Err(Fault::new(
                    MeshErrorKind::BadFace,
                    Some(at),
                    format!("face {f} has {n} vertices, expected at least 3"),
                ));
            }
            polygon.clear();
            for _ in 0..n {
                let at = values.position();
                let index = values.scalar(item)?;
                if !(0.0..f64::from(schema.vertex_count)).contains(&index) {
                    return Err(Fault::new(
                        MeshErrorKind::BadIndex,
                        Some(at),
                        format!(
                            "face {f} has vertex index {index}, expected < {} vertices",
                            schema.vertex_count
                        ),
                    ));
                }
                polygon.push(index as u32);
            }
            for pair in polygon[1..].windows(2) {
                sink.triangle([polygon[0], pair[0], pair[1]])
                    .map_err(Fault::cache)?;
            }
            if u32::try_from(sink.triangle_count()).is_err() {
                return Err(Fault::new(
                    MeshErrorKind::TooLarge,
                    Some(values.position()),
                    format!(
                        "more than {} triangles after splitting polygons, expected u32 indices",
                        u32::MAX
                    ),
                ));
            }
        }
    }
    Ok(())
}
