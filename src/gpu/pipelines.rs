//! The compute pipelines of the stage table, compiled once per engine.

use super::stages::{Stage, STAGES};
use super::GpuContext;
use crate::Result;

/// One compute pipeline per entry of [`STAGES`], in [`Stage`] order.
pub(crate) struct Pipelines {
    pipelines: Vec<wgpu::ComputePipeline>,
}

impl Pipelines {
    /// Compiles every stage's entry point on `ctx`.
    pub fn new(ctx: &GpuContext) -> Result<Pipelines> {
        let pipelines =
            STAGES.iter().map(|s| ctx.compute_pipeline(s.shader, s.entry_point)).collect::<Result<Vec<_>>>()?;
        Ok(Pipelines { pipelines })
    }

    /// The pipeline of `stage`.
    pub fn get(&self, stage: Stage) -> &wgpu::ComputePipeline {
        &self.pipelines[stage as usize]
    }
}
