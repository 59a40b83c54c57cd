//! PLY input: find the vertex and face elements, then serve them in place or convert them.
//!
//! A binary little-endian file whose vertices carry `float x, y, z` in fixed-size records and
//! whose faces are fixed-size records starting with `list uchar int|uint vertex_indices`, every
//! count 3, is used in place ([`in_place`]): opening costs one validation pass over the mapped
//! bytes. Everything else (ASCII, big-endian, `double` or integer coordinates, polygons, any
//! property order) is converted once, streaming through the file ([`convert`]), into the
//! conversion cache (`super::cache`).

mod binary;
mod convert;
pub(crate) mod header;
mod in_place;

use super::Bounds;
use super::error::{ErrorPosition, Fault, MeshErrorKind};
use header::{Header, PropertyType};

/// Where the mesh lives in a PLY file's header: element and property indices.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Schema {
    /// Index of the `vertex` element.
    pub(crate) vertex: usize,
    /// Property indices of `x`, `y`, `z` within it (all scalars).
    pub(crate) xyz: [usize; 3],
    pub(crate) vertex_count: u32,
    /// Index of the `face` element.
    pub(crate) face: usize,
    /// Property index of its `vertex_indices` (or `vertex_index`) list, integer items.
    pub(crate) indices: usize,
}

/// A PLY body whose own bytes serve the mesh.
pub(crate) struct InPlace {
    pub(crate) layout: super::Layout,
    pub(crate) triangle_count: u32,
}

/// A parsed header and the mesh's place in it.
pub(crate) struct Parsed {
    header: Header,
    pub(crate) schema: Schema,
}

/// Parses the header and locates the mesh.
pub(crate) fn parse(bytes: &[u8]) -> Result<Parsed, Fault> {
    let header = header::parse(bytes)?;
    let schema = schema(&header)?;
    Ok(Parsed { header, schema })
}

/// Validates the body in place, when its layout allows (`Ok(None)`: it must be converted).
pub(crate) fn in_place(bytes: &[u8], parsed: &Parsed) -> Result<Option<InPlace>, Fault> {
    in_place::try_read(bytes, &parsed.header, &parsed.schema)
}

/// Converts the body into `sink`; returns the bounds.
pub(crate) fn convert(
    bytes: &[u8],
    parsed: &Parsed,
    sink: &mut super::cache::CacheWriter,
) -> Result<Bounds, Fault> {
    convert::read(bytes, &parsed.header, &parsed.schema, sink)
}

/// The vertex element's scalar property named one of `names`, as an index into it.
pub(crate) fn vertex_property(parsed: &Parsed, names: &[&str]) -> Option<usize> {
    let element = &parsed.header.elements[parsed.schema.vertex];
    names.iter().find_map(|n| {
        element
            .property(n)
            .filter(|&i| matches!(element.properties[i].ty, PropertyType::Scalar(_)))
    })
}

/// Whether the vertex property `index` holds integers (colours as `uchar`, say).
pub(crate) fn vertex_property_is_integer(parsed: &Parsed, index: usize) -> bool {
    let element = &parsed.header.elements[parsed.schema.vertex];
    matches!(element.properties[index].ty, PropertyType::Scalar(s) if s.is_integer())
}

/// Reads the vertex properties `wanted` of every vertex (see `convert::vertex_scalars`).
pub(crate) fn vertex_scalars(
    bytes: &[u8],
    parsed: &Parsed,
    wanted: &[usize],
    visit: &mut dyn FnMut(&[f64]) -> Result<(), Fault>,
) -> Result<(), Fault> {
    convert::vertex_scalars(bytes, &parsed.header, &parsed.schema, wanted, visit)
}

/// Locates and checks the vertex and face elements.
fn schema(header: &Header) -> Result<Schema, Fault> {
    use MeshErrorKind::*;
    let end_line = header.body_line - 1;
    let find = |name: &str| header.elements.iter().position(|e| e.name == name);

    let Some(vertex) = find("vertex") else {
        return Err(Fault::at_line(
            NoVertices,
            end_line,
            "the header has no 'vertex' element, expected one with x, y and z",
        ));
    };
    let element = &header.elements[vertex];
    let mut xyz = [0; 3];
    for (slot, name) in xyz.iter_mut().zip(["x", "y", "z"]) {
        let Some(p) = element.property(name) else {
            return Err(Fault::at_line(
                MissingProperty,
                element.line,
                format!("element 'vertex' has no property '{name}', expected x, y and z"),
            ));
        };
        if !matches!(element.properties[p].ty, PropertyType::Scalar(_)) {
            return Err(Fault::at_line(
                BadHeader,
                element.line,
                format!("vertex property '{name}' is a list, expected a scalar"),
            ));
        }
        *slot = p;
    }
    if element.count == 0 {
        return Err(Fault::at_line(
            NoVertices,
            element.line,
            "element 'vertex' has 0 vertices, expected at least 1",
        ));
    }
    let Ok(vertex_count) = u32::try_from(element.count) else {
        return Err(Fault::at_line(
            TooLarge,
            element.line,
            format!(
                "{} vertices, expected at most {} (u32 indices)",
                element.count,
                u32::MAX
            ),
        ));
    };

    let point_cloud = || {
        Fault::at_line(
            NoFaces,
            end_line,
            format!("point cloud: the file has {vertex_count} vertices but no faces"),
        )
    };
    let Some(face) = find("face") else {
        return Err(point_cloud());
    };
    let element = &header.elements[face];
    let Some(indices) = element
        .property("vertex_indices")
        .or_else(|| element.property("vertex_index"))
    else {
        return Err(Fault::at_line(
            MissingProperty,
            element.line,
            "element 'face' has no 'vertex_indices' (or 'vertex_index') list",
        ));
    };
    match element.properties[indices].ty {
        PropertyType::List { item, .. } if item.is_integer() => {}
        _ => {
            return Err(Fault::at_line(
                BadHeader,
                element.line,
                "expected 'property list <count type> <integer type> vertex_indices'",
            ));
        }
    }
    if element.count == 0 {
        return Err(point_cloud());
    }
    Ok(Schema {
        vertex,
        xyz,
        vertex_count,
        face,
        indices,
    })
}

/// The fault for data after the header's last element, found at `at` (`found` says what is
/// there): the header declares fewer vertices or faces than the file holds, and baking only
/// the declared ones would silently drop the rest.
pub(crate) fn data_after_elements(
    header: &Header,
    schema: &Schema,
    at: ErrorPosition,
    found: &str,
) -> Fault {
    let last = header
        .elements
        .last()
        .map_or("element", |e| e.name.as_str());
    Fault::new(
        MeshErrorKind::CountMismatch,
        Some(at),
        format!(
            "{found} after the last declared {last} (the header declares {} vertices and {} \
             faces); the header's counts do not match the data",
            schema.vertex_count, header.elements[schema.face].count
        ),
    )
}

/// Grows bounds one point at a time; the first point sets them.
pub(crate) struct BoundsBuilder {
    bounds: Bounds,
}

impl BoundsBuilder {
    pub(crate) fn new() -> BoundsBuilder {
        BoundsBuilder {
            bounds: Bounds {
                min: [f32::INFINITY; 3],
                max: [f32::NEG_INFINITY; 3],
            },
        }
    }
    #[inline]
    pub(crate) fn add(&mut self, p: [f32; 3]) {
        for ((lo, hi), c) in self.bounds.min.iter_mut().zip(&mut self.bounds.max).zip(p) {
            *lo = lo.min(c);
            *hi = hi.max(c);
        }
    }
    pub(crate) fn finish(self) -> Bounds {
        self.bounds
    }
}
