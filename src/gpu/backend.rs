//! The GPU backend behind [`crate::Renderer`]: runs the WGSL stages of [`super::stages`] on a
//! [`GpuContext`].
//!
//! - **Created once, reused.** The pipelines are compiled when the backend is created. Buffers
//!   and bind groups are created for a frame *shape* (topology, number of views, image sizes,
//!   supersampling, 2D or 3D input) and reused for every frame of that shape: per frame only the
//!   frame uniform, the inputs (positions and cameras, or screen vertices) and `∂L/∂I` are
//!   written.
//! - **One submission each.** A forward is one command buffer (all stages, all views, and the
//!   copy of the images and counters to a staging buffer), a backward is another (`edge_grad`,
//!   `edge_sum`, `gather`, and the copy of the per-view vertex gradients). Only the images, the
//!   vertex gradients and a few counters are read back.
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
use std::sync::Arc;

use glam::Vec2;

use super::stages::FrameLayout;
use super::{AdapterReport, GpuContext, StageTimer};
use crate::engine::StageTiming;
use crate::engine::{BackwardStats, ViewInput};
use crate::mirror::{
    part_length, status_index, status_len, FrameParams, FrameUniform, GpuView, EDGE_GRAD_ITEMS_PER_WORKGROUP,
    LLVMPIPE_LOOP_BUDGET, LLVMPIPE_LOOP_LIMIT, MAX_VIEWS,
};
use crate::mirror::{EdgeGrad, RasterParams, ViewParams};
use crate::mirror::{
    STATUS_CANDIDATES, STATUS_CANDIDATE_TOTAL, STATUS_CULLED, STATUS_MAX_ITERATIONS, STATUS_NEEDED, STATUS_OVERFLOW,
    STATUS_PARTIALS_SHORT, STATUS_PARTS, STATUS_SEGMENTS, STATUS_VISIBLE,
};
use crate::scene::mesh::Topology;
use crate::{Error, Result};

static NEXT_BACKEND_ID: AtomicU64 = AtomicU64::new(1);

/// What a forward computes and reads back.
#[derive(Clone, Copy)]
pub(crate) enum ForwardMode<'a> {
    /// The images (the loss is computed on the host).
    Images,
    /// Not the images: the squared error against these targets (one per view, row-major, each of
    /// its view's size), whose gradient stays on the GPU, and the backward of that loss in the
    /// same submission (dispatched indirectly from the candidate count the forward finds), read
    /// back with it: one round trip for a whole optimisation step. `id` identifies the targets'
    /// contents: they are uploaded again only when it changes. The backward is left out (see
    /// [`ForwardOutput::backward`]) where the device cannot dispatch indirectly or the partials
    /// buffer is too small.
    Step { id: u64, targets: &'a [&'a [f32]] },
}

impl ForwardMode<'_> {
    fn targets(&self) -> Option<(u64, &[&[f32]])> {
        match *self {
            ForwardMode::Images => None,
            ForwardMode::Step { id, targets } => Some((id, targets)),
        }
    }
}

/// What a forward returns.
pub(crate) struct ForwardOutput {
    /// One image per view, row-major (empty for [`ForwardMode::Step`]).
    pub images: Vec<Vec<f32>>,
    /// Squared error per view (for [`ForwardMode::Step`]; empty otherwise).
    pub losses: Vec<f64>,
    /// For [`ForwardMode::Step`]: `∂L/∂(screen vertex)` per view and the segment counts, when the
    /// backward ran in the same submission (`None`: run [`GpuBackend::backward`] with no image
    /// gradients).
    pub backward: Option<(Vec<Vec<Vec2>>, Vec<BackwardStats>)>,
    /// Culled triangles per view.
    pub culled: Vec<u32>,
    /// Candidate edges per view.
    pub candidates: Vec<u32>,
    /// GPU tile side per view.
    pub tile_sizes: Vec<u32>,
    /// Identifies the GPU state this forward left behind (see [`GpuFrame`]).
    pub frame: GpuFrame,
}

/// What `run_forward` read back.
struct ForwardRead {
    images: Vec<Vec<f32>>,
    losses: Vec<f64>,
    counters: Vec<u32>,
    /// The vertex gradients of all views, for a fused step.
    grads: Option<Vec<Vec2>>,
}

/// Which forward a frame came from: the backend instance and the generation of its forward.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct GpuFrame {
    backend: u64,
    generation: u64,
}

struct Pipelines {
    project: wgpu::ComputePipeline,
    snap: wgpu::ComputePipeline,
    bin_count: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    bin_fill: wgpu::ComputePipeline,
    coverage: wgpu::ComputePipeline,
    resolve: wgpu::ComputePipeline,
    edges: wgpu::ComputePipeline,
    edge_grad: wgpu::ComputePipeline,
    edge_grad_args: wgpu::ComputePipeline,
    edge_sum: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
    loss: wgpu::ComputePipeline,
}

impl Pipelines {
    fn new(ctx: &GpuContext) -> Result<Pipelines> {
        Ok(Pipelines {
            project: ctx.compute_pipeline("project.wgsl", "main")?,
            snap: ctx.compute_pipeline("project.wgsl", "snap_vertices")?,
            bin_count: ctx.compute_pipeline("bin_count.wgsl", "main")?,
            scan: ctx.compute_pipeline("scan.wgsl", "main")?,
            bin_fill: ctx.compute_pipeline("bin_fill.wgsl", "main")?,
            coverage: ctx.compute_pipeline("coverage.wgsl", "main")?,
            resolve: ctx.compute_pipeline("resolve.wgsl", "main")?,
            edges: ctx.compute_pipeline("edges.wgsl", "main")?,
            edge_grad: ctx.compute_pipeline("edge_grad.wgsl", "main")?,
            edge_grad_args: ctx.compute_pipeline("edge_grad.wgsl", "args")?,
            edge_sum: ctx.compute_pipeline("edge_sum.wgsl", "main")?,
            gather: ctx.compute_pipeline("gather.wgsl", "main")?,
            loss: ctx.compute_pipeline("loss.wgsl", "main")?,
        })
    }
}

/// Static per-topology buffers.
struct TopologyBuffers {
    topology: Arc<Topology>,
    triangles: wgpu::Buffer,
    edges: wgpu::Buffer,
    /// Edge → faces CSR: offsets, then lists.
    edge_faces: wgpu::Buffer,
    /// Vertex → edges CSR: offsets, then lists.
    vertex_edges: wgpu::Buffer,
}

impl TopologyBuffers {
    fn new(ctx: &GpuContext, topology: &Arc<Topology>) -> Result<TopologyBuffers> {
        let flat = |rows: &[[u32; 3]]| -> Vec<u32> { rows.iter().flatten().copied().collect() };
        let triangles = ctx.storage_buffer_init("diffsil triangles", &flat(topology.triangles()))?;
        let edges_flat: Vec<u32> = topology.edges().iter().flatten().copied().collect();
        let edges = ctx.storage_buffer_init("diffsil edges", &edges_flat)?;
        let edge_faces = ctx.storage_buffer_init(
            "diffsil edge faces",
            &[topology.edge_face_offsets(), topology.edge_face_list()].concat(),
        )?;
        let vertex_edges = ctx.storage_buffer_init(
            "diffsil vertex edges",
            &[topology.vertex_edge_offsets(), topology.vertex_edge_list()].concat(),
        )?;
        Ok(TopologyBuffers { topology: topology.clone(), triangles, edges, edge_faces, vertex_edges })
    }
}

/// What the frame buffers are sized for.
#[derive(Clone, Debug, PartialEq)]
struct Shape {
    topology: usize,
    sizes: Vec<(u32, u32)>,
    supersample: u32,
    world: bool,
}

struct BindGroups {
    project: Option<wgpu::BindGroup>,
    snap: wgpu::BindGroup,
    bin_count: wgpu::BindGroup,
    scan: wgpu::BindGroup,
    bin_fill: wgpu::BindGroup,
    coverage: wgpu::BindGroup,
    resolve: wgpu::BindGroup,
    edges: wgpu::BindGroup,
    gather: wgpu::BindGroup,
    /// `edge_grad.wgsl`'s `args` (the fused step's indirect dispatch); `None` where the device
    /// cannot dispatch indirectly.
    edge_grad_args: Option<wgpu::BindGroup>,
}

/// The per-part results of `edge_grad` (grown to the candidates × parts of the frame) and the bind
/// groups that use them.
struct Partials {
    _buffer: wgpu::Buffer,
    capacity: u64,
    edge_grad: wgpu::BindGroup,
    edge_sum: wgpu::BindGroup,
}

/// The targets of [`ForwardMode::Step`], the per-tile sums and the `loss` bind group (made on the
/// first loss forward of a frame shape).
struct LossBuffers {
    target: wgpu::Buffer,
    partials: wgpu::Buffer,
    group: wgpu::BindGroup,
    /// Readback of a fused step: per-tile losses, status counters, vertex gradients.
    staging: wgpu::Buffer,
    /// Which targets `target` holds (0: none yet).
    id: u64,
}

/// Per-shape buffers and bind groups.
struct FrameBuffers {
    shape: Shape,
    uniform: Box<FrameUniform>,
    uniform_buffer: wgpu::Buffer,
    cameras: wgpu::Buffer,
    positions: wgpu::Buffer,
    screen: wgpu::Buffer,
    counts: wgpu::Buffer,
    status: wgpu::Buffer,
    image: wgpu::Buffer,
    d_image: wgpu::Buffer,
    grads: wgpu::Buffer,
    staging: wgpu::Buffer,
    groups: BindGroups,
    bins: wgpu::Buffer,
    classes: wgpu::Buffer,
    slots: wgpu::Buffer,
    partials: Option<Partials>,
    loss: Option<LossBuffers>,
    /// Candidate edges of all views in the last forward (the backward's work items are
    /// candidates × parts).
    candidates: u32,
    /// Parts per candidate in the last forward ([`STATUS_PARTS`]).
    parts: u32,
    /// Buffers only the bind groups use (masks), kept with the frame.
    _internal: Vec<wgpu::Buffer>,
    /// The occluder record of every bin list entry (`edge_grad` binds it per partials buffer).
    occluders: wgpu::Buffer,
    /// `edge_grad`'s indirect dispatch arguments in a fused step.
    dispatch: wgpu::Buffer,
}

impl FrameBuffers {
    fn params(&self) -> &FrameParams {
        &self.uniform.params
    }

    fn views(&self) -> &[GpuView] {
        &self.uniform.views[..self.params().view_count as usize]
    }
}

/// Bytes of `count` elements of `size` bytes, at least one element (a binding must hold one).
fn at_least_one(count: u64, size: usize) -> u64 {
    count.max(1) * size as u64
}

/// Fails with [`Error::GpuLimit`] when `n` does not fit the shaders' u32 indices.
fn check_index(n: u64) -> Result<u32> {
    u32::try_from(n).map_err(|_| Error::GpuLimit { limit: "u32 buffer index", needed: n, max: u32::MAX as u64 })
}

/// The GPU backend of a renderer.
pub(crate) struct GpuBackend {
    ctx: GpuContext,
    id: u64,
    pipelines: Pipelines,
    topology: Option<TopologyBuffers>,
    frame: Option<FrameBuffers>,
    /// Generation of the forward whose state the frame buffers hold (0: none).
    generation: u64,
    last_generation: u64,
    /// Per-stage timestamps, when profiling (see `super::profile`).
    timer: Option<StageTimer>,
    /// The stage timings of the last forward and backward.
    timings: Vec<StageTiming>,
}

/// How many workgroups a stage runs.
enum Dispatch<'a> {
    /// `invocations` work items, `per_workgroup` to a workgroup, as a 2D grid when needed
    /// ([`GpuContext::dispatch_1d`]).
    Linear { invocations: u32, per_workgroup: u32 },
    /// This many workgroups, as a 2D grid when needed (one work item per workgroup).
    Workgroups(u32),
    /// The grid in this buffer (written by an earlier stage of the same submission).
    Indirect(&'a wgpu::Buffer),
}

/// Records the stages of one submission: all in one compute pass (wgpu orders the dispatches), or,
/// when profiling, each in a pass of its own with timestamps around it.
#[allow(clippy::large_enum_variant)] // one per submission, on the stack: boxing would allocate
enum StagePasses<'e> {
    Shared(wgpu::ComputePass<'e>),
    Timed { encoder: &'e mut wgpu::CommandEncoder, timer: &'e mut StageTimer },
}

impl<'e> StagePasses<'e> {
    fn new(encoder: &'e mut wgpu::CommandEncoder, timer: Option<&'e mut StageTimer>) -> StagePasses<'e> {
        match timer {
            Some(timer) => StagePasses::Timed { encoder, timer },
            None => {
                StagePasses::Shared(encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("diffsil"),
                    timestamp_writes: None,
                }))
            }
        }
    }

    /// Records stage `label`: `pipeline` with bind group 0 `group`, over `dispatch`.
    fn run(
        &mut self,
        ctx: &GpuContext,
        label: &'static str,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
        dispatch: Dispatch<'_>,
    ) -> Result<()> {
        let record = |pass: &mut wgpu::ComputePass<'_>| -> Result<()> {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, group, &[]);
            match dispatch {
                Dispatch::Linear { invocations, per_workgroup } => {
                    ctx.dispatch_1d(pass, invocations, per_workgroup)?;
                }
                Dispatch::Workgroups(count) => {
                    ctx.dispatch_1d(pass, count, 1)?;
                }
                Dispatch::Indirect(arguments) => pass.dispatch_workgroups_indirect(arguments, 0),
            }
            Ok(())
        };
        match self {
            StagePasses::Shared(pass) => record(pass),
            StagePasses::Timed { encoder, timer } => {
                let timestamp_writes = timer.writes(label);
                record(
                    &mut encoder
                        .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes }),
                )
            }
        }
    }
}

/// 64 invocations per workgroup, one work item each (most stages).
fn per_invocation(invocations: u32) -> Dispatch<'static> {
    Dispatch::Linear { invocations, per_workgroup: 64 }
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

    /// Whether the adapter is Mesa's llvmpipe (lavapipe), whose shaders end every loop of an
    /// invocation after [`LLVMPIPE_LOOP_LIMIT`] iterations in total.
    fn loop_limited(&self) -> bool {
        let adapter = self.ctx.adapter();
        adapter.device_type == wgpu::DeviceType::Cpu && adapter.name.to_lowercase().contains("llvmpipe")
    }

    /// [`Error::GpuLimit`] when an invocation may have hit llvmpipe's loop limit (its results
    /// would be cut short).
    fn check_iterations(&self, most: u32) -> Result<()> {
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

    /// Makes the partials buffer hold candidates × parts entries (growing it and its bind groups).
    fn ensure_partials(&mut self) -> Result<()> {
        let ctx = &self.ctx;
        let topo = self.topology.as_ref().expect("topology uploaded");
        let f = self.frame.as_mut().expect("a forward ran");
        let needed = (f.candidates as u64 * f.parts.max(1) as u64).max(1);
        check_index(needed)?;
        if f.partials.as_ref().is_some_and(|p| p.capacity >= needed) {
            return Ok(());
        }
        f.partials = None;
        let capacity = needed + needed / 4;
        let buffer = ctx.storage_buffer("diffsil edge parts", capacity * 16)?;
        let p = &self.pipelines;
        let u = &f.uniform_buffer;
        let edge_grad = ctx.bind_entries(
            "edge_grad",
            &p.edge_grad,
            0,
            &[
                (0, u),
                (1, &f.screen),
                (2, &f.occluders),
                (3, &topo.edges),
                (4, &f.bins),
                (5, &f.classes),
                (6, &f.d_image),
                (7, &buffer),
                (8, &f.status),
            ],
        )?;
        let edge_sum = ctx.bind_entries(
            "edge_sum",
            &p.edge_sum,
            0,
            &[(0, u), (1, &f.screen), (2, &topo.edges), (3, &f.classes), (4, &buffer), (5, &f.slots), (6, &f.status)],
        )?;
        f.uniform.params.partial_capacity = capacity.min(u32::MAX as u64) as u32;
        f.partials = Some(Partials { _buffer: buffer, capacity, edge_grad, edge_sum });
        Ok(())
    }

    /// Makes the loss buffers exist and hold `targets` (uploaded when `id` changed).
    fn ensure_loss(&mut self, id: u64, targets: &[&[f32]]) -> Result<()> {
        let ctx = &self.ctx;
        let f = self.frame.as_mut().expect("frame buffers built");
        if f.loss.is_none() {
            let params = f.uniform.params;
            let target = ctx.storage_buffer("diffsil targets", params.total_pixels as u64 * 4)?;
            let partials = ctx.storage_buffer("diffsil loss per tile", params.total_tiles as u64 * 4)?;
            let group = ctx.bind_entries(
                "loss",
                &self.pipelines.loss,
                0,
                &[(0, &f.uniform_buffer), (1, &f.image), (2, &target), (3, &f.d_image), (4, &partials)],
            )?;
            let (n, vertices) = (params.view_count as u64, params.vertex_count as u64);
            let staging = ctx.staging_buffer(
                "diffsil step readback",
                params.total_tiles as u64 * 4 + status_len(n as usize) as u64 * 4 + n * vertices * 8,
            )?;
            f.loss = Some(LossBuffers { target, partials, group, staging, id: 0 });
        }
        let loss = f.loss.as_mut().expect("made above");
        if loss.id != id {
            for (view, target) in f.uniform.views.iter().zip(targets) {
                if !target.is_empty() {
                    ctx.queue().write_buffer(&loss.target, view.pixel_offset as u64 * 4, bytemuck::cast_slice(target));
                }
            }
            loss.id = id;
        }
        Ok(())
    }

    fn ensure_topology(&mut self, topology: &Arc<Topology>) -> Result<()> {
        if self.topology.as_ref().is_some_and(|t| Arc::ptr_eq(&t.topology, topology)) {
            return Ok(());
        }
        self.topology = None;
        self.frame = None;
        self.generation = 0;
        self.topology = Some(TopologyBuffers::new(&self.ctx, topology)?);
        Ok(())
    }

    /// Runs the forward of all views in one submission; returns the images and counters.
    pub fn forward(
        &mut self,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: ViewInput<'_>,
        mode: ForwardMode<'_>,
    ) -> Result<ForwardOutput> {
        let n = params.len();
        if n == 0 {
            return Ok(ForwardOutput {
                images: Vec::new(),
                losses: Vec::new(),
                backward: None,
                culled: Vec::new(),
                candidates: Vec::new(),
                tile_sizes: Vec::new(),
                frame: GpuFrame { backend: self.id, generation: 0 },
            });
        }
        if n > MAX_VIEWS {
            return Err(Error::GpuLimit { limit: "views per GPU frame", needed: n as u64, max: MAX_VIEWS as u64 });
        }
        self.ensure_topology(topology)?;
        let shape = Shape {
            topology: Arc::as_ptr(topology) as usize,
            sizes: params.iter().map(|p| (p.width, p.height)).collect(),
            supersample: params[0].supersample,
            world: matches!(input, ViewInput::World { .. }),
        };
        let layout = FrameLayout::new(params, topology.triangles().len());
        if self.frame.as_ref().is_none_or(|f| f.shape != shape) {
            self.frame = None;
            self.generation = 0;
            let triangles = topology.triangles().len() as u64;
            let capacity = (4 * n as u64 * triangles + layout.total_tiles).max(1024);
            self.frame = Some(self.build_frame(shape, &layout, capacity)?);
        }
        loop {
            let frame = self.frame.as_mut().expect("built above");
            // Settings (inside/outside) may change between frames of one shape.
            frame.uniform.views[..n].copy_from_slice(&layout.views);
            if let Some((id, targets)) = mode.targets() {
                self.ensure_loss(id, targets)?;
            }
            if matches!(mode, ForwardMode::Step { .. }) {
                self.ensure_partials()?;
            }
            let read = self.run_forward(input, mode)?;
            let (images, losses, counters) = (read.images, read.losses, read.counters);
            let frame = self.frame.as_ref().expect("built above");
            if counters[STATUS_OVERFLOW] != 0 {
                return Err(Error::GpuLimit { limit: "bin entries (u32)", needed: u64::MAX, max: u32::MAX as u64 });
            }
            let needed = counters[STATUS_NEEDED];
            if needed > frame.params().bin_capacity {
                let capacity = needed as u64 + needed as u64 / 4;
                let shape = frame.shape.clone();
                self.frame = None;
                self.generation = 0;
                self.frame = Some(self.build_frame(shape, &layout, capacity)?);
                continue;
            }
            self.check_iterations(counters[STATUS_MAX_ITERATIONS])?;
            let frame = self.frame.as_mut().expect("built above");
            frame.candidates = counters[STATUS_CANDIDATE_TOTAL];
            frame.parts = counters[STATUS_PARTS];
            self.last_generation += 1;
            self.generation = self.last_generation;
            let per_view = |k: usize| -> Vec<u32> { (0..n).map(|v| counters[status_index(v, k)]).collect() };
            let backward = read.grads.filter(|_| counters[STATUS_PARTIALS_SHORT] == 0).map(|grads| {
                let vertices = topology.vertex_count().max(1);
                let mut per_view: Vec<Vec<Vec2>> = grads.chunks(vertices).map(|c| c.to_vec()).take(n).collect();
                per_view.resize(n, Vec::new());
                let stats = (0..n)
                    .map(|v| BackwardStats {
                        segments: counters[status_index(v, STATUS_SEGMENTS)] as u64,
                        visible_segments: counters[status_index(v, STATUS_VISIBLE)] as u64,
                    })
                    .collect();
                (per_view, stats)
            });
            return Ok(ForwardOutput {
                images,
                losses,
                backward,
                culled: per_view(STATUS_CULLED),
                candidates: per_view(STATUS_CANDIDATES),
                tile_sizes: layout.views.iter().map(|v| v.raster.tile_size).collect(),
                frame: GpuFrame { backend: self.id, generation: self.generation },
            });
        }
    }

    fn build_frame(&self, shape: Shape, layout: &FrameLayout, capacity: u64) -> Result<FrameBuffers> {
        let ctx = &self.ctx;
        let topo = self.topology.as_ref().expect("topology uploaded before the frame");
        let t = &topo.topology;
        let n = layout.views.len() as u64;
        let (vertices, triangles, edges) =
            (t.vertex_count() as u64, t.triangles().len() as u64, t.edges().len() as u64);
        let wpp = layout.views[0].raster.words_per_pixel as u64;
        for count in [n * vertices, n * triangles, n * edges, 3 * triangles, n * (edges + triangles)] {
            check_index(count)?;
        }
        let total_pixels = check_index(layout.total_pixels)?;
        check_index(layout.total_pixels * wpp)?;
        let total_tiles = check_index(layout.total_tiles)?;
        let max_binding = ctx.limits().max_storage_buffer_binding_size / 4;
        let large_lists = n * triangles;
        // The occluder records take 32 bytes per list entry (large lists included).
        let max_records = ctx.limits().max_storage_buffer_binding_size / 32;
        let capacity = capacity
            .min(max_binding.saturating_sub(layout.total_tiles + 1 + large_lists))
            .min(max_records.saturating_sub(large_lists))
            .max(1);
        let bin_capacity = check_index(capacity)?;
        check_index(layout.total_tiles + 1 + capacity + large_lists)?;
        check_index(n * (3 * edges + triangles))?;
        let parts = layout
            .views
            .iter()
            .map(|v| v.raster.width.max(v.raster.height) / part_length(v.raster.tile_size) + 1)
            .max()
            .unwrap_or(1);
        if self.loop_limited() && layout.total_tiles.div_ceil(256) * 2 + 64 > LLVMPIPE_LOOP_LIMIT as u64 {
            return Err(Error::GpuLimit {
                limit: "tiles per frame on llvmpipe (65,535 loop iterations per invocation)",
                needed: layout.total_tiles,
                max: (LLVMPIPE_LOOP_LIMIT as u64 - 64) / 2 * 256,
            });
        }

        let mut uniform: Box<FrameUniform> = bytemuck::zeroed_box();
        uniform.params = FrameParams {
            view_count: n as u32,
            vertex_count: vertices as u32,
            triangle_count: triangles as u32,
            edge_count: edges as u32,
            total_tiles,
            total_pixels,
            bin_capacity,
            bin_list_offset: total_tiles + 1,
            orient_offset: (n * edges) as u32,
            zero: 0,
            large_offset: total_tiles + 1 + bin_capacity,
            parts,
            loop_budget: if self.loop_limited() { LLVMPIPE_LOOP_BUDGET } else { 0 },
            partial_capacity: 0,
            max_workgroups: ctx.limits().max_compute_workgroups_per_dimension,
            pad2: 0,
        };
        uniform.views[..layout.views.len()].copy_from_slice(&layout.views);

        let uniform_buffer = ctx.uniform_buffer_init("diffsil frame", &*uniform)?;
        let (cameras, positions) = if shape.world {
            (
                ctx.storage_buffer("diffsil cameras", at_least_one(n, std::mem::size_of::<ViewParams>()))?,
                ctx.storage_buffer("diffsil positions", at_least_one(vertices, 12))?,
            )
        } else {
            (ctx.storage_buffer("diffsil cameras (unused)", 80)?, ctx.storage_buffer("diffsil positions (unused)", 4)?)
        };
        let screen = ctx.storage_buffer("diffsil screen", at_least_one(n * vertices, 16))?;
        let snapped = ctx.storage_buffer("diffsil snapped", at_least_one(n * vertices, 8))?;
        let counts = ctx.storage_buffer("diffsil tile counts", layout.total_tiles * 4)?;
        let bins = ctx.storage_buffer("diffsil bins", (layout.total_tiles + 1 + capacity + large_lists) * 4)?;
        let occluders = ctx.storage_buffer("diffsil occluder records", (capacity + large_lists) * 32)?;
        let status_buffer = ctx.storage_buffer("diffsil status", status_len(n as usize) as u64 * 4)?;
        let masks = ctx.storage_buffer("diffsil masks", layout.total_pixels * wpp * 4)?;
        let image = ctx.storage_buffer("diffsil image", layout.total_pixels * 4)?;
        let classes = ctx.storage_buffer("diffsil classes", n * (3 * edges + triangles) * 4)?;
        let d_image = ctx.storage_buffer("diffsil image gradient", layout.total_pixels * 4)?;
        let slots =
            ctx.storage_buffer("diffsil edge slots", at_least_one(n * edges, std::mem::size_of::<EdgeGrad>()))?;
        let grads = ctx.storage_buffer("diffsil vertex gradients", at_least_one(n * vertices, 8))?;
        let status_bytes = status_len(n as usize) as u64 * 4;
        let dispatch = ctx.indirect_buffer("diffsil edge_grad dispatch", 12)?;
        let staging =
            ctx.staging_buffer("diffsil readback", (layout.total_pixels * 4).max(n * vertices * 8) + status_bytes)?;

        let p = &self.pipelines;
        let u = &uniform_buffer;
        let groups = BindGroups {
            project: if shape.world {
                Some(ctx.bind_entries(
                    "project",
                    &p.project,
                    0,
                    &[(0, u), (1, &cameras), (2, &positions), (3, &screen), (4, &snapped)],
                )?)
            } else {
                None
            },
            snap: ctx.bind_entries("snap", &p.snap, 0, &[(0, u), (3, &screen), (4, &snapped)])?,
            bin_count: ctx.bind_entries(
                "bin_count",
                &p.bin_count,
                0,
                &[
                    (0, u),
                    (1, &screen),
                    (2, &topo.triangles),
                    (3, &counts),
                    (4, &status_buffer),
                    (5, &bins),
                    (6, &classes),
                    (7, &occluders),
                    (8, &snapped),
                ],
            )?,
            scan: ctx.bind_entries("scan", &p.scan, 0, &[(0, u), (1, &counts), (2, &bins), (3, &status_buffer)])?,
            bin_fill: ctx.bind_entries(
                "bin_fill",
                &p.bin_fill,
                0,
                &[
                    (0, u),
                    (1, &screen),
                    (2, &topo.triangles),
                    (3, &counts),
                    (5, &bins),
                    (6, &classes),
                    (7, &occluders),
                    (8, &snapped),
                ],
            )?,
            coverage: ctx.bind_entries(
                "coverage",
                &p.coverage,
                0,
                &[(0, u), (2, &topo.triangles), (3, &bins), (4, &masks), (5, &status_buffer), (6, &snapped)],
            )?,
            resolve: ctx.bind_entries("resolve", &p.resolve, 0, &[(0, u), (1, &masks), (2, &image)])?,
            edges: ctx.bind_entries(
                "edges",
                &p.edges,
                0,
                &[
                    (0, u),
                    (1, &screen),
                    (2, &topo.triangles),
                    (3, &topo.edges),
                    (4, &topo.edge_faces),
                    (5, &classes),
                    (6, &status_buffer),
                ],
            )?,
            edge_grad_args: if ctx.supports_indirect_dispatch() {
                Some(ctx.bind_entries(
                    "edge_grad args",
                    &p.edge_grad_args,
                    0,
                    &[(0, u), (8, &status_buffer), (9, &dispatch)],
                )?)
            } else {
                None
            },
            gather: ctx.bind_entries(
                "gather",
                &p.gather,
                0,
                &[(0, u), (1, &topo.edges), (2, &topo.vertex_edges), (3, &slots), (4, &grads)],
            )?,
        };
        Ok(FrameBuffers {
            shape,
            uniform,
            uniform_buffer,
            cameras,
            positions,
            screen,
            counts,
            status: status_buffer,
            image,
            d_image,
            grads,
            staging,
            groups,
            bins,
            classes,
            slots,
            partials: None,
            loss: None,
            candidates: 0,
            parts: 0,
            _internal: vec![masks, snapped],
            dispatch,
            occluders,
        })
    }

    /// Uploads the inputs, records and submits the forward (and, for [`ForwardMode::Step`], the
    /// backward), and reads back the status counters and the images or the per-view losses (and
    /// the vertex gradients).
    fn run_forward(&mut self, input: ViewInput<'_>, mode: ForwardMode<'_>) -> Result<ForwardRead> {
        let started = std::time::Instant::now();
        let ctx = &self.ctx;
        let queue = ctx.queue();
        let f = self.frame.as_ref().expect("frame buffers built");
        let params = *f.params();
        let (n, vertices) = (params.view_count as u64, params.vertex_count as u64);
        let uniform_bytes = bytemuck::bytes_of(&*f.uniform);
        queue.write_buffer(
            &f.uniform_buffer,
            0,
            &uniform_bytes[..std::mem::size_of::<FrameParams>() + 64 * n as usize],
        );
        match input {
            ViewInput::Screen(screens) => {
                for (v, screen) in screens.iter().enumerate() {
                    if !screen.is_empty() {
                        queue.write_buffer(&f.screen, v as u64 * vertices * 16, bytemuck::cast_slice(screen));
                    }
                }
            }
            ViewInput::World { positions, cameras } => {
                if !positions.is_empty() {
                    queue.write_buffer(&f.positions, 0, bytemuck::cast_slice(positions));
                }
                queue.write_buffer(&f.cameras, 0, bytemuck::cast_slice(cameras));
            }
        }

        let p = &self.pipelines;
        let g = &f.groups;
        // The fused step's `args` bind group, when this forward also runs the backward.
        let fused_args = match mode {
            ForwardMode::Step { .. } if f.loss.is_some() && f.partials.is_some() => g.edge_grad_args.as_ref(),
            _ => None,
        };
        let mut timer = self.timer.take();
        if let Some(t) = &mut timer {
            t.clear();
        }
        let mut encoder = ctx.encoder("diffsil forward");
        encoder.clear_buffer(&f.counts, 0, None);
        encoder.clear_buffer(&f.status, 0, None);
        let per_triangle = check_index(n * params.triangle_count as u64)?;
        let recorded = (|| -> Result<()> {
            let mut passes = StagePasses::new(&mut encoder, timer.as_mut());
            // 3D input is projected and snapped in one stage, screen-space input only snapped.
            let per_vertex = per_invocation(check_index(n * vertices)?);
            match &g.project {
                Some(group) => passes.run(ctx, "project", &p.project, group, per_vertex)?,
                None => passes.run(ctx, "snap", &p.snap, &g.snap, per_vertex)?,
            }
            passes.run(ctx, "bin_count", &p.bin_count, &g.bin_count, per_invocation(per_triangle))?;
            passes.run(ctx, "scan", &p.scan, &g.scan, Dispatch::Workgroups(1))?;
            passes.run(ctx, "bin_fill", &p.bin_fill, &g.bin_fill, per_invocation(per_triangle))?;
            passes.run(ctx, "coverage", &p.coverage, &g.coverage, Dispatch::Workgroups(params.total_tiles))?;
            passes.run(ctx, "resolve", &p.resolve, &g.resolve, per_invocation(params.total_pixels))?;
            let per_edge = per_invocation(check_index(n * params.edge_count as u64)?);
            passes.run(ctx, "edges", &p.edges, &g.edges, per_edge)?;
            if let (Some(_), Some(loss)) = (mode.targets(), &f.loss) {
                passes.run(ctx, "loss", &p.loss, &loss.group, Dispatch::Workgroups(params.total_tiles))?;
            }
            if let (Some(args), Some(partials)) = (fused_args, &f.partials) {
                passes.run(ctx, "edge_grad_args", &p.edge_grad_args, args, Dispatch::Workgroups(1))?;
                self.record_backward(&mut passes, partials, Some(&f.dispatch))?;
            }
            Ok(())
        })();
        if let Some(t) = &timer {
            t.resolve(&mut encoder);
        }
        if let Err(e) = recorded {
            self.timer = timer;
            return Err(e);
        }
        // The staging buffer gets the images (or the per-tile losses), then the status counters
        // (then, fused, the vertex gradients).
        let loss = mode.targets().and(f.loss.as_ref());
        let data_bytes = match loss {
            Some(_) => params.total_tiles as u64 * 4,
            None => params.total_pixels as u64 * 4,
        };
        let status_bytes = status_len(n as usize) as u64 * 4;
        let grad_bytes = if fused_args.is_some() { n * vertices * 8 } else { 0 };
        let staging = match (loss, fused_args) {
            (Some(loss), Some(_)) => &loss.staging,
            _ => &f.staging,
        };
        match loss {
            Some(loss) => encoder.copy_buffer_to_buffer(&loss.partials, 0, staging, 0, data_bytes),
            None => encoder.copy_buffer_to_buffer(&f.image, 0, staging, 0, data_bytes),
        }
        encoder.copy_buffer_to_buffer(&f.status, 0, staging, data_bytes, status_bytes);
        if grad_bytes > 0 {
            encoder.copy_buffer_to_buffer(&f.grads, 0, staging, data_bytes + status_bytes, grad_bytes);
        }
        let recorded_at = started.elapsed();
        let submitted = ctx.submit(encoder);
        let submitted_at = started.elapsed();
        let read = submitted.and_then(|_| ctx.read_staging(staging, data_bytes + status_bytes + grad_bytes));
        let read_at = started.elapsed();
        self.timings = match (&timer, &read) {
            (Some(t), Ok(_)) => {
                // Host time too: recording (uploads included), submitting, waiting for the results.
                let host = |stage, d: std::time::Duration| StageTiming { stage, microseconds: d.as_secs_f64() * 1e6 };
                let mut timings = vec![
                    host("host: record", recorded_at),
                    host("host: submit", submitted_at - recorded_at),
                    host("host: wait and read", read_at - submitted_at),
                ];
                timings.extend(t.read(ctx)?);
                timings
            }
            _ => Vec::new(),
        };
        self.timer = timer;
        let bytes = read?;
        let counters: Vec<u32> =
            bytemuck::pod_collect_to_vec(&bytes[data_bytes as usize..(data_bytes + status_bytes) as usize]);
        let grads: Option<Vec<Vec2>> =
            fused_args.map(|_| bytemuck::pod_collect_to_vec(&bytes[(data_bytes + status_bytes) as usize..]));
        if loss.is_some() {
            let tiles: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes[..data_bytes as usize]);
            let losses = f
                .views()
                .iter()
                .map(|v| {
                    let start = v.tile_offset as usize;
                    tiles[start..start + v.raster.tile_count()].iter().map(|&x| f64::from(x)).sum()
                })
                .collect();
            return Ok(ForwardRead { images: Vec::new(), losses, counters, grads });
        }
        let pixels: &[f32] = bytemuck::cast_slice(&bytes[..data_bytes as usize]);
        let images = f
            .views()
            .iter()
            .map(|v| {
                let start = v.pixel_offset as usize;
                pixels[start..start + v.raster.pixel_count()].to_vec()
            })
            .collect();
        Ok(ForwardRead { images, losses: Vec::new(), counters, grads })
    }

    /// Records `edge_grad` (dispatched from `dispatch`'s arguments when given, else for the
    /// frame's candidates × parts), `edge_sum` and `gather`.
    fn record_backward(
        &self,
        passes: &mut StagePasses<'_>,
        partials: &Partials,
        dispatch: Option<&wgpu::Buffer>,
    ) -> Result<()> {
        let ctx = &self.ctx;
        let p = &self.pipelines;
        let f = self.frame.as_ref().expect("a forward ran");
        let fp = *f.params();
        let (views, vertices) = (fp.view_count as u64, fp.vertex_count as u64);
        let edge_grad = match dispatch {
            Some(arguments) => Dispatch::Indirect(arguments),
            None => Dispatch::Linear {
                invocations: check_index(f.candidates as u64 * f.parts.max(1) as u64)?,
                per_workgroup: EDGE_GRAD_ITEMS_PER_WORKGROUP,
            },
        };
        passes.run(ctx, "edge_grad", &p.edge_grad, &partials.edge_grad, edge_grad)?;
        let per_edge = per_invocation(check_index(views * fp.edge_count as u64)?);
        passes.run(ctx, "edge_sum", &p.edge_sum, &partials.edge_sum, per_edge)?;
        passes.run(ctx, "gather", &p.gather, &f.groups.gather, per_invocation(check_index(views * vertices)?))
    }

    /// The backward of all views in one submission: `∂L/∂I` per view → `∂L/∂(screen vertex)` per
    /// view, with the segment counts. Runs the frame's forward again first when the buffers no
    /// longer hold its state.
    pub fn backward(
        &mut self,
        frame: GpuFrame,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: ViewInput<'_>,
        d_images: Option<&[&[f32]]>,
    ) -> Result<(Vec<Vec<Vec2>>, Vec<BackwardStats>)> {
        let n = params.len();
        if n == 0 {
            return Ok((Vec::new(), Vec::new()));
        }
        let current = frame.backend == self.id && frame.generation != 0 && frame.generation == self.generation;
        if !current {
            if d_images.is_none() {
                return Err(Error::InvalidFrame(
                    "the GPU no longer holds this frame's loss gradient (another forward ran since)".into(),
                ));
            }
            self.forward(topology, params, input, ForwardMode::Images)?;
        }
        self.ensure_partials()?;
        let ctx = &self.ctx;
        let queue = ctx.queue();
        let f = self.frame.as_ref().expect("a forward ran");
        let partials = f.partials.as_ref().expect("ensured above");
        let fp = *f.params();
        // `None`: ∂L/∂I is already on the GPU (written by the `loss` stage).
        for (view, d) in f.views().iter().zip(d_images.unwrap_or_default()) {
            if !d.is_empty() {
                queue.write_buffer(&f.d_image, view.pixel_offset as u64 * 4, bytemuck::cast_slice(d));
            }
        }
        let (views, vertices) = (fp.view_count as u64, fp.vertex_count as u64);
        let mut timer = self.timer.take();
        if let Some(t) = &mut timer {
            t.clear();
        }
        let mut encoder = ctx.encoder("diffsil backward");
        // Clear the backward's counters; the forward's (list lengths, candidates) stay.
        encoder.clear_buffer(&f.status, STATUS_MAX_ITERATIONS as u64 * 4, Some(4));
        for v in 0..n {
            encoder.clear_buffer(&f.status, status_index(v, STATUS_SEGMENTS) as u64 * 4, Some(8));
        }
        let recorded = self.record_backward(&mut StagePasses::new(&mut encoder, timer.as_mut()), partials, None);
        if let Some(t) = &timer {
            t.resolve(&mut encoder);
        }
        if let Err(e) = recorded {
            self.timer = timer;
            return Err(e);
        }
        let grad_bytes = views * vertices * 8;
        let status_bytes = status_len(n) as u64 * 4;
        if grad_bytes > 0 {
            encoder.copy_buffer_to_buffer(&f.grads, 0, &f.staging, 0, grad_bytes);
        }
        encoder.copy_buffer_to_buffer(&f.status, 0, &f.staging, grad_bytes, status_bytes);
        let read = ctx.submit(encoder).and_then(|_| ctx.read_staging(&f.staging, grad_bytes + status_bytes));
        if let (Some(t), Ok(_)) = (&timer, &read) {
            let backward = t.read(ctx)?;
            self.timings.extend(backward);
        }
        self.timer = timer;
        let bytes = read?;
        let grads: &[Vec2] = bytemuck::cast_slice(&bytes[..grad_bytes as usize]);
        let counters: &[u32] = bytemuck::cast_slice(&bytes[grad_bytes as usize..]);
        self.check_iterations(counters[STATUS_MAX_ITERATIONS])?;
        let per_view = grads.chunks(vertices.max(1) as usize).map(|c| c.to_vec());
        let mut out: Vec<Vec<Vec2>> = per_view.take(n).collect();
        out.resize(n, Vec::new());
        let stats = (0..n)
            .map(|v| BackwardStats {
                segments: counters[status_index(v, STATUS_SEGMENTS)] as u64,
                visible_segments: counters[status_index(v, STATUS_VISIBLE)] as u64,
            })
            .collect();
        Ok((out, stats))
    }
}
