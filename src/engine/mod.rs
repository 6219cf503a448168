//! The interface both engines implement, and the types they share.
//!
//! [`crate::Renderer`] holds one `Box<dyn Engine>`: the CPU engine ([`crate::cpu::CpuEngine`]) or
//! the GPU engine (`gpu::GpuEngine`, with the `gpu` feature). It validates what the user gives
//! (cameras, sizes, finite values), turns it into raster constants and per-view input, and
//! leaves the stages to the engine: the forward, the backward, and the fused optimisation step.
//! Nothing in `render/` knows which engine runs.

mod stats;

use std::any::Any;
use std::sync::Arc;

use glam::{Vec2, Vec3};

pub use stats::{BackwardStats, RenderStats, StageTiming};

use crate::mirror::{RasterParams, ScreenVertex, ViewParams};
use crate::scene::mesh::Topology;
use crate::{loss, Image, Result};

/// The per-view input of a forward, validated by the renderer.
#[derive(Clone, Copy)]
pub(crate) enum ViewInput<'a> {
    /// Screen vertices per view (finite; vertices beyond the coordinate limit marked invalid).
    Screen(&'a [Vec<ScreenVertex>]),
    /// 3D positions (finite) and one camera per view.
    World {
        /// Vertex positions.
        positions: &'a [Vec3],
        /// Per-view projection constants.
        cameras: &'a [ViewParams],
    },
}

/// The 3D input of a batch: instances that share one topology, each with its own vertex
/// positions and views, rendered together (validated by the renderer).
#[derive(Clone, Copy)]
#[cfg_attr(not(feature = "gpu"), allow(dead_code))] // only the GPU engine reads it (the CPU's batches run per instance)
pub(crate) struct BatchInput<'a> {
    /// Every instance's positions, instance after instance (`vertex_count` each).
    pub positions: &'a [Vec3],
    /// Per view, instance after instance: projection constants.
    pub cameras: &'a [ViewParams],
    /// Per view: the first vertex of its instance in `positions`.
    pub vertex_offsets: &'a [u32],
}

/// What an engine keeps of a forward for its backward. Each engine downcasts its own; a frame
/// from the other engine is an [`crate::Error::InvalidFrame`].
pub(crate) trait FrameState: Any + Send + Sync {
    /// The state as `Any`, for the engine's downcast.
    fn as_any(&self) -> &dyn Any;
    /// The projected vertices of `view` when the state holds them (`None`: project on the host).
    fn screen_vertices(&self, view: usize) -> Option<Vec<Vec2>>;
}

/// The result of an engine's forward.
pub(crate) struct Rendered {
    /// One image per view.
    pub images: Vec<Image>,
    /// Per-view statistics.
    pub stats: Vec<RenderStats>,
    /// What the backward needs.
    pub state: Box<dyn FrameState>,
}

/// A frame handed back to its engine for the backward.
#[cfg_attr(not(feature = "gpu"), allow(dead_code))] // the CPU engine keeps all it needs in its state
pub(crate) struct FrameRef<'a> {
    /// The topology the frame was rendered with.
    pub topology: &'a Arc<Topology>,
    /// The raster constants of each view.
    pub params: &'a [RasterParams],
    /// The engine's state.
    pub state: &'a dyn FrameState,
    /// The 3D input of a frame rendered from 3D (an engine may need to run its forward again).
    pub world: Option<(&'a [Vec3], &'a [ViewParams])>,
}

/// The result of a fused step: the loss per view and `∂L/∂(screen vertex)` per view.
pub(crate) struct StepOutput {
    /// Squared error per view.
    pub view_losses: Vec<f64>,
    /// `∂L/∂(screen vertex)` per view.
    pub screen_grads: Vec<Vec<Vec2>>,
    /// Per-view statistics of the forward.
    pub stats: Vec<RenderStats>,
    /// Per-view statistics of the backward.
    pub backward: Vec<BackwardStats>,
}

/// A rendering engine: the stages of the forward and the backward on one kind of hardware.
pub(crate) trait Engine: Send {
    /// A one-line description for logs: `cpu`, or `gpu: <adapter>`.
    fn describe(&self) -> String;

    /// Whether the engine's stages run their loops on rayon's thread pool (the renderer then
    /// calls them from a thread of the pool: `render/pool.rs`).
    fn uses_thread_pool(&self) -> bool {
        false
    }

    /// The GPU adapter, for a GPU engine.
    #[cfg(feature = "gpu")]
    fn adapter(&self) -> Option<&crate::gpu::AdapterReport> {
        None
    }

    /// GPU time of every stage of the last forward and backward (empty unless profiling).
    fn stage_timings(&self) -> &[StageTiming] {
        &[]
    }

    /// Renders every view: `params[k]` and the `k`-th view of `input`.
    fn forward(&mut self, topology: &Arc<Topology>, params: &[RasterParams], input: ViewInput<'_>) -> Result<Rendered>;

    /// `∂L/∂I` per view (row-major, each of its view's size) → `∂L/∂(screen vertex)` per view.
    fn backward(&mut self, frame: FrameRef<'_>, d_images: &[&[f32]]) -> Result<(Vec<Vec<Vec2>>, Vec<BackwardStats>)>;

    /// Forward, squared error against `targets` (one per view; `targets_id` names their contents,
    /// so an engine may keep them) and backward, in one call. The default runs the three in
    /// sequence; the GPU engine runs them in one submission.
    fn squared_error_step(
        &mut self,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: ViewInput<'_>,
        targets_id: u64,
        targets: &[Image],
    ) -> Result<StepOutput> {
        let _ = targets_id;
        let rendered = self.forward(topology, params, input)?;
        let mut view_losses = Vec::with_capacity(targets.len());
        let mut grads = Vec::with_capacity(targets.len());
        for (image, target) in rendered.images.iter().zip(targets) {
            let l2 = loss::squared_error(image, target)?;
            view_losses.push(l2.value);
            grads.push(l2.grad);
        }
        let world = match input {
            ViewInput::World { positions, cameras } => Some((positions, cameras)),
            ViewInput::Screen(_) => None,
        };
        let frame = FrameRef { topology, params, state: rendered.state.as_ref(), world };
        let d: Vec<&[f32]> = grads.iter().map(|g| g.data()).collect();
        let (screen_grads, backward) = self.backward(frame, &d)?;
        Ok(StepOutput { view_losses, screen_grads, stats: rendered.stats, backward })
    }

    /// Renders every view of every instance of a batch in one pass (`params[k]` and the `k`-th
    /// view of `input`), or `None` when the engine has no joint path for batches: the renderer
    /// then runs the instances separately, side by side (the CPU engine, which keeps no state
    /// between calls). The frame's backward is [`Engine::backward`], its `world` input the
    /// batch's positions and cameras.
    fn forward_batch(
        &mut self,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: BatchInput<'_>,
    ) -> Option<Result<Rendered>> {
        let _ = (topology, params, input);
        None
    }

    /// [`Engine::squared_error_step`] for every view of every instance of a batch in one pass
    /// (`targets_ids`: one id per instance, naming its targets), or `None` as for
    /// [`Engine::forward_batch`].
    fn squared_error_step_batch(
        &mut self,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: BatchInput<'_>,
        targets_ids: &[u64],
        targets: &[&Image],
    ) -> Option<Result<StepOutput>> {
        let _ = (topology, params, input, targets_ids, targets);
        None
    }
}
