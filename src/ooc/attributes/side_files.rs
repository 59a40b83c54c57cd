//! The files a mesh names beside itself: an OBJ's material libraries (`mtllib`) and their
//! textures (`map_Kd`), a glTF's external buffers and images. They are inputs of a bake as
//! much as the mesh is, so a command compares them with its outputs before any work; and the
//! outputs that read them (a glTF `--mesh-out`) check that they are there before the bake
//! rather than after it.
//!
//! Found without reading the mesh's geometry: an OBJ is searched for `mtllib` at line starts
//! (one `memmem` pass over the mapped file, at memory speed), and each library for `map_Kd`;
//! a glTF's JSON is parsed, its binary chunk only sliced. A library that is missing has no
//! textures to list; whether that matters is the caller's call ([`SideFile::exists`]).

use super::super::gltf_mesh::{external_path, parse};
use super::super::text::Lines;
use super::super::{InputFormat, MeshError};
use crate::mapped::{Backing, open_regular};
use std::path::{Path, PathBuf};

/// A file a mesh names beside itself.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SideFile {
    /// What it is and how the mesh names it: `material library (mtllib)`, `texture of
    /// material 'earth' (map_Kd)`, `image 0 (images[0].uri)`, `buffer 0 (buffers[0].uri)`.
    pub what: String,
    /// Where it is.
    pub path: PathBuf,
    /// Whether only a `--mesh-out` with materials (glTF) reads it; `false` for what every
    /// read of the mesh needs (a glTF's buffers).
    pub materials_only: bool,
}

impl SideFile {
    /// Whether the file is there to be read.
    pub fn exists(&self) -> bool {
        self.path.is_file()
    }
}

/// The files the mesh at `path` names beside itself (none for PLY and STL). Fails only where
/// the mesh itself cannot be read, or a glTF's JSON does not parse: the bake would fail the
/// same way.
pub fn side_files(path: &Path) -> Result<Vec<SideFile>, MeshError> {
    let Ok(format) = InputFormat::of(path) else {
        return Ok(Vec::new());
    };
    if !matches!(format, InputFormat::Obj | InputFormat::Gltf) {
        return Ok(Vec::new());
    }
    let (file, metadata) = open_regular(path).map_err(|e| MeshError::io(path, &e))?;
    let bytes = crate::mapped::FileBytes::open(&file, metadata.len(), Backing::Input(path))
        .map_err(|e| MeshError::io(path, &e))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    match format {
        InputFormat::Obj => Ok(obj_side_files(&bytes, dir)),
        _ => {
            let glb = path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
            gltf_side_files(&bytes, glb, dir).map_err(|f| f.in_file(path))
        }
    }
}

/// An OBJ's `mtllib` files and the `map_Kd` images of those that exist.
fn obj_side_files(bytes: &[u8], dir: &Path) -> Vec<SideFile> {
    let mut files = Vec::new();
    for at in memchr::memmem::find_iter(bytes, b"mtllib") {
        let line_start = bytes[..at]
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |n| n + 1);
        if !bytes[line_start..at].iter().all(u8::is_ascii_whitespace) {
            continue;
        }
        let end = memchr::memchr(b'\n', &bytes[at..]).map_or(bytes.len(), |n| at + n);
        let line = String::from_utf8_lossy(&bytes[at + b"mtllib".len()..end]).into_owned();
        for library in line.split_ascii_whitespace() {
            let path = dir.join(library);
            let textures = std::fs::read(&path)
                .map(|text| textures(&text, path.parent().unwrap_or(dir)))
                .unwrap_or_default();
            files.push(SideFile {
                what: "material library (mtllib)".to_owned(),
                path,
                materials_only: true,
            });
            files.extend(textures);
        }
    }
    files
}

/// The `map_Kd` images of a material library's `text`, resolved in `dir`.
fn textures(text: &[u8], dir: &Path) -> Vec<SideFile> {
    let mut material = String::new();
    let mut files = Vec::new();
    for (_, statement) in Lines::new(text) {
        let mut words = statement
            .split(u8::is_ascii_whitespace)
            .filter(|w| !w.is_empty());
        match words.next() {
            Some(b"newmtl") => {
                material = words
                    .map(|w| String::from_utf8_lossy(w).into_owned())
                    .collect::<Vec<_>>()
                    .join(" ");
            }
            // Options come first, the file name last (as `--mesh-out` reads it).
            Some(b"map_Kd") => {
                if let Some(file) = words.next_back() {
                    let file = String::from_utf8_lossy(file).replace('\\', "/");
                    files.push(SideFile {
                        what: format!("texture of material '{material}' (map_Kd)"),
                        path: dir.join(file),
                        materials_only: true,
                    });
                }
            }
            _ => {}
        }
    }
    files
}

/// A glTF's external buffers and images.
fn gltf_side_files(
    bytes: &[u8],
    glb: bool,
    dir: &Path,
) -> Result<Vec<SideFile>, super::super::error::Fault> {
    let parsed = parse(bytes, glb)?;
    let mut files = Vec::new();
    for buffer in parsed.document.buffers() {
        if let gltf::buffer::Source::Uri(uri) = buffer.source()
            && !uri.starts_with("data:")
        {
            files.push(SideFile {
                what: format!("buffer {0} (buffers[{0}].uri)", buffer.index()),
                path: external_path(dir, uri, buffer.index())?,
                materials_only: false,
            });
        }
    }
    for image in parsed.document.images() {
        if let gltf::image::Source::Uri { uri, .. } = image.source()
            && !uri.starts_with("data:")
        {
            files.push(SideFile {
                what: format!("image {0} (images[{0}].uri)", image.index()),
                path: external_path(dir, uri, image.index())?,
                materials_only: true,
            });
        }
    }
    Ok(files)
}
