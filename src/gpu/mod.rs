//! GPU device code shared by the sampling backend (`sampler::gpu`) and the evaluator's GPU
//! frame cost (`eval::gpu_frame`), feature `gpu`: opening a device (`device.rs`), the mesh
//! uploaded regrouped by patch (`mesh.rs`), and the clip matrix and depth-tested pipeline
//! both renders use (`pipeline.rs`).

mod device;
pub(crate) mod mesh;
mod pipeline;

pub use device::GpuError;
pub(crate) use device::{describe, one_line, open_device};
pub(crate) use pipeline::depth_tested_pipeline;
pub use pipeline::view_matrix;
