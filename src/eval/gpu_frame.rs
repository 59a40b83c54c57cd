//! Frame cost on the GPU (wgpu): the seed paper's Table 1 — time to draw the whole mesh against
//! the patches a `.pvis` query returns — on a real rasterizer instead of the CPU stand-in
//! (`evaluator.rs`).
//!
//! The mesh is uploaded once, regrouped by patch, by the sampling backend's upload
//! (`gpu::mesh`), so each patch's triangles are one contiguous range of the index
//! buffers and the culled set is drawn from the same buffers as the full mesh, with one
//! `draw_indexed` per run of consecutive visible patches ([`visible_runs`], split at buffer
//! boundaries by [`chunk_draws`]). Multi-draw-indirect would put the runs into one call but is
//! not core WebGPU; the number of draws per view is reported instead
//! ([`GpuFrameCost::draws_mean`]). Each frame renders into a colour + depth target of the
//! evaluation resolution with a flat-shaded pipeline (`frame.wgsl`: the face normal from
//! screen-space derivatives, lit from the eye, like the CPU pictures) — a frame, not an ID
//! buffer. Depth is reversed Z, as in the sampler (`gpu::view_matrix`).
//!
//! Timing: every frame is its own submission, timed on the wall clock from `submit` until
//! `device.poll(Wait)` returns; where the adapter has `TIMESTAMP_QUERY`, timestamps written at
//! the start and end of the frame's render pass give the GPU time without the submission
//! overhead, and that is the figure [`GpuFrameCost::cost`] reports ([`FrameClock`]). A few
//! warm-up frames come first (shader compilation in the driver, first touches of the buffers).
//! The query for each view is asked again here (nanoseconds) rather than carried over from the
//! CPU evaluation.
//!
//! Cost: the mesh upload, about 22 bytes of GPU memory per triangle, once; per view two
//! submissions and waits (and two small read-backs with timestamps); targets of
//! `resolution² × 8` bytes.

use super::evaluator::Evaluator;
use super::evaluator::visible_runs;
use super::summary::FrameCost;
use crate::gpu::mesh::{self as upload, MeshChunk};
use crate::gpu::{GpuError, depth_tested_pipeline, describe, one_line, open_device, view_matrix};
use crate::runtime::Pvis;
use crate::sampler::Camera;
use std::ops::Range;
use std::sync::mpsc;
use std::time::Instant;

/// Frames drawn before timing starts, each the full mesh and then the culled set of the first
/// view: the first frames of a pipeline pay for the driver's shader compilation and the first
/// touches of every buffer, which no later frame does.
pub const WARMUP_FRAMES: u32 = 3;

/// The colour target's format: what a window's swap chain usually is.
const COLOUR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Bytes of the frame's uniforms (`frame.wgsl` `Frame`): a `mat4x4<f32>` and a `vec4<f32>`.
const UNIFORM_BYTES: u64 = 80;

/// Bytes the two timestamps (start and end of the render pass) resolve to.
const TIMESTAMP_BYTES: u64 = 2 * wgpu::QUERY_SIZE as u64;

/// How the GPU frame times were taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameClock {
    /// Timestamps at the start and end of each frame's render pass (`TIMESTAMP_QUERY`).
    GpuTimestamps,
    /// The wall clock from submission until the wait for it returns.
    WallClock,
}

impl FrameClock {
    /// `gpu timestamps` or `wall clock`.
    pub fn name(self) -> &'static str {
        match self {
            FrameClock::GpuTimestamps => "gpu timestamps",
            FrameClock::WallClock => "wall clock",
        }
    }
}

/// One view's GPU frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuViewCost {
    /// Seconds to draw the whole mesh, by the timer's [`FrameClock`].
    pub full_seconds: f64,
    /// Seconds to draw the query's answer, by the timer's [`FrameClock`].
    pub culled_seconds: f64,
    /// Wall-clock seconds, submission to completion, of the full frame.
    pub full_wall_seconds: f64,
    /// Wall-clock seconds, submission to completion, of the culled frame.
    pub culled_wall_seconds: f64,
    /// Draw calls of the culled frame (runs of consecutive visible patches).
    pub culled_draws: u32,
}

/// The GPU frame cost of a set of views.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuFrameCost {
    /// The adapter, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Cpu, Vulkan)`.
    pub adapter: String,
    /// Whether the adapter is a software rasterizer on the CPU (Mesa's lavapipe, WARP, …).
    pub software: bool,
    /// How [`GpuViewCost::full_seconds`] and `culled_seconds` were taken.
    pub clock: FrameClock,
    /// Warm-up frames drawn before timing.
    pub warmup_frames: u32,
    /// Per view, in camera order.
    pub views: Vec<GpuViewCost>,
}

impl GpuFrameCost {
    /// Medians and speed-up by [`Self::clock`].
    pub fn cost(&self) -> FrameCost {
        FrameCost::of(
            self.views.iter().map(|v| v.full_seconds),
            self.views.iter().map(|v| v.culled_seconds),
        )
    }

    /// Medians and speed-up on the wall clock (submission to completion).
    pub fn wall_cost(&self) -> FrameCost {
        FrameCost::of(
            self.views.iter().map(|v| v.full_wall_seconds),
            self.views.iter().map(|v| v.culled_wall_seconds),
        )
    }

    /// Mean draw calls per culled frame (0 without views).
    pub fn draws_mean(&self) -> f64 {
        if self.views.is_empty() {
            return 0.0;
        }
        let total: f64 = self.views.iter().map(|v| f64::from(v.culled_draws)).sum();
        total / self.views.len() as f64
    }
}

/// An open GPU device with the frame pipeline compiled: create once, measure many times.
#[derive(Debug)]
pub struct GpuFrameTimer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

impl GpuFrameTimer {
    /// Opens the adapter the sampling backend would (`sampler::gpu::GpuSampler::new`), with
    /// `TIMESTAMP_QUERY` where it has it, and compiles the frame pipeline.
    pub fn new() -> Result<GpuFrameTimer, GpuError> {
        let (device, queue, info) =
            open_device("patchvis frame cost", wgpu::Features::TIMESTAMP_QUERY)?;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("frame.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("frame.wgsl").into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("frame"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        // The sampler's vertices carry a patch id after the position; a frame reads only the
        // position.
        const POSITION: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x3];
        let vertices = wgpu::VertexBufferLayout {
            array_stride: upload::vertex_layout().array_stride,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &POSITION,
        };
        let pipeline = depth_tested_pipeline(
            &device,
            "frame",
            &pipeline_layout,
            &module,
            vertices,
            COLOUR_FORMAT,
        );
        Ok(GpuFrameTimer {
            device,
            queue,
            info,
            pipeline,
            layout,
        })
    }

    /// The adapter, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Cpu, Vulkan)`.
    pub fn adapter(&self) -> String {
        describe(&self.info)
    }

    /// Whether the adapter is a software rasterizer on the CPU (Mesa's lavapipe, WARP, …).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// How frames are timed on this device.
    pub fn clock(&self) -> FrameClock {
        if self
            .device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
        {
            FrameClock::GpuTimestamps
        } else {
            FrameClock::WallClock
        }
    }

    /// Times, for every camera, a frame of the whole mesh and a frame of the patches `pvis`
    /// returns for the camera's eye (see the module documentation). `evaluator` holds the
    /// mesh and tiling `pvis` was baked from.
    ///
    /// Panics (caller contract) if `pvis` and `evaluator` differ in patch count or the
    /// cameras differ in resolution.
    pub fn measure(
        &self,
        evaluator: &Evaluator<'_>,
        pvis: &Pvis<'_>,
        cameras: &[Camera],
    ) -> Result<GpuFrameCost, GpuError> {
        assert_eq!(
            pvis.patch_count(),
            evaluator.patch_count(),
            "the file and the evaluator differ in patch count"
        );
        let mut cost = GpuFrameCost {
            adapter: self.adapter(),
            software: self.is_software(),
            clock: self.clock(),
            warmup_frames: WARMUP_FRAMES,
            views: Vec::with_capacity(cameras.len()),
        };
        let Some(first) = cameras.first() else {
            return Ok(cost);
        };
        let resolution = first.resolution();
        assert!(
            cameras.iter().all(|c| c.resolution() == resolution),
            "the cameras differ in resolution"
        );
        let limit = self.device.limits().max_texture_dimension_2d;
        if resolution > limit {
            return Err(GpuError::TooLarge {
                what: "the frame side (pixels)",
                needed: resolution.into(),
                limit: limit.into(),
            });
        }
        // Out-of-memory and validation errors become values instead of wgpu's default panic;
        // scopes pop in reverse order.
        let memory_scope = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation_scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let measured = self.measure_views(evaluator, pvis, cameras, resolution, &mut cost.views);
        let validation = pollster::block_on(validation_scope.pop());
        let memory = pollster::block_on(memory_scope.pop());
        measured?;
        if let Some(e) = memory.or(validation) {
            return Err(GpuError::Failed(one_line(e)));
        }
        Ok(cost)
    }

    fn measure_views(
        &self,
        evaluator: &Evaluator<'_>,
        pvis: &Pvis<'_>,
        cameras: &[Camera],
        resolution: u32,
        out: &mut Vec<GpuViewCost>,
    ) -> Result<(), GpuError> {
        let (device, queue) = (&self.device, &self.queue);
        let center = pvis.sampling().center;
        let starts = evaluator.starts();
        let chunks = upload::upload_mesh(
            device,
            queue,
            evaluator.mesh(),
            upload::PatchOrder {
                order: evaluator.order(),
                starts,
            },
            center,
            &device.limits(),
            evaluator.budget(),
        )?;
        let chunk_ranges: Vec<Range<u32>> = chunks
            .iter()
            .map(|c| c.first_triangle..c.first_triangle + c.index_count / 3)
            .collect();
        let all =
            chunk_ranges.first().map_or(0, |r| r.start)..chunk_ranges.last().map_or(0, |r| r.end);
        let full_draws = chunk_draws(&chunk_ranges, &[all]);

        let target = |label, format| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d {
                        width: resolution,
                        height: resolution,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        let targets = Targets {
            colour: target("frame colour", COLOUR_FORMAT),
            depth: target("frame depth", wgpu::TextureFormat::Depth32Float),
        };
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniforms"),
            size: UNIFORM_BYTES,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            }],
        });
        let timestamps = (self.clock() == FrameClock::GpuTimestamps).then(|| Timestamps {
            set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("frame timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("frame timestamps resolve"),
                size: TIMESTAMP_BYTES,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            read_back: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("frame timestamps read-back"),
                size: TIMESTAMP_BYTES,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            period_ns: f64::from(queue.get_timestamp_period()),
        });
        let frame = Frame {
            targets: &targets,
            bind_group: &bind_group,
            chunks: &chunks,
            timestamps: timestamps.as_ref(),
        };

        let mut scratch = vec![0u64; pvis.scratch_words()];
        let mut culled_draws_of = |camera: &Camera| {
            let eye = camera.eye().map(|c| c as f32);
            let visible = pvis.query(eye, &mut scratch);
            chunk_draws(&chunk_ranges, &visible_runs(visible.bits(), starts))
        };
        let set_camera = |camera: &Camera| {
            let mut bytes = Vec::with_capacity(UNIFORM_BYTES as usize);
            for value in view_matrix(camera, center) {
                bytes.extend_from_slice(&value.to_le_bytes());
            }
            for value in camera.forward().map(|c| c as f32).into_iter().chain([0.0]) {
                bytes.extend_from_slice(&value.to_le_bytes());
            }
            // Ordered before the next submission, after the previous one.
            queue.write_buffer(&uniforms, 0, &bytes);
        };

        set_camera(&cameras[0]);
        let warmup_draws = culled_draws_of(&cameras[0]);
        for _ in 0..WARMUP_FRAMES {
            self.frame(&frame, &full_draws)?;
            self.frame(&frame, &warmup_draws)?;
        }
        for camera in cameras {
            set_camera(camera);
            let draws = culled_draws_of(camera);
            let (full_gpu, full_wall) = self.frame(&frame, &full_draws)?;
            let (culled_gpu, culled_wall) = self.frame(&frame, &draws)?;
            out.push(GpuViewCost {
                full_seconds: full_gpu.unwrap_or(full_wall),
                culled_seconds: culled_gpu.unwrap_or(culled_wall),
                full_wall_seconds: full_wall,
                culled_wall_seconds: culled_wall,
                culled_draws: draws.len() as u32,
            });
        }
        Ok(())
    }

    /// Draws one frame of `draws` (chunk, index range) and waits for it: the GPU seconds (with
    /// timestamps) and the wall seconds from submission to completion.
    fn frame(
        &self,
        frame: &Frame<'_>,
        draws: &[(usize, Range<u32>)],
    ) -> Result<(Option<f64>, f64), GpuError> {
        let (device, queue) = (&self.device, &self.queue);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame"),
        });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("frame"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &frame.targets.colour,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &frame.targets.depth,
                    // Reversed Z: 0 is infinitely far.
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: frame.timestamps.map(|t| wgpu::RenderPassTimestampWrites {
                    query_set: &t.set,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, frame.bind_group, &[]);
            let mut bound = None;
            for (chunk, indices) in draws {
                if bound != Some(*chunk) {
                    let c = &frame.chunks[*chunk];
                    pass.set_vertex_buffer(0, c.vertices.slice(..));
                    pass.set_index_buffer(c.indices.slice(..), wgpu::IndexFormat::Uint32);
                    bound = Some(*chunk);
                }
                pass.draw_indexed(indices.clone(), 0, 0..1);
            }
        }
        if let Some(t) = frame.timestamps {
            encoder.resolve_query_set(&t.set, 0..2, &t.resolve, 0);
            encoder.copy_buffer_to_buffer(&t.resolve, 0, &t.read_back, 0, TIMESTAMP_BYTES);
        }
        let commands = encoder.finish();
        let start = Instant::now();
        let submission = queue.submit([commands]);
        device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(submission),
                timeout: None,
            })
            .map_err(|e| GpuError::Failed(one_line(e)))?;
        let wall = start.elapsed().as_secs_f64();
        let gpu = match frame.timestamps {
            Some(t) => Some(self.read_timestamps(t)?),
            None => None,
        };
        Ok((gpu, wall))
    }

    /// Seconds between the two timestamps of the last frame (already complete).
    fn read_timestamps(&self, t: &Timestamps) -> Result<f64, GpuError> {
        let slice = t.read_back.slice(..);
        let (sender, receiver) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |result| {
            // The receiver waits below; a send can only fail if it is gone.
            let _ = sender.send(result);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Failed(one_line(e)))?;
        receiver
            .recv()
            .map_err(|_| GpuError::Failed("the timestamp read-back never completed".into()))?
            .map_err(|e| GpuError::Failed(one_line(e)))?;
        let ticks = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Failed(one_line(e)))?;
            let at = |i: usize| {
                u64::from_le_bytes(data[8 * i..8 * i + 8].try_into().expect("8-byte timestamp"))
            };
            // A driver that resets its counter between the two writes would make the end
            // smaller: that frame reads 0 rather than wrapping to an absurd figure.
            at(1).saturating_sub(at(0))
        };
        t.read_back.unmap();
        Ok(ticks as f64 * t.period_ns * 1e-9)
    }
}

/// The frame's colour and depth targets.
struct Targets {
    colour: wgpu::TextureView,
    depth: wgpu::TextureView,
}

/// The timestamp query set and its buffers.
struct Timestamps {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read_back: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
}

/// What every frame of a measurement shares.
struct Frame<'a> {
    targets: &'a Targets,
    bind_group: &'a wgpu::BindGroup,
    chunks: &'a [MeshChunk],
    timestamps: Option<&'a Timestamps>,
}

/// The draws of triangle ranges `runs` (ascending, disjoint) over index buffers holding the
/// consecutive triangle ranges `chunks`: `(chunk, index range)` pairs, a run crossing a chunk
/// boundary split in two, three indices per triangle. Triangles outside every chunk are left
/// out.
pub fn chunk_draws(chunks: &[Range<u32>], runs: &[Range<u32>]) -> Vec<(usize, Range<u32>)> {
    let mut draws = Vec::new();
    let mut c = 0;
    for run in runs {
        // Chunks wholly before this run are wholly before every later run too.
        while c < chunks.len() && chunks[c].end <= run.start {
            c += 1;
        }
        let mut k = c;
        while k < chunks.len() && chunks[k].start < run.end {
            let chunk = &chunks[k];
            let (lo, hi) = (run.start.max(chunk.start), run.end.min(chunk.end));
            if lo < hi {
                draws.push((k, 3 * (lo - chunk.start)..3 * (hi - chunk.start)));
            }
            k += 1;
        }
    }
    draws
}

#[cfg(test)]
// The expectations are lists of ranges, some of one range; not `Vec`s made from a range.
#[allow(clippy::single_range_in_vec_init)]
mod tests {
    use super::*;

    /// Patch starts for patches of `counts` triangles, and the total.
    fn starts(counts: &[u32]) -> Vec<u32> {
        let mut out = vec![0];
        for &c in counts {
            out.push(out.last().copied().unwrap_or(0) + c);
        }
        out
    }

    #[test]
    fn consecutive_visible_patches_merge_into_one_run() {
        // Patches of 3, 2, 4, 1, 5 triangles: starts 0, 3, 5, 9, 10.
        let ps = starts(&[3, 2, 4, 1, 5]);
        // Patches 0, 1, 3, 4 visible: runs 0..5 and 9..15.
        assert_eq!(visible_runs(&[0b11011], &ps), [0..5, 9..15]);
        assert_eq!(visible_runs(&[0b00100], &ps), [5..9]);
        assert_eq!(visible_runs(&[0], &ps), []);
        assert_eq!(visible_runs(&[0b11111], &ps), [0..15]);
    }

    #[test]
    fn runs_cross_word_boundaries_and_skip_empty_patches() {
        // 130 patches of one triangle each, patch 64 empty.
        let mut counts = vec![1; 130];
        counts[64] = 0;
        let ps = starts(&counts);
        // Patches 62..=65 visible (64 empty, no gap in triangles) and 129.
        let bits = [0b11 << 62, 0b11, 1 << 1];
        assert_eq!(visible_runs(&bits, &ps), [62..65, 128..129]);
    }

    #[test]
    fn draws_split_at_chunk_boundaries() {
        let chunks = [0..10, 10..25, 25..30];
        // Whole mesh: one draw per chunk, indices from 0 in each.
        assert_eq!(
            chunk_draws(&chunks, &[0..30]),
            [(0, 0..30), (1, 0..45), (2, 0..15)]
        );
        // A run inside a chunk, one across two chunks, one ending on a boundary.
        assert_eq!(
            chunk_draws(&chunks, &[2..4, 8..12, 20..25]),
            [(0, 6..12), (0, 24..30), (1, 0..6), (1, 30..45)]
        );
        assert_eq!(chunk_draws(&chunks, &[]), []);
        assert_eq!(chunk_draws(&[], &[0..5]), []);
    }
}
