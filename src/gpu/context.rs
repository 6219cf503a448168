//! The device and queue ([`GpuContext`]), error scopes, pipelines, bind groups, submission and 1D
//! dispatches. Buffer creation is in `alloc.rs`, reading results back in `readback.rs`, adapter
//! selection in `adapter.rs`.

use std::borrow::Cow;
use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use super::adapter::{select_adapter, AdapterReport, GpuOptions};
use crate::{Error, Result};

/// Errors wgpu reported outside any error scope, collected instead of panicking.
type ErrorLog = Arc<Mutex<Vec<String>>>;

/// Held around the driver calls that NVIDIA's driver was seen to deadlock on when several
/// threads made them at once: opening a device and compiling a pipeline.
///
/// Why: on an NVIDIA H100 (Vulkan, driver 580) the GPU tests on many threads hung (5 of 12 runs
/// on sixteen threads); the backtraces of a hung run showed threads destroying devices
/// (`vkDestroyDevice`), threads creating compute pipelines and a thread's exit all waiting on
/// one lock inside the driver. Devices are no longer destroyed while the process runs
/// ([`IDLE_DEVICES`]), which alone may be the fix (not settled: five runs without this lock
/// passed); this lock keeps the remaining heavy driver calls apart. They run once per context
/// (a dozen pipelines), never per frame.
static DRIVER_CALLS: Mutex<()> = Mutex::new(());

fn driver_calls() -> MutexGuard<'static, ()> {
    DRIVER_CALLS.lock().unwrap_or_else(|e| e.into_inner())
}

/// What a device was opened on and with: a context asking for the same may take it over.
#[derive(Clone, Debug, PartialEq, Eq)]
struct DeviceKey {
    adapter: wgpu::AdapterInfo,
    features: wgpu::Features,
}

/// A device with its error log and its lost flag: newly opened, or that of a dropped
/// [`GpuContext`] waiting in [`IDLE_DEVICES`] for the next context on the same adapter.
struct OpenedDevice {
    key: DeviceKey,
    device: wgpu::Device,
    queue: wgpu::Queue,
    errors: ErrorLog,
    lost: Arc<AtomicBool>,
}

/// The devices of dropped contexts, kept for the process's life and handed to the next
/// [`GpuContext::new`] on the same adapter with the same features, instead of being destroyed.
///
/// Why: destroying devices while other threads compile pipelines deadlocked NVIDIA's driver
/// (see [`DRIVER_CALLS`]). There are never more of them than contexts were open at once; the
/// resources a context made (buffers, pipelines) are freed when they are dropped, as before.
/// A device that was lost is not kept.
static IDLE_DEVICES: Mutex<Vec<OpenedDevice>> = Mutex::new(Vec::new());

/// How long a dropped context waits for its device's queue to finish before handing the device
/// on; a device still busy after that is destroyed instead.
const IDLE_WAIT: std::time::Duration = std::time::Duration::from_secs(10);

/// The idle device opened with `key` that was dropped last, taken out of [`IDLE_DEVICES`], its
/// error log emptied.
fn take_idle_device(key: &DeviceKey) -> Option<OpenedDevice> {
    let mut idle = IDLE_DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    let index = idle.iter().rposition(|d| d.key == *key && !d.lost.load(Ordering::Acquire))?;
    let device = idle.remove(index);
    device.errors.lock().unwrap_or_else(|e| e.into_inner()).clear();
    Some(device)
}

/// Opens a new device on `adapter` with `key`'s features and the limits [`GpuContext::new`]
/// describes, its uncaptured errors collected in its log and its loss flagged.
fn open_device(adapter: &wgpu::Adapter, report: &AdapterReport, key: DeviceKey) -> Result<OpenedDevice> {
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
        required_features: key.features,
        required_limits: limits,
        ..Default::default()
    };
    let (device, queue) = {
        let _driver = driver_calls();
        pollster::block_on(adapter.request_device(&descriptor))
    }
    .map_err(|e| Error::Gpu(format!("could not open a device on {report}: {e}")))?;

    let errors = ErrorLog::default();
    let lost = Arc::new(AtomicBool::new(false));
    let log = Arc::clone(&errors);
    device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
        if let Ok(mut log) = log.lock() {
            log.push(error.to_string());
        }
    }));
    let log = Arc::clone(&errors);
    let lost_flag = Arc::clone(&lost);
    device.set_device_lost_callback(move |reason, message| {
        lost_flag.store(true, Ordering::Release);
        // Destroying the device also "loses" it; that is not an error.
        if reason != wgpu::DeviceLostReason::Destroyed {
            if let Ok(mut log) = log.lock() {
                log.push(format!("device lost ({reason:?}): {message}"));
            }
        }
    });
    Ok(OpenedDevice { key, device, queue, errors, lost })
}

/// A wgpu device and queue, with the helpers the GPU stages are built from.
///
/// Every wgpu validation, out-of-memory or internal error becomes an [`Error::Gpu`]: the helpers
/// catch errors in scopes, and errors raised elsewhere (by code using [`GpuContext::device`]
/// directly) are collected and returned by [`GpuContext::check_errors`] (which
/// [`GpuContext::submit`] and [`Readback`](super::Readback) call) instead of panicking.
pub struct GpuContext {
    pub(super) device: wgpu::Device,
    queue: wgpu::Queue,
    adapter: AdapterReport,
    pub(super) limits: wgpu::Limits,
    downlevel: wgpu::DownlevelCapabilities,
    errors: ErrorLog,
    /// Set by the device-lost callback; a lost device is not kept for reuse.
    lost: Arc<AtomicBool>,
    key: DeviceKey,
}

impl Drop for GpuContext {
    /// Hands the device on to the next context opened on the same adapter instead of destroying
    /// it, once its queue is idle; unless it was lost or destroyed (the wait runs the
    /// device-lost callback of a device that `destroy` was called on) or its work does not
    /// finish within 10 s.
    fn drop(&mut self) {
        let wait = wgpu::PollType::Wait { submission_index: None, timeout: Some(IDLE_WAIT) };
        if self.device.poll(wait).is_err() || self.lost.load(Ordering::Acquire) {
            return;
        }
        let idle = OpenedDevice {
            key: self.key.clone(),
            device: self.device.clone(),
            queue: self.queue.clone(),
            errors: Arc::clone(&self.errors),
            lost: Arc::clone(&self.lost),
        };
        IDLE_DEVICES.lock().unwrap_or_else(|e| e.into_inner()).push(idle);
    }
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
    ///
    /// Devices are not destroyed while the process runs: when a context is dropped its device
    /// waits for the next context opened on the same adapter with the same features, which
    /// takes it over (its limits are the same, computed from the adapter). So a process holds
    /// at most as many devices as it had contexts open at once. (Destroying devices while other
    /// threads compiled pipelines deadlocked NVIDIA's driver.)
    pub fn new(options: &GpuOptions) -> Result<GpuContext> {
        let adapter = pollster::block_on(select_adapter(&options.adapter))?;
        let report = AdapterReport::from_info(&adapter.get_info());
        let features = if options.profile {
            adapter.features() & wgpu::Features::TIMESTAMP_QUERY
        } else {
            wgpu::Features::empty()
        };
        let key = DeviceKey { adapter: adapter.get_info(), features };
        let opened = match take_idle_device(&key) {
            Some(idle) => idle,
            None => open_device(&adapter, &report, key)?,
        };
        let OpenedDevice { key, device, queue, errors, lost } = opened;
        let limits = device.limits();
        let downlevel = adapter.get_downlevel_capabilities();
        Ok(GpuContext { device, queue, adapter: report, limits, downlevel, errors, lost, key })
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
    /// `pipeline.get_bind_group_layout(group)`).
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
            let _driver = driver_calls();
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
    /// (Test plumbing: the engine binds by reflected variable name, see `gpu::bindings`.)
    #[doc(hidden)]
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
    /// entry point's automatic layout holds only the bindings it uses). (Test plumbing: the
    /// engine binds by reflected variable name, see `gpu::bindings`.)
    #[doc(hidden)]
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

/// [`GpuContext::dispatch_1d`] with an explicit per-dimension limit (test plumbing: tests use a
/// small one to exercise the 2D tiling).
#[doc(hidden)]
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
