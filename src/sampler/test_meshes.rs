//! Generated meshes for the sampler's tests: grids, fans, nested cubes, a noisy sphere.

use crate::ooc::Mesh;

/// A tiny deterministic generator (SplitMix64), so tests need no RNG dependency.
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `[-1, 1)`.
    pub(crate) fn signed(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 23) as f32 - 1.0
    }
}

/// The square `[-1, 1]²` split into `n × n` cells of two triangles (diagonals alternating),
/// interior vertices jittered by up to `jitter` cells; `place(u, v)` maps the square into 3-D.
pub(crate) fn grid(n: u32, jitter: f32, seed: u64, place: impl Fn(f32, f32) -> [f32; 3]) -> Mesh {
    let mut rng = Rng(seed);
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
    let mut rng = Rng(seed);
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
    let mut rng = Rng(seed);
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

/// `count` roughly uniform unit directions (Fibonacci lattice), for tests that must not wait
/// for the sampling sphere.
pub(crate) fn fibonacci_directions(count: u32) -> Vec<[f32; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * i as f64;
            [(r * phi.cos()) as f32, y as f32, (r * phi.sin()) as f32]
        })
        .collect()
}

/// The bundled Stanford bunny (`assets/bunny.ply`: binary little-endian, float x y z, uchar
/// count + int indices), read here so the sampler's timing does not depend on `ooc`.
pub(crate) fn bunny() -> Mesh {
    let bytes = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/bunny.ply")).unwrap();
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = std::str::from_utf8(&bytes[..header_end]).unwrap();
    let count = |element: &str| -> usize {
        let line = header.lines().find(|l| l.starts_with(element)).unwrap();
        line.rsplit(' ').next().unwrap().parse().unwrap()
    };
    let (vertices, faces) = (count("element vertex"), count("element face"));
    let word = |at: usize| <[u8; 4]>::try_from(&bytes[at..at + 4]).unwrap();
    let positions = (0..vertices)
        .map(|v| std::array::from_fn(|k| f32::from_le_bytes(word(header_end + 12 * v + 4 * k))))
        .collect();
    let faces_start = header_end + 12 * vertices;
    let triangles = (0..faces)
        .map(|f| {
            let at = faces_start + 13 * f;
            assert_eq!(bytes[at], 3);
            std::array::from_fn(|k| u32::from_le_bytes(word(at + 1 + 4 * k)))
        })
        .collect();
    Mesh::from_memory("bunny", positions, triangles).unwrap()
}

/// A bounding sphere: the centre of the bounds and the largest distance from it.
pub(crate) fn bounding_sphere(mesh: &Mesh) -> ([f32; 3], f32) {
    let b = mesh.bounds();
    let center: [f32; 3] = std::array::from_fn(|k| 0.5 * (b.min[k] + b.max[k]));
    let radius = (0..mesh.vertex_count())
        .map(|v| {
            let p = mesh.position(v);
            (0..3)
                .map(|k| (p[k] - center[k]).powi(2))
                .sum::<f32>()
                .sqrt()
        })
        .fold(0.0, f32::max);
    (center, radius * 1.0001)
}
