//! What a bake knows about its views, as plain data: where the sampling cameras are
//! ([`SamplingParams`]) and which patches each view sees ([`VisibilityMatrix`]).
//!
//! The sampler fills these, the format writer stores them and eval reads them back; keeping
//! them here lets the writer and eval depend on two plain types instead of the whole sampler.

mod matrix;
mod params;

pub use matrix::VisibilityMatrix;
pub use params::SamplingParams;
