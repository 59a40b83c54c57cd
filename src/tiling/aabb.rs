//! Axis-aligned bounding boxes of patches: the "extension" measure of the seed paper.
//!
//! Meruvia 2002 (§3.1) measures how far a patch extends by the diagonal of its bounding box;
//! the greedy fusion compares squared diagonals, which orders the same way and needs no root.
//! Boxes keep the input's `f32` corners exactly; derived measures are computed in `f64`.
//! Cost: O(1) per operation.

/// The componentwise bounds of a set of points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Aabb {
    /// Componentwise minimum.
    pub min: [f32; 3],
    /// Componentwise maximum.
    pub max: [f32; 3],
}

impl Aabb {
    /// The box of the three corners of a triangle.
    pub fn of_triangle(p: [[f32; 3]; 3]) -> Aabb {
        let mut b = Aabb {
            min: p[0],
            max: p[0],
        };
        for q in &p[1..] {
            b.include(*q);
        }
        b
    }

    /// Grows the box to contain `p`.
    pub fn include(&mut self, p: [f32; 3]) {
        self.min = std::array::from_fn(|k| self.min[k].min(p[k]));
        self.max = std::array::from_fn(|k| self.max[k].max(p[k]));
    }

    /// The smallest box containing both.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: std::array::from_fn(|k| self.min[k].min(other.min[k])),
            max: std::array::from_fn(|k| self.max[k].max(other.max[k])),
        }
    }

    /// The squared length of the diagonal.
    pub fn diagonal_squared(&self) -> f64 {
        (0..3)
            .map(|k| {
                let d = f64::from(self.max[k]) - f64::from(self.min[k]);
                d * d
            })
            .sum()
    }

    /// The centre, in `f64` so that it is exact.
    pub fn center(&self) -> [f64; 3] {
        std::array::from_fn(|k| 0.5 * (f64::from(self.min[k]) + f64::from(self.max[k])))
    }
}
