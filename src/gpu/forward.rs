//! The forward of the GPU backend: all views, one submission (the fused step's backward included).

use std::sync::Arc;

use glam::Vec2;

use super::backend::{GpuBackend, GpuFrame};
use super::backward::split_backward;
use super::buffers::{check_index, Shape, TopologyBuffers};
use super::record::{Command, Recording, StagePasses, Work};
use super::stages::{FrameLayout, Stage};
use crate::engine::{BackwardStats, StageTiming, ViewInput};
use crate::mirror::{
    status_index, status_len, RasterParams, MAX_VIEWS, STATUS_CANDIDATES, STATUS_CANDIDATE_TOTAL, STATUS_CULLED,
    STATUS_MAX_ITERATIONS, STATUS_NEEDED, STATUS_OVERFLOW, STATUS_PARTIALS_SHORT, STATUS_PARTS,
};
use crate::scene::mesh::Topology;
use crate::{Error, Result};

/// What a forward computes and reads back.
#[derive(Clone, Copy)]
pub(crate) enum ForwardMode<'a> {
    /// The images (the loss is computed on the host).
    Images,
    /// Not the images: the squared error against these targets (one per view, row-major, each of
    /// its view's size), whose gradient stays on the GPU, and the backward of that loss in the
    /// same submission (dispatched indirectly from the candidate count the forward finds), read
    /// back with it: one round trip for a whole optimisation step. `ids` identifies the targets'
    /// contents (one id per set of targets: one set, or one per instance of a batch): they are
    /// uploaded again only when the ids change. The backward is left out (see
    /// [`ForwardOutput::backward`]) where the device cannot dispatch indirectly or the partials
    /// buffer is too small.
    Step { ids: &'a [u64], targets: &'a [&'a [f32]] },
}

impl ForwardMode<'_> {
    fn targets(&self) -> Option<(&[u64], &[&[f32]])> {
        match *self {
            ForwardMode::Images => None,
            ForwardMode::Step { ids, targets } => Some((ids, targets)),
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

impl GpuBackend {
    /// Runs the forward of all views in one submission; returns the images and counters.
    ///
    /// `vertex_offsets`: for 3D input, per view the first vertex of its instance in the
    /// positions (a batch: every instance's positions back to back); empty for one mesh (all 0).
    pub fn forward(
        &mut self,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: ViewInput<'_>,
        vertex_offsets: &[u32],
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
            return Err(Error::TooManyViews { views: n, max: MAX_VIEWS });
        }
        super::adapter::check_software_size(self.adapter(), params)?;
        self.ensure_topology(topology)?;
        let shape = Shape {
            topology: Arc::as_ptr(topology) as usize,
            sizes: params.iter().map(|p| (p.width, p.height)).collect(),
            supersample: params[0].supersample,
            positions: match input {
                ViewInput::World { positions, .. } => Some(positions.len()),
                ViewInput::Screen(_) => None,
            },
        };
        let mut layout = FrameLayout::new(params, topology.triangles().len());
        for (view, &offset) in layout.views.iter_mut().zip(vertex_offsets) {
            view.vertex_offset = offset;
        }
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
            let mut targets_uploaded = false;
            if let Some((ids, targets)) = mode.targets() {
                targets_uploaded = self.ensure_loss(ids, targets)?;
            }
            if matches!(mode, ForwardMode::Step { .. }) {
                self.ensure_partials()?;
            }
            let read = self.run_forward(input, mode, targets_uploaded)?;
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
            let backward = read
                .grads
                .filter(|_| counters[STATUS_PARTIALS_SHORT] == 0)
                .map(|grads| split_backward(&grads, &counters, n, topology.vertex_count()));
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

    /// Uploads the inputs, records and submits the forward (and, for [`ForwardMode::Step`], the
    /// backward), and reads back the status counters and the images or the per-view losses (and
    /// the vertex gradients). `targets_uploaded`: whether the step's targets were written just now
    /// (for the recording).
    fn run_forward(
        &mut self,
        input: ViewInput<'_>,
        mode: ForwardMode<'_>,
        targets_uploaded: bool,
    ) -> Result<ForwardRead> {
        let started = std::time::Instant::now();
        let ctx = &self.ctx;
        let queue = ctx.queue();
        let f = self.frame.as_ref().expect("frame buffers built");
        let params = *f.params();
        let (n, vertices) = (params.view_count as u64, params.vertex_count as u64);
        let mut recording = Recording::new("forward");
        recording.commands.extend(TopologyBuffers::NAMES.map(Command::Resident));
        let uniform_bytes = bytemuck::bytes_of(&*f.uniform);
        queue.write_buffer(
            &f.uniform_buffer,
            0,
            &uniform_bytes[..std::mem::size_of::<crate::mirror::FrameParams>() + 64 * n as usize],
        );
        recording.commands.push(Command::Upload("frame"));
        match input {
            ViewInput::Screen(screens) => {
                for (v, screen) in screens.iter().enumerate() {
                    if !screen.is_empty() {
                        queue.write_buffer(&f.screen, v as u64 * vertices * 16, bytemuck::cast_slice(screen));
                    }
                }
                recording.commands.push(Command::Upload("screen"));
            }
            ViewInput::World { positions, cameras } => {
                if !positions.is_empty() {
                    queue.write_buffer(&f.positions, 0, bytemuck::cast_slice(positions));
                }
                queue.write_buffer(&f.cameras, 0, bytemuck::cast_slice(cameras));
                recording.commands.push(Command::Upload("positions"));
                recording.commands.push(Command::Upload("cameras"));
            }
        }
        let loss = mode.targets().and(f.loss.as_ref());
        if loss.is_some() {
            recording.commands.push(if targets_uploaded {
                Command::Upload("target_image")
            } else {
                Command::Resident("target_image")
            });
        }

        let p = &self.pipelines;
        // Whether this forward also runs the backward (the fused step).
        let fused = matches!(mode, ForwardMode::Step { .. })
            && f.loss.is_some()
            && f.partials.is_some()
            && f.groups(Stage::EdgeGradArgs).is_some();
        let mut timer = self.timer.take();
        if let Some(t) = &mut timer {
            t.clear();
        }
        let mut encoder = ctx.encoder("diffsil forward");
        encoder.clear_buffer(&f.counts, 0, None);
        encoder.clear_buffer(&f.status, 0, None);
        recording.commands.push(Command::Clear("counts"));
        recording.commands.push(Command::Clear("status"));
        let per_triangle = check_index(n * params.triangle_count as u64)?;
        let recorded = (|| -> Result<()> {
            let mut passes = StagePasses::new(&mut encoder, timer.as_mut(), &mut recording);
            // 3D input is projected and snapped in one stage, screen-space input only snapped.
            let per_vertex = Work::Items(check_index(n * vertices)?);
            match f.groups(Stage::Project) {
                Some(group) => passes.run(ctx, p, Stage::Project, Some(group), per_vertex)?,
                None => passes.run(ctx, p, Stage::Snap, f.groups(Stage::Snap), per_vertex)?,
            }
            passes.run(ctx, p, Stage::BinCount, f.groups(Stage::BinCount), Work::Items(per_triangle))?;
            passes.run(ctx, p, Stage::Scan, f.groups(Stage::Scan), Work::Items(1))?;
            passes.run(ctx, p, Stage::BinFill, f.groups(Stage::BinFill), Work::Items(per_triangle))?;
            passes.run(ctx, p, Stage::Coverage, f.groups(Stage::Coverage), Work::Items(params.total_tiles))?;
            passes.run(ctx, p, Stage::Resolve, f.groups(Stage::Resolve), Work::Items(params.total_pixels))?;
            let per_edge = Work::Items(check_index(n * params.edge_count as u64)?);
            passes.run(ctx, p, Stage::Edges, f.groups(Stage::Edges), per_edge)?;
            if loss.is_some() {
                passes.run(ctx, p, Stage::Loss, f.groups(Stage::Loss), Work::Items(params.total_tiles))?;
            }
            if fused {
                passes.run(ctx, p, Stage::EdgeGradArgs, f.groups(Stage::EdgeGradArgs), Work::Items(1))?;
                self.record_backward(&mut passes, Some(&f.dispatch))?;
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
        let data_bytes = match loss {
            Some(_) => params.total_tiles as u64 * 4,
            None => params.total_pixels as u64 * 4,
        };
        let status_bytes = status_len(n as usize) as u64 * 4;
        let grad_bytes = if fused { n * vertices * 8 } else { 0 };
        let staging = match (loss, fused) {
            (Some(loss), true) => &loss.staging,
            _ => &f.staging,
        };
        match loss {
            Some(loss) => {
                encoder.copy_buffer_to_buffer(&loss.tile_losses, 0, staging, 0, data_bytes);
                recording.commands.push(Command::Copy { from: "tile_losses", to: "staging" });
            }
            None => {
                encoder.copy_buffer_to_buffer(&f.image, 0, staging, 0, data_bytes);
                recording.commands.push(Command::Copy { from: "image", to: "staging" });
            }
        }
        encoder.copy_buffer_to_buffer(&f.status, 0, staging, data_bytes, status_bytes);
        recording.commands.push(Command::Copy { from: "status", to: "staging" });
        if grad_bytes > 0 {
            encoder.copy_buffer_to_buffer(&f.grads, 0, staging, data_bytes + status_bytes, grad_bytes);
            recording.commands.push(Command::Copy { from: "grads", to: "staging" });
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
        self.recording = recording;
        let bytes = read?;
        let counters: Vec<u32> =
            bytemuck::pod_collect_to_vec(&bytes[data_bytes as usize..(data_bytes + status_bytes) as usize]);
        let grads: Option<Vec<Vec2>> =
            fused.then(|| bytemuck::pod_collect_to_vec(&bytes[(data_bytes + status_bytes) as usize..]));
        let f = self.frame.as_ref().expect("frame buffers built");
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
}
