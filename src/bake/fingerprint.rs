//! What identifies the inputs of a sharded bake's files, so that a merge refuses parts of
//! different bakes: the mesh's content and the tiling, each as an XXH64 (the hash the
//! conversion cache keys meshes by, `ooc/cache.rs`).
//!
//! The mesh is hashed as the pipeline sees it (vertex and triangle counts, every position's
//! bits, every triangle's indices), not as its file's bytes: the same mesh converted to
//! another format hashes alike, and a glTF's external buffers count. Cost: one pass over the
//! mesh at memory speed (about 0.1 s per million triangles), once per shard.

use crate::ooc::Mesh;
use crate::tiling::Tiling;
use xxhash_rust::xxh64::Xxh64;

/// Values hashed per `update` call.
const BATCH: usize = 1 << 13;

/// Feeds `u32`s to an XXH64 in batches.
struct Hasher {
    state: Xxh64,
    batch: Vec<u8>,
}

impl Hasher {
    fn new(domain: &[u8]) -> Hasher {
        let mut state = Xxh64::new(0);
        state.update(domain);
        Hasher {
            state,
            batch: Vec::with_capacity(BATCH * 4),
        }
    }

    fn word(&mut self, w: u32) {
        self.batch.extend_from_slice(&w.to_le_bytes());
        if self.batch.len() >= BATCH * 4 {
            self.state.update(&self.batch);
            self.batch.clear();
        }
    }

    fn bytes(&mut self, b: &[u8]) {
        self.state.update(&self.batch);
        self.batch.clear();
        self.state.update(b);
    }

    fn finish(mut self) -> u64 {
        self.state.update(&self.batch);
        self.state.digest()
    }
}

/// The content hash of `mesh`: its vertex and triangle counts, positions and triangles.
pub fn mesh_hash(mesh: &Mesh) -> u64 {
    let mut h = Hasher::new(b"patchvis mesh");
    h.word(mesh.vertex_count());
    h.word(mesh.triangle_count());
    for v in 0..mesh.vertex_count() {
        for c in mesh.position(v) {
            h.word(c.to_bits());
        }
    }
    for t in 0..mesh.triangle_count() {
        for i in mesh.triangle(t) {
            h.word(i);
        }
    }
    h.finish()
}

/// The hash of `tiling`: its patch records and the reordered triangles (which, with the
/// records' ranges, give every triangle's patch).
pub fn tiling_hash(tiling: &Tiling) -> u64 {
    use super::wire::Put;
    let mut h = Hasher::new(b"patchvis tiling");
    h.word(tiling.patches.len() as u32);
    let mut record = Vec::new();
    for p in &tiling.patches {
        record.clear();
        record.put_patch(p);
        h.bytes(&record);
    }
    h.word(tiling.order.len() as u32);
    for &t in tiling.order.iter() {
        h.word(t);
    }
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_kit::meshes::grid;

    #[test]
    fn hashes_tell_meshes_and_tilings_apart() {
        let a = grid(6, 5, 0.2, 1, |_, _| false).mesh();
        let b = grid(6, 5, 0.2, 2, |_, _| false).mesh();
        assert_eq!(mesh_hash(&a), mesh_hash(&a));
        assert_ne!(mesh_hash(&a), mesh_hash(&b));
        let t4 = crate::tiling::tile(&a, 4).unwrap();
        let t5 = crate::tiling::tile(&a, 5).unwrap();
        assert_eq!(tiling_hash(&t4), tiling_hash(&t4.clone()));
        assert_ne!(tiling_hash(&t4), tiling_hash(&t5));
    }
}
