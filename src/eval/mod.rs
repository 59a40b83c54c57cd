//! Evaluation: what users see when they draw only the patches a `.pvis` query returns —
//! reconstruction quality, culling rate, popping along a path, frame cost and pictures.
//!
//! The technique (Meruvia 2002) is not conservative: its worth is how many triangles it culls
//! while the picture stays the same. For each camera the evaluator renders the whole mesh and
//! the query's answer with triangle ids and compares them pixel by pixel (`evaluator.rs`);
//! `bands.rs` places the same cameras at one distance or several and evaluates each,
//! `summary.rs` aggregates views, `metrics.rs` holds the statistics (mean, nearest-rank p95,
//! PSNR), `surround.rs` the renders around the eye behind the ideal culling without the
//! frustum, `views.rs` the seeded random views and paths, `shade.rs` the pictures, `plot.rs` the
//! SVG charts, `figures.rs` the path's and the sweep's figures, and `sweep.rs` the re-baking
//! sweep over patch counts and levels (the seed paper's Figures 4–5); `gpu_frame.rs` (feature
//! `gpu`) times the frame cost on a GPU through wgpu instead of the CPU rasterizer. The last
//! stage: it may use every other module.
//!
//! The file stores triangle ranges of the *reordered* mesh. The evaluator takes that mesh as
//! the bake wrote it (`--mesh-out`), checking every patch's bounds against the file, or the
//! original mesh, which it tiles again (deterministic, within `--memory`) and refuses files
//! whose patch records differ from the re-tiling in any bit.
//!
//! Nothing assumes the eye is outside the sampling sphere: the cameras' near planes follow
//! the eye–target distance, the frustum test is the reader's sphere test (which keeps a patch
//! whose sphere holds the eye), and the full render draws whatever lies in front of the near
//! plane. A view the query flags `inside_sphere` is counted (a renderer may draw it whole)
//! and measured like the others, on the query's answer.
//!
//! Cost: two renders per view (the full mesh and the culled set), views in parallel, plus the
//! renders around the eye when the camera's image does not hold the whole mesh (nearer than
//! the sampling distance, or a turned look).

mod bands;
mod evaluator;
mod figures;
mod frustum;
#[cfg(feature = "gpu")]
mod gpu_frame;
pub mod metrics;
pub mod plot;
pub mod shade;
mod summary;
mod surround;
mod sweep;
pub mod views;

pub use bands::{Band, BandViews, ViewSet};
pub use evaluator::{
    EvalError, EvalOptions, Evaluator, Pictures, ViewMetrics, open_mesh, sampling_params,
    visible_runs, worker_bytes,
};
pub use figures::{PSNR_PLOT_CAP_DB, path_plot, sweep_plots};
pub use frustum::camera_frustum;
#[cfg(feature = "gpu")]
pub use gpu_frame::{
    FrameClock, GpuFrameCost, GpuFrameTimer, GpuViewCost, WARMUP_FRAMES, chunk_draws,
};
pub use summary::{EvalSummary, FrameCost};
pub use surround::{frames_whole_mesh, surround_cameras, surround_resolution};
pub use sweep::{SweepPoint, SweepSettings, sweep};

#[cfg(test)]
mod tests;
