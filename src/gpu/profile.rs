//! Per-stage GPU timings from timestamp queries, for finding where a frame's GPU time goes.
//!
//! Off by default: set `DIFFSIL_GPU_PROFILE=1` (or [`super::GpuOptions::profile`]) and, when the
//! adapter supports `TIMESTAMP_QUERY`, every stage runs in its own compute pass with a timestamp
//! at its start and end; [`crate::Renderer::gpu_stage_timings`] then returns the GPU time of each
//! stage of the last forward and backward. Reading the timestamps back costs one more wait per
//! submission, so leave it off when timing whole iterations.

pub use crate::engine::StageTiming;
use crate::gpu::GpuContext;
use crate::Result;

/// Timestamp queries for up to `capacity` passes per submission.
pub(crate) struct StageTimer {
    query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    staging: wgpu::Buffer,
    labels: Vec<&'static str>,
    capacity: u32,
    period_ns: f64,
}

impl StageTimer {
    /// A timer, or `None` when the device was opened without `TIMESTAMP_QUERY`.
    pub fn new(ctx: &GpuContext, capacity: u32) -> Option<StageTimer> {
        if !ctx.device().features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let device = ctx.device();
        let query_set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("diffsil stage timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2 * capacity,
        });
        let bytes = 2 * capacity as u64 * 8;
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("diffsil timestamps"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("diffsil timestamps readback"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let period_ns = ctx.queue().get_timestamp_period() as f64;
        Some(StageTimer { query_set, resolve, staging, labels: Vec::new(), capacity, period_ns })
    }

    /// Starts a new submission's list of passes.
    pub fn clear(&mut self) {
        self.labels.clear();
    }

    /// Registers pass `label` and returns its timestamp writes (`None` past the capacity).
    pub fn writes(&mut self, label: &'static str) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        let k = self.labels.len() as u32;
        if k >= self.capacity {
            return None;
        }
        self.labels.push(label);
        Some(wgpu::ComputePassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(2 * k),
            end_of_pass_write_index: Some(2 * k + 1),
        })
    }

    /// Records the resolve of this submission's timestamps and their copy to the staging buffer.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        let n = 2 * self.labels.len() as u32;
        if n > 0 {
            encoder.resolve_query_set(&self.query_set, 0..n, &self.resolve, 0);
            encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.staging, 0, n as u64 * 8);
        }
    }

    /// Reads the timings of the submitted passes (waits for the GPU).
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<StageTiming>> {
        let n = 2 * self.labels.len() as u64;
        let bytes = ctx.read_staging(&self.staging, n * 8)?;
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(self
            .labels
            .iter()
            .enumerate()
            .map(|(k, stage)| StageTiming {
                stage,
                microseconds: ticks[2 * k + 1].wrapping_sub(ticks[2 * k]) as f64 * self.period_ns / 1e3,
            })
            .collect())
    }
}
