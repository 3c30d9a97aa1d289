//! GPU path on wgpu: device setup, the shader registry, compute passes and readback.
//!
//! Every GPU operation returns a [`GpuError`] instead of panicking: no adapter, a failed
//! device request, a shader that does not compile, a lost device or a failed readback.

pub mod draw;
pub mod hemi_map;
pub mod lobes;
pub mod shade;
pub mod shaders;
pub mod testing;

/// The wgpu this crate is built on (for adapter types in callers).
pub use wgpu;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// What went wrong on the GPU side.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter was found (no GPU and no software Vulkan such as Mesa's llvmpipe).
    #[error(
        "no GPU adapter found ({0}); install a Vulkan driver (for example Mesa's `mesa-vulkan-drivers`) or use the CPU path"
    )]
    NoAdapter(String),
    /// The adapter refused to create a device.
    #[error("could not create a GPU device on {adapter}: {message}")]
    Device {
        /// The adapter's name.
        adapter: String,
        /// wgpu's message.
        message: String,
    },
    /// A shader failed to compile or a pipeline to build.
    #[error("shader {name} failed to build: {message}")]
    Shader {
        /// Registry name.
        name: &'static str,
        /// wgpu's message.
        message: String,
    },
    /// The device was lost (driver reset, GPU removed).
    #[error("the GPU device was lost")]
    DeviceLost,
    /// Reading results back failed.
    #[error("GPU readback failed: {0}")]
    Readback(String),
    /// The scene does not fit the adapter's buffer limits.
    #[error(
        "{what} need {bytes} bytes; the GPU allows {limit} per buffer (lower the quality preset or use the CPU path)"
    )]
    TooLarge {
        /// What was being uploaded.
        what: String,
        /// Its size.
        bytes: u64,
        /// The adapter's limit.
        limit: u64,
    },
    /// The data given does not match what was loaded, or cannot be laid out.
    #[error("GPU scene: {0}")]
    Scene(String),
    /// An error reported by wgpu validation during an operation.
    #[error("GPU operation {operation} failed: {message}")]
    Operation {
        /// What was being done.
        operation: &'static str,
        /// wgpu's message.
        message: String,
    },
}

/// What rsl's passes need of a device on `adapter`: the shading pass binds eight storage
/// buffers (eleven for the per-pixel pass, where the adapter has them), and visibility fields are large, so the adapter's own buffer limits; timestamps
/// where the adapter has them (`--timings`). A window that opens its own device (the
/// viewer's) asks for this one, so that rsl-gpu can use it ([`GpuContext::from_device`]).
pub fn device_descriptor(adapter: &wgpu::Adapter) -> wgpu::DeviceDescriptor<'static> {
    let available = adapter.limits();
    let required_limits = wgpu::Limits {
        // Eight for the shading pass; the RSL sum per pixel binds eleven where the adapter
        // allows (rsl_gpu::draw::GpuDraw::draw_pixels checks).
        max_storage_buffers_per_shader_stage: available.max_storage_buffers_per_shader_stage.clamp(8, 16),
        max_storage_buffer_binding_size: available.max_storage_buffer_binding_size,
        max_buffer_size: available.max_buffer_size,
        ..wgpu::Limits::downlevel_defaults().using_resolution(available)
    };
    wgpu::DeviceDescriptor {
        label: Some("rsl"),
        required_features: adapter.features() & wgpu::Features::TIMESTAMP_QUERY,
        required_limits,
        ..Default::default()
    }
}

/// A device and queue on the best available adapter.
pub struct GpuContext {
    /// The adapter.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Adapter description, for logs.
    pub info: wgpu::AdapterInfo,
    lost: Arc<AtomicBool>,
    /// The first validation or out-of-memory error wgpu reported outside an error scope.
    uncaptured: Arc<Mutex<Option<String>>>,
}

impl GpuContext {
    /// Opens the highest-performance adapter (a real GPU if present, else a software one such
    /// as llvmpipe) on Vulkan, Metal or DX12. `WGPU_BACKEND` and other wgpu environment
    /// variables are honoured.
    pub fn new() -> Result<Self, GpuError> {
        // Headless compute needs only the primary backends; probing GL would only add noise.
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&device_descriptor(&adapter)))
            .map_err(|e| GpuError::Device { adapter: info.name.clone(), message: e.to_string() })?;
        Ok(Self::from_device(adapter, device, queue))
    }

    /// A context on a device someone else opened (a viewer passes its window's device and
    /// queue). The device must have what the passes ask for: eight storage buffers per stage
    /// and buffer limits large enough for the scene's fields (loading reports what is too
    /// large). Lost-device and uncaptured-error handlers are installed on it, so failures
    /// are [`GpuError`]s here as on a device of our own.
    pub fn from_device(adapter: wgpu::Adapter, device: wgpu::Device, queue: wgpu::Queue) -> Self {
        let info = adapter.get_info();
        let lost = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&lost);
        device.set_device_lost_callback(move |reason, msg| {
            flag.store(true, Ordering::SeqCst);
            tracing::error!("GPU device lost ({reason:?}): {msg}");
        });
        // wgpu's default handler panics; keep the message and report it as an error instead.
        let uncaptured = Arc::new(Mutex::new(None));
        let slot = Arc::clone(&uncaptured);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            tracing::error!("GPU error: {e}");
            if let Ok(mut s) = slot.lock() {
                s.get_or_insert_with(|| e.to_string());
            }
        }));
        Self { adapter, device, queue, info, lost, uncaptured }
    }

    /// One line describing the adapter: name, type, backend, driver.
    pub fn describe(&self) -> String {
        let i = &self.info;
        format!("{} ({:?}, {:?}, driver {} {})", i.name, i.device_type, i.backend, i.driver, i.driver_info)
    }

    /// Errors if the device has been lost, or if wgpu reported an error outside an error
    /// scope since the last check.
    pub fn check_alive(&self) -> Result<(), GpuError> {
        if self.lost.load(Ordering::SeqCst) {
            return Err(GpuError::DeviceLost);
        }
        if let Some(message) = self.uncaptured.lock().ok().and_then(|mut s| s.take()) {
            return Err(GpuError::Operation { operation: "GPU command", message });
        }
        Ok(())
    }

    /// Builds a compute pipeline from a registered shader, reporting compile and validation
    /// errors as [`GpuError::Shader`].
    pub fn compute_pipeline(
        &self,
        shader: &shaders::Shader,
        constants: &[(&str, f64)],
    ) -> Result<wgpu::ComputePipeline, GpuError> {
        self.compute_pipeline_with_layout(shader, constants, None)
    }

    /// [`GpuContext::compute_pipeline`] with an explicit pipeline layout (`None`: derived
    /// from the shader).
    pub fn compute_pipeline_with_layout(
        &self,
        shader: &shaders::Shader,
        constants: &[(&str, f64)],
        layout: Option<&wgpu::PipelineLayout>,
    ) -> Result<wgpu::ComputePipeline, GpuError> {
        self.check_alive()?;
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(shader.name),
            source: wgpu::ShaderSource::Wgsl(shader.source().into()),
        });
        let pipeline = self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(shader.name),
            layout,
            module: &module,
            entry_point: Some(shader.entry_points[0]),
            compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
            cache: None,
        });
        match pollster::block_on(scope.pop()) {
            Some(e) => Err(GpuError::Shader { name: shader.name, message: e.to_string() }),
            None => Ok(pipeline),
        }
    }

    /// A query set of two timestamps (a pass's beginning and end) and the buffer it resolves
    /// into, or `None` when the device has no timestamp queries.
    pub fn pass_timer(&self, label: &str) -> Option<(wgpu::QuerySet, wgpu::Buffer)> {
        self.device.features().contains(wgpu::Features::TIMESTAMP_QUERY).then(|| {
            let set = self.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some(label),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            });
            let resolve = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            (set, resolve)
        })
    }

    /// Milliseconds between the two timestamps resolved into `resolve` by a pass timer.
    pub fn pass_ms(&self, resolve: &wgpu::Buffer) -> Result<f64, GpuError> {
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&self.read_buffer(resolve, 16)?);
        Ok(ticks[1].saturating_sub(ticks[0]) as f64 * f64::from(self.queue.get_timestamp_period()) / 1e6)
    }

    /// Copies the first `size` bytes of a GPU buffer into host memory (blocking).
    pub fn read_buffer(&self, src: &wgpu::Buffer, size: u64) -> Result<Vec<u8>, GpuError> {
        let staging = self.readback_buffer("readback", size);
        let mut enc = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
        enc.copy_buffer_to_buffer(src, 0, &staging, 0, size);
        self.queue.submit([enc.finish()]);
        self.read_mapped(&staging, <[u8]>::to_vec)
    }

    /// A buffer of `size` bytes that copies can write and the host can map to read.
    pub fn readback_buffer(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Waits for the work submitted so far, maps `staging` (a [`Self::readback_buffer`]),
    /// hands its bytes to `read` where they lie, and unmaps it: one pass over the bytes,
    /// no copy of the whole buffer.
    pub fn read_mapped<R>(&self, staging: &wgpu::Buffer, read: impl FnOnce(&[u8]) -> R) -> Result<R, GpuError> {
        self.check_alive()?;
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Readback(e.to_string()))?;
        self.check_alive()?;
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(GpuError::Readback(e.to_string())),
            Err(_) => return Err(GpuError::Readback("map callback never ran".into())),
        }
        let result = read(&staging.get_mapped_range(..).map_err(|e| GpuError::Readback(e.to_string()))?);
        staging.unmap();
        Ok(result)
    }
}
