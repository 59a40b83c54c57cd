//! The sampling sphere: an octahedron subdivided level by level (6, 18, 66, 258, 1026, 4098 …
//! vertices), its stable vertex numbering, the face hierarchy and point location.
//!
//! Needs only `core`: the reader uses it to find the face under a view direction.
//! The convention is normative; see `spec/FORMAT.md`, section "Sampling sphere".

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

/// Unit direction of `view` from the sphere centre. `view` must be below
/// `view_count(MAX_LEVEL)`.
pub fn direction(view: ViewIndex) -> [f32; 3] {
    todo!("{view}")
}

/// The two views whose sphere edge `view` splits, or `None` for the six level-0 views.
pub fn parents(view: ViewIndex) -> Option<[ViewIndex; 2]> {
    todo!("{view}")
}

/// The level at which `view` first appears.
pub fn level_of(view: ViewIndex) -> u32 {
    todo!("{view}")
}

/// A face of the subdivided octahedron: three views, counter-clockwise seen from outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Face {
    /// The corner views.
    pub views: [ViewIndex; 3],
    /// The corner directions (unit vectors), computed as the spec prescribes.
    pub directions: [[f32; 3]; 3],
}

/// The leaf face at `level` containing direction `dir` (need not be normalised; the zero
/// vector is treated as +X). At most 4 plane tests per level; directions exactly on an edge or
/// a vertex resolve deterministically to one face.
pub fn locate(dir: [f32; 3], level: u32) -> Face {
    todo!("{dir:?} {level}")
}
