//! A source mesh split `k × k` per triangle and displaced by smooth noise: a dense,
//! scanned-looking surface of any size, streamed without holding the output.
//!
//! Each source triangle `(a, b, c)` becomes the triangular lattice of points
//! `(k−i−j)/k·a + i/k·b + j/k·c`, `i, j ≥ 0, i + j ≤ k`, cut into `k²` triangles. For `k = 2^L`
//! the points are exactly those of L levels of midpoint subdivision (each level ×4 triangles);
//! other `k` let `--triangles` land near any request. Vertices are numbered without a
//! dedup map: source vertices first, then `k − 1` points per source edge (numbered from the
//! edge's lower-indexed end, so both triangles on an edge compute the same numbers), then each
//! triangle's interior points. Shared edges therefore share vertices and the output has the
//! source's topology (watertight where the source is). Every point is moved along its
//! interpolated vertex normal by `noise::fractal` of its position —
//! a function of the point alone, so shared points stay shared.
//!
//! Memory: the source's edge table and vertex normals (about 40 bytes per source triangle),
//! nothing per output element. Cost: one noise evaluation per output vertex.

use std::collections::HashMap;
use std::io;

use super::Model;
use super::noise;
use crate::ooc::Mesh;

/// Relief height as a fraction of the source's bounding-box diagonal: 0.4% gives visible
/// scan-like bumps on the bunny without folding its thin ears.
const RELIEF_AMPLITUDE: f32 = 0.004;
/// Noise cells across the bounding-box diagonal: bumps about 1/40 of the model, the scale of
/// the bunny's own fur-like scan noise.
const RELIEF_FREQUENCY: f32 = 40.0;

/// A source mesh, split and displaced; see the module documentation.
pub struct SubdividedMesh<'a> {
    source: &'a Mesh,
    k: u32,
    /// Source edges `[low, high]` in first-seen order; index = edge id.
    edges: Vec<[u32; 2]>,
    /// The edge ids of each source triangle: `ab`, `bc`, `ca`.
    triangle_edges: Vec<[u32; 3]>,
    /// Area-weighted unit vertex normals of the source.
    normals: Vec<[f32; 3]>,
    amplitude: f32,
    frequency: f32,
}

impl<'a> SubdividedMesh<'a> {
    /// The split factor `k` whose `k² × source triangles` is nearest to `triangles` (at least 1).
    pub fn factor_for(source: &Mesh, triangles: u64) -> u32 {
        let ratio = triangles as f64 / f64::from(source.triangle_count());
        (ratio.sqrt().round() as u32).max(1)
    }

    /// Prepares `source` split `k × k` per triangle.
    ///
    /// # Panics
    ///
    /// When `k` is 0 (a caller contract).
    pub fn new(source: &'a Mesh, k: u32) -> SubdividedMesh<'a> {
        assert!(k >= 1, "split factor k must be at least 1");
        let mut edge_ids: HashMap<(u32, u32), u32> = HashMap::new();
        let mut edges = Vec::new();
        let mut triangle_edges = Vec::with_capacity(source.triangle_count() as usize);
        let mut normals = vec![[0f32; 3]; source.vertex_count() as usize];
        for t in 0..source.triangle_count() {
            let tri = source.triangle(t);
            let ids = [0, 1, 2].map(|e| {
                let (u, v) = (tri[e], tri[(e + 1) % 3]);
                let key = (u.min(v), u.max(v));
                *edge_ids.entry(key).or_insert_with(|| {
                    edges.push([key.0, key.1]);
                    edges.len() as u32 - 1
                })
            });
            triangle_edges.push(ids);
            let [a, b, c] = tri.map(|v| source.position(v));
            let n = cross(sub(b, a), sub(c, a));
            for v in tri {
                let slot = &mut normals[v as usize];
                *slot = [slot[0] + n[0], slot[1] + n[1], slot[2] + n[2]];
            }
        }
        for n in &mut normals {
            *n = normalize(*n);
        }
        let bounds = source.bounds();
        let diagonal = length(sub(bounds.max, bounds.min));
        SubdividedMesh {
            source,
            k,
            edges,
            triangle_edges,
            normals,
            amplitude: RELIEF_AMPLITUDE * diagonal,
            frequency: RELIEF_FREQUENCY / diagonal.max(f32::MIN_POSITIVE),
        }
    }

    /// Prepares `source` split `k × k` per triangle without relief: every point stays on its
    /// source triangle, so for `k = 2^L` the output is exactly L levels of midpoint subdivision
    /// (each midpoint is `½a + ½b`, the same `f32` as `½(a + b)`).
    ///
    /// # Panics
    ///
    /// When `k` is 0 (a caller contract).
    pub fn without_relief(source: &'a Mesh, k: u32) -> SubdividedMesh<'a> {
        SubdividedMesh {
            amplitude: 0.0,
            ..SubdividedMesh::new(source, k)
        }
    }

    /// The split factor.
    pub fn k(&self) -> u32 {
        self.k
    }

    /// First vertex index of the edge points.
    fn edge_base(&self) -> u64 {
        u64::from(self.source.vertex_count())
    }
    /// First vertex index of the interior points.
    fn interior_base(&self) -> u64 {
        self.edge_base() + self.edges.len() as u64 * u64::from(self.k - 1)
    }
    /// Interior points per source triangle: `(k − 1)(k − 2) / 2`.
    fn interior_per_triangle(&self) -> u64 {
        let k = u64::from(self.k);
        (k - 1) * k.saturating_sub(2) / 2
    }

    /// The displaced point with barycentric weights `w` over source vertices `tri`.
    fn point(&self, tri: [u32; 3], w: [f32; 3]) -> [f32; 3] {
        let mut p = [0f32; 3];
        let mut n = [0f32; 3];
        for (v, wv) in tri.into_iter().zip(w) {
            let (q, m) = (self.source.position(v), self.normals[v as usize]);
            for c in 0..3 {
                p[c] += wv * q[c];
                n[c] += wv * m[c];
            }
        }
        let n = normalize(n);
        let h = self.amplitude * noise::fractal(p.map(|c| c * self.frequency));
        [p[0] + h * n[0], p[1] + h * n[1], p[2] + h * n[2]]
    }
}

impl Model for SubdividedMesh<'_> {
    fn vertex_count(&self) -> u64 {
        self.interior_base()
            + u64::from(self.source.triangle_count()) * self.interior_per_triangle()
    }

    fn triangle_count(&self) -> u64 {
        u64::from(self.source.triangle_count()) * u64::from(self.k) * u64::from(self.k)
    }

    fn vertices(&self, emit: &mut dyn FnMut([f32; 3]) -> io::Result<()>) -> io::Result<()> {
        let k = self.k as f32;
        for v in 0..self.source.vertex_count() {
            emit(self.point([v, v, v], [1.0, 0.0, 0.0]))?;
        }
        for &[u, v] in &self.edges {
            for s in 1..self.k {
                let t = s as f32 / k;
                emit(self.point([u, v, u], [1.0 - t, t, 0.0]))?;
            }
        }
        for t in 0..self.source.triangle_count() {
            let tri = self.source.triangle(t);
            for j in 1..self.k.saturating_sub(1) {
                for i in 1..self.k - j {
                    let (wi, wj) = (i as f32 / k, j as f32 / k);
                    emit(self.point(tri, [1.0 - wi - wj, wi, wj]))?;
                }
            }
        }
        Ok(())
    }

    fn triangles(&self, emit: &mut dyn FnMut([u32; 3]) -> io::Result<()>) -> io::Result<()> {
        let k = self.k;
        let interior = self.interior_per_triangle();
        for t in 0..self.source.triangle_count() {
            let tri = self.source.triangle(t);
            let [ab, bc, ca] = self.triangle_edges[t as usize];
            let first_interior = self.interior_base() + u64::from(t) * interior;
            // Index of edge `e` (from `u` to `v`) at step `s` of `k`, 0 < s < k.
            let on_edge = |e: u32, u: u32, v: u32, s: u32| -> u64 {
                let step = if u < v { s } else { k - s };
                self.edge_base() + u64::from(e) * u64::from(k - 1) + u64::from(step - 1)
            };
            let index = |i: u32, j: u32| -> u32 {
                let [a, b, c] = tri;
                let at = match (i, j) {
                    (0, 0) => u64::from(a),
                    _ if i == k => u64::from(b),
                    _ if j == k => u64::from(c),
                    (_, 0) => on_edge(ab, a, b, i),
                    (0, _) => on_edge(ca, c, a, k - j),
                    _ if i + j == k => on_edge(bc, b, c, j),
                    _ => {
                        // Row j holds i = 1..=k−1−j; rows 1..j before it.
                        let (i, j) = (u64::from(i), u64::from(j));
                        let row_start = (j - 1) * u64::from(k - 1) - (j - 1) * j / 2;
                        first_interior + row_start + i - 1
                    }
                };
                // The total was checked against u32 before writing.
                at as u32
            };
            for j in 0..k {
                for i in 0..k - j {
                    emit([index(i, j), index(i + 1, j), index(i, j + 1)])?;
                    if i + j + 2 <= k {
                        emit([index(i + 1, j), index(i + 1, j + 1), index(i, j + 1)])?;
                    }
                }
            }
        }
        Ok(())
    }
}

pub(crate) fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(crate) fn length(a: [f32; 3]) -> f32 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}
/// `a` scaled to unit length; the zero vector stays zero (isolated source vertices).
pub(crate) fn normalize(a: [f32; 3]) -> [f32; 3] {
    let l = length(a);
    if l > 0.0 { a.map(|c| c / l) } else { a }
}
