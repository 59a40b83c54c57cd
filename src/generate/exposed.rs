//! A hard model for visibility culling: an engine-like assembly with its parts exposed.
//!
//! Unlike [`Engine`](super::engine::Engine), nothing is hidden inside a casing: an open frame
//! on a base plate carries a bank of thin cooling fins with heat pipes through them, a train of
//! gears on shafts in front of a plate perforated with square holes, two rows of cylinders
//! behind it with narrow gaps between them, a stack of thin plates, and pipes (some hollow)
//! across the whole. Most parts are seen only through gaps of a few hundredths of the model's
//! size, between fins, through holes and pipes, so what is visible changes quickly with the
//! viewing direction: a bake must sample directions finely to find it all, and a coarse one
//! misses pixels.
//!
//! The layout is fixed (about 150 parts, the model about 4 × 2.3 × 2.4 units, `y` up); the
//! triangle budget only sets how finely the parts are tessellated (`parts::fit`). Every part
//! is closed and faces outwards; parts touch or pass through each other where they are joined.
//! The few choices that vary between parts (fin heights, which cylinders are hollow) come from
//! a hash of the part's number, so the model is the same on every run.
//!
//! Memory: the part list; cost: one pass per section.

use super::noise::cell_hash;
use super::parts::{self, Assembled, Assembler, Assembly};

/// Top of the base plate; everything stands on it.
const FLOOR: f32 = -1.0;
/// Half-extents of the base plate (its top at `FLOOR`).
const BASE_HALF: [f32; 3] = [2.0, 0.1, 1.2];
/// Width of the frame's posts and rails.
const FRAME_BAR: f32 = 0.1;
/// Thickness of a cooling fin: 1% of the model's length.
const FIN_THICKNESS: f32 = 0.04;
/// Cooling fins in the bank; with the bank 1.5 long the gaps between fins are 0.054.
const FINS: u32 = 16;
/// Width of the perforated plate's bars, and the hole size it aims for.
const PLATE_BAR: f32 = 0.06;
const PLATE_HOLE: f32 = 0.18;
/// Radius of a cylinder in the bank, and the gap between neighbours.
const CYLINDER_RADIUS: f32 = 0.14;
const CYLINDER_GAP: f32 = 0.03;
/// Thickness of a plate in the stack, and the gap between plates.
const STACK_PLATE: f32 = 0.03;
const STACK_GAP: f32 = 0.04;

/// The exposed-engine model.
pub struct ExposedEngine {
    assembly: Assembly,
}

impl ExposedEngine {
    /// An exposed engine of about `triangles` triangles (never more, unless below its
    /// fewest: about 3,500).
    pub fn new(triangles: u64) -> ExposedEngine {
        ExposedEngine {
            assembly: parts::fit(triangles, layout),
        }
    }

    /// Number of closed parts.
    pub fn part_count(&self) -> usize {
        self.assembly.part_count()
    }

    /// Vertices of each part in emission order.
    pub fn part_vertex_counts(&self) -> Vec<u64> {
        self.assembly.part_vertex_counts()
    }
}

/// The whole assembly: `x` along the engine, `y` up, `z` across; the fins on the left (`x <
/// 0`), the gears in front (`z > 0`) of the perforated plate on the right, the cylinders and
/// the plate stack behind it.
fn layout(a: &mut Assembler) {
    frame(a);
    fin_bank(a);
    gear_train(a);
    perforated_plate(a);
    cylinder_bank(a);
    plate_stack(a);
    pipes(a);
}

/// The base plate and an open frame of four posts and four top rails.
fn frame(a: &mut Assembler) {
    let [hx, hy, hz] = BASE_HALF;
    a.block([-hx, FLOOR - 2.0 * hy, -hz], [hx, FLOOR, hz]);
    let (x, z) = (hx - 0.08, hz - 0.08);
    let (bar, top) = (0.5 * FRAME_BAR, 1.0);
    for (sx, sz) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
        let (cx, cz) = (sx * x, sz * z);
        // Posts reach into the rails, so the joints leave no seam.
        a.block([cx - bar, FLOOR, cz - bar], [cx + bar, top + bar, cz + bar]);
    }
    for s in [-1.0, 1.0] {
        a.block(
            [-x - bar, top, s * z - bar],
            [x + bar, top + FRAME_BAR, s * z + bar],
        );
        a.block(
            [s * x - bar, top + 0.01, -z + bar],
            [s * x + bar, top + FRAME_BAR - 0.01, z - bar],
        );
    }
}

/// Cooling fins across `x` on a block, with three heat pipes (one hollow) through them.
fn fin_bank(a: &mut Assembler) {
    let (x0, x1) = (-1.8, -0.3);
    let (z0, z1) = (-0.9, 0.3);
    let block_top = FLOOR + 0.3;
    a.block([x0, FLOOR, z0], [x1, block_top, z1]);
    let pitch = (x1 - x0) / FINS as f32;
    for fin in 0..FINS {
        let x = x0 + pitch * (fin as f32 + 0.5);
        // Uneven tops, as on a cast cylinder head: 0.4 to 0.5.
        let top = 0.5 - 0.05 * (cell_hash(fin) % 3) as f32;
        let t = 0.5 * FIN_THICKNESS;
        a.block([x - t, block_top - 0.02, z0], [x + t, top, z1]);
    }
    let (from, to) = (x0 - 0.15, x1 + 0.15);
    a.rod([from, 0.25, -0.7], [to, 0.25, -0.7], 0.05);
    a.tube([from, -0.2, -0.3], [to, -0.2, -0.3], 0.05, 0.035);
    a.rod([from, 0.25, 0.1], [to, 0.25, 0.1], 0.05);
}

/// Four gears in a chain, 0.02 apart, each on a shaft through its hole into the plate.
fn gear_train(a: &mut Assembler) {
    // (centre x, centre y, outer radius); teeth at about the same pitch on all.
    const GEARS: [(f32, f32, f32); 4] = [
        (0.65, -0.35, 0.5),
        (1.278, 0.177, 0.3),
        (1.563, -0.317, 0.25),
        (1.278, 0.697, 0.2),
    ];
    let z = 0.85;
    for (x, y, r) in GEARS {
        let teeth = (40.0 * r).round() as u32;
        a.gear([x, y, z], [0.0, 0.0, 1.0], r, teeth);
        // The hole's radius is 0.45 r: the shaft leaves a ring of gap around itself.
        a.rod([x, y, 0.38], [x, y, 1.0], 0.3 * r);
    }
}

/// A plate across `z` built from bars around a grid of square holes.
fn perforated_plate(a: &mut Assembler) {
    let (x0, x1, y0, y1) = (0.15, 1.85, FLOOR, 0.95);
    let (z0, z1) = (0.35, 0.43);
    let holes = |length: f32| ((length - PLATE_BAR) / (PLATE_HOLE + PLATE_BAR)).round() as u32;
    let (nx, ny) = (holes(x1 - x0), holes(y1 - y0));
    let hole_x = (x1 - x0 - PLATE_BAR * (nx + 1) as f32) / nx as f32;
    let hole_y = (y1 - y0 - PLATE_BAR * (ny + 1) as f32) / ny as f32;
    let row = |j: u32| y0 + j as f32 * (hole_y + PLATE_BAR);
    for j in 0..=ny {
        a.block([x0, row(j), z0], [x1, row(j) + PLATE_BAR, z1]);
    }
    for j in 0..ny {
        for i in 0..=nx {
            let x = x0 + i as f32 * (hole_x + PLATE_BAR);
            a.block([x, row(j) + PLATE_BAR, z0], [x + PLATE_BAR, row(j + 1), z1]);
        }
    }
}

/// Two rows of five upright cylinders of uneven heights, some of them hollow liners.
fn cylinder_bank(a: &mut Assembler) {
    let pitch = 2.0 * CYLINDER_RADIUS + CYLINDER_GAP;
    for (row, z) in [0.1, 0.1 - pitch].into_iter().enumerate() {
        for i in 0..5u32 {
            let n = row as u32 * 5 + i;
            let h = cell_hash(100 + n);
            let x = 0.35 + pitch * i as f32;
            let top = 0.15 * (h % 5) as f32;
            if (h >> 8) & 3 == 0 {
                let inner = 0.75 * CYLINDER_RADIUS;
                a.tube([x, FLOOR, z], [x, top, z], CYLINDER_RADIUS, inner);
            } else {
                a.rod([x, FLOOR, z], [x, top, z], CYLINDER_RADIUS);
            }
        }
    }
}

/// A sump block and above it a stack of thin plates on two posts.
fn plate_stack(a: &mut Assembler) {
    let (x0, x1, z0, z1) = (0.2, 1.8, -1.05, -0.55);
    let bottom = -0.6;
    a.block([x0, FLOOR, z0], [x1, bottom - 0.05, z1]);
    let pitch = STACK_PLATE + STACK_GAP;
    let plates = (1.2 / pitch) as u32;
    for p in 0..plates {
        let y = bottom + pitch * p as f32;
        a.block([x0, y, z0], [x1, y + STACK_PLATE, z1]);
    }
    let top = bottom + pitch * plates as f32;
    for x in [x0 + 0.05, x1 - 0.05] {
        a.block([x - 0.03, bottom - 0.05, -0.83], [x + 0.03, top, -0.77]);
    }
}

/// Pipes across the top and a hollow manifold between the fins and the gears.
fn pipes(a: &mut Assembler) {
    a.rod([-2.0, 0.8, -0.9], [2.0, 0.8, -0.9], 0.05);
    a.tube([-2.0, 0.8, -0.5], [2.0, 0.8, -0.5], 0.05, 0.035);
    // Crosses just above the two, 0.01 clear of them.
    a.rod([-0.1, 0.9, -1.15], [-0.1, 0.9, 1.15], 0.04);
    a.tube([-0.1, -0.55, -1.1], [-0.1, -0.55, 1.1], 0.17, 0.12);
}

impl Assembled for ExposedEngine {
    fn assembly(&self) -> &Assembly {
        &self.assembly
    }
}
