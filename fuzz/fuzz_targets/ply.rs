//! Fuzz target: the mesh parsers (PLY, OBJ, STL; glTF has its own target, `gltf`). The first
//! byte picks the format, the rest is the file. Opening must return a mesh or an error, never panic; a mesh that opens must
//! answer every `position` and `triangle` query in range with finite coordinates.
//!
//! Run: `cargo fuzz run ply` (nightly). Files go through a temporary directory because the
//! converters write a cache file; `cache_dir: None` keeps it unnamed.

#![no_main]

use libfuzzer_sys::fuzz_target;
use patchvis::ooc::{Mesh, OpenOptions};

fuzz_target!(|data: &[u8]| {
    let Some((&which, file)) = data.split_first() else {
        return;
    };
    let extension = ["ply", "obj", "stl"][which as usize % 3];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("fuzz.{extension}"));
    std::fs::write(&path, file).unwrap();
    let options = OpenOptions {
        cache_dir: None,
        // Small, so STL welding takes its partitioned path too.
        memory_budget: 4096,
    };
    if let Ok(mesh) = Mesh::open_with(&path, &options) {
        for v in 0..mesh.vertex_count() {
            assert!(mesh.position(v).iter().all(|c| c.is_finite()));
        }
        for t in 0..mesh.triangle_count() {
            assert!(mesh.triangle(t).iter().all(|&i| i < mesh.vertex_count()));
        }
    }
});
