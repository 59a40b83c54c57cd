//! What the unit tests share, written once: seeded random numbers ([`rng`]), meshes generated
//! in code ([`meshes`]), well-spread view directions ([`directions`]) and the bundled Stanford
//! bunny ([`bunny`]).
//!
//! Compiled only for `cargo test`. The integration tests in `tests/` see only the public API
//! and share `tests/common` instead. The unit-test convention the crate follows: a file's own
//! tests in an inline `#[cfg(test)] mod tests` at its end; a folder module's tests that span
//! its files in `tests.rs` beside its `mod.rs`. Everything but [`rng`] needs the `bake`
//! feature, as the modules whose tests use it do.

#[cfg(feature = "bake")]
pub(crate) mod bunny;
#[cfg(feature = "bake")]
pub(crate) mod directions;
#[cfg(feature = "bake")]
pub(crate) mod meshes;
pub(crate) mod rng;
