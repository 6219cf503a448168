//! The GPU engine: the WGSL stages (run by [`GpuBackend`]) behind the [`Engine`] interface.

use std::any::Any;
use std::sync::Arc;

use glam::Vec2;

use super::backend::{ForwardMode, ForwardOutput, GpuBackend, GpuFrame};
use super::{AdapterReport, GpuContext};
use crate::engine::{
    BackwardStats, BatchInput, Engine, FrameRef, FrameState, RenderStats, Rendered, StageTiming, StepOutput, ViewInput,
};
use crate::mirror::{RasterParams, ScreenVertex};
use crate::scene::mesh::Topology;
use crate::{Error, Image, Result};

/// The GPU engine: WGSL compute stages on one wgpu device.
pub(crate) struct GpuEngine {
    backend: GpuBackend,
}

impl GpuEngine {
    /// Compiles the pipelines on `context`.
    pub fn new(context: GpuContext) -> Result<GpuEngine> {
        Ok(GpuEngine { backend: GpuBackend::new(context)? })
    }
}

/// What a GPU forward keeps: which forward left the GPU buffers as they are, and (for screen-space
/// input) the screen vertices, so the forward can run again should the buffers have been reused
/// (for a batch, with its views' vertex offsets).
struct GpuFrameState {
    frame: GpuFrame,
    screens: Vec<Vec<ScreenVertex>>,
    vertex_offsets: Vec<u32>,
}

impl FrameState for GpuFrameState {
    fn as_any(&self) -> &dyn Any {
        self
    }

    fn screen_vertices(&self, view: usize) -> Option<Vec<Vec2>> {
        self.screens.get(view).map(|s| s.iter().map(|v| Vec2::from(v.position)).collect())
    }
}

/// Per-view statistics of a GPU forward.
fn render_stats(out: &ForwardOutput) -> Vec<RenderStats> {
    (0..out.culled.len())
        .map(|k| RenderStats {
            culled_triangles: out.culled[k],
            candidate_edges: out.candidates[k],
            tile_size: out.tile_sizes[k],
            clipped_triangles: 0, // clipping runs before the engine (render/clip.rs)
        })
        .collect()
}

impl Engine for GpuEngine {
    fn describe(&self) -> String {
        format!("gpu: {}", self.backend.adapter())
    }

    fn adapter(&self) -> Option<&AdapterReport> {
        Some(self.backend.adapter())
    }

    fn stage_timings(&self) -> &[StageTiming] {
        self.backend.stage_timings()
    }

    fn forward(&mut self, topology: &Arc<Topology>, params: &[RasterParams], input: ViewInput<'_>) -> Result<Rendered> {
        self.render(topology, params, input, &[])
    }

    fn forward_batch(
        &mut self,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: BatchInput<'_>,
    ) -> Option<Result<Rendered>> {
        let views = ViewInput::World { positions: input.positions, cameras: input.cameras };
        Some(self.render(topology, params, views, input.vertex_offsets))
    }

    fn backward(&mut self, frame: FrameRef<'_>, d_images: &[&[f32]]) -> Result<(Vec<Vec<Vec2>>, Vec<BackwardStats>)> {
        let Some(state) = frame.state.as_any().downcast_ref::<GpuFrameState>() else {
            return Err(Error::InvalidFrame(
                "this frame was rendered by the CPU engine, but this renderer runs on the GPU engine: \
                 differentiate a frame with a renderer on the engine that rendered it"
                    .into(),
            ));
        };
        let input = match frame.world {
            Some((positions, cameras)) => ViewInput::World { positions, cameras },
            None => ViewInput::Screen(&state.screens),
        };
        self.backend.backward(state.frame, frame.topology, frame.params, input, &state.vertex_offsets, Some(d_images))
    }

    fn squared_error_step(
        &mut self,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: ViewInput<'_>,
        targets_id: u64,
        targets: &[Image],
    ) -> Result<StepOutput> {
        let targets: Vec<&Image> = targets.iter().collect();
        self.step(topology, params, input, &[], &[targets_id], &targets)
    }

    fn squared_error_step_batch(
        &mut self,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: BatchInput<'_>,
        targets_ids: &[u64],
        targets: &[&Image],
    ) -> Option<Result<StepOutput>> {
        let views = ViewInput::World { positions: input.positions, cameras: input.cameras };
        Some(self.step(topology, params, views, input.vertex_offsets, targets_ids, targets))
    }
}

impl GpuEngine {
    /// The forward of one mesh (`vertex_offsets` empty) or of a batch, every view in one
    /// submission.
    fn render(
        &mut self,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: ViewInput<'_>,
        vertex_offsets: &[u32],
    ) -> Result<Rendered> {
        let out = self.backend.forward(topology, params, input, vertex_offsets, ForwardMode::Images)?;
        let stats = render_stats(&out);
        let images = params
            .iter()
            .zip(out.images)
            .map(|(p, image)| Image::from_vec(p.width, p.height, image))
            .collect::<Result<Vec<_>>>()?;
        let screens = match input {
            ViewInput::Screen(screens) => screens.to_vec(),
            ViewInput::World { .. } => Vec::new(),
        };
        let state = GpuFrameState { frame: out.frame, screens, vertex_offsets: vertex_offsets.to_vec() };
        Ok(Rendered { images, stats, state: Box::new(state) })
    }

    /// The fused step of one mesh (`vertex_offsets` empty) or of a batch: one submission.
    fn step(
        &mut self,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: ViewInput<'_>,
        vertex_offsets: &[u32],
        targets_ids: &[u64],
        targets: &[&Image],
    ) -> Result<StepOutput> {
        let data: Vec<&[f32]> = targets.iter().map(|i| i.data()).collect();
        let mode = ForwardMode::Step { ids: targets_ids, targets: &data };
        let mut out = self.backend.forward(topology, params, input, vertex_offsets, mode)?;
        let (screen_grads, backward) = match out.backward.take() {
            Some(backward) => backward,
            None => self.backend.backward(out.frame, topology, params, input, vertex_offsets, None)?,
        };
        let stats = render_stats(&out);
        Ok(StepOutput { view_losses: out.losses, screen_grads, stats, backward })
    }
}
