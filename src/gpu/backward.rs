//! The backward of the GPU backend: `edge_grad`, `edge_sum` and `gather` for all views, one
//! submission (or recorded into the fused step's).

use std::sync::Arc;

use glam::Vec2;

use super::backend::{GpuBackend, GpuFrame};
use super::buffers::{check_index, TopologyBuffers};
use super::record::{Command, Recording, StagePasses, Work};
use super::stages::Stage;
use crate::engine::{BackwardStats, ViewInput};
use crate::mirror::{status_index, status_len, RasterParams, STATUS_MAX_ITERATIONS, STATUS_SEGMENTS, STATUS_VISIBLE};
use crate::scene::mesh::Topology;
use crate::{Error, Result};

impl GpuBackend {
    /// Records `edge_grad` (dispatched from `dispatch`'s arguments when given, else for the
    /// frame's candidates × parts), `edge_sum` and `gather`.
    pub(super) fn record_backward(&self, passes: &mut StagePasses<'_>, dispatch: Option<&wgpu::Buffer>) -> Result<()> {
        let ctx = &self.ctx;
        let p = &self.pipelines;
        let f = self.frame.as_ref().expect("a forward ran");
        let fp = *f.params();
        let (views, vertices) = (fp.view_count as u64, fp.vertex_count as u64);
        let edge_grad = match dispatch {
            Some(arguments) => Work::Indirect("dispatch_args", arguments),
            None => Work::Items(check_index(f.candidates as u64 * f.parts.max(1) as u64)?),
        };
        passes.run(ctx, p, Stage::EdgeGrad, f.groups(Stage::EdgeGrad), edge_grad)?;
        let per_edge = Work::Items(check_index(views * fp.edge_count as u64)?);
        passes.run(ctx, p, Stage::EdgeSum, f.groups(Stage::EdgeSum), per_edge)?;
        passes.run(ctx, p, Stage::Gather, f.groups(Stage::Gather), Work::Items(check_index(views * vertices)?))
    }

    /// The backward of all views in one submission: `∂L/∂I` per view → `∂L/∂(screen vertex)` per
    /// view, with the segment counts. Runs the frame's forward again first (from `input` and
    /// `vertex_offsets`, as [`GpuBackend::forward`] takes them) when the buffers no longer hold
    /// its state.
    pub fn backward(
        &mut self,
        frame: GpuFrame,
        topology: &Arc<Topology>,
        params: &[RasterParams],
        input: ViewInput<'_>,
        vertex_offsets: &[u32],
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
            self.forward(topology, params, input, vertex_offsets, super::backend::ForwardMode::Images)?;
        }
        self.ensure_partials()?;
        let ctx = &self.ctx;
        let queue = ctx.queue();
        let f = self.frame.as_ref().expect("a forward ran");
        let fp = *f.params();
        let mut recording = Recording::new("backward");
        recording.commands.extend(TopologyBuffers::NAMES.map(Command::Resident));
        // What the forward left in the buffers.
        for name in ["frame", "screen", "snapped", "bins", "classes", "occluders", "status"] {
            recording.commands.push(Command::Resident(name));
        }
        // `None`: ∂L/∂I is already on the GPU (written by the `loss` stage).
        for (view, d) in f.views().iter().zip(d_images.unwrap_or_default()) {
            if !d.is_empty() {
                queue.write_buffer(&f.d_image, view.pixel_offset as u64 * 4, bytemuck::cast_slice(d));
            }
        }
        recording.commands.push(match d_images {
            Some(_) => Command::Upload("d_image"),
            None => Command::Resident("d_image"),
        });
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
        recording.commands.push(Command::Clear("status"));
        let recorded = self.record_backward(&mut StagePasses::new(&mut encoder, timer.as_mut(), &mut recording), None);
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
            recording.commands.push(Command::Copy { from: "grads", to: "staging" });
        }
        encoder.copy_buffer_to_buffer(&f.status, 0, &f.staging, grad_bytes, status_bytes);
        recording.commands.push(Command::Copy { from: "status", to: "staging" });
        let read = ctx.submit(encoder).and_then(|_| ctx.read_staging(&f.staging, grad_bytes + status_bytes));
        if let (Some(t), Ok(_)) = (&timer, &read) {
            let backward = t.read(ctx)?;
            self.timings.extend(backward);
        }
        self.timer = timer;
        self.recording = recording;
        let bytes = read?;
        let grads: &[Vec2] = bytemuck::cast_slice(&bytes[..grad_bytes as usize]);
        let counters: &[u32] = bytemuck::cast_slice(&bytes[grad_bytes as usize..]);
        self.check_iterations(counters[STATUS_MAX_ITERATIONS])?;
        Ok(split_backward(grads, counters, n, vertices as usize))
    }
}

/// The read-back of a backward, per view: the vertex gradients of all views (`vertices` each,
/// view after view) cut into one list per view, and each view's segment counters.
pub(super) fn split_backward(
    grads: &[Vec2],
    counters: &[u32],
    n: usize,
    vertices: usize,
) -> (Vec<Vec<Vec2>>, Vec<BackwardStats>) {
    let mut per_view: Vec<Vec<Vec2>> = grads.chunks(vertices.max(1)).map(|c| c.to_vec()).take(n).collect();
    per_view.resize(n, Vec::new());
    let stats = (0..n)
        .map(|v| BackwardStats {
            segments: counters[status_index(v, STATUS_SEGMENTS)] as u64,
            visible_segments: counters[status_index(v, STATUS_VISIBLE)] as u64,
        })
        .collect();
    (per_view, stats)
}
