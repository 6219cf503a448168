//! Adapter selection, the device, and the small helpers every GPU stage uses.

use std::borrow::Cow;
use std::fmt;
use std::sync::{mpsc, Arc, Mutex};

use bytemuck::Pod;

use crate::{Error, Result};

/// Which adapter [`GpuContext::new`] picks.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AdapterChoice {
    /// The best compute-capable adapter: discrete GPU, then integrated, then virtual, then any
    /// other hardware, then a CPU (software) implementation such as lavapipe.
    #[default]
    Best,
    /// The best adapter whose name contains this string, compared case-insensitively
    /// (e.g. `"llvmpipe"`, `"nvidia"`).
    Name(String),
    /// The best adapter of these backends (e.g. `wgpu::Backends::VULKAN`).
    Backend(wgpu::Backends),
}

impl fmt::Display for AdapterChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AdapterChoice::Best => f.write_str("the best adapter"),
            AdapterChoice::Name(name) => write!(f, "an adapter whose name contains {name:?}"),
            AdapterChoice::Backend(backends) => write!(f, "an adapter on backend(s) {backends:?}"),
        }
    }
}

/// How to set up the GPU.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GpuOptions {
    /// Which adapter to use.
    pub adapter: AdapterChoice,
    /// Time every stage on the GPU with timestamp queries (when the adapter supports them; see
    /// [`crate::Renderer::gpu_stage_timings`]). Costs an extra wait per submission.
    pub profile: bool,
}

impl GpuOptions {
    /// Options from the environment.
    ///
    /// `DIFFSIL_ADAPTER` selects the adapter: `vulkan` (or `vk`), `gl` (`gles`, `opengl`),
    /// `metal` (`mtl`) or `dx12` (`d3d12`) pick a backend; any other non-empty value is a
    /// case-insensitive substring of the adapter name; unset or empty means
    /// [`AdapterChoice::Best`]. Independently, wgpu's own `WGPU_BACKEND` (a comma list such as
    /// `vulkan,gl`) restricts the backends that are looked at in the first place: it is read by
    /// [`GpuContext::new`] and [`hardware_gpu_available`], whatever these options say.
    /// `DIFFSIL_GPU_PROFILE=1` turns on [`GpuOptions::profile`].
    pub fn from_env() -> Self {
        let adapter = match std::env::var("DIFFSIL_ADAPTER") {
            Ok(value) => parse_adapter_choice(&value),
            Err(_) => AdapterChoice::Best,
        };
        let profile = std::env::var("DIFFSIL_GPU_PROFILE").is_ok_and(|v| !v.is_empty() && v != "0");
        GpuOptions { adapter, profile }
    }
}

fn parse_adapter_choice(value: &str) -> AdapterChoice {
    let value = value.trim();
    match value.to_ascii_lowercase().as_str() {
        "" => AdapterChoice::Best,
        "vulkan" | "vk" => AdapterChoice::Backend(wgpu::Backends::VULKAN),
        "gl" | "gles" | "opengl" => AdapterChoice::Backend(wgpu::Backends::GL),
        "metal" | "mtl" => AdapterChoice::Backend(wgpu::Backends::METAL),
        "dx12" | "d3d12" => AdapterChoice::Backend(wgpu::Backends::DX12),
        _ => AdapterChoice::Name(value.to_owned()),
    }
}

/// What adapter a [`GpuContext`] runs on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterReport {
    /// The adapter's name, e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`.
    pub name: String,
    /// The graphics API wgpu drives it through.
    pub backend: wgpu::Backend,
    /// Discrete, integrated, virtual, CPU or other.
    pub device_type: wgpu::DeviceType,
    /// The driver's name and version information, as reported.
    pub driver: String,
}

impl AdapterReport {
    fn from_info(info: &wgpu::AdapterInfo) -> Self {
        let driver = match (info.driver.trim(), info.driver_info.trim()) {
            (d, "") => d.to_owned(),
            ("", i) => i.to_owned(),
            (d, i) => format!("{d} {i}"),
        };
        AdapterReport { name: info.name.clone(), backend: info.backend, device_type: info.device_type, driver }
    }
}

impl fmt::Display for AdapterReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({}, {:?}", self.name, self.backend, self.device_type)?;
        if !self.driver.is_empty() {
            write!(f, ", driver {}", self.driver)?;
        }
        f.write_str(")")
    }
}

/// An instance honouring `WGPU_BACKEND` (and wgpu's other `WGPU_*` instance variables).
fn instance_from_env() -> wgpu::Instance {
    wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env())
}

fn supports_compute(adapter: &wgpu::Adapter) -> bool {
    adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
        && adapter.limits().max_compute_workgroups_per_dimension > 0
}

/// Lower is better.
fn device_type_rank(device_type: wgpu::DeviceType) -> u8 {
    match device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

/// Whether a compute-capable adapter that is not a CPU implementation (lavapipe, llvmpipe,
/// SwiftShader) exists, among the backends `WGPU_BACKEND` allows. Use it to choose between the
/// GPU and the CPU backend automatically: on a machine with only a software rasterizer the CPU
/// backend is faster.
pub fn hardware_gpu_available() -> bool {
    let adapters = pollster::block_on(instance_from_env().enumerate_adapters(wgpu::Backends::all()));
    adapters.iter().any(|a| supports_compute(a) && a.get_info().device_type != wgpu::DeviceType::Cpu)
}

/// Errors wgpu reported outside any error scope, collected instead of panicking.
type ErrorLog = Arc<Mutex<Vec<String>>>;

/// A wgpu device and queue, with the helpers the GPU stages are built from.
///
/// Every wgpu validation, out-of-memory or internal error becomes an [`Error::Gpu`]: the helpers
/// catch errors in scopes, and errors raised elsewhere (by code using [`GpuContext::device`]
/// directly) are collected and returned by [`GpuContext::check_errors`] (which
/// [`GpuContext::submit`] and [`Readback`] call) instead of panicking.
pub struct GpuContext {
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter: AdapterReport,
    limits: wgpu::Limits,
    downlevel: wgpu::DownlevelCapabilities,
    errors: ErrorLog,
}

impl fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GpuContext").field("adapter", &self.adapter).finish_non_exhaustive()
    }
}

impl GpuContext {
    /// Picks an adapter as `options` say and opens a device on it (blocking).
    ///
    /// The device gets the WebGPU default limits (or the adapter's, where it has less), except
    /// `max_storage_buffer_binding_size`, `max_buffer_size` and the number of storage buffers
    /// per shader stage, which are raised to what the adapter supports so that large meshes fit.
    /// No optional feature is requested, except `TIMESTAMP_QUERY` when [`GpuOptions::profile`] is
    /// set and the adapter has it. Returns [`Error::NoAdapter`] (listing the adapters
    /// that were seen) when nothing matches.
    pub fn new(options: &GpuOptions) -> Result<GpuContext> {
        pollster::block_on(Self::new_async(options))
    }

    async fn new_async(options: &GpuOptions) -> Result<GpuContext> {
        let instance = instance_from_env();
        let adapter = select_adapter(&instance, &options.adapter).await?;
        let report = AdapterReport::from_info(&adapter.get_info());

        let available = adapter.limits();
        let mut limits = wgpu::Limits::default().or_worse_values_from(&available);
        limits.max_storage_buffer_binding_size =
            limits.max_storage_buffer_binding_size.max(available.max_storage_buffer_binding_size);
        limits.max_buffer_size = limits.max_buffer_size.max(available.max_buffer_size);
        limits.max_storage_buffers_per_shader_stage =
            limits.max_storage_buffers_per_shader_stage.max(available.max_storage_buffers_per_shader_stage);
        limits.max_buffers_and_acceleration_structures_per_shader_stage = limits
            .max_buffers_and_acceleration_structures_per_shader_stage
            .max(available.max_buffers_and_acceleration_structures_per_shader_stage);

        let descriptor = wgpu::DeviceDescriptor {
            label: Some("diffsil"),
            required_features: if options.profile {
                adapter.features() & wgpu::Features::TIMESTAMP_QUERY
            } else {
                wgpu::Features::empty()
            },
            required_limits: limits,
            ..Default::default()
        };
        let (device, queue) = adapter
            .request_device(&descriptor)
            .await
            .map_err(|e| Error::Gpu(format!("could not open a device on {report}: {e}")))?;

        let errors = ErrorLog::default();
        let log = Arc::clone(&errors);
        device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
            if let Ok(mut log) = log.lock() {
                log.push(error.to_string());
            }
        }));
        let log = Arc::clone(&errors);
        device.set_device_lost_callback(move |reason, message| {
            // Dropping the device also "loses" it; that is not an error.
            if reason != wgpu::DeviceLostReason::Destroyed {
                if let Ok(mut log) = log.lock() {
                    log.push(format!("device lost ({reason:?}): {message}"));
                }
            }
        });

        let limits = device.limits();
        let downlevel = adapter.get_downlevel_capabilities();
        Ok(GpuContext { device, queue, adapter: report, limits, downlevel, errors })
    }

    /// The adapter this context runs on.
    pub fn adapter(&self) -> &AdapterReport {
        &self.adapter
    }

    /// The wgpu device.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The wgpu queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Whether the device can take dispatch sizes from a buffer (`dispatch_workgroups_indirect`):
    /// every backend but WebGL2 can.
    pub fn supports_indirect_dispatch(&self) -> bool {
        self.downlevel.flags.contains(wgpu::DownlevelFlags::INDIRECT_EXECUTION)
    }

    /// The limits the device was opened with.
    pub fn limits(&self) -> &wgpu::Limits {
        &self.limits
    }

    /// Returns (and clears) the errors wgpu reported outside the helpers' error scopes since the
    /// last call, as one [`Error::Gpu`].
    pub fn check_errors(&self) -> Result<()> {
        let errors = match self.errors.lock() {
            Ok(mut log) => std::mem::take(&mut *log),
            Err(poisoned) => std::mem::take(&mut *poisoned.into_inner()),
        };
        if errors.is_empty() {
            Ok(())
        } else {
            Err(Error::Gpu(errors.join("\n")))
        }
    }

    /// Runs `f` inside validation, out-of-memory and internal error scopes; any error caught
    /// becomes `Error::Gpu("<what>: <wgpu's message>")`.
    ///
    /// Scopes are per thread: errors caused by `f` on another thread are not caught here (they
    /// end up in [`GpuContext::check_errors`]).
    pub fn scoped<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T> {
        let out_of_memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let value = f();
        // Pop in reverse order of pushing; each pop takes effect at once.
        let validation = validation.pop();
        let internal = internal.pop();
        let out_of_memory = out_of_memory.pop();
        let errors: Vec<String> =
            [pollster::block_on(validation), pollster::block_on(internal), pollster::block_on(out_of_memory)]
                .into_iter()
                .flatten()
                .map(|e| e.to_string().trim_end().to_owned())
                .collect();
        if errors.is_empty() {
            Ok(value)
        } else {
            Err(Error::Gpu(format!("{what}: {}", errors.join("\n"))))
        }
    }

    /// Compiles the entry point `entry_point` of the embedded shader `shader` (a path under
    /// `shaders/`, e.g. `"smoke.wgsl"`, with its `//!include`s resolved) into a compute pipeline
    /// with an automatic layout (get its bind group layouts with
    /// `pipeline.get_bind_group_layout(group)`, or use [`GpuContext::bind_buffers`]).
    pub fn compute_pipeline(&self, shader: &str, entry_point: &str) -> Result<wgpu::ComputePipeline> {
        let resolved = super::shader::resolve(super::SHADERS, shader).map_err(|e| Error::Gpu(e.to_string()))?;
        self.create_compute_pipeline(shader, resolved.source, entry_point)
    }

    /// Like [`GpuContext::compute_pipeline`], for WGSL given as text (its `//!include`s are
    /// resolved against the embedded `shaders/`); `label` names it in error messages. Invalid
    /// WGSL or a missing entry point is an [`Error::Gpu`] carrying wgpu's (naga's) message.
    pub fn compute_pipeline_from_wgsl(
        &self,
        label: &str,
        source: &str,
        entry_point: &str,
    ) -> Result<wgpu::ComputePipeline> {
        let resolved =
            super::shader::resolve_source(super::SHADERS, label, source).map_err(|e| Error::Gpu(e.to_string()))?;
        self.create_compute_pipeline(label, resolved.source, entry_point)
    }

    fn create_compute_pipeline(&self, label: &str, source: String, entry_point: &str) -> Result<wgpu::ComputePipeline> {
        self.scoped(&format!("compiling `{label}` entry point `{entry_point}`"), || {
            let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(Cow::Owned(source)),
            });
            self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(&format!("{label}:{entry_point}")),
                layout: None,
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
        })
    }

    /// A bind group for `group` of `pipeline` (automatic layout) binding `buffers[i]`, whole, at
    /// binding `i`. Every binding the shader declares in that group must be given, in order.
    pub fn bind_buffers(
        &self,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        group: u32,
        buffers: &[&wgpu::Buffer],
    ) -> Result<wgpu::BindGroup> {
        self.scoped(&format!("binding buffers for `{label}`"), || {
            let layout = pipeline.get_bind_group_layout(group);
            let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
                .iter()
                .zip(0u32..)
                .map(|(buffer, binding)| wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() })
                .collect();
            self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &layout,
                entries: &entries,
            })
        })
    }

    /// A bind group for `group` of `pipeline` (automatic layout) binding each `(binding, buffer)`
    /// pair, whole. Unlike [`GpuContext::bind_buffers`] the bindings need not be consecutive (an
    /// entry point's automatic layout holds only the bindings it uses).
    pub fn bind_entries(
        &self,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        group: u32,
        entries: &[(u32, &wgpu::Buffer)],
    ) -> Result<wgpu::BindGroup> {
        self.scoped(&format!("binding buffers for `{label}`"), || {
            let layout = pipeline.get_bind_group_layout(group);
            let entries: Vec<wgpu::BindGroupEntry<'_>> = entries
                .iter()
                .map(|(binding, buffer)| wgpu::BindGroupEntry {
                    binding: *binding,
                    resource: buffer.as_entire_binding(),
                })
                .collect();
            self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &layout,
                entries: &entries,
            })
        })
    }

    /// A `MAP_READ | COPY_DST` staging buffer of at least `bytes` bytes (rounded up to a multiple
    /// of 4), to copy results into and read them with [`GpuContext::read_staging`].
    pub fn staging_buffer(&self, label: &str, bytes: u64) -> Result<wgpu::Buffer> {
        let size = padded_size(bytes);
        self.check_size("max_buffer_size", size, self.limits.max_buffer_size)?;
        self.create_buffer(label, size, wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST, None)
    }

    /// Maps the first `bytes` bytes (a multiple of 4) of `staging` after all submitted work has
    /// finished, copies them out and unmaps.
    pub fn read_staging(&self, staging: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>> {
        if bytes == 0 {
            return Ok(Vec::new());
        }
        let slice = staging.slice(..bytes);
        let (sender, receiver) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |result| {
            let _ = sender.send(result);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::Gpu(format!("waiting for the GPU: {e}")))?;
        let mapped = receiver.recv().map_err(|_| Error::Gpu("the map callback never ran".into()))?;
        if let Err(e) = mapped {
            self.check_errors()?;
            return Err(Error::Gpu(format!("mapping a staging buffer failed: {e}")));
        }
        let data = slice.get_mapped_range().map(|view| view.to_vec());
        staging.unmap();
        self.check_errors()?;
        data.map_err(|e| Error::Gpu(format!("reading a staging buffer: {e}")))
    }

    fn check_size(&self, limit: &'static str, needed: u64, max: u64) -> Result<()> {
        if needed > max {
            Err(Error::GpuLimit { limit, needed, max })
        } else {
            Ok(())
        }
    }

    fn check_storage_size(&self, bytes: u64) -> Result<()> {
        self.check_size("max_storage_buffer_binding_size", bytes, self.limits.max_storage_buffer_binding_size)?;
        self.check_size("max_buffer_size", bytes, self.limits.max_buffer_size)
    }

    fn create_buffer(
        &self,
        label: &str,
        size: u64,
        usage: wgpu::BufferUsages,
        data: Option<&[u8]>,
    ) -> Result<wgpu::Buffer> {
        let buffer = self.scoped(&format!("creating buffer `{label}` ({size} bytes)"), || {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: data.is_some(),
            })
        })?;
        if let Some(data) = data {
            let mut view = buffer
                .get_mapped_range_mut(..)
                .map_err(|e| Error::Gpu(format!("initialising buffer `{label}`: {e}")))?;
            view.slice(..data.len()).copy_from_slice(data);
            drop(view);
            buffer.unmap();
        }
        Ok(buffer)
    }

    /// A zero-filled storage buffer of at least `bytes` bytes (rounded up to a multiple of 4, at
    /// least 4), usable as `STORAGE | COPY_SRC | COPY_DST`. Checks the device's buffer limits
    /// ([`Error::GpuLimit`]).
    pub fn storage_buffer(&self, label: &str, bytes: u64) -> Result<wgpu::Buffer> {
        let size = padded_size(bytes);
        self.check_storage_size(size)?;
        self.create_buffer(label, size, storage_usage(), None)
    }

    /// A zero-filled `STORAGE | INDIRECT` buffer of at least `bytes` bytes, for dispatch arguments
    /// a shader writes.
    pub fn indirect_buffer(&self, label: &str, bytes: u64) -> Result<wgpu::Buffer> {
        let size = padded_size(bytes);
        self.check_storage_size(size)?;
        self.create_buffer(label, size, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT, None)
    }

    /// A storage buffer holding `data` (padded with zeros to a multiple of 4 bytes, at least 4),
    /// usable as `STORAGE | COPY_SRC | COPY_DST`.
    pub fn storage_buffer_init<T: Pod>(&self, label: &str, data: &[T]) -> Result<wgpu::Buffer> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let size = padded_size(bytes.len() as u64);
        self.check_storage_size(size)?;
        self.create_buffer(label, size, storage_usage(), Some(bytes))
    }

    /// A uniform buffer holding `value` (padded with zeros to a multiple of 16 bytes), usable as
    /// `UNIFORM | COPY_DST` (update it with `queue().write_buffer`).
    pub fn uniform_buffer_init<T: Pod>(&self, label: &str, value: &T) -> Result<wgpu::Buffer> {
        let bytes: &[u8] = bytemuck::bytes_of(value);
        let size = (bytes.len() as u64).div_ceil(16).max(1) * 16;
        self.check_size("max_uniform_buffer_binding_size", size, self.limits.max_uniform_buffer_binding_size)?;
        self.create_buffer(label, size, wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST, Some(bytes))
    }

    /// A command encoder labelled `label`.
    pub fn encoder(&self, label: &str) -> wgpu::CommandEncoder {
        self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) })
    }

    /// Finishes `encoder` and submits it, turning validation errors in the recorded commands
    /// (and any earlier uncaught ones, see [`GpuContext::check_errors`]) into [`Error::Gpu`].
    pub fn submit(&self, encoder: wgpu::CommandEncoder) -> Result<wgpu::SubmissionIndex> {
        self.check_errors()?;
        let index = self.scoped("submitting GPU work", || self.queue.submit([encoder.finish()]))?;
        self.check_errors()?;
        Ok(index)
    }

    /// Records a 1D dispatch of `invocations` invocations of `workgroup_size` each, tiled into a
    /// 2D grid of workgroups when there are more than the device allows per dimension (see
    /// [`workgroup_grid`](super::workgroup_grid) and `shaders/shared/dispatch.wgsl` for the shader side). Returns the
    /// grid dispatched.
    pub fn dispatch_1d(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        invocations: u32,
        workgroup_size: u32,
    ) -> Result<[u32; 3]> {
        dispatch_1d_with_limit(pass, invocations, workgroup_size, self.limits.max_compute_workgroups_per_dimension)
    }
}

/// [`GpuContext::dispatch_1d`] with an explicit per-dimension limit (tests use a small one to
/// exercise the 2D tiling).
pub fn dispatch_1d_with_limit(
    pass: &mut wgpu::ComputePass<'_>,
    invocations: u32,
    workgroup_size: u32,
    max_per_dimension: u32,
) -> Result<[u32; 3]> {
    if workgroup_size == 0 {
        return Err(Error::Gpu("dispatch_1d: the workgroup size must be at least 1".into()));
    }
    let grid = super::workgroup_grid(invocations.div_ceil(workgroup_size), max_per_dimension)?;
    // The shader computes linear indices in u32: the whole grid must fit.
    let total = u64::from(grid[0]) * u64::from(grid[1]) * u64::from(workgroup_size);
    if total > 1 << 32 {
        return Err(Error::GpuLimit { limit: "u32 invocation index", needed: total, max: 1 << 32 });
    }
    if grid[0] > 0 {
        pass.dispatch_workgroups(grid[0], grid[1], grid[2]);
    }
    Ok(grid)
}

fn storage_usage() -> wgpu::BufferUsages {
    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST
}

/// Rounds up to a multiple of `wgpu::COPY_BUFFER_ALIGNMENT` (4), and to at least 4 bytes.
fn padded_size(bytes: u64) -> u64 {
    bytes.div_ceil(wgpu::COPY_BUFFER_ALIGNMENT).max(1) * wgpu::COPY_BUFFER_ALIGNMENT
}

async fn select_adapter(instance: &wgpu::Instance, choice: &AdapterChoice) -> Result<wgpu::Adapter> {
    let adapters = instance.enumerate_adapters(wgpu::Backends::all()).await;
    let seen: Vec<String> = adapters
        .iter()
        .map(|a| {
            let report = AdapterReport::from_info(&a.get_info());
            if supports_compute(a) {
                report.to_string()
            } else {
                format!("{report} [no compute shaders]")
            }
        })
        .collect();
    let matches = |a: &wgpu::Adapter| {
        let info = a.get_info();
        match choice {
            AdapterChoice::Best => true,
            AdapterChoice::Name(name) => info.name.to_lowercase().contains(&name.to_lowercase()),
            AdapterChoice::Backend(backends) => backends.contains(wgpu::Backends::from(info.backend)),
        }
    };
    adapters
        .into_iter()
        .filter(|a| supports_compute(a) && matches(a))
        .enumerate()
        .min_by_key(|(order, a)| (device_type_rank(a.get_info().device_type), *order))
        .map(|(_, a)| a)
        .ok_or_else(|| {
            let backends = match std::env::var("WGPU_BACKEND") {
                Ok(value) => format!(" with WGPU_BACKEND={value:?}"),
                Err(_) => String::new(),
            };
            let seen = if seen.is_empty() { "none".to_owned() } else { seen.join("; ") };
            Error::NoAdapter(format!("wanted {choice}; adapters seen{backends}: {seen}"))
        })
}

/// A reusable `MAP_READ` staging buffer for copying GPU buffers back to the CPU.
///
/// Keep one per output and reuse it across frames: it grows to the largest read and is
/// recreated only then.
#[derive(Debug)]
pub struct Readback {
    label: String,
    staging: Option<wgpu::Buffer>,
}

impl Readback {
    /// An empty readback; `label` names its staging buffer.
    pub fn new(label: &str) -> Self {
        Readback { label: label.to_owned(), staging: None }
    }

    /// Copies the first `count` elements of `source` (which needs `COPY_SRC`) back, waiting for
    /// all previously submitted work.
    pub fn read<T: Pod>(&mut self, ctx: &GpuContext, source: &wgpu::Buffer, count: usize) -> Result<Vec<T>> {
        let encoder = ctx.encoder(&self.label);
        self.submit_and_read(ctx, encoder, source, count)
    }

    /// Appends the copy of the first `count` elements of `source` to `encoder` (which may hold
    /// the compute passes that produce them: one submission for both), submits it, waits, and
    /// returns the elements.
    pub fn submit_and_read<T: Pod>(
        &mut self,
        ctx: &GpuContext,
        mut encoder: wgpu::CommandEncoder,
        source: &wgpu::Buffer,
        count: usize,
    ) -> Result<Vec<T>> {
        let bytes = count
            .checked_mul(std::mem::size_of::<T>())
            .ok_or_else(|| Error::Gpu(format!("readback `{}`: {count} elements overflow", self.label)))?
            as u64;
        if bytes == 0 {
            ctx.submit(encoder)?;
            return Ok(vec![T::zeroed(); count]);
        }
        let size = padded_size(bytes);
        if size > source.size() {
            return Err(Error::Gpu(format!(
                "readback `{}`: {bytes} bytes ({size} with padding) requested from a buffer of {} bytes",
                self.label,
                source.size()
            )));
        }
        let staging = match &self.staging {
            Some(buffer) if buffer.size() >= size => buffer.clone(),
            _ => {
                let buffer = ctx.create_buffer(
                    &self.label,
                    size,
                    wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    None,
                )?;
                self.staging = Some(buffer.clone());
                buffer
            }
        };
        encoder.copy_buffer_to_buffer(source, 0, &staging, 0, size);
        ctx.submit(encoder)?;

        let slice = staging.slice(..size);
        let (sender, receiver) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |result| {
            // The receiver waits below; if it is gone there is nobody to tell.
            let _ = sender.send(result);
        });
        ctx.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::Gpu(format!("readback `{}`: waiting for the GPU: {e}", self.label)))?;
        let mapped = receiver
            .recv()
            .map_err(|_| Error::Gpu(format!("readback `{}`: the map callback never ran", self.label)))?;
        if let Err(e) = mapped {
            ctx.check_errors()?;
            return Err(Error::Gpu(format!("readback `{}`: mapping failed: {e}", self.label)));
        }
        let result = slice.get_mapped_range().map(|view| bytemuck::pod_collect_to_vec(&view[..bytes as usize]));
        staging.unmap();
        ctx.check_errors()?;
        result.map_err(|e| Error::Gpu(format!("readback `{}`: {e}", self.label)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adapter_choice_from_strings() {
        assert_eq!(parse_adapter_choice(""), AdapterChoice::Best);
        assert_eq!(parse_adapter_choice(" Vulkan "), AdapterChoice::Backend(wgpu::Backends::VULKAN));
        assert_eq!(parse_adapter_choice("GL"), AdapterChoice::Backend(wgpu::Backends::GL));
        assert_eq!(parse_adapter_choice("metal"), AdapterChoice::Backend(wgpu::Backends::METAL));
        assert_eq!(parse_adapter_choice("dx12"), AdapterChoice::Backend(wgpu::Backends::DX12));
        assert_eq!(parse_adapter_choice("LLVMpipe"), AdapterChoice::Name("LLVMpipe".into()));
    }

    #[test]
    fn padding() {
        assert_eq!(padded_size(0), 4);
        assert_eq!(padded_size(1), 4);
        assert_eq!(padded_size(4), 4);
        assert_eq!(padded_size(5), 8);
    }

    #[test]
    fn device_type_order() {
        use wgpu::DeviceType::*;
        let mut types = [Cpu, Other, VirtualGpu, IntegratedGpu, DiscreteGpu];
        types.sort_by_key(|t| device_type_rank(*t));
        assert_eq!(types, [DiscreteGpu, IntegratedGpu, VirtualGpu, Other, Cpu]);
    }
}
