//! An OBJ's texture coordinates, normals and materials (`usemtl`, with the `mtllib` files'
//! `Kd`, `d`/`Tr` and `map_Kd`), in the triangle order of `super::super::obj`.
//!
//! Two passes: the first collects the `vt` and `vn` tables (into mapped temporary files) and
//! the material names; the second welds every face corner's `(v, vt, vn)` into an output
//! vertex and records each fan triangle's corners and material. Texture coordinates are
//! flipped to glTF's convention (`1 - v`). Memory: one polygon's corners, the seam triples.

use std::collections::HashMap;
use std::path::Path;

use super::super::error::{Fault, MeshErrorKind};
use super::super::obj::resolve;
use super::super::text::{Lines, finite_f32, tokens};
use super::{Attributes, Builder, Material, NO_MATERIAL, Numbering, texture_file};
use crate::mapped::{Array, RecordWriter, read_regular};
use crate::ooc::Mesh;

/// A face corner: vertex, texture coordinate and normal indices (0-based; `u32::MAX` when
/// absent).
type Corner = [u32; 3];
const ABSENT: u32 = u32::MAX;
/// The largest material library read: 64 MiB, thousands of times a large scene's.
const MTL_MAX_BYTES: u64 = 64 << 20;

/// Reads `bytes` (the OBJ `mesh` was converted from); `dir` resolves `mtllib` files, which
/// and whose `map_Kd` images are read when `textures` (else the materials are their names).
pub(super) fn read(
    bytes: &[u8],
    dir: &Path,
    mesh: &Mesh,
    textures: bool,
) -> Result<Attributes, Fault> {
    // Pass 1: the vt and vn tables, the material libraries and names.
    let mut uvs: RecordWriter<[f32; 2]> = RecordWriter::temp_file().map_err(Fault::cache)?;
    let mut normals: RecordWriter<[f32; 3]> = RecordWriter::temp_file().map_err(Fault::cache)?;
    let mut libraries: Vec<String> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for (line, text) in Lines::new(bytes) {
        let mut words = tokens(text);
        match words.next() {
            Some(b"vt") => {
                let u = finite_f32(words.next(), line, "u")?;
                let v = match words.next() {
                    Some(t) => finite_f32(Some(t), line, "v")?,
                    None => 0.0,
                };
                uvs.push(&[[u, 1.0 - v]]).map_err(Fault::cache)?;
            }
            Some(b"vn") => {
                let n = [
                    finite_f32(words.next(), line, "normal x")?,
                    finite_f32(words.next(), line, "normal y")?,
                    finite_f32(words.next(), line, "normal z")?,
                ];
                normals.push(&[n]).map_err(Fault::cache)?;
            }
            Some(b"mtllib") => {
                libraries.extend(words.map(|w| String::from_utf8_lossy(w).into_owned()));
            }
            Some(b"usemtl") => {
                let name = rest_of(text, b"usemtl");
                if !names.contains(&name) {
                    names.push(name);
                }
            }
            _ => {}
        }
    }
    let (uv_count, normal_count) = (uvs.len() as u64, normals.len() as u64);
    let uvs = uvs.finish().map_err(Fault::cache)?;
    let normals = normals.finish().map_err(Fault::cache)?;
    let materials = materials(dir, &libraries, &names, textures)?;

    // Pass 2: faces.
    let numbering = if uv_count == 0 && normal_count == 0 {
        Numbering::Plain
    } else {
        Numbering::Welded
    };
    let mut out = Builder::new(numbering)?;
    let mut weld = Weld {
        first: Array::zeroed_in_file(mesh.vertex_count() as usize).map_err(Fault::cache)?,
        seams: HashMap::new(),
        next: 0,
    };
    let mut seen = [0u64; 3];
    let mut material = NO_MATERIAL;
    let mut polygon: Vec<u32> = Vec::new();
    for (line, text) in Lines::new(bytes) {
        let mut words = tokens(text);
        match words.next() {
            Some(b"v") => seen[0] += 1,
            Some(b"vt") => seen[1] += 1,
            Some(b"vn") => seen[2] += 1,
            Some(b"usemtl") => {
                let name = rest_of(text, b"usemtl");
                material = names.iter().position(|n| *n == name).unwrap_or(0) as u32;
            }
            Some(b"f") => {
                polygon.clear();
                for word in words {
                    let corner = corner(word, seen, line)?;
                    if corner[0] >= mesh.vertex_count() {
                        return Err(Fault::at_line(
                            MeshErrorKind::BadIndex,
                            line,
                            format!(
                                "face refers to vertex {}, expected at most {}",
                                u64::from(corner[0]) + 1,
                                mesh.vertex_count()
                            ),
                        ));
                    }
                    for (k, (count, what)) in
                        [(uv_count, "texture coordinate"), (normal_count, "normal")]
                            .into_iter()
                            .enumerate()
                    {
                        let i = corner[k + 1];
                        if i != ABSENT && u64::from(i) >= count {
                            return Err(Fault::at_line(
                                MeshErrorKind::BadIndex,
                                line,
                                format!(
                                    "face refers to {what} {}, expected at most {count}",
                                    u64::from(i) + 1
                                ),
                            ));
                        }
                    }
                    let vertex = match numbering {
                        Numbering::Welded => weld.vertex(corner, &uvs, &normals, &mut out)?,
                        _ => corner[0],
                    };
                    polygon.push(vertex);
                }
                for pair in polygon[1..].windows(2) {
                    out.triangle(Some([polygon[0], pair[0], pair[1]]), material)?;
                }
            }
            _ => {}
        }
    }
    out.finish(mesh, materials)
}

/// Output vertices of `(v, vt, vn)` triples.
struct Weld {
    /// Per mesh vertex: its first triple's `vt + 1`, `vn + 1` (0: absent) and output vertex
    /// `+ 1` (0: not yet used).
    first: Array<[u32; 3]>,
    /// The other triples: seams where a position has two texture coordinates or normals.
    seams: HashMap<Corner, u32>,
    next: u32,
}

impl Weld {
    fn vertex(
        &mut self,
        corner: Corner,
        uvs: &[[f32; 2]],
        normals: &[[f32; 3]],
        out: &mut Builder,
    ) -> Result<u32, Fault> {
        let key = [corner[1].wrapping_add(1), corner[2].wrapping_add(1)];
        let first = &mut self.first[corner[0] as usize];
        if first[2] != 0 && [first[0], first[1]] == key {
            return Ok(first[2] - 1);
        }
        if first[2] != 0 {
            if let Some(&o) = self.seams.get(&corner) {
                return Ok(o);
            }
            self.seams.insert(corner, self.next);
        } else {
            *first = [key[0], key[1], self.next + 1];
        }
        let uv = (corner[1] != ABSENT).then(|| uvs[corner[1] as usize]);
        let normal = (corner[2] != ABSENT).then(|| normals[corner[2] as usize]);
        out.vertex(corner[0], normal, uv, None)?;
        self.next += 1;
        Ok(self.next - 1)
    }
}

/// A face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`, resolved against the counts `seen` so far.
fn corner(word: &[u8], seen: [u64; 3], line: u64) -> Result<Corner, Fault> {
    let mut parts = word.split(|&b| b == b'/');
    let mut out = [ABSENT; 3];
    for (k, slot) in out.iter_mut().enumerate() {
        match parts.next() {
            Some(p) if !p.is_empty() => *slot = resolve(p, seen[k], line)?,
            _ => {}
        }
    }
    Ok(out)
}

/// The text after `keyword` on a statement line, trimmed (material names may hold spaces).
fn rest_of(text: &[u8], keyword: &[u8]) -> String {
    let text = text.trim_ascii();
    let rest = text.strip_prefix(keyword).unwrap_or(text);
    String::from_utf8_lossy(rest.trim_ascii()).into_owned()
}

/// The materials `names`, in order, from the `mtllib` files (a name no library defines keeps
/// the defaults).
fn materials(
    dir: &Path,
    libraries: &[String],
    names: &[String],
    textures: bool,
) -> Result<Vec<Material>, Fault> {
    let mut defined: Vec<Material> = Vec::new();
    // Without textures the output is a PLY, which keeps no material but its grouping.
    let libraries = if textures { libraries } else { &[] };
    for library in libraries {
        let path = dir.join(library);
        let origin = format!("mtllib {library}");
        let text = read_regular(&path, MTL_MAX_BYTES, "a material library").map_err(|e| {
            Fault::new(
                MeshErrorKind::Io,
                None,
                format!(
                    "{origin}: cannot read '{}': {e}; --mesh-out needs the material library \
                     beside the OBJ",
                    path.display()
                ),
            )
        })?;
        let library_dir = path.parent().unwrap_or(dir);
        for (line, statement) in Lines::new(&text) {
            let mut words = tokens(statement);
            let Some(keyword) = words.next() else {
                continue;
            };
            let at = |what: &str| format!("{library} line {line}: {what}");
            if keyword == b"newmtl" {
                defined.push(Material::named(&rest_of(statement, b"newmtl")));
                continue;
            }
            let Some(current) = defined.last_mut() else {
                continue;
            };
            match keyword {
                b"Kd" => {
                    for k in 0..3 {
                        current.base_colour[k] = finite_f32(words.next(), line, "a Kd value")
                            .map_err(|_| bad(at("expected Kd r g b")))?;
                    }
                }
                b"d" => {
                    current.base_colour[3] = finite_f32(words.next(), line, "d")
                        .map_err(|_| bad(at("expected d alpha")))?;
                }
                b"Tr" => {
                    current.base_colour[3] = 1.0
                        - finite_f32(words.next(), line, "Tr")
                            .map_err(|_| bad(at("expected Tr transparency")))?;
                }
                b"map_Kd" if textures => {
                    // Options (`-s 1 1 1`, `-clamp on`, ...) come first; the file name last.
                    let Some(file) = words.last() else {
                        return Err(bad(at("map_Kd without a file name")));
                    };
                    let file = String::from_utf8_lossy(file).replace('\\', "/");
                    current.texture = Some(texture_file(
                        library_dir.join(&file),
                        &format!("map_Kd of material '{}'", current.name),
                    )?);
                }
                _ => {}
            }
        }
    }
    Ok(names
        .iter()
        .map(|name| {
            let mut m = defined
                .iter()
                .find(|m| m.name == *name)
                .cloned()
                .unwrap_or_else(|| Material::named(name));
            if m.base_colour[3] < 1.0 {
                m.alpha = super::AlphaMode::Blend;
            }
            m
        })
        .collect())
}

fn bad(what: String) -> Fault {
    Fault::new(MeshErrorKind::BadValue, None, what)
}
