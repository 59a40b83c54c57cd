//! Opening a GPU: the adapter and device selection shared by the sampling backend
//! (`sampler::gpu`) and the evaluator's GPU frame cost (`eval::gpu_frame`), their error type,
//! and how adapters and wgpu's messages are shown.

/// Why the GPU backend could not sample.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No GPU adapter is available (no driver, no Vulkan/Metal/DX12 loader, or none found).
    #[error("no GPU adapter found ({0})")]
    NoAdapter(String),
    /// The adapter exists but refused to open a device.
    #[error("GPU adapter {adapter}: cannot open a device: {reason}")]
    Device {
        /// The adapter's description.
        adapter: String,
        /// wgpu's reason.
        reason: String,
    },
    /// A sampling option the GPU backend does not implement.
    #[error("the GPU backend does not support {0}; use the CPU backend")]
    Unsupported(&'static str),
    /// The job exceeds one of the device's limits.
    #[error("{what} needs {needed}, but this GPU allows at most {limit}")]
    TooLarge {
        /// What does not fit.
        what: &'static str,
        /// What it needs.
        needed: u64,
        /// The device's limit.
        limit: u64,
    },
    /// The device reported an error while sampling (out of memory, device lost, …).
    #[error("GPU error: {0}")]
    Failed(String),
}

/// Opens the highest-performance adapter wgpu finds (honouring wgpu's `WGPU_BACKEND` and
/// `WGPU_ADAPTER_NAME` environment variables) with all its limits and those of `optional`
/// features it has: the device selection of the sampler, shared with the evaluator's GPU
/// frame cost (`eval::gpu_frame`).
pub(crate) fn open_device(
    label: &str,
    optional: wgpu::Features,
) -> Result<(wgpu::Device, wgpu::Queue, wgpu::AdapterInfo), GpuError> {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))
    .map_err(|e| GpuError::NoAdapter(one_line(e)))?;
    let info = adapter.get_info();
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some(label),
        required_features: adapter.features() & optional,
        // Everything the adapter offers: big meshes want its largest buffers.
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| GpuError::Device {
        adapter: describe(&info),
        reason: one_line(e),
    })?;
    Ok((device, queue, info))
}

/// One line of an error text from wgpu, whose messages may span several lines.
pub(crate) fn one_line(text: impl std::fmt::Display) -> String {
    text.to_string()
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

/// `name (type, backend)` of an adapter.
pub(crate) fn describe(info: &wgpu::AdapterInfo) -> String {
    format!("{} ({:?}, {:?})", info.name, info.device_type, info.backend)
}
