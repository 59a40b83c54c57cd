//! A hard model for visibility culling: a thin lattice that is seen through, not around.
//!
//! A cubic truss of `n × n × n` cells (a cube 4 units across): a node block at every lattice
//! point, thin square beams along every cell edge, a body diagonal in some cells and a face
//! diagonal on some cell faces, and in some of the cells without a body diagonal a cluster of
//! three crossed "leaf cards" (thin boxes, like foliage billboards) around a tilted axis. The
//! beams are 6% of a cell wide, so from almost any direction most of the inside shows through
//! the gaps, and a small turn moves a beam across what was seen: which triangles are visible
//! flips quickly with the viewing direction, and a visibility bake must sample it finely.
//!
//! The cell count grows with the budget (`TRIANGLES_PER_CELL`; about 40,000 triangles give
//! the 6 × 6 × 6 lattice), and `parts::fit` spends the rest on finer tessellation. Every
//! part is closed and faces outwards; beams pass into the node blocks rather than touching
//! them. The cell's braces and cards come from a hash of the cell's number, so the model is
//! the same on every run.
//!
//! Memory: the part list (a few hundred bytes per cell); cost: one pass per section.

use std::f32::consts::TAU;

use super::noise::cell_hash;
use super::parts::{self, Assembled, Assembler, Assembly};
use super::shapes::{UNROTATED, axes_along};

/// The lattice's side: it spans `-2..2` on every axis.
const SIZE: f32 = 4.0;
/// Target triangles per cell when choosing the cell count, set so that 40,000 triangles give
/// 6 cells a side. The coarsest lattice spends about 80 per cell (12 per box), so the fit
/// always has room left for tessellation.
const TRIANGLES_PER_CELL: f64 = 200.0;
/// Fewest and most cells a side. Past the most, a bigger budget tessellates more finely.
const MIN_CELLS: u32 = 2;
const MAX_CELLS: u32 = 24;
/// Beam width as a fraction of the cell: a face of the lattice is 88% open.
const BEAM_WIDTH: f32 = 0.06;
/// Node block and diagonal widths, as multiples of the beam width.
const NODE_WIDTH: f32 = 1.6;
const DIAGONAL_WIDTH: f32 = 0.75;
/// A leaf card's half-extents as fractions of the cell: half-width, half-height (along the
/// cluster's axis) and half-thickness. Its corners stay 0.08 of a cell clear of the beams.
const CARD_HALF: [f32; 3] = [0.28, 0.2, 0.0025];
/// How far a card cluster may sit from the cell's centre, and tilt from vertical (radians).
const CARD_OFFSET: f32 = 0.05;
const CARD_TILT: f32 = 0.5;

/// The truss model.
pub struct Truss {
    cells: u32,
    assembly: Assembly,
}

impl Truss {
    /// A truss of about `triangles` triangles (never more, unless below its fewest: about
    /// 1,200).
    pub fn new(triangles: u64) -> Truss {
        let cells = (triangles as f64 / TRIANGLES_PER_CELL)
            .cbrt()
            .round()
            .clamp(f64::from(MIN_CELLS), f64::from(MAX_CELLS)) as u32;
        Truss {
            cells,
            assembly: parts::fit(triangles, |a| layout(a, cells)),
        }
    }

    /// Cells along each side of the lattice.
    pub fn cells_per_side(&self) -> u32 {
        self.cells
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

/// Nodes, then edge beams, then each cell's braces and cards.
fn layout(a: &mut Assembler, n: u32) {
    let cell = SIZE / n as f32;
    let at = |p: [u32; 3]| p.map(|i| -0.5 * SIZE + cell * i as f32);
    let beam = BEAM_WIDTH * cell;
    let node_half = 0.5 * NODE_WIDTH * beam;
    for k in 0..=n {
        for j in 0..=n {
            for i in 0..=n {
                a.cuboid(at([i, j, k]), [node_half; 3], UNROTATED);
            }
        }
    }
    // A member between two lattice points, its ends inside the node blocks.
    let member = |a: &mut Assembler, from: [u32; 3], to: [u32; 3], width: f32| {
        let (p, q) = (at(from), at(to));
        let d = [0, 1, 2].map(|c| q[c] - p[c]);
        let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let inset = 0.5 * node_half / length;
        let end = |t: f32| [0, 1, 2].map(|c| p[c] + t * d[c]);
        a.beam(end(inset), end(1.0 - inset), width);
    };
    for axis in 0..3 {
        for k in 0..=n {
            for j in 0..=n {
                for i in 0..n {
                    // (i along the beam's axis, j and k across it)
                    let mut from = [0; 3];
                    from[axis] = i;
                    from[(axis + 1) % 3] = j;
                    from[(axis + 2) % 3] = k;
                    let mut to = from;
                    to[axis] += 1;
                    member(a, from, to, beam);
                }
            }
        }
    }
    let diagonal = DIAGONAL_WIDTH * beam;
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let h = cell_hash((k * n + j) * n + i);
                let corner = |o: [u32; 3]| [i + o[0], j + o[1], k + o[2]];
                let braced = h % 5 < 2;
                if braced {
                    // One of the four body diagonals: from a bottom corner to the top one
                    // opposite.
                    let [x, y] = [(h >> 3) & 1, (h >> 4) & 1];
                    member(a, corner([x, y, 0]), corner([1 - x, 1 - y, 1]), diagonal);
                }
                if (h >> 5).is_multiple_of(3) {
                    // A diagonal on one of the cell's three lower faces (each face is the
                    // lower face of one cell only, so no face gets two).
                    let face = ((h >> 7) % 3) as usize;
                    let flip = (h >> 9) & 1;
                    let (u, v) = ((face + 1) % 3, (face + 2) % 3);
                    let (mut from, mut to) = ([0; 3], [0; 3]);
                    from[u] = flip;
                    to[u] = 1 - flip;
                    to[v] = 1;
                    member(a, corner(from), corner(to), diagonal);
                }
                if !braced && (h >> 10) & 1 == 0 {
                    let centre = at([i, j, k]).map(|c| c + 0.5 * cell);
                    leaf_cluster(a, centre, cell, h);
                }
            }
        }
    }
}

/// Three crossed cards around an axis tilted from vertical, near `centre`.
fn leaf_cluster(a: &mut Assembler, centre: [f32; 3], cell: f32, h: u32) {
    let unit = |bits: u32| (cell_hash(h ^ bits) >> 8) as f32 / (1u32 << 24) as f32;
    let (tilt, heading, spin) = (CARD_TILT * unit(1), TAU * unit(2), TAU * unit(3));
    let offset = [4, 5, 6].map(|b| CARD_OFFSET * cell * (2.0 * unit(b) - 1.0));
    let axis = [
        tilt.sin() * heading.cos(),
        tilt.cos(),
        tilt.sin() * heading.sin(),
    ];
    let centre = [0, 1, 2].map(|c| centre[c] + offset[c]);
    let half = CARD_HALF.map(|f| f * cell);
    for card in 0..3 {
        // The card's plane holds the axis: its local y goes along the axis, its normal turns
        // about it, 60° from card to card.
        let [x, y, z] = axes_along(axis, spin + TAU / 6.0 * card as f32);
        let axes = [x, z, y.map(|c| -c)];
        a.cuboid(centre, half, axes);
    }
}

impl Assembled for Truss {
    fn assembly(&self) -> &Assembly {
        &self.assembly
    }
}
