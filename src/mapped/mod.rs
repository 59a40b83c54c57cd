//! Memory-mapped arrays: the one module that maps files, and so the one that holds the
//! `unsafe` those maps need.
//!
//! Data that outgrows the heap budget on large meshes lives in maps instead, behind a type
//! that derefs to a plain slice, so that the algorithms using it take a slice and never see
//! where the bytes are:
//!
//! - [`FileBytes`] (`file_bytes.rs`): an input file's bytes, mapped read-only in place, or
//!   copied into an anonymous map where the file cannot be mapped; also the bytes a converter
//!   produces. What `ooc::Mesh` reads from.
//!
//! The only `unsafe` is the call that creates a map of a file (`Mmap::map`), with a
//! `// SAFETY:` comment; ripgrep's `searcher/mmap.rs` is the model.
//!
//! # Safety
//!
//! A file map is sound only while nothing truncates or rewrites the file behind it, a
//! condition the type system cannot check. An input file is the user's: the pipeline opens it
//! read-only and never writes it, and the documentation asks users not to edit a mesh during
//! a bake (see [`FileBytes::open`]).

mod file_bytes;

pub(crate) use file_bytes::FileBytes;
