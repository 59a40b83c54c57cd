//! Copies of a source mesh on a floor grid: many separate, identical-looking objects, the
//! layout of a scene rather than of one scan.
//!
//! Copy `c` sits in row `c / columns`, column `c % columns`, spaced 1.25 footprints apart on
//! the `x`–`z` floor (the bunny is `y`-up) and turned about the vertical axis by a golden-angle
//! step, so no two neighbours face the same way. Memory: nothing beyond the source; cost: one
//! rotation per output vertex.

use std::io;

use super::Model;
use crate::ooc::Mesh;

/// Gap between copies, as a multiple of the source's larger floor extent.
const SPACING: f32 = 1.25;
/// Turn per copy: the golden angle, which never repeats a heading.
const GOLDEN_ANGLE_RADIANS: f32 = 2.399_963_2;

/// A grid of copies of a source mesh.
pub struct BunnyGrid<'a> {
    source: &'a Mesh,
    copies: u32,
    columns: u32,
    pitch: f32,
    /// Centre of the source's floor footprint, moved to each grid cell.
    centre: [f32; 2],
}

impl<'a> BunnyGrid<'a> {
    /// Number of copies whose triangle total is nearest to `triangles` (at least 1).
    pub fn copies_for(source: &Mesh, triangles: u64) -> u32 {
        let copies = (triangles as f64 / f64::from(source.triangle_count())).round();
        copies.clamp(1.0, f64::from(u32::MAX)) as u32
    }

    /// `copies` copies of `source` in a near-square grid.
    ///
    /// # Panics
    ///
    /// When `copies` is 0 (a caller contract).
    pub fn new(source: &'a Mesh, copies: u32) -> BunnyGrid<'a> {
        assert!(copies >= 1, "at least one copy");
        let columns = f64::from(copies).sqrt().ceil() as u32;
        let b = source.bounds();
        let extent = (b.max[0] - b.min[0]).max(b.max[2] - b.min[2]);
        BunnyGrid {
            source,
            copies,
            columns,
            pitch: SPACING * extent,
            centre: [0.5 * (b.min[0] + b.max[0]), 0.5 * (b.min[2] + b.max[2])],
        }
    }
}

impl Model for BunnyGrid<'_> {
    fn vertex_count(&self) -> u64 {
        u64::from(self.copies) * u64::from(self.source.vertex_count())
    }

    fn triangle_count(&self) -> u64 {
        u64::from(self.copies) * u64::from(self.source.triangle_count())
    }

    fn vertices(&self, emit: &mut dyn FnMut([f32; 3]) -> io::Result<()>) -> io::Result<()> {
        for c in 0..self.copies {
            let (sin, cos) = (c as f32 * GOLDEN_ANGLE_RADIANS).sin_cos();
            let offset = [
                (c % self.columns) as f32 * self.pitch,
                (c / self.columns) as f32 * self.pitch,
            ];
            for v in 0..self.source.vertex_count() {
                let [x, y, z] = self.source.position(v);
                let (dx, dz) = (x - self.centre[0], z - self.centre[1]);
                emit([
                    offset[0] + cos * dx + sin * dz,
                    y,
                    offset[1] - sin * dx + cos * dz,
                ])?;
            }
        }
        Ok(())
    }

    fn triangles(&self, emit: &mut dyn FnMut([u32; 3]) -> io::Result<()>) -> io::Result<()> {
        let n = self.source.vertex_count();
        for c in 0..self.copies {
            // The total was checked against u32 before writing.
            let base = c.wrapping_mul(n);
            for t in 0..self.source.triangle_count() {
                emit(self.source.triangle(t).map(|v| base + v))?;
            }
        }
        Ok(())
    }
}
