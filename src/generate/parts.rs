//! Assemblies of closed solids built to a triangle budget: boxes, rods and tubes placed by
//! their corners or end points, and gears, all tessellated to one target edge length.
//!
//! A model describes its layout once, as a function that places parts through an
//! [`Assembler`]; [`fit`] bisects the edge length until the layout's triangle total is the
//! largest that does not exceed the budget (or the coarsest layout, when even that is over).
//! Each grid count is `floor(length / step + dither)`, with a dither per part from a hash, so
//! the total grows smoothly as the step shrinks instead of jumping when hundreds of identical
//! beams round up together. Cost: `FIT_ITERATIONS` layouts of the part list (milliseconds for
//! tens of thousands of parts), nothing per triangle.

use std::f32::consts::{PI, TAU};
use std::io;

use super::Model;
use super::noise::cell_hash;
use super::shapes::{Part, Shape, UNROTATED, axes_along, gear_steps};

/// Bisection steps on the logarithm of the edge length: the range below is 14 e-folds, so
/// the step ends within a factor 1 + 2⁻³⁵ of the best, far finer than any count change.
const FIT_ITERATIONS: u32 = 48;
/// The finest edge length tried: for models a few units across, far past `u32` triangles.
const FINEST_STEP: f32 = 1e-4;
/// The coarsest edge length tried: every part at its fewest triangles.
const COARSEST_STEP: f32 = 100.0;
/// Most cells along one side of one part's grid, which keeps index arithmetic in range.
const MAX_GRID_STEPS: f32 = 65_536.0;
/// Fewest sides of a rod or tube: still reads as round.
const MIN_ROUND_SIDES: u32 = 8;

/// Closed parts, emitted one after another.
pub(crate) struct Assembly {
    parts: Vec<Part>,
}

impl Assembly {
    /// The parts, emitted in this order.
    pub(crate) fn new(parts: Vec<Part>) -> Assembly {
        Assembly { parts }
    }

    /// Vertices of each part in emission order.
    pub(crate) fn part_vertex_counts(&self) -> Vec<u64> {
        self.parts.iter().map(Part::vertex_count).collect()
    }

    /// Number of parts.
    pub(crate) fn part_count(&self) -> usize {
        self.parts.len()
    }
}

impl Model for Assembly {
    fn vertex_count(&self) -> u64 {
        self.parts.iter().map(Part::vertex_count).sum()
    }

    fn triangle_count(&self) -> u64 {
        self.parts.iter().map(Part::triangle_count).sum()
    }

    fn vertices(&self, emit: &mut dyn FnMut([f32; 3]) -> io::Result<()>) -> io::Result<()> {
        self.parts.iter().try_for_each(|p| p.vertices(emit))
    }

    fn triangles(&self, emit: &mut dyn FnMut([u32; 3]) -> io::Result<()>) -> io::Result<()> {
        let mut base = 0u64;
        for part in &self.parts {
            // The total was checked against u32 before writing.
            part.triangles(base as u32, emit)?;
            base += part.vertex_count();
        }
        Ok(())
    }
}

/// A model that is one [`Assembly`]: it is emitted as its assembly is.
pub(crate) trait Assembled {
    /// The parts.
    fn assembly(&self) -> &Assembly;
}

impl<T: Assembled> Model for T {
    fn vertex_count(&self) -> u64 {
        self.assembly().vertex_count()
    }

    fn triangle_count(&self) -> u64 {
        self.assembly().triangle_count()
    }

    fn vertices(&self, emit: &mut dyn FnMut([f32; 3]) -> io::Result<()>) -> io::Result<()> {
        self.assembly().vertices(emit)
    }

    fn triangles(&self, emit: &mut dyn FnMut([u32; 3]) -> io::Result<()>) -> io::Result<()> {
        self.assembly().triangles(emit)
    }
}

/// Lays out `layout`'s parts at the edge length whose triangle total is nearest `triangles`
/// from below.
pub(crate) fn fit(triangles: u64, layout: impl Fn(&mut Assembler)) -> Assembly {
    let build = |step: f32| {
        let mut assembler = Assembler {
            step,
            parts: Vec::new(),
        };
        layout(&mut assembler);
        assembler.parts
    };
    let total = |parts: &[Part]| parts.iter().map(Part::triangle_count).sum::<u64>();
    // Invariant: the coarse end's total is within the budget, or it is the coarsest step.
    let (mut fine, mut coarse) = (FINEST_STEP.ln(), COARSEST_STEP.ln());
    for _ in 0..FIT_ITERATIONS {
        let middle = 0.5 * (fine + coarse);
        if total(&build(middle.exp())) > triangles {
            fine = middle;
        } else {
            coarse = middle;
        }
    }
    Assembly {
        parts: build(coarse.exp()),
    }
}

/// Places parts tessellated to one edge length.
pub(crate) struct Assembler {
    step: f32,
    parts: Vec<Part>,
}

impl Assembler {
    /// Grid cells along `length`: at least `min`, rounded by this part's dither.
    fn cells(&self, length: f32, min: u32) -> u32 {
        let dither = cell_hash(self.parts.len() as u32) as f32 / 2f32.powi(32);
        let cells = (length / self.step + dither).floor().min(MAX_GRID_STEPS);
        (cells as u32).max(min)
    }

    /// An axis-aligned box between corners `min` and `max`.
    pub(crate) fn block(&mut self, min: [f32; 3], max: [f32; 3]) {
        let centre = [0, 1, 2].map(|a| 0.5 * (min[a] + max[a]));
        let half = [0, 1, 2].map(|a| 0.5 * (max[a] - min[a]));
        self.cuboid(centre, half, UNROTATED);
    }

    /// A box of half-extents `half` turned by `axes` (a rotation) and centred at `centre`.
    pub(crate) fn cuboid(&mut self, centre: [f32; 3], half: [f32; 3], axes: [[f32; 3]; 3]) {
        let steps = half.map(|h| self.cells(2.0 * h, 1));
        self.parts.push(Part {
            shape: Shape::Cuboid { half, steps },
            axes,
            centre,
        });
    }

    /// A beam of square cross-section `width` from `from` to `to`.
    pub(crate) fn beam(&mut self, from: [f32; 3], to: [f32; 3], width: f32) {
        let (centre, d, length) = span(from, to);
        self.cuboid(
            centre,
            [0.5 * width, 0.5 * width, 0.5 * length],
            axes_along(d, 0.0),
        );
    }

    /// A solid rod of `radius` from `from` to `to`.
    pub(crate) fn rod(&mut self, from: [f32; 3], to: [f32; 3], radius: f32) {
        self.along(from, to, |a, length| Shape::Prism {
            radius,
            half_length: 0.5 * length,
            sides: a.cells(TAU * radius, MIN_ROUND_SIDES),
            segments: a.cells(length, 1),
        });
    }

    /// A pipe from `from` to `to`, open along its axis: it can be looked through.
    pub(crate) fn tube(&mut self, from: [f32; 3], to: [f32; 3], outer: f32, inner: f32) {
        self.along(from, to, |a, length| Shape::Tube {
            outer,
            inner,
            half_length: 0.5 * length,
            sides: a.cells(TAU * outer, MIN_ROUND_SIDES),
            segments: a.cells(length, 1),
        });
    }

    /// Places `shape(self, length)`, a shape along its `z` axis, from `from` to `to`.
    fn along(&mut self, from: [f32; 3], to: [f32; 3], shape: impl FnOnce(&Self, f32) -> Shape) {
        let (centre, d, length) = span(from, to);
        let shape = shape(self, length);
        self.parts.push(Part {
            shape,
            axes: axes_along(d, 0.0),
            centre,
        });
    }

    /// A gear of outer `radius` with `teeth` teeth, its axis along `axis`, with a central
    /// hole of 0.45 `radius` (the engine's proportions).
    pub(crate) fn gear(&mut self, centre: [f32; 3], axis: [f32; 3], radius: f32, teeth: u32) {
        let (ring, tube) = (0.65 * radius, 0.2 * radius);
        // Two triangles per step² of the torus's area.
        let area = 4.0 * PI * PI * ring * tube;
        let (nu, nv) = gear_steps(f64::from(2.0 * area / (self.step * self.step)), teeth);
        let shape = Shape::Gear {
            ring,
            tube,
            teeth,
            tooth_depth: 0.15 * radius,
            nu,
            nv,
        };
        // A turn per gear, so neighbouring teeth do not line up.
        let turn = TAU * cell_hash(self.parts.len() as u32) as f32 / 2f32.powi(32);
        self.parts.push(Part {
            shape,
            axes: axes_along(axis, turn),
            centre,
        });
    }
}

/// Centre, direction and length of the segment `from`–`to`.
fn span(from: [f32; 3], to: [f32; 3]) -> ([f32; 3], [f32; 3], f32) {
    let d = [0, 1, 2].map(|a| to[a] - from[a]);
    let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    ([0, 1, 2].map(|a| 0.5 * (from[a] + to[a])), d, length)
}
