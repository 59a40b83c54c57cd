//! GPU sampling backend (wgpu): the visibility matrix of [`super::sample_tiled`], with the ID
//! buffers rendered by the GPU's rasterizer and reduced to per-view patch bitfields on the GPU.
//!
//! Technique: Meruvia 2002, section 3, on graphics hardware as the paper ran it, with the
//! ID-bitfield reduction of the second paper done in a compute pass. The mesh is uploaded once,
//! regrouped by patch (`crate::gpu` mesh upload: each patch's own vertices, holding the position
//! relative to the bounding-sphere centre and the patch id, and its triangles as indices). Views go
//! in batches, one command buffer per batch: every view of the batch renders into its own layer of
//! an R32Uint array texture (the patch id; empty pixels keep [`NO_PATCH`]) with a `Depth32Float`
//! layer (reversed Z: depth `near / w`, cleared to 0, nearest wins), then one compute dispatch over
//! all layers sets bit `id` of the view's row with `atomicOr` (`reduce.wgsl`; with `min_pixels` it
//! counts pixels with `atomicAdd` and thresholds them instead), and only the rows are copied back,
//! never an image. Two read-back buffers let the CPU read batch `k` while the GPU draws batch `k +
//! 1`.
//!
//! The cameras are [`Camera::sampling`]'s (same eye, basis, field of view, near plane and
//! resolution; `view_matrix` turns one into a clip matrix), or in a near pass
//! ([`SamplingOptions::shell`]) each of a near view's cameras ([`super::near_cameras`]) in a
//! layer of its own, whose rows are ORed into the view's row on the CPU. The result is not
//! bit-identical to the CPU backend's: the GPU transforms in `f32` and snaps vertices with its
//! own subpixel precision and tie rules, so pixels on triangle edges can change hands, and a
//! patch seen only through such pixels can differ (tests/gpu.rs bounds the difference; BENCHMARKS.md
//! records it). Options: `min_pixels` runs on the GPU; `dilate` and `always_visible` are the
//! CPU backend's post-processing of the rows; `conservative` and `resume` are refused
//! ([`GpuError::Unsupported`]); no checkpoint is written.
//!
//! Cost: mesh upload about 22 bytes per triangle (GPU memory, once); per view one full draw of
//! the mesh (no culling by coarser levels) and one pass over the pixels; per batch one
//! submission and `views × ⌈patches / 64⌉ × 8` bytes read back. GPU memory besides the mesh:
//! `resolution² × 8` bytes per batched view, capped at [`BATCH_TARGET_BYTES`].

use super::marks::{Marks, needs_graph, patch_graph};
use super::{Camera, SamplingOptions, SamplingParams, VisibilityMatrix, near_cameras};
pub use crate::gpu::GpuError;
use crate::gpu::mesh::{self as upload};
use crate::gpu::{depth_tested_pipeline, describe, one_line, open_device, view_matrix};
use crate::ooc::Mesh;
use crate::progress::Progress;
use crate::sphere::view_count;
use crate::tiling::Tiling;
use std::sync::mpsc;

/// The id of an empty pixel in the GPU's ID buffers (the colour target's clear value); the
/// shaders' `NO_PATCH`. Patch ids stay below it because a tiling has fewer than `2^32 - 1`
/// patches.
pub const NO_PATCH: u32 = u32::MAX;

/// Most views in one batch: the length of the shader's matrix array (`render.wgsl`), 16 KiB
/// of uniforms, well below the 64 KiB every device allows.
pub const MAX_BATCH_VIEWS: u32 = 256;

/// GPU memory a batch's ID and depth layers may take. Large enough that a batch holds
/// dozens of 512² views (amortising a submission and its read-back), small enough for any
/// discrete or integrated GPU.
pub const BATCH_TARGET_BYTES: u64 = 256 << 20;

/// Bytes per pixel of a batched view: a 4-byte patch id and a 4-byte depth.
const BYTES_PER_PIXEL: u64 = 8;

/// Side of the square workgroup of the per-pixel passes (`reduce.wgsl` `PIXEL_GROUP`).
const PIXEL_GROUP: u32 = 16;

/// Invocations per workgroup of the threshold pass (`reduce.wgsl` `WORD_GROUP`).
const WORD_GROUP: u32 = 64;

/// Bytes of one view's clip matrix in the uniform array (a `mat4x4<f32>`).
const MATRIX_BYTES: u64 = 64;

/// An open GPU device with the sampling pipelines compiled: create once, sample many times.
#[derive(Debug)]
pub struct GpuSampler {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    render: wgpu::RenderPipeline,
    render_layout: wgpu::BindGroupLayout,
    mark: wgpu::ComputePipeline,
    count: wgpu::ComputePipeline,
    threshold: wgpu::ComputePipeline,
    reduce_layout: wgpu::BindGroupLayout,
}

impl GpuSampler {
    /// Opens the highest-performance adapter wgpu finds (honouring wgpu's `WGPU_BACKEND` and
    /// `WGPU_ADAPTER_NAME` environment variables) and compiles the pipelines.
    pub fn new() -> Result<GpuSampler, GpuError> {
        let (device, queue, info) = open_device("patchvis sampling", wgpu::Features::empty())?;
        let pipelines = Pipelines::new(&device);
        Ok(GpuSampler {
            device,
            queue,
            info,
            render: pipelines.render,
            render_layout: pipelines.render_layout,
            mark: pipelines.mark,
            count: pipelines.count,
            threshold: pipelines.threshold,
            reduce_layout: pipelines.reduce_layout,
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

    /// Renders every view of `params` on the GPU and returns which patches each one shows,
    /// for the patches of `tiling` (a tiling of `mesh`); the counterpart of
    /// [`super::sample_tiled`] (see the module documentation for the differences).
    ///
    /// Panics (caller contract) if an always-visible id is not a patch of `tiling`.
    pub fn sample(
        &self,
        mesh: &Mesh,
        tiling: &Tiling,
        params: &SamplingParams,
        options: &SamplingOptions,
        progress: &dyn Progress,
    ) -> Result<VisibilityMatrix, GpuError> {
        if options.conservative_raster {
            return Err(GpuError::Unsupported("conservative rasterization"));
        }
        if options.probe.is_some() {
            return Err(GpuError::Unsupported("the probe pass (--conservative)"));
        }
        if options.resume {
            return Err(GpuError::Unsupported("resuming from a checkpoint"));
        }
        assert!(
            params.radius > 0.0 && params.radius.is_finite(),
            "sampling radius must be positive and finite, got {}",
            params.radius
        );
        let patch_count = u32::try_from(tiling.patches.len())
            .ok()
            .filter(|&n| n < NO_PATCH)
            .expect("a tiling has fewer than 2^32 - 1 patches");
        for &p in &options.always_visible {
            assert!(
                p < patch_count,
                "always-visible patch {p} is not below {patch_count}"
            );
        }
        let limits = self.device.limits();
        if params.resolution > limits.max_texture_dimension_2d {
            return Err(GpuError::TooLarge {
                what: "the ID buffer side (pixels)",
                needed: params.resolution.into(),
                limit: limits.max_texture_dimension_2d.into(),
            });
        }
        let views = view_count(params.level);
        // Every view's cameras, view after view: one each, or a near view's one or five (a far
        // shell's one).
        let cameras: Vec<Camera> = match options.shell {
            None => (0..views)
                .map(|v| Camera::sampling_view(params, v))
                .collect(),
            Some(distance) => (0..views)
                .flat_map(|v| near_cameras(params, crate::sphere::direction(v), distance).to_vec())
                .collect(),
        };
        let per_view = cameras.len() / views as usize;
        let mut matrix = VisibilityMatrix::new(views, patch_count);
        progress.start("sampling", cameras.len() as u64);
        if patch_count > 0 {
            let mut camera_rows = if per_view == 1 {
                None
            } else {
                Some(VisibilityMatrix::new(cameras.len() as u32, patch_count))
            };
            // Out-of-memory and validation errors become values instead of wgpu's default
            // panic; scopes pop in reverse order.
            let memory_scope = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
            let validation_scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
            let sampled = self.sample_rows(
                mesh,
                tiling,
                params,
                options,
                &cameras,
                camera_rows.as_mut().unwrap_or(&mut matrix),
                progress,
            );
            let validation = pollster::block_on(validation_scope.pop());
            let memory = pollster::block_on(memory_scope.pop());
            sampled?;
            if let Some(e) = memory.or(validation) {
                return Err(GpuError::Failed(one_line(e)));
            }
            if let Some(rows) = &camera_rows {
                for view in 0..views {
                    let first = view * per_view as u32;
                    for c in first..first + per_view as u32 {
                        for (r, w) in matrix.row_mut(view).iter_mut().zip(rows.row(c)) {
                            *r |= w;
                        }
                    }
                }
            }
            let eyes: Vec<[f64; 3]> = cameras.iter().step_by(per_view).map(Camera::eye).collect();
            post_process(mesh, tiling, options, &eyes, &mut matrix);
        } else {
            progress.inc(cameras.len() as u64);
        }
        progress.finish();
        Ok(matrix)
    }

    /// Fills the rows of `matrix`, one per camera of `cameras`, batch by batch (the module
    /// documentation's technique): while the GPU draws and reduces a batch, the CPU reads the
    /// rows of the one before.
    #[allow(clippy::too_many_arguments)]
    fn sample_rows(
        &self,
        mesh: &Mesh,
        tiling: &Tiling,
        params: &SamplingParams,
        options: &SamplingOptions,
        cameras: &[Camera],
        matrix: &mut VisibilityMatrix,
        progress: &dyn Progress,
    ) -> Result<(), GpuError> {
        let (device, queue) = (&self.device, &self.queue);
        let limits = device.limits();
        let patches = matrix.patches();
        let words64 = u64::from(patches).div_ceil(64);
        let words32 = 2 * words64;
        let counting = options.min_pixels > 1;
        let batch = batch_views(params.resolution, patches, words32, counting, &limits)?;
        let starts = tiling.starts();
        let host_bytes = options.memory.map_or(u64::MAX, |share| share.gpu_staging);
        let chunks = upload::upload_mesh(
            device,
            queue,
            mesh,
            upload::PatchOrder::of(tiling, &starts),
            params.center,
            &limits,
            host_bytes,
        )?;
        let layers = Layers::new(device, params.resolution, batch);
        let buffers = self.batch_buffers(&layers, params, options, patches, words32, batch);

        let views = matrix.views();
        let mut pending: Option<Pending> = None;
        for (k, first) in (0..views).step_by(batch as usize).enumerate() {
            let count = batch.min(views - first);
            let batch_cameras = &cameras[first as usize..(first + count) as usize];
            // Ordered after the previous submission and before the next one, so the batch in
            // flight keeps its matrices.
            queue.write_buffer(
                &buffers.matrices,
                0,
                &matrix_bytes(batch_cameras, params.center),
            );
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("sampling batch"),
            });
            encoder.clear_buffer(&buffers.bits, 0, None);
            self.render_batch(&mut encoder, &layers, &buffers, &chunks, count);
            self.reduce_batch(&mut encoder, &buffers, params.resolution, count, counting);
            let target = &buffers.read_back[k % 2];
            encoder.copy_buffer_to_buffer(
                &buffers.bits,
                0,
                target,
                0,
                buffers.row_bytes * u64::from(count),
            );
            let submission = queue.submit([encoder.finish()]);
            if let Some(done) = pending.take() {
                self.read_rows(&done, words64, matrix)?;
                progress.inc(u64::from(done.count));
            }
            pending = Some(Pending {
                buffer: target.clone(),
                submission,
                first,
                count,
            });
        }
        if let Some(done) = pending.take() {
            self.read_rows(&done, words64, matrix)?;
            progress.inc(u64::from(done.count));
        }
        Ok(())
    }

    /// The buffers and bind groups of a batch of `batch` views over `patches` patches
    /// (`words32` 32-bit words a row): the rows, the pixel counts of `min_pixels`, the reduce
    /// parameters (written here), the view matrices and two read-back buffers.
    fn batch_buffers(
        &self,
        layers: &Layers,
        params: &SamplingParams,
        options: &SamplingOptions,
        patches: u32,
        words32: u64,
        batch: u32,
    ) -> BatchBuffers {
        let device = &self.device;
        let counting = options.min_pixels > 1;
        let row_bytes = words32 * 4;
        let bits = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rows"),
            size: row_bytes * u64::from(batch),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // Pixel counts for `min_pixels`; a placeholder word otherwise (the binding must exist).
        // Created zeroed; `threshold` resets what it read.
        let counts = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pixel counts"),
            size: if counting {
                4 * u64::from(patches) * u64::from(batch)
            } else {
                4
            },
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let reduce_params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("reduce parameters"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let words32 =
            u32::try_from(words32).expect("fewer than 2^32 patches make fewer than 2^28 words");
        let param_words = [params.resolution, patches, words32, options.min_pixels];
        self.queue
            .write_buffer(&reduce_params, 0, &u32s_to_bytes(&param_words));
        let matrices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view matrices"),
            size: MATRIX_BYTES * u64::from(MAX_BATCH_VIEWS),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let render_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("render"),
            layout: &self.render_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: matrices.as_entire_binding(),
            }],
        });
        let reduce_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("reduce"),
            layout: &self.reduce_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&layers.ids_array),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: bits.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: counts.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: reduce_params.as_entire_binding(),
                },
            ],
        });
        let read_back: [wgpu::Buffer; 2] = std::array::from_fn(|_| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("rows read-back"),
                size: row_bytes * u64::from(batch),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        BatchBuffers {
            bits,
            _counts: counts,
            _reduce_params: reduce_params,
            matrices,
            render_group,
            reduce_group,
            read_back,
            row_bytes,
            words32,
        }
    }

    /// Records the ID buffer of each of the batch's first `count` views: the mesh drawn into
    /// the view's layer with the view's matrix.
    fn render_batch(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        layers: &Layers,
        buffers: &BatchBuffers,
        chunks: &[upload::MeshChunk],
        count: u32,
    ) {
        for layer in 0..count {
            let (ids, depth) = &layers.per_view[layer as usize];
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("ID buffer"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: ids,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: f64::from(NO_PATCH),
                            g: 0.0,
                            b: 0.0,
                            a: 0.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: depth,
                    // Reversed Z: 0 is infinitely far.
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.render);
            pass.set_bind_group(0, &buffers.render_group, &[]);
            for chunk in chunks {
                pass.set_vertex_buffer(0, chunk.vertices.slice(..));
                pass.set_index_buffer(chunk.indices.slice(..), wgpu::IndexFormat::Uint32);
                // The instance index selects the view's matrix.
                pass.draw_indexed(0..chunk.index_count, 0, layer..layer + 1);
            }
        }
    }

    /// Records the reduction of the batch's first `count` ID buffers to rows of patch bits:
    /// one pass marking every pixel's patch, or with `counting` (`min_pixels`) one counting
    /// them and one thresholding the counts.
    fn reduce_batch(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        buffers: &BatchBuffers,
        resolution: u32,
        count: u32,
        counting: bool,
    ) {
        let pixel_groups = resolution.div_ceil(PIXEL_GROUP);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("reduce"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &buffers.reduce_group, &[]);
        if counting {
            pass.set_pipeline(&self.count);
            pass.dispatch_workgroups(pixel_groups, pixel_groups, count);
            pass.set_pipeline(&self.threshold);
            pass.dispatch_workgroups(buffers.words32.div_ceil(WORD_GROUP), count, 1);
        } else {
            pass.set_pipeline(&self.mark);
            pass.dispatch_workgroups(pixel_groups, pixel_groups, count);
        }
    }

    /// Waits for the batch `done`, then copies its rows from the read-back buffer.
    fn read_rows(
        &self,
        done: &Pending,
        words64: u64,
        matrix: &mut VisibilityMatrix,
    ) -> Result<(), GpuError> {
        let bytes = words64 * 8 * u64::from(done.count);
        let slice = done.buffer.slice(..bytes);
        let (sender, receiver) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |result| {
            // The receiver waits below; a send can only fail if it is gone.
            let _ = sender.send(result);
        });
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(done.submission.clone()),
                timeout: None,
            })
            .map_err(|e| GpuError::Failed(one_line(e)))?;
        receiver
            .recv()
            .map_err(|_| GpuError::Failed("the read-back never completed".into()))?
            .map_err(|e| GpuError::Failed(one_line(e)))?;
        {
            let data = slice
                .get_mapped_range()
                .map_err(|e| GpuError::Failed(one_line(e)))?;
            // Rows of 32-bit words, low word first: exactly the little-endian bytes of the
            // 64-bit words of a matrix row.
            for (i, row_bytes) in data.chunks_exact(words64 as usize * 8).enumerate() {
                let row = matrix.row_mut(done.first + i as u32);
                for (word, bytes) in row.iter_mut().zip(row_bytes.chunks_exact(8)) {
                    *word = u64::from_le_bytes(bytes.try_into().expect("8-byte chunk"));
                }
            }
        }
        done.buffer.unmap();
        Ok(())
    }
}

/// What every batch of a sampling run draws and reduces with ([`GpuSampler::batch_buffers`]).
struct BatchBuffers {
    /// The batch's rows of patch bits, 32-bit words.
    bits: wgpu::Buffer,
    /// Bound in `reduce_group`: the pixel counts of `min_pixels`.
    _counts: wgpu::Buffer,
    /// Bound in `reduce_group`: resolution, patches, words a row and `min_pixels`.
    _reduce_params: wgpu::Buffer,
    /// The batch's view matrices, [`MATRIX_BYTES`] each.
    matrices: wgpu::Buffer,
    render_group: wgpu::BindGroup,
    reduce_group: wgpu::BindGroup,
    /// Batch `k` is read back through buffer `k % 2`.
    read_back: [wgpu::Buffer; 2],
    /// Bytes of one view's row.
    row_bytes: u64,
    /// 32-bit words of one view's row.
    words32: u32,
}

/// The clip matrices of `cameras` ([`view_matrix`], positions relative to `center`) as the
/// shader's uniform array holds them.
fn matrix_bytes(cameras: &[Camera], center: [f32; 3]) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(MATRIX_BYTES as usize * cameras.len());
    for camera in cameras {
        bytes.extend(view_matrix(camera, center).map(f32::to_le_bytes).concat());
    }
    bytes
}

/// A submitted batch whose rows are still to be read.
struct Pending {
    buffer: wgpu::Buffer,
    submission: wgpu::SubmissionIndex,
    first: u32,
    count: u32,
}

/// Adds what the CPU backend adds after point sampling, with the same [`Marks`]: `dilate`'s
/// facing neighbours of the seen patches, then the always-visible patches.
fn post_process(
    mesh: &Mesh,
    tiling: &Tiling,
    options: &SamplingOptions,
    eyes: &[[f64; 3]],
    matrix: &mut VisibilityMatrix,
) {
    let graph = needs_graph(options).then(|| patch_graph(mesh, tiling));
    let marks = Marks::new(tiling, options, graph.as_ref());
    for (view, &eye) in (0..matrix.views()).zip(eyes) {
        let seen = matrix.row(view).to_vec();
        marks.apply(tiling, eye, &seen, matrix.row_mut(view));
    }
}

/// How many views a batch holds: as many as [`BATCH_TARGET_BYTES`], [`MAX_BATCH_VIEWS`] and
/// the device's array-layer and storage-binding limits allow; at least one, or an error if
/// even one view does not fit.
fn batch_views(
    resolution: u32,
    patches: u32,
    words32: u64,
    counting: bool,
    limits: &wgpu::Limits,
) -> Result<u32, GpuError> {
    let storage = limits.max_storage_buffer_binding_size;
    let row_bytes = words32 * 4;
    if row_bytes > storage {
        return Err(GpuError::TooLarge {
            what: "one view's row of patch bits (bytes)",
            needed: row_bytes,
            limit: storage,
        });
    }
    let count_bytes = 4 * u64::from(patches);
    if counting && count_bytes > storage {
        return Err(GpuError::TooLarge {
            what: "one view's pixel counts for --min-pixels (bytes)",
            needed: count_bytes,
            limit: storage,
        });
    }
    let layer_bytes = u64::from(resolution).pow(2) * BYTES_PER_PIXEL;
    let mut batch = (BATCH_TARGET_BYTES / layer_bytes)
        .max(1)
        .min(u64::from(MAX_BATCH_VIEWS))
        .min(u64::from(limits.max_texture_array_layers))
        .min(u64::from(limits.max_compute_workgroups_per_dimension))
        .min(storage / row_bytes);
    if counting {
        batch = batch.min(storage / count_bytes);
    }
    Ok(batch.max(1) as u32)
}

/// The batch's render targets: per view an ID layer and a depth layer, and the ID layers as
/// one array for the reduction.
struct Layers {
    per_view: Vec<(wgpu::TextureView, wgpu::TextureView)>,
    ids_array: wgpu::TextureView,
}

impl Layers {
    fn new(device: &wgpu::Device, resolution: u32, batch: u32) -> Layers {
        let texture = |label, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: resolution,
                    height: resolution,
                    depth_or_array_layers: batch,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let ids = texture(
            "ID buffers",
            wgpu::TextureFormat::R32Uint,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let depth = texture(
            "depth buffers",
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let layer = |texture: &wgpu::Texture, i| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_array_layer: i,
                array_layer_count: Some(1),
                ..Default::default()
            })
        };
        Layers {
            per_view: (0..batch)
                .map(|i| (layer(&ids, i), layer(&depth, i)))
                .collect(),
            ids_array: ids.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            }),
        }
    }
}

/// The compiled pipelines and their bind group layouts.
struct Pipelines {
    render: wgpu::RenderPipeline,
    render_layout: wgpu::BindGroupLayout,
    mark: wgpu::ComputePipeline,
    count: wgpu::ComputePipeline,
    threshold: wgpu::ComputePipeline,
    reduce_layout: wgpu::BindGroupLayout,
}

impl Pipelines {
    fn new(device: &wgpu::Device) -> Pipelines {
        let render_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("render.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("render.wgsl").into()),
        });
        let reduce_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("reduce.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("reduce.wgsl").into()),
        });
        let render_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("render"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let storage = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: false },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let reduce_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("reduce"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Uint,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                storage(1),
                storage(2),
                wgpu::BindGroupLayoutEntry {
                    binding: 3,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let render_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("render"),
                bind_group_layouts: &[Some(&render_layout)],
                immediate_size: 0,
            });
        let reduce_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("reduce"),
                bind_group_layouts: &[Some(&reduce_layout)],
                immediate_size: 0,
            });
        let render = depth_tested_pipeline(
            device,
            "ID buffer",
            &render_pipeline_layout,
            &render_module,
            upload::vertex_layout(),
            wgpu::TextureFormat::R32Uint,
        );
        let compute = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&reduce_pipeline_layout),
                module: &reduce_module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        Pipelines {
            render,
            render_layout,
            mark: compute("mark"),
            count: compute("count"),
            threshold: compute("threshold"),
            reduce_layout,
        }
    }
}

/// `words` as little-endian bytes, for buffer uploads.
fn u32s_to_bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}
