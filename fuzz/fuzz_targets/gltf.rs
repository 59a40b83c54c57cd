//! Fuzz target: glTF 2.0 input (`.gltf` JSON and `.glb`, told apart by content). Opening must
//! return a mesh or an error, never panic; a mesh that opens must answer every `position` and
//! `triangle` query in range with finite coordinates. External buffer URIs resolve inside an
//! empty temporary directory, so they fail to open (an error, which is also checked).
//!
//! Run: `RUSTC_BOOTSTRAP=1 cargo fuzz run -O gltf corpus/gltf` (see README.md), seeded with a
//! few small `.gltf` / `.glb` files (a JSON file with a data URI and a GLB with a BIN chunk).

#![no_main]

use libfuzzer_sys::fuzz_target;
use patchvis::ooc::{Mesh, OpenOptions};

fuzz_target!(|data: &[u8]| {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fuzz.glb");
    std::fs::write(&path, data).unwrap();
    let options = OpenOptions {
        cache_dir: None,
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
