//! Wavefront OBJ to the conversion cache, streaming.
//!
//! Reads `v x y z [w]` (extra values such as vertex colours ignored) and `f` with the corner
//! forms `v`, `v/vt`, `v//vn`, `v/vt/vn`, positive (1-based) or negative (relative to the
//! vertices read so far) indices; polygons are fan-triangulated `(c0, ck, ck+1)`. Texture
//! coordinates, normals, objects, groups, materials, smoothing groups, lines, points and the
//! free-form statements are read past; all objects and groups form one mesh. An unknown
//! statement is an error (a renamed binary file is refused on its first line rather than
//! read as an empty mesh). Faces may refer to vertices defined later in the file, as the
//! format allows; the largest index is checked once the vertex count is known.
//!
//! Memory: one polygon's corners; cost: one pass, dominated by float parsing.

use super::Bounds;
use super::cache::CacheWriter;
use super::error::{Fault, MeshErrorKind, snippet};
use super::ply::BoundsBuilder;
use super::text::{Lines, finite_f32, integer, tokens};

/// Statements read past: texture and normal data, grouping, materials, display attributes,
/// lines and points, and the free-form geometry statements (curves and surfaces are not
/// triangulated; their control points `v` still count as vertices).
const IGNORED: &[&[u8]] = &[
    b"vt",
    b"vn",
    b"vp",
    b"o",
    b"g",
    b"s",
    b"usemtl",
    b"mtllib",
    b"usemap",
    b"maplib",
    b"l",
    b"p",
    b"mg",
    b"cstype",
    b"deg",
    b"bmat",
    b"step",
    b"curv",
    b"curv2",
    b"surf",
    b"parm",
    b"trim",
    b"hole",
    b"scrv",
    b"sp",
    b"end",
    b"con",
    b"bevel",
    b"c_interp",
    b"d_interp",
    b"lod",
    b"shadow_obj",
    b"trace_obj",
    b"ctech",
    b"stech",
    b"call",
    b"csh",
];

/// Converts an OBJ file into `sink`; returns the bounds.
pub(crate) fn convert(bytes: &[u8], sink: &mut CacheWriter) -> Result<Bounds, Fault> {
    use MeshErrorKind::*;
    let mut bounds = BoundsBuilder::new();
    let mut polygon: Vec<u32> = Vec::new();
    // The largest vertex index used and the line using it, checked at the end.
    let mut largest: Option<(u32, u64)> = None;
    let mut last_line = 0;
    for (line, text) in Lines::new(bytes) {
        last_line = line;
        let mut words = tokens(text);
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            b"v" => {
                let x = finite_f32(words.next(), line, "x")?;
                let y = finite_f32(words.next(), line, "y")?;
                let z = finite_f32(words.next(), line, "z")?;
                if sink.vertex_count() >= u64::from(u32::MAX) {
                    return Err(Fault::at_line(
                        TooLarge,
                        line,
                        format!("more than {} vertices, expected u32 indices", u32::MAX),
                    ));
                }
                bounds.add([x, y, z]);
                sink.vertex([x, y, z]).map_err(Fault::cache)?;
            }
            b"f" => {
                polygon.clear();
                for corner in words {
                    let index_text = corner.split(|&b| b == b'/').next().unwrap_or(corner);
                    let index = resolve(index_text, sink.vertex_count(), line)?;
                    if largest.is_none_or(|(i, _)| index > i) {
                        largest = Some((index, line));
                    }
                    polygon.push(index);
                }
                if polygon.len() < 3 {
                    return Err(Fault::at_line(
                        BadFace,
                        line,
                        format!("face with {} vertices, expected at least 3", polygon.len()),
                    ));
                }
                for pair in polygon[1..].windows(2) {
                    sink.triangle([polygon[0], pair[0], pair[1]])
                        .map_err(Fault::cache)?;
                }
                if sink.triangle_count() > u64::from(u32::MAX) {
                    return Err(Fault::at_line(
                        TooLarge,
                        line,
                        format!("more than {} triangles, expected u32 indices", u32::MAX),
                    ));
                }
            }
            _ if keyword[0] == b'#' => {}
            _ if IGNORED.contains(&keyword) => {}
            _ => {
                return Err(Fault::at_line(
                    BadHeader,
                    line,
                    format!(
                        "unknown statement '{}', expected an OBJ statement such as v, f, vt, \
                         vn, o, g or usemtl",
                        snippet(keyword)
                    ),
                ));
            }
        }
    }
    let vertices = sink.vertex_count();
    if vertices == 0 {
        return Err(Fault::at_line(
            NoVertices,
            last_line.max(1),
            "no 'v' statements, expected vertices and faces",
        ));
    }
    let Some((index, line)) = largest else {
        return Err(Fault::at_line(
            NoFaces,
            last_line,
            format!("point cloud: the file has {vertices} vertices but no faces"),
        ));
    };
    if u64::from(index) >= vertices {
        return Err(Fault::at_line(
            BadIndex,
            line,
            format!(
                "face refers to vertex {}, expected at most {vertices} (the file's vertex count)",
                u64::from(index) + 1
            ),
        ));
    }
    Ok(bounds.finish())
}

/// A 0-based vertex index from an OBJ index: `1..` absolute, `-1..` relative to the `seen`
/// vertices so far.
fn resolve(text: &[u8], seen: u64, line: u64) -> Result<u32, Fault> {
    let bad = |message: String| Err(Fault::at_line(MeshErrorKind::BadIndex, line, message));
    match integer(text) {
        Some(i) if i > 0 => match u32::try_from(i - 1) {
            Ok(i) => Ok(i),
            Err(_) => bad(format!("vertex index {i}, expected at most {}", u32::MAX)),
        },
        Some(0) => bad("vertex index 0, expected 1-based (or negative, relative) indices".into()),
        Some(i) => {
            let absolute = seen as i64 + i;
            if absolute < 0 {
                return bad(format!(
                    "relative vertex index {i}, but only {seen} vertices precede it"
                ));
            }
            Ok(absolute as u32)
        }
        None => Err(Fault::at_line(
            MeshErrorKind::BadValue,
            line,
            format!("expected a vertex index, found '{}'", snippet(text)),
        )),
    }
}
