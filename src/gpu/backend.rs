//! The GPU backend behind [`crate::Renderer`]: runs the WGSL stages of [`super::stages`] on a
//! [`GpuContext`].
//!
//! - **Created once, reused.** The pipelines are compiled when the backend is created
//!   (`pipelines.rs`). Buffers and bind groups are created for a frame *shape* (topology, number
//!   of views, image sizes, supersampling, 2D or 3D input and, for 3D, the number of input
//!   positions: a batch's instances) and reused for every frame of that shape (`buffers.rs`):
//!   per frame only the frame uniform, the inputs (positions and cameras, or screen
//!   vertices) and `∂L/∂I` are written. Bind groups come from the bindings reflected at build time,
//!   by variable name (`bindings.rs`).
//! - **One submission each.** A forward is one command buffer (all stages, all views, and the
//!   copy of the images and counters to a staging buffer; `forward.rs`), a backward is another
//!   (`edge_grad`, `edge_sum`, `gather`, and the copy of the per-view vertex gradients;
//!   `backward.rs`). Only the images, the vertex gradients and a few counters are read back. Each
//!   submission is recorded buffer by buffer (`record.rs`, [`GpuBackend::last_recording`]).
//! - **Backward work items.** The forward reads back how many candidate edges there are; the
//!   backward runs `edge_grad` on candidates × parts (each part a slab of 4 to 16 pixel lines of
//!   the edge's major axis, as many per candidate as the frame's longest candidate needs, a count
//!   the `edges` stage finds) and `edge_sum` adds the parts of each edge in order.
//! - **Bin capacity.** The number of (triangle, tile) entries is only known on the GPU. The
//!   forward writes at most the current capacity and reports the number needed with the image;
//!   when it did not fit, the buffer grows and the forward runs again (rarely: the capacity is
//!   kept for later frames). Nothing is ever written out of bounds.
//! - **The frame's state stays on the GPU.** The backward needs the forward's screen vertices,
//!   bins and edge sides; they stay in the buffers. A frame remembers the generation of its
//!   forward; if the buffers have since been used by another forward (or by another renderer),
//!   the backward first runs that forward again from the inputs the frame keeps.
//! - **3D backward.** The camera Jacobian is applied on the CPU to the per-view 2D gradients read
//!   back (`Renderer::backward`), the same code as the CPU backend: it is O(V) per view and keeps
//!   the 3D gradient bit-identical between the backends given the same 2D gradients.

use std::sync::atomic::{AtomicU64, Ordering};

use super::buffers::{FrameBuffers, TopologyBuffers};
use super::pipelines::Pipelines;
use super::record::Recording;
use super::{AdapterReport, GpuContext, StageTimer};
use crate::engine::StageTiming;
use crate::mirror::LLVMPIPE_LOOP_BUDGET;
use crate::{Error, Result};

pub(crate) use super::forward::{ForwardMode, ForwardOutput};

static NEXT_BACKEND_ID: AtomicU64 = AtomicU64::new(1);

/// Which forward a frame came from: the backend instance and the generation of its forward.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct GpuFrame {
    pub(super) backend: u64,
    pub(super) generation: u64,
}

/// The GPU backend of a renderer.
pub(crate) struct GpuBackend {
    pub(super) ctx: GpuContext,
    pub(super) id: u64,
    pub(super) pipelines: Pipelines,
    pub(super) topology: Option<TopologyBuffers>,
    pub(super) frame: Option<FrameBuffers>,
    /// Generation of the forward whose state the frame buffers hold (0: none).
    pub(super) generation: u64,
    pub(super) last_generation: u64,
    /// Per-stage timestamps, when profiling (see `super::profile`).
    pub(super) timer: Option<StageTimer>,
    /// The stage timings of the last forward and backward.
    pub(super) timings: Vec<StageTiming>,
    /// What the last submission did.
    pub(super) recording: Recording,
}

impl GpuBackend {
    /// Compiles the pipelines on `ctx`.
    pub fn new(ctx: GpuContext) -> Result<GpuBackend> {
        let pipelines = Pipelines::new(&ctx)?;
        let timer = StageTimer::new(&ctx, 16);
        Ok(GpuBackend {
            timer,
            timings: Vec::new(),
            ctx,
            id: NEXT_BACKEND_ID.fetch_add(1, Ordering::Relaxed),
            pipelines,
            topology: None,
            frame: None,
            generation: 0,
            last_generation: 0,
            recording: Recording::default(),
        })
    }

    /// The adapter.
    pub fn adapter(&self) -> &AdapterReport {
        self.ctx.adapter()
    }

    /// Stage timings of the last forward and backward (empty unless profiling).
    pub fn stage_timings(&self) -> &[StageTiming] {
        &self.timings
    }

    /// What the last submission did, buffer by buffer.
    #[allow(dead_code)] // read by tests
    pub fn last_recording(&self) -> &Recording {
        &self.recording
    }

    /// Whether the adapter is Mesa's llvmpipe (lavapipe), whose shaders end every loop of an
    /// invocation after [`LLVMPIPE_LOOP_LIMIT`](crate::mirror::LLVMPIPE_LOOP_LIMIT) iterations in total.
    pub(super) fn loop_limited(&self) -> bool {
        let adapter = self.ctx.adapter();
        adapter.device_type == wgpu::DeviceType::Cpu && adapter.name.to_lowercase().contains("llvmpipe")
    }

    /// [`Error::GpuLimit`] when an invocation may have hit llvmpipe's loop limit (its results
    /// would be cut short).
    pub(super) fn check_iterations(&self, most: u32) -> Result<()> {
        let max = LLVMPIPE_LOOP_BUDGET;
        if self.loop_limited() && most > max {
            return Err(Error::GpuLimit {
                limit: "loop iterations per shader invocation on llvmpipe (too many triangles in one tile)",
                needed: most as u64,
                max: max as u64,
            });
        }
        Ok(())
    }
}
