//! patchvis bakes precomputed visibility for huge triangle meshes into a small `.pvis` file,
//! and reads it back in a `no_std`, allocation-free reader.
//!
//! The pipeline follows Meruvia 2002, "Visibility preprocessing using spherical sampling of
//! polygonal patches", and the modules follow the data:
//!
//! [`ooc`] (memory-mapped mesh) → [`tiling`] (patches) → [`sphere`] (sampling directions) →
//! [`sampler`] (ID buffers → bitfields) → [`format`](mod@format) (`.pvis` writer) → [`runtime`] (reader), and [`eval`] measures what
//! a renderer drawing only the answer shows.
//!
//! Only [`sphere`] and [`runtime`] exist without the `bake` feature; they need nothing but
//! `core`. See `ARCHITECTURE.md` for the invariants and `spec/FORMAT.md` for the file format.
#![cfg_attr(not(any(feature = "std", test)), no_std)]
#![warn(missing_docs)]

#[cfg(feature = "capi")]
pub mod capi;
pub mod runtime;
pub mod sphere;

#[cfg(feature = "bake")]
pub mod bake;
#[cfg(feature = "bake")]
pub mod eval;
#[cfg(feature = "bake")]
pub mod format;
#[cfg(feature = "bake")]
pub mod generate;
#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(feature = "bake")]
pub mod heap;
#[cfg(feature = "bake")]
pub(crate) mod mapped;
#[cfg(feature = "bake")]
pub mod memory;
#[cfg(feature = "bake")]
pub mod ooc;
#[cfg(feature = "bake")]
pub mod progress;
#[cfg(feature = "bake")]
pub mod sampler;
#[cfg(feature = "bake")]
pub mod tiling;
#[cfg(feature = "bake")]
pub mod visibility;

#[cfg(test)]
pub(crate) mod test_kit;

#[cfg(all(feature = "bake", not(feature = "std")))]
compile_error!("the `bake` feature needs `std`");

/// Compiles the README's Rust examples as doctests, so they stay true.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
