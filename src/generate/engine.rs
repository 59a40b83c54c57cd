//! A high-depth-complexity model: an engine-like assembly whose inside is never visible.
//!
//! A closed, boxy outer casing (a superellipsoid) holds a closed inner housing, which holds a
//! lattice of closed machine parts: gears, pistons, bearings, and hollow shells with a gear
//! inside. Every part is closed and lies strictly inside the casing, so from any viewpoint
//! outside only the casing's few percent of the triangles can be seen: a visibility bake
//! should cull almost everything for outside views. The part in each lattice cell and its
//! orientation come from a hash of the cell, so the model is the same on every run.
//!
//! Memory: the part list (a few kilobytes per thousand parts); cost: one pass per section.

use super::noise::cell_hash;
use super::parts::{Assembled, Assembly};
use super::shapes::{Part, Shape, gear_steps, superellipsoid_steps};

/// Casing half-extents: an engine block longer than it is tall and wide.
const CASING_RADII: [f32; 3] = [2.0, 1.2, 1.2];
/// Superellipsoid exponent of casing and housing: small is boxy with rounded edges.
const BOXY: f32 = 0.3;
/// The housing's half-extents, a fraction of the casing's.
const HOUSING_SCALE: f32 = 0.9;
/// The part lattice's half-extents, a fraction of the housing's: every part point then
/// satisfies the housing's implicit inequality with a wide margin (checked in the tests).
const LATTICE_SCALE: f32 = 0.85;
/// Share of the triangles spent on each of casing and housing; the rest go to the parts.
const SHELL_SHARE: f64 = 0.02;
/// Fewest triangles for a shell, so small models still have round corners.
const MIN_SHELL_TRIANGLES: f64 = 2_000.0;
/// Target triangles per lattice cell: enough for a smooth gear, small enough that a
/// multi-million-triangle engine has thousands of parts.
const TRIANGLES_PER_CELL: f64 = 4_000.0;
/// The part's extent as a fraction of its cell's half-size; the rest is clearance.
const PART_FILL: f32 = 0.9;

/// The engine model.
pub struct Engine {
    assembly: Assembly,
}

/// The rotations a part can take: the identity and the two cyclic axis permutations (all
/// proper rotations, so triangles keep facing outwards).
const ORIENTATIONS: [[[f32; 3]; 3]; 3] = [
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
    [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
];

impl Engine {
    /// An engine of about `triangles` triangles (at least a few thousand).
    pub fn new(triangles: u64) -> Engine {
        let total = triangles as f64;
        let shell = (SHELL_SHARE * total).max(MIN_SHELL_TRIANGLES);
        let casing = |scale: f32| {
            let (nu, nv) = superellipsoid_steps(shell);
            Part {
                shape: Shape::Superellipsoid {
                    radii: CASING_RADII.map(|r| r * scale),
                    e_lat: BOXY,
                    e_lon: BOXY,
                    nu,
                    nv,
                },
                axes: ORIENTATIONS[0],
                centre: [0.0; 3],
            }
        };
        let mut parts = vec![casing(1.0), casing(HOUSING_SCALE)];

        // Lattice cells: cubes, as many as the part budget asks for, in the lattice's aspect.
        let half = CASING_RADII.map(|r| r * HOUSING_SCALE * LATTICE_SCALE);
        let budget = (total - 2.0 * shell).max(TRIANGLES_PER_CELL);
        let cells_wanted = (budget / TRIANGLES_PER_CELL).max(1.0);
        let volume = 8.0 * f64::from(half[0] * half[1] * half[2]);
        let side = (volume / cells_wanted).cbrt() as f32;
        let counts = half.map(|h| ((2.0 * h / side).round() as u32).max(1));
        let cells = counts[0] * counts[1] * counts[2];
        let per_cell = budget / f64::from(cells);
        let size = [0, 1, 2].map(|a| 2.0 * half[a] / counts[a] as f32);
        // The part's radius: it must fit the cell's smallest side.
        let r = 0.5 * PART_FILL * size[0].min(size[1]).min(size[2]);

        for cell in 0..cells {
            let (i, j, k) = (
                cell % counts[0],
                cell / counts[0] % counts[1],
                cell / (counts[0] * counts[1]),
            );
            let centre = [
                -half[0] + (i as f32 + 0.5) * size[0],
                -half[1] + (j as f32 + 0.5) * size[1],
                -half[2] + (k as f32 + 0.5) * size[2],
            ];
            let h = cell_hash(cell);
            let axes = ORIENTATIONS[(h >> 8) as usize % ORIENTATIONS.len()];
            let place = |shape| Part {
                shape,
                axes,
                centre,
            };
            match h % 4 {
                0 => parts.push(place(gear(r, per_cell, 8 + (h >> 12) % 16))),
                1 => parts.push(place(superellipsoid(
                    [0.6 * r, 0.6 * r, r],
                    0.2,
                    1.0,
                    per_cell,
                ))),
                2 => parts.push(place(superellipsoid([r; 3], 1.0, 1.0, per_cell))),
                _ => {
                    // A hollow shell with a gear inside: depth complexity within a part.
                    parts.push(place(superellipsoid([r; 3], 0.5, 0.5, 0.4 * per_cell)));
                    parts.push(place(gear(0.6 * r, 0.6 * per_cell, 10)));
                }
            }
        }
        Engine {
            assembly: Assembly::new(parts),
        }
    }

    /// Number of closed parts, casing and housing included.
    pub fn part_count(&self) -> usize {
        self.assembly.part_count()
    }

    /// Vertices of each part in emission order (casing first, then housing, then the lattice).
    pub fn part_vertex_counts(&self) -> Vec<u64> {
        self.assembly.part_vertex_counts()
    }
}

impl Assembled for Engine {
    fn assembly(&self) -> &Assembly {
        &self.assembly
    }
}

fn superellipsoid(radii: [f32; 3], e_lat: f32, e_lon: f32, triangles: f64) -> Shape {
    let (nu, nv) = superellipsoid_steps(triangles);
    Shape::Superellipsoid {
        radii,
        e_lat,
        e_lon,
        nu,
        nv,
    }
}

/// A gear whose outermost point (ring + teeth + tube) is at `radius`.
fn gear(radius: f32, triangles: f64, teeth: u32) -> Shape {
    let (nu, nv) = gear_steps(triangles, teeth);
    Shape::Gear {
        ring: 0.65 * radius,
        tube: 0.2 * radius,
        teeth,
        tooth_depth: 0.15 * radius,
        nu,
        nv,
    }
}

#[cfg(test)]
pub(crate) fn casing_inside(p: [f32; 3], scale: f32) -> f32 {
    // The superellipsoid's implicit function: below 1 inside.
    let [a, b, c] = CASING_RADII.map(|r| r * scale);
    let (e1, e2) = (BOXY, BOXY);
    let xy = (p[0] / a).abs().powf(2.0 / e2) + (p[1] / b).abs().powf(2.0 / e2);
    xy.powf(e2 / e1) + (p[2] / c).abs().powf(2.0 / e1)
}
