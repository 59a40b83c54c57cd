//! patchvis bakes precomputed visibility for huge triangle meshes into a small `.pvis` file,
//! and reads it back in a `no_std`, allocation-free reader.
//!
//! The technique is Meruvia 2002, "Visibility preprocessing using spherical sampling of
//! polygonal patches". Two stacks:
//!
//! - the reader, `no_std` and allocation-free: [`sphere`] (sampling directions, point
//!   location) and [`runtime`] (`.pvis` parsing and queries), plus `capi` (feature `capi`);
//!   they need nothing but `core` and `libm`;
//! - the bake pipeline (feature `bake`), following the data: `ooc` (memory-mapped mesh) →
//!   `tiling` (patches) → `sampler` (ID buffers → bitfields) → `format` (`.pvis` writer),
//!   run as one recipe by `bake` (settings, the `memory` budget split, the sampling backend,
//!   stages); `visibility` holds the plain data the stages pass on, `gpu` the device code
//!   the GPU backend and eval share, and `eval` measures what a renderer drawing only the
//!   answer shows.
//!
//! See `ARCHITECTURE.md` for the code map and invariants and `spec/FORMAT.md` for the file
//! format.
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
pub mod meshout;
#[cfg(feature = "bake")]
pub mod ooc;
#[cfg(feature = "bake")]
pub mod output;
#[cfg(feature = "bake")]
pub mod progress;
#[cfg(feature = "bake")]
pub mod sampler;
#[cfg(feature = "bake")]
pub mod tiling;
#[cfg(feature = "bake")]
pub mod visibility;

#[cfg(any(test, feature = "bake"))]
mod splitmix;
#[cfg(test)]
pub(crate) mod test_kit;

#[cfg(all(feature = "bake", not(feature = "std")))]
compile_error!("the `bake` feature needs `std`");

/// Compiles the README's Rust examples as doctests, so they stay true.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
