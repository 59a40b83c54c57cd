//! Meshes generated in code for the unit tests: grids, icospheres and soups of components (the
//! tiling's tests, which also build the defects real scans have from them), jittered and
//! placed grids, fans, cubes and noisy spheres (the sampler's). Seeded by [`Rng`], so a seed
//! gives the same mesh everywhere. Generators whose meshes tests edit further return a
//! [`Soup`]; the others a finished [`Mesh`].

use super::rng::Rng;
use crate::ooc::Mesh;

/// Vertices and triangles of a mesh under construction.
#[derive(Clone, Debug, Default)]
pub(crate) struct Soup {
    pub(crate) positions: Vec<[f32; 3]>,
    pub(crate) triangles: Vec<[u32; 3]>,
}

impl Soup {
    pub(crate) fn mesh(&self) -> Mesh {
        Mesh::from_memory("generated", self.positions.clone(), self.triangles.clone())
            .expect("generated meshes are valid")
    }

    /// Appends `other`, moved by `offset`.
    pub(crate) fn append(&mut self, other: &Soup, offset: [f32; 3]) {
        let base = self.positions.len() as u32;
        self.positions.extend(
            other
                .positions
                .iter()
                .map(|p| [p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]]),
        );
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|v| v + base)));
    }
}

/// An `nx` × `ny` grid of unit quads in the z = 0 plane, two triangles per quad, with heights
/// perturbed by up to `noise`. Quads where `hole(x, y)` holds are left out.
pub(crate) fn grid(
    nx: u32,
    ny: u32,
    noise: f32,
    seed: u64,
    hole: impl Fn(u32, u32) -> bool,
) -> Soup {
    let mut rng = Rng::new(seed);
    let mut s = Soup::default();
    for y in 0..=ny {
        for x in 0..=nx {
            s.positions.push([x as f32, y as f32, noise * rng.signed()]);
        }
    }
    let v = |x: u32, y: u32| y * (nx + 1) + x;
    for y in 0..ny {
        for x in 0..nx {
            if !hole(x, y) {
                s.triangles.push([v(x, y), v(x + 1, y), v(x + 1, y + 1)]);
                s.triangles.push([v(x, y), v(x + 1, y + 1), v(x, y + 1)]);
            }
        }
    }
    s
}

/// An icosphere of radius 1: an icosahedron with each triangle split in four `level` times
/// (20 · 4^level triangles).
pub(crate) fn icosphere(level: u32) -> Soup {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<[f32; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut midpoint = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, positions: &mut Vec<[f32; 3]>| {
            *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (p, q) = (positions[a as usize], positions[b as usize]);
                positions.push([0, 1, 2].map(|k| 0.5 * (p[k] + q[k])));
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let (ab, bc, ca) = (
                mid(a, b, &mut positions),
                mid(b, c, &mut positions),
                mid(c, a, &mut positions),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    for p in &mut positions {
        let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        *p = p.map(|c| c / l);
    }
    Soup {
        positions,
        triangles,
    }
}

/// The square `[-1, 1]²` split into `n × n` cells of two triangles (diagonals alternating),
/// interior vertices jittered by up to `jitter` cells; `place(u, v)` maps the square into 3-D.
pub(crate) fn square_grid(
    n: u32,
    jitter: f32,
    seed: u64,
    place: impl Fn(f32, f32) -> [f32; 3],
) -> Mesh {
    let mut rng = Rng::new(seed);
    let cell = 2.0 / n as f32;
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let interior = i > 0 && i < n && j > 0 && j < n;
            let (du, dv) = if interior {
                (rng.signed() * jitter * cell, rng.signed() * jitter * cell)
            } else {
                (0.0, 0.0)
            };
            positions.push(place(
                -1.0 + i as f32 * cell + du,
                -1.0 + j as f32 * cell + dv,
            ));
        }
    }
    let mut triangles = Vec::new();
    let at = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            if (i + j) % 2 == 0 {
                triangles.extend([[a, b, c], [a, c, d]]);
            } else {
                triangles.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    Mesh::from_memory("grid", positions, triangles).unwrap()
}

/// A fan of `k` triangles around the origin in the plane z = 0, rim on the unit circle at
/// jittered angles; it covers the polygon of its rim.
pub(crate) fn fan(k: u32, seed: u64) -> Mesh {
    let mut rng = Rng::new(seed);
    let mut positions = vec![[0.0, 0.0, 0.0]];
    for i in 0..k {
        let angle = (i as f32 + 0.3 * rng.signed()) / k as f32 * std::f32::consts::TAU;
        positions.push([angle.cos(), angle.sin(), 0.0]);
    }
    let triangles = (0..k).map(|i| [0, 1 + i, 1 + (i + 1) % k]).collect();
    Mesh::from_memory("fan", positions, triangles).unwrap()
}

/// Appends an axis-aligned cube (12 triangles, faces in the order +X, −X, +Y, −Y, +Z, −Z) to
/// `positions`/`triangles`.
pub(crate) fn push_cube(
    center: [f32; 3],
    half: f32,
    positions: &mut Vec<[f32; 3]>,
    triangles: &mut Vec<[u32; 3]>,
) {
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = positions.len() as u32;
            for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let mut p = center;
                p[axis] += sign * half;
                p[u] += su * half;
                p[v] += sv * half;
                positions.push(p);
            }
            triangles.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        }
    }
}

/// A closed UV sphere of radius about 1 with `2 · segments · (rings − 1)` triangles and
/// seeded radial bumps of up to ±`bump`.
pub(crate) fn noisy_sphere(rings: u32, segments: u32, bump: f32, seed: u64) -> Mesh {
    let mut rng = Rng::new(seed);
    let mut point = |theta: f32, phi: f32| {
        let r = 1.0 + bump * (0.5 * (3.0 * theta).sin() * (5.0 * phi).cos() + 0.5 * rng.signed());
        [
            r * theta.sin() * phi.cos(),
            r * theta.cos(),
            r * theta.sin() * phi.sin(),
        ]
    };
    let mut positions = vec![point(0.0, 0.0)];
    for ring in 1..rings {
        let theta = ring as f32 / rings as f32 * std::f32::consts::PI;
        for s in 0..segments {
            positions.push(point(
                theta,
                s as f32 / segments as f32 * std::f32::consts::TAU,
            ));
        }
    }
    positions.push(point(std::f32::consts::PI, 0.0));
    let south = positions.len() as u32 - 1;
    let at = |ring: u32, s: u32| 1 + (ring - 1) * segments + s % segments;
    let mut triangles = Vec::new();
    for s in 0..segments {
        triangles.push([0, at(1, s + 1), at(1, s)]);
        triangles.push([south, at(rings - 1, s), at(rings - 1, s + 1)]);
    }
    for ring in 1..rings - 1 {
        for s in 0..segments {
            let (a, b) = (at(ring, s), at(ring, s + 1));
            let (c, d) = (at(ring + 1, s + 1), at(ring + 1, s));
            triangles.extend([[a, b, c], [a, c, d]]);
        }
    }
    Mesh::from_memory("noisy sphere", positions, triangles).unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generators_have_their_documented_counts() {
        let ico = icosphere(2);
        assert_eq!(ico.triangles.len(), 20 * 16);
        assert!(ico.positions.iter().all(|p| {
            let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            (l - 1.0).abs() < 1e-6
        }));
        let holed = grid(4, 3, 0.1, 1, |x, y| (x, y) == (1, 1));
        assert_eq!((holed.positions.len(), holed.triangles.len()), (20, 22));
        assert_eq!(
            square_grid(5, 0.2, 3, |u, v| [u, v, 0.0]).triangle_count(),
            50
        );
        assert_eq!(fan(7, 1).triangle_count(), 7);
        assert_eq!(noisy_sphere(6, 10, 0.1, 2).triangle_count(), 2 * 10 * 5);
        let (mut positions, mut triangles) = (Vec::new(), Vec::new());
        push_cube([0.0; 3], 1.0, &mut positions, &mut triangles);
        assert_eq!((positions.len(), triangles.len()), (24, 12));
        // Same seed, same mesh.
        assert_eq!(
            grid(3, 3, 0.5, 9, |_, _| false).positions,
            grid(3, 3, 0.5, 9, |_, _| false).positions
        );
    }
}
