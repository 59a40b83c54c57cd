//! Moved to `crate::test_kit`. What is left re-exports the one generator that
//! `patch_mesh.rs`'s tests still import from here; delete this file together with the
//! `mod test_meshes;` line in `sampler/mod.rs` once that import names `test_kit`.

pub(crate) use crate::test_kit::meshes::noisy_sphere;
