//! A glTF's normals, first texture coordinates and materials, per vertex in the order of
//! `super::super::gltf_mesh` (the same instances, the same primitives, the same skips).
//!
//! Normals are taken through each instance's normal matrix (the inverse transpose of its
//! transform) and renormalised. Texture coordinates are `FLOAT`, or normalised unsigned byte
//! or short. Materials keep the metallic-roughness base colour (factor and texture, whose
//! image is copied from its buffer view, `data:` URI or file), the metallic and roughness
//! factors, the alpha mode and double-sidedness. Memory: the images of used textures.

use std::path::Path;

use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use gltf::{Accessor, Semantic};

use super::super::error::{Fault, MeshErrorKind};
use super::super::gltf_mesh::{
    BufferBytes, Strided, data_uri, external_path, instances, load_buffers, parse, strided,
    type_name,
};
use super::{AlphaMode, Attributes, Builder, Material, NO_MATERIAL, Numbering, Texture};
use crate::ooc::Mesh;

/// Reads `bytes` (the glTF `mesh` was converted from); `dir` resolves external files; the
/// base colour images are read when `textures`.
pub(super) fn read(
    bytes: &[u8],
    glb: bool,
    dir: &Path,
    mesh: &Mesh,
    textures: bool,
) -> Result<Attributes, Fault> {
    let parsed = parse(bytes, glb)?;
    let document = &parsed.document;
    let buffers = load_buffers(bytes, &parsed, dir)?;
    let mut out = Builder::new(Numbering::PerVertex)?;
    for instance in instances(document)? {
        let normal_matrix = glam::DMat3::from_mat4(instance.world).inverse().transpose();
        for primitive in instance.mesh.primitives() {
            let mode = primitive.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                continue;
            }
            let role = instance.role(&primitive);
            let Some(positions) = primitive.get(&Semantic::Positions) else {
                continue;
            };
            let normals = match primitive.get(&Semantic::Normals) {
                Some(a) => Some(vec3_accessor(&a, &buffers, &format!("{role}.NORMAL"))?),
                None => None,
            };
            let uvs = match primitive.get(&Semantic::TexCoords(0)) {
                Some(a) => Some(uv_accessor(&a, &buffers, &format!("{role}.TEXCOORD_0"))?),
                None => None,
            };
            let count = positions.count();
            for (name, n) in [
                ("NORMAL", normals.as_ref().map(|s| s.count)),
                ("TEXCOORD_0", uvs.as_ref().map(|s| s.count)),
            ] {
                if let Some(n) = n.filter(|&n| n != count) {
                    return Err(Fault::new(
                        MeshErrorKind::BadValue,
                        None,
                        format!(
                            "{role}: {name} has {n} elements, POSITION {count}; expected equal counts"
                        ),
                    ));
                }
            }
            for i in 0..count {
                let normal = normals.as_ref().map(|s| {
                    let n = normal_matrix * glam::DVec3::from(s.vec3(i).map(f64::from));
                    n.normalize_or_zero().as_vec3().to_array()
                });
                let uv = uvs.as_ref().map(|s| uv(s, i));
                let source = (out.vertices.len()) as u32;
                out.vertex(source, normal, uv, None)?;
            }
            let k = primitive.indices().map_or(count, |a| a.count());
            let triangles = match mode {
                Mode::Triangles => k / 3,
                _ => k.saturating_sub(2),
            };
            let material = primitive
                .material()
                .index()
                .map_or(NO_MATERIAL, |m| m as u32);
            for _ in 0..triangles {
                out.triangle(None, material)?;
            }
        }
    }
    let mut materials = Vec::new();
    for m in document.materials() {
        materials.push(material(&m, &buffers, dir, textures)?);
    }
    out.finish(mesh, materials)
}

/// A `VEC3` of `FLOAT` accessor.
fn vec3_accessor<'b>(
    a: &Accessor,
    buffers: &'b [BufferBytes],
    role: &str,
) -> Result<Strided<'b>, Fault> {
    if a.dimensions() != Dimensions::Vec3 || a.data_type() != DataType::F32 {
        return Err(unsupported(a, role, "VEC3 of FLOAT"));
    }
    strided(a, buffers, role)
}

/// A `VEC2` of `FLOAT`, or normalised `UNSIGNED_BYTE` / `UNSIGNED_SHORT`, accessor.
fn uv_accessor<'b>(
    a: &Accessor,
    buffers: &'b [BufferBytes],
    role: &str,
) -> Result<Strided<'b>, Fault> {
    let ok = a.dimensions() == Dimensions::Vec2
        && (a.data_type() == DataType::F32
            || (a.normalized() && matches!(a.data_type(), DataType::U8 | DataType::U16)));
    if !ok {
        return Err(unsupported(
            a,
            role,
            "VEC2 of FLOAT or of normalized UNSIGNED_BYTE or UNSIGNED_SHORT",
        ));
    }
    strided(a, buffers, role)
}

fn unsupported(a: &Accessor, role: &str, expected: &str) -> Fault {
    Fault::new(
        MeshErrorKind::UnsupportedFormat,
        None,
        format!(
            "{role}: accessor {} is {}, expected {expected}",
            a.index(),
            type_name(a)
        ),
    )
}

/// Element `i` of a texture coordinate accessor.
fn uv(s: &Strided, i: usize) -> [f32; 2] {
    let at = i * s.stride;
    let b = s.bytes;
    match s.component {
        DataType::U8 => [b[at], b[at + 1]].map(|c| f32::from(c) / 255.0),
        DataType::U16 => {
            [0, 2].map(|o| f32::from(u16::from_le_bytes([b[at + o], b[at + o + 1]])) / 65535.0)
        }
        _ => [0, 4].map(|o| f32::from_le_bytes(super::super::four(b, at + o))),
    }
}

/// The parts of a material `--mesh-out` keeps.
fn material(
    m: &gltf::Material,
    buffers: &[BufferBytes],
    dir: &Path,
    textures: bool,
) -> Result<Material, Fault> {
    let pbr = m.pbr_metallic_roughness();
    let name = m.name().map_or_else(
        || format!("materials[{}]", m.index().unwrap_or(0)),
        String::from,
    );
    let texture = match pbr
        .base_color_texture()
        .filter(|t| textures && t.tex_coord() == 0)
    {
        Some(info) => Some(image(&info.texture().source(), buffers, dir)?),
        None => None,
    };
    Ok(Material {
        name,
        base_colour: pbr.base_color_factor(),
        texture,
        metallic: pbr.metallic_factor(),
        roughness: pbr.roughness_factor(),
        double_sided: m.double_sided(),
        alpha: match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask(m.alpha_cutoff().unwrap_or(0.5)),
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        },
    })
}

/// An image's bytes.
fn image(image: &gltf::Image, buffers: &[BufferBytes], dir: &Path) -> Result<Texture, Fault> {
    let i = image.index();
    let origin = format!("images[{i}]");
    let bytes = match image.source() {
        gltf::image::Source::View { view, .. } => {
            let data = buffers[view.buffer().index()].bytes();
            data.get(view.offset()..view.offset().saturating_add(view.length()))
                .ok_or_else(|| {
                    Fault::new(
                        MeshErrorKind::Truncated,
                        None,
                        format!(
                            "{origin}: bufferViews[{}] lies outside its buffer",
                            view.index()
                        ),
                    )
                })?
                .to_vec()
        }
        gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => data_uri(uri, i)?,
        gltf::image::Source::Uri { uri, .. } => {
            let path = external_path(dir, uri, i)?;
            return super::texture_file(path, &origin);
        }
    };
    Texture::new(origin, bytes).map_err(|e| Fault::new(MeshErrorKind::UnsupportedFormat, None, e))
}
