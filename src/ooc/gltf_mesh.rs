//! glTF 2.0 (`.gltf` JSON and `.glb` binary) to the conversion cache, streaming.
//!
//! The JSON is parsed and validated by the `gltf` crate (JSON only: no image decoding, no
//! buffer import); the GLB container, the buffers and the accessors are read here, so every
//! byte range is checked and every error names the JSON path and accessor index. What counts
//! as the mesh: every triangle primitive (`TRIANGLES`; `TRIANGLE_STRIP` and `TRIANGLE_FAN`
//! unrolled into triangles as glTF 2.0 § 3.7.2.1 specifies) of every mesh instance in the
//! default scene, or in all scenes when none is the default (with no scenes at all, every
//! root node), with node transforms (matrix or translation · rotation · scale) composed down
//! the hierarchy in `f64`. A mesh reached through two nodes appears twice. `POINTS` and
//! `LINE*` primitives are skipped. Positions must be `VEC3` of `FLOAT` and indices `SCALAR` of
//! unsigned byte, short or int; sparse accessors, accessors without a buffer view and required
//! extensions (Draco, meshopt, quantization) are refused by name. A transform with a negative
//! determinant mirrors the mesh; the triangle winding is flipped to keep front faces front.
//!
//! Buffers: the GLB `BIN` chunk and external `.bin` files (URIs relative to the glTF file,
//! percent-decoded) are memory-mapped, not copied; `data:` URIs are base64-decoded onto the
//! heap (they live inside the JSON, which is on the heap already). The output is never held
//! in memory: each primitive instance writes its transformed vertices and its triangles to the
//! cache as it is read. Cost: one pass over every instanced primitive's accessors.

use std::path::{Path, PathBuf};

use base64::Engine as _;
use glam::{DMat4, DVec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::json::validation::{Error as ValidationError, Validate};
use gltf::mesh::Mode;
use gltf::{Accessor, Document, Semantic};

use super::Bounds;
use super::cache::CacheWriter;
use super::error::{Fault, MeshErrorKind, snippet};
use super::ply::BoundsBuilder;
use crate::mapped::{Backing, FileBytes, open_regular};

/// `glTF`, the first four bytes of a GLB file.
const GLB_MAGIC: &[u8; 4] = b"glTF";
/// The only GLB container version (glTF 2.0).
const GLB_VERSION: u32 = 2;
/// GLB header: magic, version, total length.
const GLB_HEADER_BYTES: usize = 12;
/// Chunk header: length, type.
const CHUNK_HEADER_BYTES: usize = 8;
/// Chunk type `JSON` (little-endian `u32`).
const CHUNK_JSON: u32 = 0x4E4F_534A;
/// Chunk type `BIN\0`.
const CHUNK_BIN: u32 = 0x004E_4942;

/// A parsed, validated glTF document and where its GLB `BIN` chunk lies in the file.
pub(crate) struct Parsed {
    pub(crate) document: Document,
    /// Byte range of the `BIN` chunk's data (GLB only).
    bin: Option<std::ops::Range<usize>>,
}

impl Parsed {
    /// True when a buffer lives in another file: the conversion cache, keyed by this file
    /// alone, could then go stale, so such files are converted on every open.
    pub(crate) fn has_external_buffers(&self) -> bool {
        self.document.buffers().any(|b| match b.source() {
            gltf::buffer::Source::Uri(uri) => !uri.starts_with("data:"),
            gltf::buffer::Source::Bin => false,
        })
    }
}

/// Parses a `.gltf` (JSON) or `.glb` (binary container, recognised by its magic) file.
/// `glb_name`: the file is named `.glb`, so that bytes which are neither a GLB container nor
/// JSON are refused as "not a GLB file" rather than reported as JSON that does not parse.
pub(crate) fn parse(bytes: &[u8], glb_name: bool) -> Result<Parsed, Fault> {
    let json_text = bytes
        .iter()
        .find(|b| !b.is_ascii_whitespace())
        .is_some_and(|&b| b == b'{');
    if glb_name && !bytes.starts_with(GLB_MAGIC) && !json_text {
        let found: Vec<String> = bytes.iter().take(4).map(|b| format!("{b:02x}")).collect();
        return Err(Fault::at_byte(
            MeshErrorKind::BadHeader,
            0,
            format!(
                "not a GLB file: expected the magic 'glTF' (67 6c 54 46), found {}",
                found.join(" ")
            ),
        ));
    }
    let (json, bin) = if bytes.starts_with(GLB_MAGIC) {
        let (json, bin) = split_glb(bytes)?;
        (&bytes[json], bin)
    } else {
        (bytes, None)
    };
    let root = gltf::json::deserialize::from_slice::<gltf::json::Root>(json).map_err(|e| {
        let line = e.line() as u64;
        let message = format!("the glTF JSON does not parse: {e}");
        if bin.is_some() || line == 0 {
            Fault::new(MeshErrorKind::BadHeader, None, message)
        } else {
            Fault::at_line(MeshErrorKind::BadHeader, line, message)
        }
    })?;
    if let Some(extension) = root.extensions_required.first() {
        return Err(Fault::new(
            MeshErrorKind::UnsupportedFormat,
            None,
            format!(
                "extensionsRequired: the file needs the extension '{}', expected a glTF 2.0 \
                 file without required extensions",
                snippet(extension.as_bytes())
            ),
        ));
    }
    // gltf-json 1.4.1 indexes the POSITION accessor without a bounds check while validating
    // (a panic, found by fuzzing): check that index first.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(Semantic::Positions);
            if let Some(index) = primitive.attributes.get(&position)
                && index.value() >= root.accessors.len()
            {
                return Err(Fault::new(
                    MeshErrorKind::BadIndex,
                    None,
                    format!(
                        "meshes[{m}].primitives[{p}].attributes.POSITION: accessor {} does not \
                         exist, expected < {} accessors",
                        index.value(),
                        root.accessors.len()
                    ),
                ));
            }
        }
    }
    // The crate's validation, run here so that one omission can be let through: glTF asks
    // for POSITION `min`/`max`, exporters often leave them out, and nothing here reads them.
    // Everything else it reports is fatal (the accessors below rely on it).
    let mut problems = Vec::new();
    root.validate(&root, gltf::json::Path::new, &mut |path, error| {
        let path = path();
        let bounds = path.as_str().ends_with(".min") || path.as_str().ends_with(".max");
        if !(bounds && error == ValidationError::Missing) {
            problems.push((path, error));
        }
    });
    if let Some((path, problem)) = problems.first() {
        let kind = match problem {
            ValidationError::IndexOutOfBounds => MeshErrorKind::BadIndex,
            ValidationError::Missing => MeshErrorKind::MissingProperty,
            _ => MeshErrorKind::BadHeader,
        };
        let more = match problems.len() {
            1 => String::new(),
            n => format!(" (and {} more problems)", n - 1),
        };
        return Err(Fault::new(kind, None, format!("{path}: {problem}{more}")));
    }
    let document = Document::from_json_without_validation(root);
    Ok(Parsed { document, bin })
}

/// Splits a GLB container into its JSON chunk and optional `BIN` chunk (byte ranges).
#[allow(clippy::type_complexity)]
fn split_glb(
    bytes: &[u8],
) -> Result<(std::ops::Range<usize>, Option<std::ops::Range<usize>>), Fault> {
    use MeshErrorKind::*;
    let u32_at = |at: usize| u32::from_le_bytes(super::four(bytes, at));
    if bytes.len() < GLB_HEADER_BYTES {
        return Err(Fault::at_byte(
            Truncated,
            bytes.len(),
            format!(
                "the file ends after {} bytes, expected a {GLB_HEADER_BYTES}-byte GLB header",
                bytes.len()
            ),
        ));
    }
    let version = u32_at(4);
    if version != GLB_VERSION {
        return Err(Fault::at_byte(
            UnsupportedFormat,
            4,
            format!("GLB version {version}, expected {GLB_VERSION} (glTF 2.0)"),
        ));
    }
    let declared = u32_at(8) as usize;
    if declared > bytes.len() {
        return Err(Fault::at_byte(
            Truncated,
            bytes.len(),
            format!(
                "the file ends after {} bytes, but its GLB header declares {declared}",
                bytes.len()
            ),
        ));
    }
    let body = &bytes[..declared];
    let mut at = GLB_HEADER_BYTES;
    let (mut json, mut bin) = (None, None);
    while at < body.len() {
        if body.len() - at < CHUNK_HEADER_BYTES {
            return Err(Fault::at_byte(
                Truncated,
                at,
                format!(
                    "{} bytes left, expected an {CHUNK_HEADER_BYTES}-byte GLB chunk header",
                    body.len() - at
                ),
            ));
        }
        let (length, kind) = (u32_at(at) as usize, u32_at(at + 4));
        let data = at + CHUNK_HEADER_BYTES;
        if length > body.len() - data {
            return Err(Fault::at_byte(
                Truncated,
                at,
                format!(
                    "a GLB chunk of {length} bytes, but only {} bytes follow its header",
                    body.len() - data
                ),
            ));
        }
        match (json.is_some(), kind) {
            (false, CHUNK_JSON) => json = Some(data..data + length),
            (false, _) => {
                return Err(Fault::at_byte(
                    BadHeader,
                    at + 4,
                    format!("GLB chunk type {kind:#010x}, expected the JSON chunk first"),
                ));
            }
            (true, CHUNK_BIN) if bin.is_none() => bin = Some(data..data + length),
            // Later chunks of other types are extension data, ignored as the spec says.
            (true, _) => {}
        }
        at = data + length;
    }
    match json {
        Some(json) => Ok((json, bin)),
        None => Err(Fault::at_byte(
            Truncated,
            body.len(),
            "the GLB file ends here, expected a JSON chunk",
        )),
    }
}

/// One buffer's bytes: borrowed from the GLB, mapped from a `.bin` file, or decoded.
pub(crate) enum BufferBytes<'a> {
    Borrowed(&'a [u8]),
    Mapped(FileBytes),
    Owned(Vec<u8>),
}

impl BufferBytes<'_> {
    pub(crate) fn bytes(&self) -> &[u8] {
        match self {
            BufferBytes::Borrowed(b) => b,
            BufferBytes::Mapped(m) => m,
            BufferBytes::Owned(v) => v,
        }
    }
}

/// Loads every buffer, each checked to hold at least its declared `byteLength`.
pub(crate) fn load_buffers<'a>(
    bytes: &'a [u8],
    parsed: &Parsed,
    dir: &Path,
) -> Result<Vec<BufferBytes<'a>>, Fault> {
    use MeshErrorKind::*;
    let mut out = Vec::new();
    for buffer in parsed.document.buffers() {
        let i = buffer.index();
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => match &parsed.bin {
                Some(range) => BufferBytes::Borrowed(&bytes[range.clone()]),
                None => {
                    return Err(Fault::new(
                        MissingProperty,
                        None,
                        format!("buffers[{i}] has no uri, expected a GLB file with a BIN chunk"),
                    ));
                }
            },
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                BufferBytes::Owned(data_uri(uri, i)?)
            }
            gltf::buffer::Source::Uri(uri) => {
                let path = external_path(dir, uri, i)?;
                let io_error = |e: std::io::Error| {
                    Fault::new(
                        Io,
                        None,
                        format!("buffers[{i}].uri: cannot read '{}': {e}", path.display()),
                    )
                };
                // Checked before it is opened: a FIFO would block the open.
                let (file, metadata) = open_regular(&path).map_err(io_error)?;
                if metadata.len() == 0 {
                    BufferBytes::Owned(Vec::new())
                } else {
                    let bytes = FileBytes::open(&file, metadata.len(), Backing::Input(&path));
                    BufferBytes::Mapped(bytes.map_err(io_error)?)
                }
            }
        };
        if data.bytes().len() < buffer.length() {
            return Err(Fault::new(
                Truncated,
                None,
                format!(
                    "buffers[{i}] holds {} bytes, expected its byteLength {}",
                    data.bytes().len(),
                    buffer.length()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// Decodes a `data:[<media type>];base64,<data>` URI.
pub(crate) fn data_uri(uri: &str, buffer: usize) -> Result<Vec<u8>, Fault> {
    let bad = |what: String| {
        Fault::new(
            MeshErrorKind::BadValue,
            None,
            format!("buffers[{buffer}].uri: {what}"),
        )
    };
    let Some((head, payload)) = uri.split_once(',') else {
        return Err(bad(
            "a data URI without ',', expected data:…;base64,…".into()
        ));
    };
    if !head.ends_with(";base64") {
        return Err(bad(format!(
            "data URI '{}', expected base64 data (';base64,')",
            snippet(head.as_bytes())
        )));
    }
    // Padding is optional in practice: some exporters drop it.
    let engine = base64::engine::GeneralPurpose::new(
        &base64::alphabet::STANDARD,
        base64::engine::GeneralPurposeConfig::new()
            .with_decode_padding_mode(base64::engine::DecodePaddingMode::Indifferent),
    );
    engine
        .decode(payload.trim_ascii())
        .map_err(|e| bad(format!("invalid base64: {e}")))
}

/// The file an external buffer URI names: a relative reference, percent-decoded, resolved
/// against the glTF file's directory.
pub(crate) fn external_path(dir: &Path, uri: &str, buffer: usize) -> Result<PathBuf, Fault> {
    let unsupported = |what: &str| {
        Fault::new(
            MeshErrorKind::UnsupportedFormat,
            None,
            format!(
                "buffers[{buffer}].uri '{}': {what}, expected a relative file name or a data: URI",
                snippet(uri.as_bytes())
            ),
        )
    };
    // A scheme (`http:`, `file:`) comes before any '/'; relative references have none.
    let first_special = uri.find([':', '/', '?', '#']);
    if first_special.is_some_and(|at| uri.as_bytes()[at] == b':') {
        return Err(unsupported("a URI with a scheme"));
    }
    if uri.starts_with('/') {
        return Err(unsupported("an absolute path"));
    }
    let mut decoded = Vec::with_capacity(uri.len());
    let mut rest = uri.as_bytes();
    while let Some((&b, tail)) = rest.split_first() {
        if b == b'%' {
            let hex = tail.get(..2).and_then(|h| std::str::from_utf8(h).ok());
            let Some(value) = hex.and_then(|h| u8::from_str_radix(h, 16).ok()) else {
                return Err(unsupported("a malformed %-escape"));
            };
            decoded.push(value);
            rest = &tail[2..];
        } else {
            decoded.push(b);
            rest = tail;
        }
    }
    let Ok(decoded) = String::from_utf8(decoded) else {
        return Err(unsupported("%-escapes that are not UTF-8"));
    };
    Ok(dir.join(decoded))
}

/// An accessor's elements inside its buffer: element `i` starts at `i * stride`.
pub(crate) struct Strided<'b> {
    pub(crate) bytes: &'b [u8],
    pub(crate) stride: usize,
    pub(crate) count: usize,
    pub(crate) component: DataType,
}

impl Strided<'_> {
    /// Element `i` of a `VEC3` `FLOAT` accessor.
    #[inline]
    pub(crate) fn vec3(&self, i: usize) -> [f32; 3] {
        let at = i * self.stride;
        [0, 4, 8].map(|o| f32::from_le_bytes(super::four(self.bytes, at + o)))
    }
    /// Element `i` of a `SCALAR` unsigned-integer accessor.
    #[inline]
    fn index(&self, i: usize) -> u32 {
        let at = i * self.stride;
        match self.component {
            DataType::U8 => u32::from(self.bytes[at]),
            DataType::U16 => u32::from(u16::from_le_bytes([self.bytes[at], self.bytes[at + 1]])),
            _ => u32::from_le_bytes(super::four(self.bytes, at)),
        }
    }
}

/// Resolves `accessor` to its bytes, checked to lie inside its buffer view and buffer.
/// `role` says where it is used, for errors (`meshes[0].primitives[1].indices`).
pub(crate) fn strided<'b>(
    accessor: &Accessor,
    buffers: &'b [BufferBytes],
    role: &str,
) -> Result<Strided<'b>, Fault> {
    use MeshErrorKind::*;
    let a = accessor.index();
    let fail = |kind, what: String| {
        Err(Fault::new(
            kind,
            None,
            format!("{role}: accessor {a} {what}"),
        ))
    };
    if accessor.sparse().is_some() {
        return fail(
            UnsupportedFormat,
            "is sparse, expected a dense accessor".into(),
        );
    }
    let Some(view) = accessor.view() else {
        return fail(UnsupportedFormat, "has no bufferView, expected data".into());
    };
    let element = accessor.size();
    let stride = view.stride().unwrap_or(element);
    if stride < element {
        return fail(
            BadValue,
            format!(
                "has {element}-byte elements but bufferViews[{}].byteStride is {stride}",
                view.index()
            ),
        );
    }
    let data = buffers[view.buffer().index()].bytes();
    let view_end = view.offset().checked_add(view.length());
    if view_end.is_none_or(|end| end > view.buffer().length().min(data.len())) {
        return fail(
            Truncated,
            format!(
                "uses bufferViews[{}] (bytes {}..+{}), which does not fit in buffers[{}] ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                view.buffer().index(),
                view.buffer().length()
            ),
        );
    }
    let count = accessor.count();
    let needed = match count {
        0 => Some(0),
        n => (n - 1)
            .checked_mul(stride)
            .and_then(|b| b.checked_add(element))
            .and_then(|b| b.checked_add(accessor.offset())),
    };
    if needed.is_none_or(|n| n > view.length()) {
        return fail(
            Truncated,
            format!(
                "has {count} elements from byte {} of bufferViews[{}], which holds {} bytes",
                accessor.offset(),
                view.index(),
                view.length()
            ),
        );
    }
    // With elements, the check above puts the start inside the view; without, the offset
    // may point anywhere and is not used.
    let bytes = match count {
        0 => &[][..],
        _ => &data[view.offset() + accessor.offset()..view.offset() + view.length()],
    };
    Ok(Strided {
        bytes,
        stride,
        count,
        component: accessor.data_type(),
    })
}

/// Names a type for errors: `VEC2 of UNSIGNED_SHORT`.
pub(crate) fn type_name(accessor: &Accessor) -> String {
    let dims = match accessor.dimensions() {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    };
    let component = match accessor.data_type() {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    };
    format!("{dims} of {component}")
}

/// Counts while converting, for the final checks and messages.
struct Totals {
    bounds: BoundsBuilder,
    skipped_primitives: usize,
}

/// One node that holds a mesh, with its world transform.
pub(crate) struct Instance<'d> {
    /// The node's index.
    pub(crate) node: usize,
    pub(crate) mesh: gltf::Mesh<'d>,
    /// The node's transforms composed from its root, in `f64`.
    pub(crate) world: DMat4,
}

impl Instance<'_> {
    /// Names a primitive of this instance for errors.
    pub(crate) fn role(&self, primitive: &gltf::Primitive) -> String {
        format!(
            "meshes[{}].primitives[{}] (via nodes[{}])",
            self.mesh.index(),
            primitive.index(),
            self.node
        )
    }
}

/// The mesh instances of the scene(s) in the order the mesh is built from them: the nodes of
/// the default scene (or of all scenes; with no scenes, every root node), depth first.
pub(crate) fn instances(document: &Document) -> Result<Vec<Instance<'_>>, Fault> {
    use MeshErrorKind::*;
    // glTF requires the node hierarchy to be disjoint trees whose roots are the scenes'
    // nodes; checking that (at most one parent each, scene nodes parentless) also rules out
    // cycles and exponential re-instancing through shared children.
    let node_count = document.nodes().len();
    let mut parent: Vec<Option<usize>> = vec![None; node_count];
    for node in document.nodes() {
        for child in node.children() {
            let c = child.index();
            if let Some(first) = parent[c] {
                return Err(Fault::new(
                    BadHeader,
                    None,
                    format!(
                        "nodes[{c}] is a child of nodes[{first}] and nodes[{}], expected one \
                         parent (a tree)",
                        node.index()
                    ),
                ));
            }
            parent[c] = Some(node.index());
        }
    }
    let scenes: Vec<gltf::Scene> = match document.default_scene() {
        Some(scene) => vec![scene],
        None => document.scenes().collect(),
    };
    let mut roots: Vec<usize> = Vec::new();
    for scene in &scenes {
        for (k, node) in scene.nodes().enumerate() {
            if let Some(p) = parent[node.index()] {
                return Err(Fault::new(
                    BadHeader,
                    None,
                    format!(
                        "scenes[{}].nodes[{k}]: nodes[{}] is a child of nodes[{p}], expected a \
                         root node",
                        scene.index(),
                        node.index()
                    ),
                ));
            }
            roots.push(node.index());
        }
    }
    if scenes.is_empty() {
        roots.extend((0..node_count).filter(|&n| parent[n].is_none()));
    }

    let nodes: Vec<gltf::Node> = document.nodes().collect();
    let mut out = Vec::new();
    // Depth-first with an explicit stack: a deep hierarchy cannot overflow the call stack.
    let mut stack: Vec<(usize, DMat4)> =
        roots.iter().rev().map(|&n| (n, DMat4::IDENTITY)).collect();
    while let Some((n, parent_transform)) = stack.pop() {
        let node = &nodes[n];
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent_transform * local;
        if let Some(mesh) = node.mesh() {
            out.push(Instance {
                node: n,
                mesh,
                world,
            });
        }
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child.index(), world));
        }
    }
    Ok(out)
}

/// Converts the document's scene(s) into `sink`; returns the bounds.
pub(crate) fn convert(
    bytes: &[u8],
    parsed: &Parsed,
    dir: &Path,
    sink: &mut CacheWriter,
) -> Result<Bounds, Fault> {
    use MeshErrorKind::*;
    let document = &parsed.document;
    let buffers = load_buffers(bytes, parsed, dir)?;
    let mut totals = Totals {
        bounds: BoundsBuilder::new(),
        skipped_primitives: 0,
    };
    for instance in instances(document)? {
        for primitive in instance.mesh.primitives() {
            emit(&instance, &primitive, &buffers, sink, &mut totals)?;
        }
    }

    if sink.triangle_count() == 0 {
        let skipped = match totals.skipped_primitives {
            0 => String::new(),
            n => format!(" ({n} point or line primitives skipped)"),
        };
        return Err(Fault::new(
            NoFaces,
            None,
            format!(
                "no triangles: the scene has {} vertices in triangle primitives{skipped}, \
                 expected at least one triangle",
                sink.vertex_count()
            ),
        ));
    }
    Ok(totals.bounds.finish())
}

/// Writes `primitive` of `instance`: its positions under the instance's world matrix, then
/// its triangles.
fn emit(
    instance: &Instance,
    primitive: &gltf::Primitive,
    buffers: &[BufferBytes],
    sink: &mut CacheWriter,
    totals: &mut Totals,
) -> Result<(), Fault> {
    let (role, world) = (&instance.role(primitive), &instance.world);
    let mode = primitive.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        totals.skipped_primitives += 1;
        return Ok(());
    }
    let positions = emit_positions(primitive, role, world, buffers, sink, totals)?;
    let indices = indices(primitive, role, buffers)?;
    emit_triangles(mode, role, world, &positions, indices.as_ref(), sink)
}

/// Where a primitive's vertices went in the cache.
struct Emitted {
    /// Its `POSITION` accessor, for errors.
    accessor: usize,
    /// Its vertex count.
    count: usize,
    /// The cache's index of its first vertex.
    base: u64,
}

/// Writes a primitive's `POSITION` accessor under `world`: `VEC3` of `FLOAT`, finite after
/// the transform, and the scene's vertices still numbered by `u32`.
fn emit_positions(
    primitive: &gltf::Primitive,
    role: &str,
    world: &DMat4,
    buffers: &[BufferBytes],
    sink: &mut CacheWriter,
    totals: &mut Totals,
) -> Result<Emitted, Fault> {
    use MeshErrorKind::*;
    let Some(positions) = primitive.get(&Semantic::Positions) else {
        return Err(Fault::new(
            MissingProperty,
            None,
            format!("{role}: no POSITION attribute, expected one"),
        ));
    };
    let position_role = format!("{role}.attributes.POSITION");
    if positions.dimensions() != Dimensions::Vec3 || positions.data_type() != DataType::F32 {
        return Err(Fault::new(
            UnsupportedFormat,
            None,
            format!(
                "{position_role}: accessor {} is {}, expected VEC3 of FLOAT",
                positions.index(),
                type_name(&positions)
            ),
        ));
    }
    let points = strided(&positions, buffers, &position_role)?;
    let base = sink.vertex_count();
    if base + points.count as u64 > u64::from(u32::MAX) {
        return Err(Fault::new(
            TooLarge,
            None,
            format!(
                "{role}: more than {} vertices in the scene, expected u32 indices",
                u32::MAX
            ),
        ));
    }
    for i in 0..points.count {
        let p = points.vec3(i);
        let q = world
            .transform_point3(DVec3::from(p.map(f64::from)))
            .as_vec3()
            .to_array();
        if !q.iter().all(|c| c.is_finite()) {
            // Name the stored value when it is the culprit, else the transformed one.
            let (shown, why) = if p.iter().all(|c| c.is_finite()) {
                (q, "after the node transform ")
            } else {
                (p, "")
            };
            return Err(Fault::new(
                NonFinite,
                None,
                format!(
                    "{position_role}: accessor {} element {i} is ({}, {}, {}) {why}as float, \
                     expected finite coordinates",
                    positions.index(),
                    shown[0],
                    shown[1],
                    shown[2]
                ),
            ));
        }
        totals.bounds.add(q);
        sink.vertex(q).map_err(Fault::cache)?;
    }
    Ok(Emitted {
        accessor: positions.index(),
        count: points.count,
        base,
    })
}

/// A primitive's indices accessor, with its role for errors.
struct Indices<'b> {
    accessor: usize,
    role: String,
    data: Strided<'b>,
}

/// The primitive's indices accessor, checked to be `SCALAR` of an unsigned integer type; none
/// when the primitive has none (its vertices in order).
fn indices<'b>(
    primitive: &gltf::Primitive,
    role: &str,
    buffers: &'b [BufferBytes],
) -> Result<Option<Indices<'b>>, Fault> {
    let Some(accessor) = primitive.indices() else {
        return Ok(None);
    };
    let index_role = format!("{role}.indices");
    if accessor.dimensions() != Dimensions::Scalar
        || !matches!(
            accessor.data_type(),
            DataType::U8 | DataType::U16 | DataType::U32
        )
    {
        return Err(Fault::new(
            MeshErrorKind::UnsupportedFormat,
            None,
            format!(
                "{index_role}: accessor {} is {}, expected SCALAR of UNSIGNED_BYTE, \
                 UNSIGNED_SHORT or UNSIGNED_INT",
                accessor.index(),
                type_name(&accessor)
            ),
        ));
    }
    let data = strided(&accessor, buffers, &index_role)?;
    Ok(Some(Indices {
        accessor: accessor.index(),
        role: index_role,
        data,
    }))
}

/// Writes the triangles of a primitive in `mode` over its vertices `positions`, through
/// `indices` (or in order without): each index checked against the vertex count, the count
/// fitting the mode, the scene's triangles still numbered by `u32`, and the winding kept
/// under a mirroring `world`.
fn emit_triangles(
    mode: Mode,
    role: &str,
    world: &DMat4,
    positions: &Emitted,
    indices: Option<&Indices>,
    sink: &mut CacheWriter,
) -> Result<(), Fault> {
    use MeshErrorKind::*;
    let base = positions.base;
    let k = indices.map_or(positions.count, |i| i.data.count);
    let vertex = |j: usize| -> Result<u32, Fault> {
        let Some(Indices {
            accessor: a,
            role: index_role,
            data,
        }) = indices
        else {
            return Ok(base as u32 + j as u32);
        };
        let i = data.index(j);
        if i as usize >= positions.count {
            return Err(Fault::new(
                BadIndex,
                None,
                format!(
                    "{index_role}: accessor {a} element {j} is {i}, expected < {} (the count of \
                     POSITION accessor {})",
                    positions.count, positions.accessor
                ),
            ));
        }
        Ok(base as u32 + i)
    };
    let triangles = match mode {
        Mode::Triangles if !k.is_multiple_of(3) => {
            return Err(Fault::new(
                BadFace,
                None,
                format!("{role}: {k} vertices in TRIANGLES mode, expected a multiple of 3"),
            ));
        }
        Mode::Triangles => k / 3,
        _ if k > 0 && k < 3 => {
            return Err(Fault::new(
                BadFace,
                None,
                format!("{role}: {k} vertices in a strip or fan, expected at least 3"),
            ));
        }
        _ => k.saturating_sub(2),
    };
    if sink.triangle_count() + triangles as u64 > u64::from(u32::MAX) {
        return Err(Fault::new(
            TooLarge,
            None,
            format!(
                "{role}: more than {} triangles in the scene, expected u32 indices",
                u32::MAX
            ),
        ));
    }
    // A mirroring transform turns counter-clockwise triangles clockwise: swap to keep them.
    let mirrored = world.determinant() < 0.0;
    for t in 0..triangles {
        // glTF 2.0 § 3.7.2.1: strips alternate winding, fans pivot on the first vertex.
        let [a, b, c] = match mode {
            Mode::Triangles => [3 * t, 3 * t + 1, 3 * t + 2],
            Mode::TriangleStrip => [t, t + 1 + t % 2, t + 2 - t % 2],
            _ => [t + 1, t + 2, 0],
        };
        let (a, b, c) = (vertex(a)?, vertex(b)?, vertex(c)?);
        let triangle = if mirrored { [a, c, b] } else { [a, b, c] };
        sink.triangle(triangle).map_err(Fault::cache)?;
    }
    Ok(())
}
