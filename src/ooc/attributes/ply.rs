//! A PLY's vertex normals (`nx, ny, nz`), texture coordinates (`s, t`, `u, v` or
//! `texture_u, texture_v`, flipped to glTF's convention) and colours (`red, green, blue`
//! and `alpha`, `uchar` or `0..1` floats), per vertex. PLY has no materials.

use super::super::error::Fault;
use super::super::ply::{self, vertex_property, vertex_property_is_integer};
use super::{Attributes, Builder, Numbering};
use crate::ooc::Mesh;

/// Reads `bytes` (the PLY `mesh` was read from).
pub(super) fn read(bytes: &[u8], mesh: &Mesh) -> Result<Attributes, Fault> {
    let parsed = ply::parse(bytes)?;
    let find = |names: &[&str]| vertex_property(&parsed, names);
    let normal = [find(&["nx"]), find(&["ny"]), find(&["nz"])];
    let uv = [
        find(&["s", "u", "texture_u", "texture_s"]),
        find(&["t", "v", "texture_v", "texture_t"]),
    ];
    let colour = [
        find(&["red", "r"]),
        find(&["green", "g"]),
        find(&["blue", "b"]),
        find(&["alpha", "a"]),
    ];
    let has_normals = normal.iter().all(Option::is_some);
    let has_uvs = uv.iter().all(Option::is_some);
    let has_colours = colour[..3].iter().all(Option::is_some);
    if !has_normals && !has_uvs && !has_colours {
        return Ok(Attributes::none(mesh));
    }
    // Missing properties read as property 0 and are ignored below.
    let wanted: Vec<usize> = normal
        .iter()
        .chain(&uv)
        .chain(&colour)
        .map(|p| p.unwrap_or(0))
        .collect();
    let integer_colours = colour[0].is_some_and(|p| vertex_property_is_integer(&parsed, p));
    let byte = |x: f64| -> u8 {
        let x = if integer_colours { x } else { x * 255.0 };
        x.round().clamp(0.0, 255.0) as u8
    };
    let mut out = Builder::new(Numbering::PerVertex)?;
    let mut v = 0u32;
    ply::vertex_scalars(bytes, &parsed, &wanted, &mut |row| {
        let n = has_normals.then(|| [row[0] as f32, row[1] as f32, row[2] as f32]);
        let t = has_uvs.then(|| [row[3] as f32, 1.0 - row[4] as f32]);
        let c = has_colours.then(|| {
            let alpha = if colour[3].is_some() {
                byte(row[8])
            } else {
                255
            };
            [byte(row[5]), byte(row[6]), byte(row[7]), alpha]
        });
        out.vertex(v, n, t, c)?;
        v += 1;
        Ok(())
    })?;
    for _ in 0..mesh.triangle_count() {
        out.triangle(None, super::NO_MATERIAL)?;
    }
    out.finish(mesh, Vec::new())
}
