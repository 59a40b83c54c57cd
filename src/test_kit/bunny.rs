//! The bundled Stanford bunny (`assets/bunny.ply`: 99,785 triangles, 50,000 vertices), the
//! real scan the unit tests run on, opened by the crate's own reader (mapped in place).

use std::path::Path;

use crate::ooc::Mesh;

/// Where the bunny is.
pub(crate) const BUNNY_PATH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/bunny.ply");

/// The bunny, memory-mapped by [`Mesh::open`].
pub(crate) fn bunny() -> Mesh {
    Mesh::open(Path::new(BUNNY_PATH)).expect("the bundled bunny opens")
}
