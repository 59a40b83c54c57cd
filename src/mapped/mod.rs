//! Memory-mapped arrays: the one module that maps files, and so the one that holds the
//! `unsafe` those maps need.
//!
//! Three kinds of data outgrow the heap budget on large meshes and live in maps instead,
//! each behind a type that derefs to a plain slice, so that the algorithms using them take
//! `&[T]` and never see where the bytes are:
//!
//! - [`FileBytes`] (`file_bytes.rs`): an input file's bytes, mapped read-only in place, or
//!   copied into an anonymous map where the file cannot be mapped; also the bytes a converter
//!   produces. What `ooc::Mesh` reads from.
//! - [`Array`] (`array.rs`): a fixed-length array of plain records, zeroed and mutable, on the
//!   heap or in an unlinked temporary file mapped read-write. What `tiling::TriangleMap`
//!   stores.
//! - [`RecordWriter`] (`records.rs`): records appended one batch after the other to the heap
//!   or to an unlinked temporary file, then mapped as an [`Array`]. What the sampler's
//!   patch-ordered mesh copy (`sampler::patch_mesh`) is written with.
//!
//! Records are `bytemuck::Pod` types (no padding, every bit pattern valid), so viewing mapped
//! bytes as records is `bytemuck::cast_slice`, which checks length and alignment and needs no
//! `unsafe` (a map starts on a page boundary, so the alignment check always passes). The
//! `unsafe` left is the two calls that create maps of files (`Mmap::map` of an input,
//! `MmapMut::map_mut` of a temporary file), each with a `// SAFETY:` comment; ripgrep's
//! `searcher/mmap.rs` is the model; and the `SIGBUS` handler of `fault.rs`, which every file
//! map registers with, so that a fault in one ends the process with a line saying why.
//!
//! # Safety
//!
//! A file map is sound only while nothing truncates or rewrites the file behind it, a
//! condition the type system cannot check. The temporary files are unlinked as soon as they
//! are created (`tempfile::tempfile`), so this process holds their only handle. An input file
//! is the user's: the pipeline opens it read-only and never writes it, and the documentation
//! asks users not to edit a mesh during a bake (see [`FileBytes::open`]). Should another
//! program truncate it all the same, or a disk fill under a temporary file, the read or write
//! that finds no page raises `SIGBUS`, and `fault.rs` ends the process with an error line.

mod array;
mod fault;
mod file_bytes;
mod input;
mod records;

pub(crate) use array::Array;
pub(crate) use fault::{Backing, RemovedOnFault};
pub(crate) use file_bytes::FileBytes;
pub use input::{open_regular, read_regular};
pub(crate) use records::RecordWriter;
