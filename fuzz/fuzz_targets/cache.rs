//! Fuzz target: the conversion cache (`ooc::cache`), the file a converted mesh (OBJ here) is
//! kept in and mapped from on the next open. A fixed OBJ is opened once with a cache
//! directory, which writes its cache; the input then damages that cache, picked by the first
//! byte:
//!
//! - replaced: the rest of the input is the whole cache file;
//! - patched: the rest is (offset, byte) pairs written over the valid cache.
//!
//! Reopening must never panic, and must give exactly the mesh of the first open: a damaged
//! cache is converted again (its checksum catches it), never served.
//!
//! Run: `cargo fuzz run cache` (nightly, or `RUSTC_BOOTSTRAP=1`; fuzz/README.md).

#![no_main]

use libfuzzer_sys::fuzz_target;
use patchvis::ooc::{Mesh, OpenOptions};

/// A small mesh in a format that is converted (OBJ), not served in place.
const OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 2 2 2\nf 1 2 3\nf 1 2 4\nf 2 3 4\nf 1 3 4\n";

/// Every vertex and triangle of `mesh`.
fn contents(mesh: &Mesh) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let vertices = (0..mesh.vertex_count()).map(|v| mesh.position(v)).collect();
    let triangles = (0..mesh.triangle_count()).map(|t| mesh.triangle(t)).collect();
    (vertices, triangles)
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mesh.obj");
    std::fs::write(&path, OBJ).unwrap();
    let options = OpenOptions {
        cache_dir: Some(dir.path().join("cache")),
        memory_budget: 1 << 20,
    };
    let expected = contents(&Mesh::open_with(&path, &options).unwrap());
    let cache = std::fs::read_dir(dir.path().join("cache"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "pvmesh"))
        .expect("the first open writes a cache");
    let mut bytes = std::fs::read(&cache).unwrap();
    if mode % 2 == 0 {
        bytes = rest.to_vec();
    } else {
        let len = bytes.len().max(1);
        for pair in rest.chunks_exact(3) {
            let at = u16::from_le_bytes([pair[0], pair[1]]) as usize;
            if let Some(b) = bytes.get_mut(at % len) {
                *b = pair[2];
            }
        }
    }
    std::fs::write(&cache, &bytes).unwrap();
    if let Ok(mesh) = Mesh::open_with(&path, &options) {
        assert_eq!(contents(&mesh), expected, "a damaged cache was served");
    }
});
