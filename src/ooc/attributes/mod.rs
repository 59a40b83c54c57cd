//! What a mesh carries beside its positions (normals, texture coordinates, vertex colours,
//! materials), read again from its source file for `--mesh-out`.
//!
//! The conversion cache and the in-place PLY hold positions and triangles only: the tiling
//! and the sampler need nothing else, and a cache with attributes would double the mapped
//! bytes of every bake for the one output that uses them. So `--mesh-out` re-reads the input
//! once, streaming, after the bake ([`Attributes::read`]), in the same triangle order as the
//! conversion (`obj.rs`, `gltf.rs` and `ply.rs` here follow their converters' order).
//!
//! Output vertices: where the input's attributes are per vertex (PLY, glTF), an output vertex
//! is a mesh vertex. An OBJ face corner names its position, texture coordinate and normal
//! separately, so its output vertex is the distinct `(v, vt, vn)` triple ("welding"): a mesh
//! vertex keeps its first triple in a mapped per-vertex table; only the other triples (seams)
//! go into a hash map.
//!
//! Memory: the per-vertex records, the per-triangle corners and materials, and the OBJ's
//! texture coordinate and normal tables live in mapped temporary files (`mapped::Array`), not
//! on the heap; the heap holds the seam triples and the material table. Cost: one pass over
//! the input (two for OBJ).

mod gltf;
mod obj;
mod ply;
mod side_files;

pub use side_files::{SideFile, side_files};

use std::path::PathBuf;

use super::error::Fault;
use super::{InputFormat, Mesh, MeshError, MeshSource};
use crate::mapped::{Array, Backing, RecordWriter, open_regular, read_regular};

/// Material id of a triangle without a material.
pub const NO_MATERIAL: u32 = u32::MAX;

/// `u32` words of one output vertex record: source vertex, normal (3 × `f32` bits), texture
/// coordinate (2 × `f32` bits), colour (RGBA bytes).
const VERTEX_WORDS: usize = 7;
/// The largest texture file read: 1 GiB (a 16,384² RGBA image uncompressed).
const TEXTURE_MAX_BYTES: u64 = 1 << 30;

/// Which attributes the input had.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Present {
    /// Vertex normals.
    pub normals: bool,
    /// Texture coordinates (the first set).
    pub uvs: bool,
    /// Vertex colours.
    pub colours: bool,
}

/// How a material's alpha is used (glTF's `alphaMode`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Alpha ignored.
    Opaque,
    /// Alpha below the cutoff is transparent, the rest opaque.
    Mask(f32),
    /// Alpha blended.
    Blend,
}

/// A material: the base colour and its texture, as glTF's metallic-roughness model has them.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Its name in the input.
    pub name: String,
    /// Linear RGBA factor.
    pub base_colour: [f32; 4],
    /// The base colour texture (sampled with texture coordinate set 0).
    pub texture: Option<Texture>,
    /// Metalness factor (0 for OBJ).
    pub metallic: f32,
    /// Roughness factor (1 for OBJ).
    pub roughness: f32,
    /// Whether back faces are drawn.
    pub double_sided: bool,
    /// How alpha is used.
    pub alpha: AlphaMode,
}

impl Material {
    /// A material called `name` with glTF's defaults (white, rough, not metallic).
    pub fn named(name: &str) -> Material {
        Material {
            name: name.to_string(),
            base_colour: [1.0; 4],
            texture: None,
            metallic: 0.0,
            roughness: 1.0,
            double_sided: false,
            alpha: AlphaMode::Opaque,
        }
    }
}

/// A texture image: PNG or JPEG bytes (the formats glTF 2.0 allows).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Where it came from, for messages: a file, or the input's image index.
    pub origin: String,
    /// The image file's bytes.
    pub bytes: Vec<u8>,
    /// `image/png` or `image/jpeg`, from the bytes' signature.
    pub mime: &'static str,
}

impl Texture {
    /// Checks that `bytes` are a PNG or a JPEG image.
    fn new(origin: String, bytes: Vec<u8>) -> Result<Texture, String> {
        let mime = if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
            "image/png"
        } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
            "image/jpeg"
        } else {
            return Err(format!(
                "texture {origin} is neither PNG nor JPEG, the image formats glTF 2.0 allows; \
                 convert it to PNG"
            ));
        };
        Ok(Texture {
            origin,
            bytes,
            mime,
        })
    }
}

/// A mesh's attributes, in output vertices.
pub struct Attributes {
    /// Per output vertex; `None`: the output vertices are the mesh's, without attributes.
    vertices: Option<Array<[u32; VERTEX_WORDS]>>,
    /// Per input triangle, its output vertices; `None`: the mesh's own triangles.
    corners: Option<Array<[u32; 3]>>,
    /// Per input triangle, its material; `None`: no materials.
    material_of: Option<Array<u32>>,
    materials: Vec<Material>,
    present: Present,
    vertex_count: u32,
}

impl Attributes {
    /// Reads `mesh`'s attributes from its source file, with the material libraries of an OBJ
    /// and every material's texture images when `textures` (a PLY output has no use for them,
    /// so it reads neither and fails for neither; its triangles are still grouped by the
    /// OBJ's `usemtl` names). A mesh built in memory has none.
    pub fn read(mesh: &Mesh, textures: bool) -> Result<Attributes, MeshError> {
        let none = Attributes::none(mesh);
        if mesh.source() == MeshSource::Memory {
            return Ok(none);
        }
        let path = mesh.path();
        let format = InputFormat::of(path).map_err(|f| f.in_file(path))?;
        let (file, metadata) = open_regular(path).map_err(|e| MeshError::io(path, &e))?;
        let bytes = crate::mapped::FileBytes::open(&file, metadata.len(), Backing::Input(path))
            .map_err(|e| MeshError::io(path, &e))?;
        let dir = path.parent().unwrap_or(std::path::Path::new("."));
        let read = match format {
            InputFormat::Ply => ply::read(&bytes, mesh),
            InputFormat::Obj => obj::read(&bytes, dir, mesh, textures),
            InputFormat::Gltf => {
                let glb = path
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
                gltf::read(&bytes, glb, dir, mesh, textures)
            }
            InputFormat::Stl => return Ok(none),
        };
        read.map_err(|f| f.in_file(path))
    }

    /// No attributes: the mesh's own vertices and triangles.
    fn none(mesh: &Mesh) -> Attributes {
        Attributes {
            vertices: None,
            corners: None,
            material_of: None,
            materials: Vec::new(),
            present: Present::default(),
            vertex_count: mesh.vertex_count(),
        }
    }

    /// Which attributes the input had.
    pub fn present(&self) -> Present {
        self.present
    }
    /// Number of output vertices.
    pub fn vertex_count(&self) -> u32 {
        self.vertex_count
    }
    /// The mesh vertex (its position) output vertex `o` stands for.
    pub fn source(&self, o: u32) -> u32 {
        match &self.vertices {
            Some(v) => v[o as usize][0],
            None => o,
        }
    }
    /// The input's normal of output vertex `o`; `None` when the input had none for it (a
    /// writer computes one then).
    pub fn normal(&self, o: u32) -> Option<[f32; 3]> {
        let r = &self.vertices.as_ref()?[o as usize];
        let n = [1, 2, 3].map(|k| f32::from_bits(r[k]));
        (n != [0.0; 3]).then_some(n)
    }
    /// Texture coordinate of output vertex `o`, glTF's convention (origin at the image's
    /// top left), when the input had them.
    pub fn uv(&self, o: u32) -> Option<[f32; 2]> {
        let r = &self.vertices.as_ref().filter(|_| self.present.uvs)?[o as usize];
        Some([f32::from_bits(r[4]), f32::from_bits(r[5])])
    }
    /// Colour of output vertex `o` (RGBA bytes), when the input had colours.
    pub fn colour(&self, o: u32) -> Option<[u8; 4]> {
        let r = &self.vertices.as_ref().filter(|_| self.present.colours)?[o as usize];
        Some(r[6].to_le_bytes())
    }
    /// Output vertices of input triangle `t`.
    pub fn corners(&self, mesh: &Mesh, t: u32) -> [u32; 3] {
        match &self.corners {
            Some(c) => c[t as usize],
            None => mesh.triangle(t),
        }
    }
    /// Material of input triangle `t`, an index into [`materials`](Self::materials), or
    /// [`NO_MATERIAL`].
    pub fn material(&self, t: u32) -> u32 {
        match &self.material_of {
            Some(m) => m[t as usize],
            None => NO_MATERIAL,
        }
    }
    /// The materials the triangles use.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }
}

/// How a reader numbers output vertices.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Numbering {
    /// The mesh's vertices, without attributes: only materials are read.
    Plain,
    /// The mesh's vertices, one record each, in order.
    PerVertex,
    /// The reader's own, with every triangle's corners recorded.
    Welded,
}

/// Collects the records of [`Attributes`] as a reader streams through its input.
struct Builder {
    numbering: Numbering,
    vertices: RecordWriter<[u32; VERTEX_WORDS]>,
    corners: Option<RecordWriter<[u32; 3]>>,
    material_of: RecordWriter<u32>,
    any_material: bool,
    present: Present,
}

impl Builder {
    fn new(numbering: Numbering) -> Result<Builder, Fault> {
        Ok(Builder {
            numbering,
            vertices: RecordWriter::temp_file().map_err(Fault::cache)?,
            corners: match numbering {
                Numbering::Welded => Some(RecordWriter::temp_file().map_err(Fault::cache)?),
                _ => None,
            },
            material_of: RecordWriter::temp_file().map_err(Fault::cache)?,
            any_material: false,
            present: Present::default(),
        })
    }

    /// Appends an output vertex.
    fn vertex(
        &mut self,
        source: u32,
        normal: Option<[f32; 3]>,
        uv: Option<[f32; 2]>,
        colour: Option<[u8; 4]>,
    ) -> Result<(), Fault> {
        self.present.normals |= normal.is_some();
        self.present.uvs |= uv.is_some();
        self.present.colours |= colour.is_some();
        // A non-finite normal counts as none (the writers compute one); a non-finite texture
        // coordinate as (0, 0).
        let n = normal
            .filter(|n| n.iter().all(|c| c.is_finite()))
            .unwrap_or([0.0; 3]);
        let t = uv
            .filter(|t| t.iter().all(|c| c.is_finite()))
            .unwrap_or([0.0; 2]);
        let record = [
            source,
            n[0].to_bits(),
            n[1].to_bits(),
            n[2].to_bits(),
            t[0].to_bits(),
            t[1].to_bits(),
            u32::from_le_bytes(colour.unwrap_or([255; 4])),
        ];
        self.vertices.push(&[record]).map_err(Fault::cache)
    }

    /// Appends an input triangle: its output vertices (welded readers) and material.
    fn triangle(&mut self, corners: Option<[u32; 3]>, material: u32) -> Result<(), Fault> {
        if let (Some(out), Some(c)) = (&mut self.corners, corners) {
            out.push(&[c]).map_err(Fault::cache)?;
        }
        self.any_material |= material != NO_MATERIAL;
        self.material_of.push(&[material]).map_err(Fault::cache)
    }

    /// The attributes, checked against `mesh`: a source that no longer gives the mesh's
    /// triangle count (changed since the bake read it) is refused.
    fn finish(self, mesh: &Mesh, materials: Vec<Material>) -> Result<Attributes, Fault> {
        let triangles = self.material_of.len();
        let vertex_count = self.vertices.len();
        let expected_vertices = match self.numbering {
            Numbering::Welded | Numbering::Plain => vertex_count,
            Numbering::PerVertex => mesh.vertex_count() as usize,
        };
        if triangles != mesh.triangle_count() as usize || vertex_count != expected_vertices {
            return Err(Fault::new(
                super::MeshErrorKind::BadValue,
                None,
                format!(
                    "reading the file again for --mesh-out gives {triangles} triangles and \
                     {vertex_count} vertices, but the bake read {} and {}: the file changed \
                     during the bake; run it again",
                    mesh.triangle_count(),
                    mesh.vertex_count()
                ),
            ));
        }
        let corners = match self.corners {
            Some(c) => Some(c.finish().map_err(Fault::cache)?),
            None => None,
        };
        let material_of = match self.any_material {
            true => Some(self.material_of.finish().map_err(Fault::cache)?),
            false => None,
        };
        let (vertices, vertex_count) = match self.numbering {
            Numbering::Plain => (None, mesh.vertex_count()),
            _ => (
                Some(self.vertices.finish().map_err(Fault::cache)?),
                vertex_count as u32,
            ),
        };
        Ok(Attributes {
            vertices,
            corners,
            material_of,
            materials,
            present: self.present,
            vertex_count,
        })
    }
}

/// Reads a texture file named by the input (`origin` names where, for errors).
fn texture_file(path: PathBuf, origin: &str) -> Result<Texture, Fault> {
    let fail = |what: String| Fault::new(super::MeshErrorKind::Io, None, what);
    let bytes = read_regular(&path, TEXTURE_MAX_BYTES, "a texture")
        .map_err(|e| fail(format!("{origin}: cannot read '{}': {e}", path.display())))?;
    Texture::new(format!("'{}' ({origin})", path.display()), bytes)
        .map_err(|e| Fault::new(super::MeshErrorKind::UnsupportedFormat, None, e))
}

#[cfg(test)]
mod tests;
