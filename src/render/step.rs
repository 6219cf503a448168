//! One optimisation step in one call: render, squared error against fixed targets, backward to
//! the 3D vertices. On the GPU backend the images and `∂L/∂I` never leave the device.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::{Vec2, Vec3};

use super::clip::ClipView;
use super::views::ViewGradient;
use super::Renderer;
use crate::engine::{RenderStats, StepOutput, ViewInput};
use crate::mirror::{RasterParams, ViewParams};
use crate::{Camera, Error, Image, Mesh, Result};

static NEXT_TARGETS_ID: AtomicU64 = AtomicU64::new(1);

/// Target silhouettes for [`Renderer::squared_error_step`], one per view.
///
/// Make them once and reuse them for every step of a fit: the GPU backend uploads a set of
/// targets the first time it sees it and keeps it on the device.
#[derive(Clone, Debug)]
pub struct Targets {
    pub(super) id: u64,
    /// One id per view, for the one-view engine calls of a step with clipped views.
    view_ids: Vec<u64>,
    pub(super) images: Vec<Image>,
}

/// Checks that every pixel of every target is finite: [`Error::InvalidSettings`] naming the first
/// view and pixel that is not. Shared by [`Targets::new`] and the pose fit.
pub(crate) fn check_finite_targets(images: &[Image]) -> Result<()> {
    for (view, image) in images.iter().enumerate() {
        if let Some(p) = image.data().iter().position(|v| !v.is_finite()) {
            return Err(Error::InvalidSettings(format!("target {view} has a non-finite value at pixel {p}")));
        }
    }
    Ok(())
}

impl Targets {
    /// Targets from one image per view. A non-finite pixel is an [`Error::InvalidSettings`].
    pub fn new(images: Vec<Image>) -> Result<Targets> {
        check_finite_targets(&images)?;
        let id = NEXT_TARGETS_ID.fetch_add(1 + images.len() as u64, Ordering::Relaxed);
        let view_ids = (1..=images.len() as u64).map(|k| id + k).collect();
        Ok(Targets { id, view_ids, images })
    }

    /// The target images.
    pub fn images(&self) -> &[Image] {
        &self.images
    }
}

/// What [`Renderer::squared_error_step`] returns.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    /// The loss `L = Σ_views Σ_pixels (I − T)²` (paper Eq. 18).
    pub loss: f64,
    /// Each view's share of the loss.
    pub view_losses: Vec<f64>,
    /// `∂L/∂(3D vertex)`, one per mesh vertex, summed over views.
    pub gradient: Vec<Vec3>,
    /// `∂L/∂(screen vertex)` per view, one per mesh vertex (what [`Step::gradient`] is chained
    /// from; [`camera_gradient`](crate::camera_gradient) takes one view's). Empty for a view with
    /// triangles clipped at the near or far plane (`stats[k].clipped_triangles > 0`): clipping
    /// adds vertices, so there is no per-vertex screen gradient (and `camera_gradient` refuses
    /// the empty one with an error).
    pub screen_gradients: Vec<Vec<Vec2>>,
    /// Per-view statistics of the forward.
    pub stats: Vec<RenderStats>,
}

impl Step {
    /// The step of an engine's output and the 3D gradient chained from it; `what` names the call
    /// (and instance) in the error when a view's loss overflowed f32.
    pub(super) fn from_output(what: &str, out: StepOutput, gradient: Vec<Vec3>) -> Result<Step> {
        if let Some(view) = out.view_losses.iter().position(|l| !l.is_finite()) {
            return Err(Error::InvalidSettings(format!(
                "{what}: the loss of view {view} overflowed ({}): the targets or the inside/outside values are too \
                 large; keep them within ±1e18",
                out.view_losses[view]
            )));
        }
        Ok(Step {
            loss: out.view_losses.iter().sum(),
            view_losses: out.view_losses,
            gradient,
            screen_gradients: out.screen_grads,
            stats: out.stats,
        })
    }
}

impl Renderer {
    /// Renders `mesh` from each camera, takes the squared error of each image against its target
    /// ([`crate::loss::squared_error`]) and differentiates it back to the 3D vertex positions: the whole
    /// iteration of a silhouette fit.
    ///
    /// The result equals `render`, `loss::squared_error` per view and `backward` in sequence. On
    /// the GPU backend it is faster: the loss and its gradient are computed on the device (the
    /// `loss` stage), the backward runs in the same submission (its size dispatched indirectly
    /// from the candidate count), and only the vertex gradient and the per-tile loss sums come
    /// back, not the images: one round trip per step. The gradient there is the same as through `render`/`backward`; the loss value is
    /// summed in f32 per tile before f64 across tiles (relative difference ~1e-6 from the CPU's
    /// f64 sum). Use [`Renderer::render`] when you need the images.
    ///
    /// Errors: a target count other than the camera count ([`Error::ViewCountMismatch`]), a target
    /// of another size than its camera's image ([`Error::SizeMismatch`]), and whatever
    /// [`Renderer::render`] rejects.
    pub fn squared_error_step(&mut self, mesh: &Mesh, cameras: &[Camera], targets: &Targets) -> Result<Step> {
        self.on_pool(|r| r.squared_error_step_impl(mesh, cameras, targets))
    }

    /// [`Renderer::squared_error_step`] on the calling thread.
    fn squared_error_step_impl(&mut self, mesh: &Mesh, cameras: &[Camera], targets: &Targets) -> Result<Step> {
        if targets.images.len() != cameras.len() {
            return Err(Error::ViewCountMismatch { what: "targets", views: cameras.len(), got: targets.images.len() });
        }
        for (camera, target) in cameras.iter().zip(&targets.images) {
            target.expect_size("target", camera.width, camera.height)?;
        }
        let (views, params) = super::views::world_views(&self.settings, cameras)?;
        let clips = super::views::clip_views(&views, mesh, &mut self.clip_topologies)?;
        let (mut out, view_grads) = if clips.iter().all(Option::is_none) {
            let input = ViewInput::World { positions: mesh.positions(), cameras: &views };
            let out = self.engine.squared_error_step(mesh.topology(), &params, input, targets.id, &targets.images)?;
            let view_grads: Vec<ViewGradient<'_>> = Vec::new();
            (out, view_grads)
        } else {
            self.clipped_step(mesh, &views, &params, &clips, targets)?
        };
        self.last_backward = std::mem::take(&mut out.backward);
        let gradient = if view_grads.is_empty() {
            let screen: Vec<ViewGradient<'_>> = out.screen_grads.iter().map(|g| ViewGradient::Screen(g)).collect();
            super::views::chain_to_3d("squared_error_step", mesh.positions(), &views, &screen)?
        } else {
            super::views::chain_to_3d("squared_error_step", mesh.positions(), &views, &view_grads)?
        };
        Step::from_output("squared_error_step", out, gradient)
    }

    /// [`Renderer::squared_error_step`] when a view has clipped triangles: one engine call per
    /// view (clipped views from their clipped geometry, with their own target ids). Returns the
    /// merged output (empty screen gradients for clipped views) and every view's gradient on its
    /// way to 3D.
    fn clipped_step(
        &mut self,
        mesh: &Mesh,
        views: &[ViewParams],
        params: &[RasterParams],
        clips: &[Option<ClipView>],
        targets: &Targets,
    ) -> Result<(StepOutput, Vec<ViewGradient<'static>>)> {
        let n = views.len();
        let mut merged =
            StepOutput { view_losses: Vec::new(), screen_grads: Vec::new(), stats: Vec::new(), backward: Vec::new() };
        let mut view_grads = Vec::with_capacity(n);
        for k in 0..n {
            let part_params = [params[k]];
            let target = std::slice::from_ref(&targets.images[k]);
            let id = targets.view_ids[k];
            let mut out = match &clips[k] {
                None => {
                    let input = ViewInput::World { positions: mesh.positions(), cameras: &views[k..k + 1] };
                    self.engine.squared_error_step(mesh.topology(), &part_params, input, id, target)?
                }
                Some(c) => {
                    let input = ViewInput::Screen(std::slice::from_ref(&c.screen));
                    let mut out = self.engine.squared_error_step(&c.topology, &part_params, input, id, target)?;
                    out.stats[0].culled_triangles = c.culled_triangles;
                    out.stats[0].clipped_triangles = c.clipped_triangles;
                    out
                }
            };
            let grads = out.screen_grads.pop().unwrap_or_default();
            super::views::check_finite_gradients("squared_error_step", Some(k), &grads, |g: Vec2| g.is_finite())?;
            match &clips[k] {
                None => {
                    view_grads.push(ViewGradient::World(super::views::view_to_3d(&views[k], mesh.positions(), &grads)));
                    merged.screen_grads.push(grads);
                }
                Some(c) => {
                    view_grads.push(ViewGradient::World(c.chain_to_3d(&views[k], mesh.positions(), &grads)));
                    merged.screen_grads.push(Vec::new());
                }
            }
            merged.view_losses.extend(out.view_losses);
            merged.stats.extend(out.stats);
            merged.backward.extend(out.backward);
        }
        Ok((merged, view_grads))
    }
}
