//! The sampling sphere: an octahedron subdivided level by level (6, 18, 66, 258, 1026, 4098 …
//! vertices), its stable vertex numbering, the face hierarchy and point location.
//!
//! Follows Meruvia 2002, §3.2.1 (sampling positions) and §3.3.1 (finding the face under a
//! viewing ray in at most 4 tests per level). Needs only `core` (and `libm`'s correctly
//! rounded square root where that is a hardware instruction, `sqrt.rs`): the reader uses it
//! to find the face under a view direction.
//! The convention is normative; see `spec/FORMAT.md`, section "Sampling sphere".
//!
//! Cost: numbering a vertex is O(2^level) integer steps at most (a ring walk, ≤ 128 at
//! [`MAX_LEVEL`]); point location is 3 sign tests per level plus 3 midpoints per level.

mod locate;
mod numbering;
mod sqrt;

#[cfg(any(feature = "std", test))]
pub use locate::leaf_faces;
pub use locate::{Face, children, locate, root_face, root_faces};
pub use numbering::{LatticePoint, direction, lattice_point, level_of, parents, view_index};
pub use sqrt::{sqrtf, sqrtf_digits};

/// Index of a sampling view (a vertex of the subdivided octahedron). Level `l`'s views are
/// `0..view_count(l)`, a prefix of level `l + 1`'s.
pub type ViewIndex = u32;

/// The finest subdivision level a file may use (65,538 views).
pub const MAX_LEVEL: u32 = 7;

/// Number of views (sphere vertices) at `level`: `4·4^level + 2`.
pub const fn view_count(level: u32) -> u32 {
    4 * (1 << (2 * level)) + 2
}

/// Number of faces at `level`: `8·4^level`.
pub const fn face_count(level: u32) -> u32 {
    8 * (1 << (2 * level))
}

/// `v / |v|` in f32, computed exactly as the spec prescribes: `len = sqrt((x·x + y·y) + z·z)`
/// with a correctly rounded square root, then each component divided by `len`. Every
/// implementation that follows these steps gets bit-identical directions.
pub fn normalize(v: [f32; 3]) -> [f32; 3] {
    let len = sqrtf((v[0] * v[0] + v[1] * v[1]) + v[2] * v[2]);
    [v[0] / len, v[1] / len, v[2] / len]
}

pub(crate) fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub(crate) fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]
}
