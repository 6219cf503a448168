//! The device and queue ([`GpuContext`]), error scopes, pipelines, bind groups, submission and 1D
//! dispatches. Buffer creation is in `alloc.rs`, reading results back in `readback.rs`, adapter
//! selection in `adapter.rs`.

use std::borrow::Cow;
use std::fmt;
use std::sync::{Arc, Mutex};

use super::adapter::{select_adapter, AdapterReport, GpuOptions};
use crate::{Error, Result};

/// Errors wgpu reported outside any error scope, collected instead of panicking.
type ErrorLog = Arc<Mutex<Vec<String>>>;

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
        let adapter = select_adapter(&options.adapter).await?;
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
