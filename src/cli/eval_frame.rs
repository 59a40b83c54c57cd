//! `patchvis eval --frame-backend`: where the frame cost is timed besides the CPU rasterizer
//! (the library's `eval::GpuFrameTimer`, feature `gpu`), and how the GPU figure is reported.
//!
//! `auto` takes a hardware adapter only: a software rasterizer such as Mesa's lavapipe runs on
//! the same cores as the CPU rasterizer and says nothing about a GPU, so `auto` reports the CPU
//! figure alone and says why; `gpu` times whatever adapter there is.

use super::args::FrameBackendArg;
use super::out::{StdoutError, outln};
use super::progress::Bars;
use anyhow::Result;
use patchvis::eval::{Evaluator, FrameCost};
use patchvis::runtime::Pvis;
use patchvis::sampler::Camera;
use serde_json::{Value, json};

/// Where the frame cost is timed besides the CPU.
pub enum FrameBackend {
    /// The CPU rasterizer only, and why.
    Cpu {
        /// Why not the GPU.
        why: String,
    },
    /// A GPU through wgpu, and why it was chosen.
    #[cfg(feature = "gpu")]
    Gpu {
        /// The open device.
        timer: Box<patchvis::eval::GpuFrameTimer>,
        /// Why it was chosen.
        why: String,
    },
}

/// The GPU frame cost, as reported.
pub struct GpuReport {
    /// The adapter's description.
    pub adapter: String,
    /// Whether it is a software rasterizer.
    pub software: bool,
    /// `gpu timestamps` or `wall clock`.
    pub clock: &'static str,
    /// Warm-up frames before timing.
    pub warmup_frames: u32,
    /// Medians by `clock`.
    pub cost: FrameCost,
    /// Medians on the wall clock (submission to completion).
    pub wall: FrameCost,
    /// Mean draw calls per culled frame.
    pub draws_mean: f64,
    /// Per view, milliseconds by `clock`: (full, culled).
    pub per_view_ms: Vec<(f64, f64)>,
}

impl FrameBackend {
    /// Opens the backend of `--frame-backend` (see the module documentation).
    pub fn open(arg: FrameBackendArg) -> Result<FrameBackend> {
        match arg {
            FrameBackendArg::Cpu => Ok(FrameBackend::Cpu {
                why: "--frame-backend cpu".into(),
            }),
            #[cfg(feature = "gpu")]
            FrameBackendArg::Gpu => {
                use anyhow::Context;
                let timer = patchvis::eval::GpuFrameTimer::new().context("--frame-backend gpu")?;
                Ok(FrameBackend::Gpu {
                    timer: Box::new(timer),
                    why: "--frame-backend gpu".into(),
                })
            }
            #[cfg(not(feature = "gpu"))]
            FrameBackendArg::Gpu => Err(super::UsageError(
                "--frame-backend gpu: this patchvis was built without the `gpu` feature".into(),
            )
            .into()),
            FrameBackendArg::Auto => {
                #[cfg(feature = "gpu")]
                let why = match patchvis::eval::GpuFrameTimer::new() {
                    Ok(timer) if !timer.is_software() => {
                        return Ok(FrameBackend::Gpu {
                            timer: Box::new(timer),
                            why: "--frame-backend auto: a hardware adapter".into(),
                        });
                    }
                    Ok(timer) => format!(
                        "{} is a software rasterizer; --frame-backend gpu times it anyway",
                        timer.adapter()
                    ),
                    Err(e) => e.to_string(),
                };
                #[cfg(not(feature = "gpu"))]
                let why = "built without the `gpu` feature".to_string();
                Ok(FrameBackend::Cpu {
                    why: format!("--frame-backend auto: {why}"),
                })
            }
        }
    }

    /// `cpu` or `gpu`.
    pub fn name(&self) -> &'static str {
        match self {
            FrameBackend::Cpu { .. } => "cpu",
            #[cfg(feature = "gpu")]
            FrameBackend::Gpu { .. } => "gpu",
        }
    }

    /// Why this backend.
    pub fn why(&self) -> &str {
        match self {
            FrameBackend::Cpu { why } => why,
            #[cfg(feature = "gpu")]
            FrameBackend::Gpu { why, .. } => why,
        }
    }

    /// The GPU frame cost over `cameras`, or `None` on the CPU backend.
    pub fn measure(
        &self,
        evaluator: &Evaluator<'_>,
        pvis: &Pvis<'_>,
        cameras: &[Camera],
        bars: &Bars,
    ) -> Result<Option<GpuReport>> {
        match self {
            FrameBackend::Cpu { .. } => {
                // Only read by the GPU backend.
                let _ = (evaluator, pvis, cameras, bars);
                Ok(None)
            }
            #[cfg(feature = "gpu")]
            FrameBackend::Gpu { timer, .. } => {
                use anyhow::Context;
                let cost = bars
                    .spin("frame cost on the GPU", || {
                        timer.measure(evaluator, pvis, cameras)
                    })
                    .context("GPU frame cost")?;
                Ok(Some(GpuReport {
                    adapter: cost.adapter.clone(),
                    software: cost.software,
                    clock: cost.clock.name(),
                    warmup_frames: cost.warmup_frames,
                    cost: cost.cost(),
                    wall: cost.wall_cost(),
                    draws_mean: cost.draws_mean(),
                    per_view_ms: cost
                        .views
                        .iter()
                        .map(|v| (1e3 * v.full_seconds, 1e3 * v.culled_seconds))
                        .collect(),
                }))
            }
        }
    }
}

/// The JSON fields of the frame backend: `frame_backend`, `frame_backend_reason` and, with a
/// GPU, `frame_cost_gpu`.
pub fn frame_json(backend: &FrameBackend, gpu: Option<&GpuReport>) -> Value {
    let mut out = json!({
        "frame_backend": backend.name(),
        "frame_backend_reason": backend.why(),
    });
    if let (Value::Object(o), Value::Object(cost)) = (&mut out, gpu_json(gpu)) {
        o.extend(cost);
    }
    out
}

/// The `frame_cost_gpu` field of a GPU report (an empty object without one).
pub fn gpu_json(gpu: Option<&GpuReport>) -> Value {
    let mut out = json!({});
    if let (Some(g), Value::Object(o)) = (gpu, &mut out) {
        o.insert(
            "frame_cost_gpu".into(),
            json!({
                "adapter": g.adapter,
                "software": g.software,
                "clock": g.clock,
                "warmup_frames": g.warmup_frames,
                "full_ms_median": g.cost.full_ms_median,
                "culled_ms_median": g.cost.culled_ms_median,
                "speedup": g.cost.speedup,
                "wall_full_ms_median": g.wall.full_ms_median,
                "wall_culled_ms_median": g.wall.culled_ms_median,
                "wall_speedup": g.wall.speedup,
                "culled_draws_mean": g.draws_mean,
            }),
        );
    }
    out
}

/// The text report's lines on the frame backend.
pub fn print_frame(backend: &FrameBackend, gpu: Option<&GpuReport>) -> Result<(), StdoutError> {
    let Some(g) = gpu else {
        return outln!("frame cost on the GPU: not measured ({})", backend.why());
    };
    let kind = if g.software {
        "software rasterizer, not GPU hardware"
    } else {
        "hardware"
    };
    outln!(
        "frame cost (GPU: {}, {kind}; {}, median per view): full {:.2} ms, culled {:.2} ms, speed-up {:.2}x",
        g.adapter,
        g.clock,
        g.cost.full_ms_median,
        g.cost.culled_ms_median,
        g.cost.speedup
    )?;
    outln!(
        "  wall clock, submit to completion: full {:.2} ms, culled {:.2} ms, speed-up {:.2}x; {:.1} draws per culled frame; {} warm-up frames",
        g.wall.full_ms_median,
        g.wall.culled_ms_median,
        g.wall.speedup,
        g.draws_mean,
        g.warmup_frames
    )
}
