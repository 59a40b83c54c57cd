//! `--mesh-out X.glb` / `X.gltf`: glTF 2.0 for engines and viewers.
//!
//! One mesh, one buffer. The buffer holds, in this order: `POSITION`, `NORMAL` (the input's,
//! renormalised, else area-weighted vertex normals), `TEXCOORD_0` and `COLOR_0` (normalised
//! `UNSIGNED_BYTE` `VEC4`) when the input had them, then one index buffer view of `UNSIGNED_INT`
//! triangles in the output order, then the original triangle index of every output triangle,
//! then the material images (PNG or JPEG, embedded). Each primitive is a run of one material
//! (`super::sequence`); its index accessor is a slice of the one index view, so patch `i`'s
//! triangles are elements `3·first[i]..3·first[i+1]` of that view whichever primitive they
//! fall in. The mesh's `extras.patchvis` says so:
//!
//! ```json
//! { "patch_count": P, "triangle_count": T,
//!   "patch_first_triangle": [first[0], …, first[P - 1], T],
//!   "index_buffer_view": k, "original_triangle_buffer_view": m }
//! ```
//!
//! and each primitive's `extras.patchvis` gives its `first_triangle` and `triangle_count`.
//! `patch_first_triangle` is the `.pvis` file's patch table: patch `i` covers triangles
//! `first[i]..first[i + 1]`, exactly the range a query returns for it.
//!
//! A `.glb` is the JSON chunk and the binary chunk; a `.gltf` carries the buffer as a base64
//! `data:` URI, so that either is one self-contained file. Streaming: the vertex and index
//! data go from the mapped mesh and attributes to the output through a buffer; computed normals
//! are accumulated in a mapped temporary file. Deterministic: one thread, fixed order.

use std::io::{self, BufWriter, Write};

use serde_json::{Value, json};

use super::Sequence;
use crate::mapped::Array;
use crate::ooc::Mesh;
use crate::ooc::attributes::{AlphaMode, Attributes, Material, NO_MATERIAL};

/// Output buffer size.
const WRITE_BUFFER_BYTES: usize = 64 * 1024;
/// Stands in for the `.gltf` buffer's URI until the JSON is written.
const URI_PLACEHOLDER: &str = "patchvis:bin";
/// `ARRAY_BUFFER` and `ELEMENT_ARRAY_BUFFER` buffer view targets.
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
/// Component types.
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const UNSIGNED_BYTE: u32 = 5121;
/// The normal of a vertex whose faces have no area (glTF requires unit normals).
const FALLBACK_NORMAL: [f32; 3] = [0.0, 0.0, 1.0];

/// Writes the glTF (`glb`: binary container) of `mesh` in `sequence`'s order.
pub(super) fn write(
    out: &mut impl Write,
    glb: bool,
    mesh: &Mesh,
    attributes: &Attributes,
    sequence: &Sequence,
) -> io::Result<()> {
    let normals = Normals::new(mesh, attributes)?;
    let (document, buffer_length) = document(glb, mesh, attributes, sequence);
    let text = serde_json::to_string(&document).map_err(io::Error::other)?;
    let mut out = BufWriter::with_capacity(WRITE_BUFFER_BYTES, out);
    let bin = |out: &mut dyn Write| {
        write_buffer(out, mesh, attributes, sequence, &normals, buffer_length)
    };
    if glb {
        write_glb(&mut out, &text, buffer_length, bin)?;
    } else {
        write_gltf(&mut out, &text, bin)?;
    }
    out.flush()
}

/// The `NORMAL` of each output vertex: the input's, else the area-weighted normal of its
/// source vertex (computed only when some vertex lacks one), scaled to unit length.
struct Normals {
    /// [`vertex_normals`] of the mesh, where the input lacks normals.
    computed: Option<Array<[f32; 3]>>,
}

impl Normals {
    /// Computes the vertex normals if any output vertex has none in `attributes`.
    fn new(mesh: &Mesh, attributes: &Attributes) -> io::Result<Normals> {
        let computed = if (0..attributes.vertex_count()).all(|o| attributes.normal(o).is_some()) {
            None
        } else {
            Some(vertex_normals(mesh)?)
        };
        Ok(Normals { computed })
    }

    /// The unit normal of output vertex `o`.
    fn of(&self, attributes: &Attributes, o: u32) -> [f32; 3] {
        let n = attributes.normal(o).unwrap_or_else(|| {
            self.computed
                .as_ref()
                .map_or(FALLBACK_NORMAL, |c| c[attributes.source(o) as usize])
        });
        unit(n)
    }
}

/// The buffer views, in buffer order: each starts on a 4-byte boundary.
#[derive(Default)]
struct BufferViews {
    /// The views' JSON.
    views: Vec<Value>,
    /// The buffer's length so far: where the next view starts.
    length: u64,
}

impl BufferViews {
    /// Appends a view of `length` bytes, for `target` if it has one; returns its index.
    fn push(&mut self, length: u64, target: Option<u32>) -> usize {
        let mut v = json!({ "buffer": 0, "byteOffset": self.length, "byteLength": length });
        if let Some(target) = target {
            v["target"] = json!(target);
        }
        self.views.push(v);
        self.length += length.next_multiple_of(4);
        self.views.len() - 1
    }
}

/// The glTF document of `mesh` in `sequence`'s order, and the length of its buffer.
fn document(glb: bool, mesh: &Mesh, attributes: &Attributes, sequence: &Sequence) -> (Value, u64) {
    let mut views = BufferViews::default();
    let (mut accessors, attribute_map) = vertex_accessors(&mut views, mesh, attributes);
    let t = u64::from(sequence.triangle_count());
    let index_view = views.push(12 * t, Some(ELEMENT_ARRAY_BUFFER));
    let original_view = views.push(4 * t, None);
    let materials = materials_json(&mut views, attributes.materials());
    let buffer_length = views.length;
    let primitives = primitives(sequence, &attribute_map, index_view, &mut accessors);
    let firsts = sequence.patch_firsts();
    let mut buffer = json!({ "byteLength": buffer_length });
    if !glb {
        buffer["uri"] = json!(URI_PLACEHOLDER);
    }
    let mut document = json!({
        "asset": { "version": "2.0", "generator": "patchvis --mesh-out" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{
            "primitives": primitives,
            "extras": { "patchvis": {
                "patch_count": firsts.len().saturating_sub(1),
                "triangle_count": t,
                "patch_first_triangle": firsts,
                "index_buffer_view": index_view,
                "original_triangle_buffer_view": original_view,
            } },
        }],
        "accessors": accessors,
        "bufferViews": views.views,
        "buffers": [buffer],
    });
    if !materials.materials.is_empty() {
        document["materials"] = json!(materials.materials);
    }
    if !materials.images.is_empty() {
        document["images"] = json!(materials.images);
        document["textures"] = json!(materials.textures);
        // Linear filtering with mipmaps, repeating: what OBJ textures assume.
        document["samplers"] =
            json!([{ "magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497 }]);
    }
    (document, buffer_length)
}

/// The vertex attributes' views and accessors, `POSITION` and `NORMAL`, then `TEXCOORD_0` and
/// `COLOR_0` where the input has them; returns the accessors and the primitives' `attributes`.
fn vertex_accessors(
    views: &mut BufferViews,
    mesh: &Mesh,
    attributes: &Attributes,
) -> (Vec<Value>, Value) {
    let present = attributes.present();
    let (min, max) = position_bounds(mesh, attributes);
    let v = u64::from(attributes.vertex_count());
    let mut accessors = vec![
        json!({ "bufferView": views.push(12 * v, Some(ARRAY_BUFFER)), "componentType": FLOAT,
                "count": v, "type": "VEC3", "min": min, "max": max }),
        json!({ "bufferView": views.push(12 * v, Some(ARRAY_BUFFER)), "componentType": FLOAT,
                "count": v, "type": "VEC3" }),
    ];
    let mut attribute_map = json!({ "POSITION": 0, "NORMAL": 1 });
    if present.uvs {
        attribute_map["TEXCOORD_0"] = json!(accessors.len());
        accessors.push(json!({ "bufferView": views.push(8 * v, Some(ARRAY_BUFFER)),
                               "componentType": FLOAT, "count": v, "type": "VEC2" }));
    }
    if present.colours {
        attribute_map["COLOR_0"] = json!(accessors.len());
        accessors.push(json!({ "bufferView": views.push(4 * v, Some(ARRAY_BUFFER)),
                               "componentType": UNSIGNED_BYTE, "normalized": true, "count": v,
                               "type": "VEC4" }));
    }
    (accessors, attribute_map)
}

/// The bounds of the output vertices' positions (`POSITION` needs them).
fn position_bounds(mesh: &Mesh, attributes: &Attributes) -> ([f32; 3], [f32; 3]) {
    let mut min = [f32::INFINITY; 3];
    let mut max = [f32::NEG_INFINITY; 3];
    for o in 0..attributes.vertex_count() {
        let p = mesh.position(attributes.source(o));
        for k in 0..3 {
            min[k] = min[k].min(p[k]);
            max[k] = max[k].max(p[k]);
        }
    }
    (min, max)
}

/// The document's `materials`, `images` and `textures`.
struct MaterialsJson {
    materials: Vec<Value>,
    images: Vec<Value>,
    textures: Vec<Value>,
}

/// The materials as glTF's metallic-roughness materials, each texture an image embedded in a
/// view of the buffer (appended to `views`, in material order).
fn materials_json(views: &mut BufferViews, materials: &[Material]) -> MaterialsJson {
    let mut json = MaterialsJson {
        materials: Vec::new(),
        images: Vec::new(),
        textures: Vec::new(),
    };
    for m in materials {
        let mut pbr = json!({
            "baseColorFactor": m.base_colour.map(|c| c.clamp(0.0, 1.0)),
            "metallicFactor": m.metallic.clamp(0.0, 1.0),
            "roughnessFactor": m.roughness.clamp(0.0, 1.0),
        });
        if let Some(texture) = &m.texture {
            let image_view = views.push(texture.bytes.len() as u64, None);
            json.images
                .push(json!({ "bufferView": image_view, "mimeType": texture.mime }));
            json.textures
                .push(json!({ "sampler": 0, "source": json.images.len() - 1 }));
            pbr["baseColorTexture"] = json!({ "index": json.textures.len() - 1 });
        }
        let mut material = json!({ "name": m.name, "pbrMetallicRoughness": pbr });
        if m.double_sided {
            material["doubleSided"] = json!(true);
        }
        match m.alpha {
            AlphaMode::Opaque => {}
            AlphaMode::Mask(cutoff) => {
                material["alphaMode"] = json!("MASK");
                material["alphaCutoff"] = json!(cutoff.max(0.0));
            }
            AlphaMode::Blend => material["alphaMode"] = json!("BLEND"),
        }
        json.materials.push(material);
    }
    json
}

/// One primitive per material run of `sequence`, each indexing its slice of the one index
/// view through an accessor appended to `accessors`.
fn primitives(
    sequence: &Sequence,
    attribute_map: &Value,
    index_view: usize,
    accessors: &mut Vec<Value>,
) -> Vec<Value> {
    let mut primitives = Vec::new();
    for run in sequence.runs() {
        let mut primitive = json!({
            "attributes": attribute_map,
            "indices": accessors.len(),
            "mode": 4,
            "extras": { "patchvis": { "first_triangle": run.first, "triangle_count": run.count } },
        });
        if run.material != NO_MATERIAL {
            primitive["material"] = json!(run.material);
        }
        accessors.push(json!({ "bufferView": index_view,
                               "byteOffset": 12 * u64::from(run.first),
                               "componentType": UNSIGNED_INT, "count": 3 * u64::from(run.count),
                               "type": "SCALAR" }));
        primitives.push(primitive);
    }
    primitives
}

/// Writes the buffer, view by view in [`document`]'s order: the vertex attributes, the
/// triangles' corners in output order, their original indices, then the texture images, each
/// padded to 4 bytes. `buffer_length` is what the document says it holds.
fn write_buffer(
    out: &mut dyn Write,
    mesh: &Mesh,
    attributes: &Attributes,
    sequence: &Sequence,
    normals: &Normals,
    buffer_length: u64,
) -> io::Result<()> {
    let present = attributes.present();
    let vertices = attributes.vertex_count();
    let mut written = 0u64;
    let mut put = |out: &mut dyn Write, bytes: &[u8]| -> io::Result<()> {
        written += bytes.len() as u64;
        out.write_all(bytes)
    };
    for o in 0..vertices {
        put(out, &floats(mesh.position(attributes.source(o))))?;
    }
    for o in 0..vertices {
        put(out, &floats(normals.of(attributes, o)))?;
    }
    if present.uvs {
        for o in 0..vertices {
            put(out, &floats(attributes.uv(o).unwrap_or([0.0; 2])))?;
        }
    }
    if present.colours {
        for o in 0..vertices {
            put(out, &attributes.colour(o).unwrap_or([255; 4]))?;
        }
    }
    let mut failed = Ok(());
    sequence.for_each(|tri| {
        if failed.is_ok() {
            let c = attributes.corners(mesh, tri);
            let mut record = [0u8; 12];
            for (field, i) in record.chunks_exact_mut(4).zip(c) {
                field.copy_from_slice(&i.to_le_bytes());
            }
            failed = put(out, &record);
        }
    });
    failed?;
    let mut failed = Ok(());
    sequence.for_each(|tri| {
        if failed.is_ok() {
            failed = put(out, &tri.to_le_bytes());
        }
    });
    failed?;
    for m in attributes.materials() {
        if let Some(texture) = &m.texture {
            put(out, &texture.bytes)?;
            let pad = texture.bytes.len().next_multiple_of(4) - texture.bytes.len();
            put(out, &[0u8; 3][..pad])?;
        }
    }
    debug_assert_eq!(written, buffer_length);
    Ok(())
}

/// The binary container: the 12-byte header, the JSON chunk (`text`, padded with spaces), then
/// the binary chunk of `buffer_length` bytes that `bin` writes.
fn write_glb(
    out: &mut impl Write,
    text: &str,
    buffer_length: u64,
    bin: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    let json_length = text.len().next_multiple_of(4);
    let total = 12 + 8 + json_length as u64 + 8 + buffer_length;
    let total = u32::try_from(total).map_err(|_| {
        io::Error::other(format!(
            "the GLB would be {total} bytes, more than the 4 GiB a GLB can hold; write .gltf or .ply"
        ))
    })?;
    out.write_all(b"glTF")?;
    out.write_all(&2u32.to_le_bytes())?;
    out.write_all(&total.to_le_bytes())?;
    out.write_all(&(json_length as u32).to_le_bytes())?;
    out.write_all(b"JSON")?;
    out.write_all(text.as_bytes())?;
    out.write_all(&b"   "[..json_length - text.len()])?;
    out.write_all(&(buffer_length as u32).to_le_bytes())?;
    out.write_all(b"BIN\0")?;
    bin(out)
}

/// The JSON file, with the buffer that `bin` writes as a base64 `data:` URI in place of the
/// placeholder URI in `text`.
fn write_gltf(
    out: &mut impl Write,
    text: &str,
    bin: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    let quoted = format!("\"{URI_PLACEHOLDER}\"");
    let (head, tail) = text
        .split_once(&quoted)
        .expect("the buffer's URI placeholder is in the JSON");
    out.write_all(head.as_bytes())?;
    out.write_all(b"\"data:application/octet-stream;base64,")?;
    {
        let mut encoder = base64::write::EncoderWriter::new(
            &mut *out,
            &base64::engine::general_purpose::STANDARD,
        );
        bin(&mut encoder)?;
        encoder.finish()?;
    }
    out.write_all(b"\"")?;
    out.write_all(tail.as_bytes())?;
    out.write_all(b"\n")
}

/// Area-weighted vertex normals of `mesh` (unnormalised sums of its faces' cross products), in
/// a mapped temporary file; one pass in triangle order.
fn vertex_normals(mesh: &Mesh) -> io::Result<Array<[f32; 3]>> {
    let mut sums: Array<[f32; 3]> = Array::zeroed_in_file(mesh.vertex_count() as usize)?;
    for t in 0..mesh.triangle_count() {
        let corners = mesh.triangle(t);
        let [a, b, c] = corners.map(|v| mesh.position(v));
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            u[1] * w[2] - u[2] * w[1],
            u[2] * w[0] - u[0] * w[2],
            u[0] * w[1] - u[1] * w[0],
        ];
        for v in corners {
            let s = &mut sums[v as usize];
            for k in 0..3 {
                s[k] += n[k];
            }
        }
    }
    Ok(sums)
}

/// `n` scaled to unit length, or [`FALLBACK_NORMAL`] when it has none.
fn unit(n: [f32; 3]) -> [f32; 3] {
    let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if length > 0.0 && length.is_finite() {
        n.map(|c| c / length)
    } else {
        FALLBACK_NORMAL
    }
}

/// Little-endian bytes of `N` floats.
fn floats<const N: usize>(values: [f32; N]) -> Vec<u8> {
    values.iter().flat_map(|c| c.to_le_bytes()).collect()
}
