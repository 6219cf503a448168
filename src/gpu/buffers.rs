//! The buffers of the GPU engine: per topology ([`TopologyBuffers`]) and per frame shape
//! ([`FrameBuffers`]: sizing, the frame uniform, every stage's buffer and bind groups), and the
//! buffers made on demand (`edge_grad`'s partials, the step's loss buffers).

use std::sync::Arc;

use super::backend::GpuBackend;
use super::bindings::{bind_stage, BufferTable, StageGroups};
use super::stages::{FrameLayout, Stage};
use super::GpuContext;
use crate::mirror::{
    part_length, status_len, EdgeGrad, FrameParams, FrameUniform, GpuView, ViewParams, LLVMPIPE_LOOP_BUDGET,
    LLVMPIPE_LOOP_LIMIT,
};
use crate::scene::mesh::Topology;
use crate::{Error, Result};

/// Static per-topology buffers.
pub(super) struct TopologyBuffers {
    pub topology: Arc<Topology>,
    triangles: wgpu::Buffer,
    edges: wgpu::Buffer,
    /// Edge → faces CSR: offsets, then lists.
    edge_faces: wgpu::Buffer,
    /// Vertex → edges CSR: offsets, then lists.
    vertex_edges: wgpu::Buffer,
}

impl TopologyBuffers {
    pub fn new(ctx: &GpuContext, topology: &Arc<Topology>) -> Result<TopologyBuffers> {
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

    /// The names of the buffers uploaded with the topology (resident in every submission).
    pub const NAMES: [&'static str; 4] = ["triangles", "edges", "edge_faces", "vertex_edges"];
}

/// What the frame buffers are sized for.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Shape {
    pub topology: usize,
    pub sizes: Vec<(u32, u32)>,
    pub supersample: u32,
    /// 3D input: the number of input positions (one mesh's vertices, or every instance's of a
    /// batch); `None` for screen-space input.
    pub positions: Option<usize>,
}

/// The per-part results of `edge_grad` (grown to the candidates × parts of the frame).
pub(super) struct Partials {
    buffer: wgpu::Buffer,
    capacity: u64,
}

/// The targets of a step, the per-tile losses, and the readback of a fused step (made on the
/// first step of a frame shape).
pub(super) struct LossBuffers {
    pub target: wgpu::Buffer,
    pub tile_losses: wgpu::Buffer,
    /// Readback of a fused step: per-tile losses, status counters, vertex gradients.
    pub staging: wgpu::Buffer,
    /// Which targets `target` holds (the ids of its sets; empty: none yet).
    pub ids: Vec<u64>,
}

/// Per-shape buffers and bind groups.
pub(super) struct FrameBuffers {
    pub shape: Shape,
    pub uniform: Box<FrameUniform>,
    pub uniform_buffer: wgpu::Buffer,
    pub cameras: wgpu::Buffer,
    pub positions: wgpu::Buffer,
    pub screen: wgpu::Buffer,
    snapped: wgpu::Buffer,
    pub counts: wgpu::Buffer,
    pub status: wgpu::Buffer,
    masks: wgpu::Buffer,
    pub image: wgpu::Buffer,
    pub d_image: wgpu::Buffer,
    pub grads: wgpu::Buffer,
    pub staging: wgpu::Buffer,
    bins: wgpu::Buffer,
    classes: wgpu::Buffer,
    slots: wgpu::Buffer,
    /// The occluder record of every bin list entry.
    occluders: wgpu::Buffer,
    /// `edge_grad`'s indirect dispatch arguments in a fused step.
    pub dispatch: wgpu::Buffer,
    pub partials: Option<Partials>,
    pub loss: Option<LossBuffers>,
    /// Bind groups per stage ([`Stage`] order), made once their buffers exist.
    groups: Vec<Option<StageGroups>>,
    /// Candidate edges of all views in the last forward (the backward's work items are
    /// candidates × parts).
    pub candidates: u32,
    /// Parts per candidate in the last forward ([`crate::mirror::STATUS_PARTS`]).
    pub parts: u32,
}

impl FrameBuffers {
    pub fn params(&self) -> &FrameParams {
        &self.uniform.params
    }

    pub fn views(&self) -> &[GpuView] {
        &self.uniform.views[..self.params().view_count as usize]
    }

    /// The bind groups of `stage`, if made.
    pub fn groups(&self, stage: Stage) -> Option<&StageGroups> {
        self.groups[stage as usize].as_ref()
    }

    /// Every buffer of the frame by its WGSL variable name.
    pub fn table<'a>(&'a self, topo: &'a TopologyBuffers) -> BufferTable<'a> {
        let mut table = BufferTable::default()
            .with("frame", &self.uniform_buffer)
            .with("cameras", &self.cameras)
            .with("positions", &self.positions)
            .with("screen", &self.screen)
            .with("snapped", &self.snapped)
            .with("triangles", &topo.triangles)
            .with("edges", &topo.edges)
            .with("edge_faces", &topo.edge_faces)
            .with("vertex_edges", &topo.vertex_edges)
            .with("counts", &self.counts)
            .with("status", &self.status)
            .with("bins", &self.bins)
            .with("classes", &self.classes)
            .with("occluders", &self.occluders)
            .with("masks", &self.masks)
            .with("image", &self.image)
            .with("d_image", &self.d_image)
            .with("slots", &self.slots)
            .with("grads", &self.grads)
            .with("dispatch_args", &self.dispatch);
        if let Some(partials) = &self.partials {
            table = table.with("partials", &partials.buffer);
        }
        if let Some(loss) = &self.loss {
            table = table.with("target_image", &loss.target).with("tile_losses", &loss.tile_losses);
        }
        table
    }

    /// Makes the bind groups of `stages` from the frame's buffers.
    fn bind(&mut self, backend: &GpuBackend, topo: &TopologyBuffers, stages: &[Stage]) -> Result<()> {
        for &stage in stages {
            let group = bind_stage(&backend.ctx, backend.pipelines.get(stage), stage, &self.table(topo))?;
            self.groups[stage as usize] = Some(group);
        }
        Ok(())
    }
}

/// Bytes of `count` elements of `size` bytes, at least one element (a binding must hold one).
fn at_least_one(count: u64, size: usize) -> u64 {
    count.max(1) * size as u64
}

/// Fails with [`Error::GpuLimit`] when `n` does not fit the shaders' u32 indices.
pub(super) fn check_index(n: u64) -> Result<u32> {
    u32::try_from(n).map_err(|_| Error::GpuLimit { limit: "u32 buffer index", needed: n, max: u32::MAX as u64 })
}

impl GpuBackend {
    /// Makes the partials buffer hold candidates × parts entries (growing it and its bind groups).
    pub(super) fn ensure_partials(&mut self) -> Result<()> {
        let topo = self.topology.take().expect("topology uploaded");
        let mut f = self.frame.take().expect("a forward ran");
        let result = self.grow_partials(&topo, &mut f);
        self.topology = Some(topo);
        self.frame = Some(f);
        result
    }

    fn grow_partials(&self, topo: &TopologyBuffers, f: &mut FrameBuffers) -> Result<()> {
        let needed = (f.candidates as u64 * f.parts.max(1) as u64).max(1);
        check_index(needed)?;
        if f.partials.as_ref().is_some_and(|p| p.capacity >= needed) {
            return Ok(());
        }
        f.partials = None;
        f.groups[Stage::EdgeGrad as usize] = None;
        f.groups[Stage::EdgeSum as usize] = None;
        let capacity = needed + needed / 4;
        let buffer = self.ctx.storage_buffer("diffsil edge parts", capacity * 16)?;
        f.partials = Some(Partials { buffer, capacity });
        f.bind(self, topo, &[Stage::EdgeGrad, Stage::EdgeSum])?;
        f.uniform.params.partial_capacity = capacity.min(u32::MAX as u64) as u32;
        Ok(())
    }

    /// Makes the loss buffers exist and hold `targets` (uploaded when `ids` changed); returns whether
    /// they were uploaded now.
    pub(super) fn ensure_loss(&mut self, ids: &[u64], targets: &[&[f32]]) -> Result<bool> {
        let topo = self.topology.take().expect("topology uploaded");
        let mut f = self.frame.take().expect("frame buffers built");
        let result = self.make_loss(&topo, &mut f, ids, targets);
        self.topology = Some(topo);
        self.frame = Some(f);
        result
    }

    fn make_loss(&self, topo: &TopologyBuffers, f: &mut FrameBuffers, ids: &[u64], targets: &[&[f32]]) -> Result<bool> {
        let ctx = &self.ctx;
        if f.loss.is_none() {
            let params = f.uniform.params;
            let target = ctx.storage_buffer("diffsil targets", params.total_pixels as u64 * 4)?;
            let tile_losses = ctx.storage_buffer("diffsil loss per tile", params.total_tiles as u64 * 4)?;
            let (n, vertices) = (params.view_count as u64, params.vertex_count as u64);
            let staging = ctx.staging_buffer(
                "diffsil step readback",
                params.total_tiles as u64 * 4 + status_len(n as usize) as u64 * 4 + n * vertices * 8,
            )?;
            f.loss = Some(LossBuffers { target, tile_losses, staging, ids: Vec::new() });
            f.bind(self, topo, &[Stage::Loss])?;
        }
        let loss = f.loss.as_mut().expect("made above");
        if loss.ids == ids {
            return Ok(false);
        }
        for (view, target) in f.uniform.views.iter().zip(targets) {
            if !target.is_empty() {
                ctx.queue().write_buffer(&loss.target, view.pixel_offset as u64 * 4, bytemuck::cast_slice(target));
            }
        }
        loss.ids = ids.to_vec();
        Ok(true)
    }

    pub(super) fn ensure_topology(&mut self, topology: &Arc<Topology>) -> Result<()> {
        if self.topology.as_ref().is_some_and(|t| Arc::ptr_eq(&t.topology, topology)) {
            return Ok(());
        }
        self.topology = None;
        self.frame = None;
        self.generation = 0;
        self.topology = Some(TopologyBuffers::new(&self.ctx, topology)?);
        Ok(())
    }

    /// Makes the buffers and bind groups of a frame of `shape` laid out as `layout`, with room for
    /// `capacity` bin entries.
    pub(super) fn build_frame(&self, shape: Shape, layout: &FrameLayout, capacity: u64) -> Result<FrameBuffers> {
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
        // `scan` is one workgroup: each invocation sums a chunk of the tiles.
        let scan = Stage::Scan.info();
        let scan_lanes = super::workgroup_size(scan.shader, scan.entry_point)
            .map(|[x, y, z]| u64::from(x * y * z))
            .ok_or_else(|| Error::Gpu("no reflected workgroup size for `scan.wgsl`".into()))?;
        if self.loop_limited() && layout.total_tiles.div_ceil(scan_lanes) * 2 + 64 > LLVMPIPE_LOOP_LIMIT as u64 {
            return Err(Error::GpuLimit {
                limit: "tiles per frame on llvmpipe (65,535 loop iterations per invocation)",
                needed: layout.total_tiles,
                max: (LLVMPIPE_LOOP_LIMIT as u64 - 64) / 2 * scan_lanes,
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
        let (cameras, positions) = if let Some(positions) = shape.positions {
            check_index(3 * positions as u64)?;
            (
                ctx.storage_buffer("diffsil cameras", at_least_one(n, std::mem::size_of::<ViewParams>()))?,
                ctx.storage_buffer("diffsil positions", at_least_one(positions as u64, 12))?,
            )
        } else {
            (ctx.storage_buffer("diffsil cameras (unused)", 80)?, ctx.storage_buffer("diffsil positions (unused)", 4)?)
        };
        let screen = ctx.storage_buffer("diffsil screen", at_least_one(n * vertices, 16))?;
        let snapped = ctx.storage_buffer("diffsil snapped", at_least_one(n * vertices, 8))?;
        let counts = ctx.storage_buffer("diffsil tile counts", layout.total_tiles * 4)?;
        let bins = ctx.storage_buffer("diffsil bins", (layout.total_tiles + 1 + capacity + large_lists) * 4)?;
        let occluders = ctx.storage_buffer("diffsil occluder records", (capacity + large_lists) * 32)?;
        let status = ctx.storage_buffer("diffsil status", status_len(n as usize) as u64 * 4)?;
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

        let world = shape.positions.is_some();
        let mut frame = FrameBuffers {
            shape,
            uniform,
            uniform_buffer,
            cameras,
            positions,
            screen,
            snapped,
            counts,
            status,
            masks,
            image,
            d_image,
            grads,
            staging,
            bins,
            classes,
            slots,
            occluders,
            dispatch,
            partials: None,
            loss: None,
            groups: Stage::ALL.iter().map(|_| None).collect(),
            candidates: 0,
            parts: 0,
        };
        let mut stages = vec![
            Stage::Snap,
            Stage::BinCount,
            Stage::Scan,
            Stage::BinFill,
            Stage::Coverage,
            Stage::Resolve,
            Stage::Edges,
            Stage::Gather,
        ];
        if world {
            stages.push(Stage::Project);
        }
        // `edge_grad.wgsl`'s `args` (the fused step's indirect dispatch), where the device can
        // dispatch indirectly.
        if ctx.supports_indirect_dispatch() {
            stages.push(Stage::EdgeGradArgs);
        }
        frame.bind(self, topo, &stages)?;
        Ok(frame)
    }
}
