//! Batches: many instances of one topology (B poses of one body, B people or frames, a population)
//! rendered, compared and differentiated in one call.
//!
//! On the GPU engine a batch is one frame: every view of every instance goes through each stage
//! in one dispatch, all in one submission, the positions of all instances back to back in one
//! buffer (each view reads its instance's from its `vertex_offset`). On the CPU engine the
//! instances run side by side with rayon, each through the engine's ordinary per-call path.
//! Either way the results are those of separate calls.
//!
//! A batch in which some view needs near/far clipping (`render/clip.rs`) is run as one
//! [`Renderer::render`] / [`Renderer::squared_error_step`] call per instance instead: a clipped
//! view has its own topology, so it cannot share the batch's dispatches. The results are the
//! same; only the single submission is lost for that batch.

use std::ops::Range;
use std::sync::Arc;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::views;
use super::{Frame, Renderer, Step, Targets};
use crate::cpu::CpuEngine;
use crate::engine::{BackwardStats, BatchInput, Engine, FrameRef, FrameState, RenderStats, StepOutput, ViewInput};
use crate::mirror::{RasterParams, ViewParams};
use crate::scene::mesh::Topology;
use crate::{Camera, Error, Image, Mesh, Result};

/// One instance of a batch: a mesh and the cameras it is seen from.
///
/// Every instance of a batch shares one topology (the same `Arc`, see [`Mesh::with_topology`]);
/// the number of cameras, and the cameras, may differ from instance to instance.
#[derive(Clone, Copy, Debug)]
pub struct Instance<'a> {
    /// The mesh: the batch's topology, this instance's vertex positions.
    pub mesh: &'a Mesh,
    /// The views of this instance, one image each.
    pub cameras: &'a [Camera],
}

/// What the backward of a batch needs: one state for the whole batch (an engine with a joint
/// batch path), one per instance (instances run separately on the CPU engine), or one frame per
/// instance (a batch with clipped views, rendered by `Renderer::render` instance by instance).
enum BatchState {
    Joint(Box<dyn FrameState>),
    Separate(Vec<Box<dyn FrameState>>),
    Clipped(Vec<Frame>),
}

/// The result of [`Renderer::render_batch`]: every instance's images and what the backward needs.
pub struct BatchFrame {
    images: Vec<Image>,
    stats: Vec<RenderStats>,
    topology: Arc<Topology>,
    params: Vec<RasterParams>,
    /// Every instance's positions, back to back.
    positions: Vec<Vec3>,
    /// Every view's projection constants, instance after instance.
    views: Vec<ViewParams>,
    /// The views of each instance.
    ranges: Vec<Range<usize>>,
    state: BatchState,
}

impl std::fmt::Debug for BatchFrame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BatchFrame")
            .field("instances", &self.ranges.len())
            .field("views", &self.images.len())
            .field("vertices", &self.topology.vertex_count())
            .field("joint", &matches!(self.state, BatchState::Joint(_)))
            .finish_non_exhaustive()
    }
}

impl BatchFrame {
    /// Number of instances.
    pub fn instance_count(&self) -> usize {
        self.ranges.len()
    }

    /// The images of instance `instance`, one per camera in the order given; empty when there is
    /// no such instance.
    pub fn images(&self, instance: usize) -> &[Image] {
        self.ranges.get(instance).map_or(&[], |r| &self.images[r.clone()])
    }

    /// Per-view statistics of instance `instance`; empty when there is no such instance.
    pub fn stats(&self, instance: usize) -> &[RenderStats] {
        self.ranges.get(instance).map_or(&[], |r| &self.stats[r.clone()])
    }

    /// Number of views of all instances together.
    pub fn view_count(&self) -> usize {
        self.images.len()
    }
}

/// The validated input of a batch: raster and projection constants of every view, the positions
/// of every instance back to back, and the views of each instance.
struct Prepared {
    topology: Arc<Topology>,
    params: Vec<RasterParams>,
    views: Vec<ViewParams>,
    positions: Vec<Vec3>,
    offsets: Vec<u32>,
    ranges: Vec<Range<usize>>,
    /// Whether some view of some instance crosses its near or far plane (see the module docs).
    clipped: bool,
}

impl Prepared {
    fn new(renderer: &mut Renderer, instances: &[Instance<'_>]) -> Result<Prepared> {
        let Some(first) = instances.first() else {
            return Err(Error::EmptyBatch);
        };
        let topology = first.mesh.topology().clone();
        let n = topology.vertex_count();
        let mut params = Vec::new();
        let mut views = Vec::new();
        let mut ranges = Vec::with_capacity(instances.len());
        let mut offsets = Vec::new();
        let mut clipped = false;
        for (instance, item) in instances.iter().enumerate() {
            if !Arc::ptr_eq(item.mesh.topology(), &topology) {
                return Err(Error::TopologyMismatch { instance });
            }
            let (v, p) = views::world_views(&renderer.settings, item.cameras)?;
            if !clipped {
                let clips = views::clip_views(&v, item.mesh, &mut renderer.clip_topologies)?;
                clipped = clips.iter().any(Option::is_some);
            }
            let offset = u32::try_from(instance as u64 * n as u64).map_err(|_| Error::GpuLimit {
                limit: "vertices of a batch (u32)",
                needed: instances.len() as u64 * n as u64,
                max: u32::MAX as u64,
            })?;
            ranges.push(views.len()..views.len() + v.len());
            offsets.extend(std::iter::repeat_n(offset, v.len()));
            views.extend(v);
            params.extend(p);
        }
        // All the batch's frames are held at once.
        super::settings::check_frame_memory(&params)?;
        let mut positions = Vec::with_capacity(instances.len() * n);
        for item in instances {
            positions.extend_from_slice(item.mesh.positions());
        }
        Ok(Prepared { topology, params, views, positions, offsets, ranges, clipped })
    }

    fn input(&self) -> BatchInput<'_> {
        BatchInput { positions: &self.positions, cameras: &self.views, vertex_offsets: &self.offsets }
    }

    /// The positions of instance `i`.
    fn instance_positions(&self, i: usize) -> &[Vec3] {
        let n = self.topology.vertex_count();
        &self.positions[i * n..(i + 1) * n]
    }

    /// The 3D input of instance `i` alone.
    fn instance_input(&self, i: usize) -> ViewInput<'_> {
        ViewInput::World { positions: self.instance_positions(i), cameras: &self.views[self.ranges[i].clone()] }
    }
}

/// `∂L/∂(screen vertex)` of the views of instance `range` → `∂L/∂(3D vertex)` of the instance,
/// checked finite: the code [`Renderer::backward`] runs, so the result is the same bits.
fn chain_instance(positions: &[Vec3], views: &[ViewParams], screen: &[Vec<Vec2>], what: &str) -> Result<Vec<Vec3>> {
    let screen: Vec<_> = screen.iter().map(|g| views::ViewGradient::Screen(g)).collect();
    let grads = views::chain_to_3d(what, positions, views, &screen)?;
    Ok(grads)
}

impl Renderer {
    /// Renders a batch: every instance from each of its cameras, in one call. The images equal
    /// those of a [`Renderer::render`] call per instance, bit for bit.
    ///
    /// On the GPU engine the whole batch is one submission, every view of every instance in
    /// every dispatch (at most [`crate::mirror::MAX_VIEWS`] views in all, else
    /// [`Error::TooManyViews`]); the buffers are made for the first batch of a shape (topology,
    /// instance count, image sizes) and reused for the next. On the CPU engine the instances run
    /// side by side.
    ///
    /// Errors: no instance ([`Error::EmptyBatch`]), an instance whose mesh does not share the
    /// first one's topology `Arc` ([`Error::TopologyMismatch`]: the check is
    /// [`Arc::ptr_eq`], make the meshes with [`Mesh::with_topology`]), and whatever
    /// [`Renderer::render`] rejects for an instance.
    pub fn render_batch(&mut self, instances: &[Instance<'_>]) -> Result<BatchFrame> {
        self.on_pool(|r| r.render_batch_impl(instances))
    }

    /// [`Renderer::render_batch`] on the calling thread.
    fn render_batch_impl(&mut self, instances: &[Instance<'_>]) -> Result<BatchFrame> {
        let batch = Prepared::new(self, instances)?;
        let (images, stats, state) = if batch.clipped {
            let frames = instances.iter().map(|i| self.render(i.mesh, i.cameras)).collect::<Result<Vec<_>>>()?;
            let images = frames.iter().flat_map(|f| f.images().iter().cloned()).collect();
            let stats = frames.iter().flat_map(|f| f.stats().iter().copied()).collect();
            (images, stats, BatchState::Clipped(frames))
        } else {
            match self.engine.forward_batch(&batch.topology, &batch.params, batch.input()) {
                Some(rendered) => {
                    let rendered = rendered?;
                    (rendered.images, rendered.stats, BatchState::Joint(rendered.state))
                }
                None => {
                    let rendered = (0..instances.len())
                        .into_par_iter()
                        .map(|i| {
                            CpuEngine::default().forward(
                                &batch.topology,
                                &batch.params[batch.ranges[i].clone()],
                                batch.instance_input(i),
                            )
                        })
                        .collect::<Result<Vec<_>>>()?;
                    let (mut images, mut stats, mut states) = (Vec::new(), Vec::new(), Vec::new());
                    for r in rendered {
                        images.extend(r.images);
                        stats.extend(r.stats);
                        states.push(r.state);
                    }
                    (images, stats, BatchState::Separate(states))
                }
            }
        };
        Ok(BatchFrame {
            images,
            stats,
            topology: batch.topology,
            params: batch.params,
            positions: batch.positions,
            views: batch.views,
            ranges: batch.ranges,
            state,
        })
    }

    /// The backward of a batch: `∂L/∂I` per view of each instance (`d_images[i]`: one image per
    /// camera of instance `i`) → `∂L/∂(3D vertex)` per instance, summed over its views. Equals a
    /// [`Renderer::backward`] call per instance; [`Renderer::last_backward_stats`] then holds
    /// every view's counts, instance after instance.
    ///
    /// Errors: a gradient count other than the instance count ([`Error::LengthMismatch`]) or
    /// than an instance's view count ([`Error::ViewCountMismatch`]), a gradient of another size
    /// than its view ([`Error::SizeMismatch`]) or with a non-finite value, and a frame rendered
    /// by the other engine ([`Error::InvalidFrame`]).
    pub fn backward_batch(&mut self, frame: &BatchFrame, d_images: &[Vec<Image>]) -> Result<Vec<Vec<Vec3>>> {
        self.on_pool(|r| r.backward_batch_impl(frame, d_images))
    }

    /// [`Renderer::backward_batch`] on the calling thread.
    fn backward_batch_impl(&mut self, frame: &BatchFrame, d_images: &[Vec<Image>]) -> Result<Vec<Vec<Vec3>>> {
        if d_images.len() != frame.instance_count() {
            return Err(Error::LengthMismatch {
                what: "image gradients of a batch (one list per instance)",
                expected: frame.instance_count(),
                got: d_images.len(),
            });
        }
        for (range, d) in frame.ranges.iter().zip(d_images) {
            if d.len() != range.len() {
                return Err(Error::ViewCountMismatch { what: "image gradients", views: range.len(), got: d.len() });
            }
            for (image, d_image) in frame.images[range.clone()].iter().zip(d) {
                d_image.expect_size("image gradient", image.width(), image.height())?;
                if let Some(p) = d_image.data().iter().position(|g| !g.is_finite()) {
                    return Err(Error::InvalidSettings(format!("image gradient has a non-finite value at pixel {p}")));
                }
            }
        }
        self.last_backward.clear();
        if let BatchState::Clipped(frames) = &frame.state {
            let mut grads = Vec::with_capacity(frames.len());
            let mut stats = Vec::new();
            for (f, d) in frames.iter().zip(d_images) {
                grads.push(self.backward(f, d)?);
                stats.extend_from_slice(self.last_backward_stats());
            }
            self.last_backward = stats;
            return Ok(grads);
        }
        let n = frame.topology.vertex_count();
        let positions = |i: usize| &frame.positions[i * n..(i + 1) * n];
        let (screen, stats): (Vec<Vec<Vec<Vec2>>>, Vec<BackwardStats>) = match &frame.state {
            BatchState::Joint(state) => {
                let d: Vec<&[f32]> = d_images.iter().flatten().map(|i| i.data()).collect();
                let world = Some((frame.positions.as_slice(), frame.views.as_slice()));
                let frame_ref =
                    FrameRef { topology: &frame.topology, params: &frame.params, state: state.as_ref(), world };
                let (mut grads, stats) = self.engine.backward(frame_ref, &d)?;
                let mut per_instance = Vec::with_capacity(frame.ranges.len());
                for range in frame.ranges.iter().rev() {
                    per_instance.push(grads.split_off(range.start));
                }
                per_instance.reverse();
                (per_instance, stats)
            }
            // Handled above, before any engine state is touched.
            BatchState::Clipped(_) => (Vec::new(), Vec::new()),
            BatchState::Separate(states) => {
                if self.is_gpu() {
                    return Err(Error::InvalidFrame(
                        "this batch was rendered by the CPU engine, but this renderer runs on the GPU engine: \
                         differentiate a batch with a renderer on the engine that rendered it"
                            .into(),
                    ));
                }
                let out = (0..states.len())
                    .into_par_iter()
                    .map(|i| {
                        let range = frame.ranges[i].clone();
                        let world = Some((positions(i), &frame.views[range.clone()]));
                        let frame_ref = FrameRef {
                            topology: &frame.topology,
                            params: &frame.params[range],
                            state: states[i].as_ref(),
                            world,
                        };
                        let d: Vec<&[f32]> = d_images[i].iter().map(|i| i.data()).collect();
                        CpuEngine::default().backward(frame_ref, &d)
                    })
                    .collect::<Result<Vec<_>>>()?;
                let mut stats = Vec::new();
                let grads = out
                    .into_iter()
                    .map(|(g, s)| {
                        stats.extend(s);
                        g
                    })
                    .collect();
                (grads, stats)
            }
        };
        self.last_backward = stats;
        screen
            .par_iter()
            .enumerate()
            .map(|(i, g)| {
                for (k, view) in g.iter().enumerate() {
                    let global = frame.ranges[i].start + k;
                    views::check_finite_gradients("backward_batch", Some(global), view, |g: Vec2| g.is_finite())?;
                }
                chain_instance(positions(i), &frame.views[frame.ranges[i].clone()], g, "backward_batch")
            })
            .collect()
    }

    /// [`Renderer::squared_error_step`] for every instance of a batch in one call: `targets[i]`
    /// holds one target per camera of instance `i` (the same [`Targets`] may serve several
    /// instances). Returns one [`Step`] per instance, equal to a `squared_error_step` call per
    /// instance (see there for the GPU's loss sums).
    ///
    /// On the GPU engine the forward, the loss and the backward of the whole batch are one
    /// submission, and only the vertex gradients and per-tile losses come back; the targets stay
    /// on the device while the same ones come again. [`Renderer::last_backward_stats`] holds every
    /// view's counts, instance after instance.
    ///
    /// Errors: those of [`Renderer::render_batch`], a target count other than the instance
    /// count ([`Error::LengthMismatch`]) or than an instance's camera count
    /// ([`Error::ViewCountMismatch`]), and a target of another size than its camera's image
    /// ([`Error::SizeMismatch`]).
    pub fn squared_error_step_batch(&mut self, instances: &[Instance<'_>], targets: &[&Targets]) -> Result<Vec<Step>> {
        self.on_pool(|r| r.squared_error_step_batch_impl(instances, targets))
    }

    /// [`Renderer::squared_error_step_batch`] on the calling thread.
    fn squared_error_step_batch_impl(&mut self, instances: &[Instance<'_>], targets: &[&Targets]) -> Result<Vec<Step>> {
        if targets.len() != instances.len() {
            return Err(Error::LengthMismatch {
                what: "targets of a batch (one set per instance)",
                expected: instances.len(),
                got: targets.len(),
            });
        }
        for (instance, t) in instances.iter().zip(targets) {
            if t.images.len() != instance.cameras.len() {
                return Err(Error::ViewCountMismatch {
                    what: "targets",
                    views: instance.cameras.len(),
                    got: t.images.len(),
                });
            }
            for (camera, target) in instance.cameras.iter().zip(&t.images) {
                target.expect_size("target", camera.width, camera.height)?;
            }
        }
        let batch = Prepared::new(self, instances)?;
        if batch.clipped {
            let mut steps = Vec::with_capacity(instances.len());
            let mut stats = Vec::new();
            for (instance, t) in instances.iter().zip(targets) {
                steps.push(self.squared_error_step(instance.mesh, instance.cameras, t)?);
                stats.extend_from_slice(self.last_backward_stats());
            }
            self.last_backward = stats;
            return Ok(steps);
        }
        let flat: Vec<&Image> = targets.iter().flat_map(|t| t.images.iter()).collect();
        let ids: Vec<u64> = targets.iter().map(|t| t.id).collect();
        let step = self.engine.squared_error_step_batch(&batch.topology, &batch.params, batch.input(), &ids, &flat);
        let outputs: Vec<StepOutput> = match step {
            Some(out) => {
                let mut out = out?;
                let mut per_instance = Vec::with_capacity(batch.ranges.len());
                for range in batch.ranges.iter().rev() {
                    per_instance.push(StepOutput {
                        view_losses: out.view_losses.split_off(range.start),
                        screen_grads: out.screen_grads.split_off(range.start),
                        stats: out.stats.split_off(range.start),
                        backward: out.backward.split_off(range.start),
                    });
                }
                per_instance.reverse();
                per_instance
            }
            None => (0..instances.len())
                .into_par_iter()
                .map(|i| {
                    let range = batch.ranges[i].clone();
                    let (id, images) = (targets[i].id, &targets[i].images);
                    CpuEngine::default().squared_error_step(
                        &batch.topology,
                        &batch.params[range],
                        batch.instance_input(i),
                        id,
                        images,
                    )
                })
                .collect::<Result<Vec<_>>>()?,
        };
        self.last_backward = outputs.iter().flat_map(|o| o.backward.iter().copied()).collect();
        outputs
            .into_par_iter()
            .enumerate()
            .map(|(i, out)| {
                let range = batch.ranges[i].clone();
                let gradient = chain_instance(
                    batch.instance_positions(i),
                    &batch.views[range],
                    &out.screen_grads,
                    "squared_error_step",
                )?;
                Step::from_output(&format!("squared_error_step_batch, instance {i}"), out, gradient)
            })
            .collect()
    }
}
