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
///
/// Errors are reported in file order. A face may name a vertex defined further on, so an
/// index past the end is known only once the vertices are counted: then the file is scanned
/// again for the first face whose index is out of range, and that face is reported if it
/// comes before any other error (a later malformed line does not hide an earlier bad face).
/// The second scan happens only on the error path.
pub(crate) fn convert(bytes: &[u8], sink: &mut CacheWriter) -> Result<Bounds, Fault> {
    use MeshErrorKind::*;
    let mut bounds = BoundsBuilder::new();
    let mut polygon: Vec<u32> = Vec::new();
    // The largest vertex index used, checked at the end.
    let mut largest: Option<u32> = None;
    let mut last_line = 0;
    for (line, text) in Lines::new(bytes) {
        last_line = line;
        let read = statement(line, text, sink, &mut bounds, &mut polygon, &mut largest);
        if let Err(fault) = read {
            // A face before this line may already point past the last vertex.
            let pending = largest.is_some_and(|i| u64::from(i) >= sink.vertex_count());
            if pending {
                let vertices = sink.vertex_count() + vertex_statements_from(bytes, line + 1);
                if let Some(earlier) = first_bad_index(bytes, vertices, line) {
                    return Err(earlier);
                }
            }
            return Err(fault);
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
    let Some(index) = largest else {
        return Err(Fault::at_line(
            NoFaces,
            last_line,
            format!("point cloud: the file has {vertices} vertices but no faces"),
        ));
    };
    if u64::from(index) >= vertices {
        // Only an absolute index can point past the end, so the scan finds this one.
        return Err(
            first_bad_index(bytes, vertices, u64::MAX).unwrap_or_else(|| {
                Fault::new(
                    BadIndex,
                    None,
                    format!(
                        "a face refers to vertex {}, expected at most {vertices}",
                        u64::from(index) + 1
                    ),
                )
            }),
        );
    }
    Ok(bounds.finish())
}

/// Reads one line: a vertex, a face, or a statement read past.
fn statement(
    line: u64,
    text: &[u8],
    sink: &mut CacheWriter,
    bounds: &mut BoundsBuilder,
    polygon: &mut Vec<u32>,
    largest: &mut Option<u32>,
) -> Result<(), Fault> {
    use MeshErrorKind::*;
    let mut words = tokens(text);
    let Some(keyword) = words.next() else {
        return Ok(());
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
                let index = resolve(corner_index(corner), sink.vertex_count(), line)?;
                if largest.is_none_or(|i| index > i) {
                    *largest = Some(index);
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
    Ok(())
}

/// The vertex index of a face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`.
fn corner_index(corner: &[u8]) -> &[u8] {
    corner.split(|&b| b == b'/').next().unwrap_or(corner)
}

/// The number of `v` statements on line `from` and after it.
fn vertex_statements_from(bytes: &[u8], from: u64) -> u64 {
    Lines::new(bytes)
        .skip_while(|&(line, _)| line < from)
        .filter(|(_, text)| tokens(text).next() == Some(b"v"))
        .count() as u64
}

/// The first face before line `before` with an absolute index past `vertices`, as the error
/// to report. (A relative index counts back from the vertices read so far, so it cannot
/// point past the end.)
fn first_bad_index(bytes: &[u8], vertices: u64, before: u64) -> Option<Fault> {
    Lines::new(bytes)
        .take_while(|&(line, _)| line < before)
        .find_map(|(line, text)| {
            let mut words = tokens(text);
            if words.next() != Some(b"f") {
                return None;
            }
            let index = words
                .filter_map(|corner| integer(corner_index(corner)))
                .find(|&i| i > 0 && (i - 1) as u64 >= vertices)?;
            Some(Fault::at_line(
                MeshErrorKind::BadIndex,
                line,
                format!(
                    "face refers to vertex {index}, expected at most {vertices} (the file's \
                     vertex count)"
                ),
            ))
        })
}

/// A 0-based vertex index from an OBJ index: `1..` absolute, `-1..` relative to the `seen`
/// vertices so far.
pub(crate) fn resolve(text: &[u8], seen: u64, line: u64) -> Result<u32, Fault> {
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
