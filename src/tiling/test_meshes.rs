//! Meshes generated in code for the tiling tests: grids, icospheres, soups of components,
//! and the defects real scans have (non-manifold fins, duplicates, degenerate triangles,
//! inconsistent orientation).

use crate::ooc::Mesh;

/// Vertices and triangles of a mesh under construction.
#[derive(Clone, Debug, Default)]
pub struct Soup {
    pub positions: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

impl Soup {
    pub fn mesh(&self) -> Mesh {
        Mesh::from_memory("generated", self.positions.clone(), self.triangles.clone())
            .expect("generated meshes are valid")
    }

    /// Appends `other`, moved by `offset`.
    pub fn append(&mut self, other: &Soup, offset: [f32; 3]) {
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

/// A tiny deterministic generator (SplitMix64) for noise.
pub struct Noise(u64);

impl Noise {
    pub fn new(seed: u64) -> Noise {
        Noise(seed)
    }
    /// Uniform in [-1, 1).
    pub fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 23) as f32 - 1.0
    }
}

/// An `nx` × `ny` grid of unit quads in the z = 0 plane, two triangles per quad, with heights
/// perturbed by up to `noise`. Quads where `hole(x, y)` holds are left out.
pub fn grid(nx: u32, ny: u32, noise: f32, seed: u64, hole: impl Fn(u32, u32) -> bool) -> Soup {
    let mut rng = Noise::new(seed);
    let mut s = Soup::default();
    for y in 0..=ny {
        for x in 0..=nx {
            s.positions.push([x as f32, y as f32, noise * rng.next()]);
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
pub fn icosphere(level: u32) -> Soup {
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
