//! The public rendering API: the renderer and its settings, frames and their backward, and the
//! fused optimisation step. It validates input and hands the stages to an engine
//! ([`crate::engine`]); it never matches on which engine runs.

pub mod batch;
mod clip;
mod frame;
pub mod params;
mod pool;
mod settings;
mod step;
mod views;

use std::sync::Arc;

use glam::{Vec2, Vec3};

pub use crate::engine::{BackwardStats, RenderStats};
use crate::engine::{Engine, FrameRef, StageTiming, ViewInput};
pub use frame::{Frame, ScreenView};
use frame::{NoState, Part, Source};
pub use settings::{frame_bytes, Backend, RenderSettings, MAX_FRAME_BYTES, MAX_PIXEL_VALUE};
#[cfg(feature = "pose")]
pub(crate) use step::check_finite_targets;
pub use step::{Step, Targets};
use views::ViewGradient;

use crate::cpu::CpuEngine;
use crate::scene::mesh::Topology;
use crate::{Camera, Error, Image, Mesh, Result};

/// Renders silhouettes and differentiates them.
///
/// ```
/// use diffsil::{Camera, Mesh, Renderer, RenderSettings, Vec3};
/// let mesh = Mesh::new(
///     vec![Vec3::new(-0.5, -0.5, 0.0), Vec3::new(0.5, -0.5, 0.0), Vec3::new(0.0, 0.5, 0.0)],
///     vec![[0, 1, 2]],
/// )?;
/// let camera = Camera::perspective(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, 1.0, 32, 32);
/// let mut renderer = Renderer::new(RenderSettings::default())?;
/// let frame = renderer.render(&mesh, &[camera])?;
/// let target = diffsil::Image::filled(32, 32, 0.0);
/// let loss = diffsil::loss::squared_error(&frame.images()[0], &target)?;
/// let grad = renderer.backward(&frame, &[loss.grad])?; // ∂L/∂(3D vertex)
/// assert_eq!(grad.len(), 3);
/// # Ok::<(), diffsil::Error>(())
/// ```
///
/// The same calls run on either engine ([`Renderer::with_backend`]); the GPU engine returns the
/// same images (bit for bit for screen-space input) and the same gradients (to f32 rounding).
pub struct Renderer {
    settings: RenderSettings,
    last_backward: Vec<BackwardStats>,
    engine: Box<dyn Engine>,
    note: Option<String>,
    clip_topologies: clip::TopologyCache,
}

impl std::fmt::Debug for Renderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Renderer")
            .field("backend", &self.backend_name())
            .field("settings", &self.settings)
            .finish_non_exhaustive()
    }
}

impl Renderer {
    /// A renderer on the CPU engine. Errors if the settings are invalid.
    pub fn new(settings: RenderSettings) -> Result<Renderer> {
        views::raster_params(&settings, 1, 1)?;
        Ok(Renderer {
            settings,
            last_backward: Vec::new(),
            engine: Box::new(CpuEngine::default()),
            note: None,
            clip_topologies: clip::TopologyCache::default(),
        })
    }

    /// A renderer on `backend`. Errors if the settings are invalid, or for `Backend::Gpu` when no
    /// adapter matches or the device or the pipelines cannot be created ([`Backend::Auto`] falls
    /// back to the CPU instead, see [`Renderer::backend_name`]).
    pub fn with_backend(settings: RenderSettings, backend: Backend) -> Result<Renderer> {
        let mut renderer = Renderer::new(settings)?;
        match backend {
            Backend::Cpu => {}
            #[cfg(feature = "gpu")]
            Backend::Gpu(options) => {
                renderer.engine = Box::new(crate::gpu::GpuEngine::new(crate::gpu::GpuContext::new(&options)?)?);
            }
            Backend::Auto => renderer.auto_engine(),
        }
        Ok(renderer)
    }

    /// [`Backend::Auto`]: a hardware GPU (or the adapter `DIFFSIL_ADAPTER` names), else the CPU.
    #[cfg(feature = "gpu")]
    fn auto_engine(&mut self) {
        use crate::gpu::{hardware_gpu_available, AdapterChoice, GpuContext, GpuEngine, GpuOptions};
        let from_env = GpuOptions::from_env();
        let options = if from_env.adapter != AdapterChoice::Best {
            Some(from_env)
        } else if hardware_gpu_available() {
            Some(GpuOptions { adapter: AdapterChoice::Best, ..from_env })
        } else {
            self.note = Some("no hardware GPU".into());
            None
        };
        if let Some(options) = options {
            match GpuContext::new(&options).and_then(GpuEngine::new) {
                Ok(gpu) => self.engine = Box::new(gpu),
                Err(e) => self.note = Some(format!("GPU unavailable: {e}")),
            }
        }
    }

    /// [`Backend::Auto`] without the `gpu` feature: the CPU.
    #[cfg(not(feature = "gpu"))]
    fn auto_engine(&mut self) {
        self.note = Some("built without the gpu feature".into());
    }

    /// A renderer on the GPU engine, on a context the caller opened.
    #[cfg(feature = "gpu")]
    pub fn with_gpu_context(settings: RenderSettings, context: crate::gpu::GpuContext) -> Result<Renderer> {
        let mut renderer = Renderer::new(settings)?;
        renderer.engine = Box::new(crate::gpu::GpuEngine::new(context)?);
        Ok(renderer)
    }

    /// A one-line description of the engine, for logs and examples: `cpu`, or `gpu: <adapter>`
    /// (and, for [`Backend::Auto`] on the CPU, why).
    pub fn backend_name(&self) -> String {
        match &self.note {
            Some(note) => format!("{} ({note})", self.engine.describe()),
            None => self.engine.describe(),
        }
    }

    /// The GPU adapter, on the GPU engine.
    #[cfg(feature = "gpu")]
    pub fn adapter(&self) -> Option<&crate::gpu::AdapterReport> {
        self.engine.adapter()
    }

    /// Whether this renderer runs on the GPU engine.
    pub fn is_gpu(&self) -> bool {
        #[cfg(feature = "gpu")]
        return self.engine.adapter().is_some();
        #[cfg(not(feature = "gpu"))]
        false
    }

    /// The settings.
    pub fn settings(&self) -> RenderSettings {
        self.settings
    }

    /// Renders `mesh` from each camera. Images may differ in size per camera.
    ///
    /// Triangles crossing a camera's near or far plane are drawn clipped to the part between them
    /// ([`RenderStats::clipped_triangles`]); a view with such triangles is rendered by an engine
    /// call of its own, and then so is every other view of the call.
    pub fn render(&mut self, mesh: &Mesh, cameras: &[Camera]) -> Result<Frame> {
        self.on_pool(|r| r.render_impl(mesh, cameras))
    }

    /// [`Renderer::render`] on the calling thread.
    fn render_impl(&mut self, mesh: &Mesh, cameras: &[Camera]) -> Result<Frame> {
        let (views, params) = views::world_views(&self.settings, cameras)?;
        let clips = views::clip_views(&views, mesh, &mut self.clip_topologies)?;
        if clips.iter().all(Option::is_none) {
            let input = ViewInput::World { positions: mesh.positions(), cameras: &views };
            let rendered = self.engine.forward(mesh.topology(), &params, input)?;
            let source = Source::World { positions: mesh.positions().to_vec(), views };
            return Ok(Frame {
                images: rendered.images,
                stats: rendered.stats,
                topology: mesh.topology().clone(),
                params,
                source,
                state: rendered.state,
                parts: None,
            });
        }
        let (mut images, mut stats, mut parts) = (Vec::new(), Vec::new(), Vec::new());
        for (k, clip) in clips.into_iter().enumerate() {
            let part_params = vec![params[k]];
            let rendered = match &clip {
                None => {
                    let input = ViewInput::World { positions: mesh.positions(), cameras: &views[k..k + 1] };
                    self.engine.forward(mesh.topology(), &part_params, input)?
                }
                Some(c) => {
                    let input = ViewInput::Screen(std::slice::from_ref(&c.screen));
                    let mut rendered = self.engine.forward(&c.topology, &part_params, input)?;
                    rendered.stats[0].culled_triangles = c.culled_triangles;
                    rendered.stats[0].clipped_triangles = c.clipped_triangles;
                    rendered
                }
            };
            images.extend(rendered.images);
            stats.extend(rendered.stats);
            parts.push(Part { params: part_params, state: rendered.state, clip });
        }
        Ok(Frame {
            images,
            stats,
            topology: mesh.topology().clone(),
            params,
            source: Source::World { positions: mesh.positions().to_vec(), views },
            state: Box::new(NoState),
            parts: Some(parts),
        })
    }

    /// Renders views given directly in screen space (a custom projection, or a 2D problem).
    pub fn render_screen(&mut self, topology: &Arc<Topology>, views: &[ScreenView]) -> Result<Frame> {
        self.on_pool(|r| r.render_screen_impl(topology, views))
    }

    /// [`Renderer::render_screen`] on the calling thread.
    fn render_screen_impl(&mut self, topology: &Arc<Topology>, views: &[ScreenView]) -> Result<Frame> {
        let (params, screens) = views::screen_views(&self.settings, topology, views)?;
        let rendered = self.engine.forward(topology, &params, ViewInput::Screen(&screens))?;
        Ok(Frame {
            images: rendered.images,
            stats: rendered.stats,
            topology: topology.clone(),
            params,
            source: Source::Screen,
            state: rendered.state,
            parts: None,
        })
    }

    /// Backward in screen space: `∂L/∂I` per view → `∂L/∂(screen vertex)` per view.
    ///
    /// A frame with a view whose triangles were clipped at the near or far plane
    /// ([`RenderStats::clipped_triangles`] > 0) has no per-vertex screen gradient there (clipping
    /// added vertices): that is an [`Error::InvalidFrame`]; use [`Renderer::backward`].
    pub fn backward_screen(&mut self, frame: &Frame, d_images: &[Image]) -> Result<Vec<Vec<Vec2>>> {
        self.on_pool(|r| r.backward_screen_impl(frame, d_images))
    }

    /// [`Renderer::backward_screen`] on the calling thread.
    fn backward_screen_impl(&mut self, frame: &Frame, d_images: &[Image]) -> Result<Vec<Vec<Vec2>>> {
        if frame.parts.is_some() {
            let view = frame.stats.iter().position(|s| s.clipped_triangles > 0).unwrap_or(0);
            return Err(Error::InvalidFrame(format!(
                "view {view} of this frame has triangles clipped at the camera's near or far plane, so its screen \
                 gradient is not one per mesh vertex: use backward (3D), which chains the clipped vertices"
            )));
        }
        check_d_images(frame, d_images)?;
        self.last_backward.clear();
        if frame.view_count() == 0 {
            return Ok(Vec::new());
        }
        let d: Vec<&[f32]> = d_images.iter().map(|i| i.data()).collect();
        let (grads, stats) = self.engine.backward(frame.engine_ref(), &d)?;
        self.last_backward = stats;
        for (view, g) in grads.iter().enumerate() {
            views::check_finite_gradients("backward", Some(view), g, |g: Vec2| g.is_finite())?;
        }
        Ok(grads)
    }

    /// Backward through the cameras: `∂L/∂I` per view → `∂L/∂(3D vertex)`, summed over views.
    /// The frame must come from [`Renderer::render`]. Vertices added by clipping pass their
    /// gradient to the two mesh vertices of the edge they lie on.
    pub fn backward(&mut self, frame: &Frame, d_images: &[Image]) -> Result<Vec<Vec3>> {
        self.on_pool(|r| r.backward_impl(frame, d_images))
    }

    /// [`Renderer::backward`] on the calling thread.
    fn backward_impl(&mut self, frame: &Frame, d_images: &[Image]) -> Result<Vec<Vec3>> {
        let Source::World { positions, views } = &frame.source else {
            return Err(Error::InvalidFrame(
                "this frame was rendered from screen-space vertices: use backward_screen".into(),
            ));
        };
        let Some(parts) = &frame.parts else {
            let screen_grads = self.backward_screen(frame, d_images)?;
            let view_grads: Vec<ViewGradient<'_>> = screen_grads.iter().map(|g| ViewGradient::Screen(g)).collect();
            let grads = views::chain_to_3d("backward", positions, views, &view_grads)?;
            return Ok(grads);
        };
        check_d_images(frame, d_images)?;
        self.last_backward.clear();
        let mut screen_grads = Vec::with_capacity(parts.len());
        let mut stats = Vec::with_capacity(parts.len());
        for (k, part) in parts.iter().enumerate() {
            let (topology, world) = match &part.clip {
                None => (&frame.topology, Some((positions.as_slice(), &views[k..k + 1]))),
                Some(c) => (&c.topology, None),
            };
            let part_ref = FrameRef { topology, params: &part.params, state: part.state.as_ref(), world };
            let (mut grads, s) = self.engine.backward(part_ref, &[d_images[k].data()])?;
            let grads = grads.pop().unwrap_or_default();
            views::check_finite_gradients("backward", Some(k), &grads, |g: Vec2| g.is_finite())?;
            screen_grads.push(grads);
            stats.extend(s);
        }
        self.last_backward = stats;
        let view_grads: Vec<ViewGradient<'_>> = parts
            .iter()
            .zip(&screen_grads)
            .enumerate()
            .map(|(k, (part, g))| match &part.clip {
                None => ViewGradient::Screen(g),
                Some(c) => ViewGradient::World(c.chain_to_3d(&views[k], positions, g)),
            })
            .collect();
        let grads = views::chain_to_3d("backward", positions, views, &view_grads)?;
        Ok(grads)
    }

    /// Segment counts of the last backward, per view.
    pub fn last_backward_stats(&self) -> &[BackwardStats] {
        &self.last_backward
    }

    /// GPU time of every stage of the last forward and the backward after it, in order. Empty on
    /// the CPU engine, and unless profiling was asked for (`GpuOptions::profile`,
    /// `DIFFSIL_GPU_PROFILE=1`) on an adapter with timestamp queries.
    pub fn gpu_stage_timings(&self) -> &[StageTiming] {
        self.engine.stage_timings()
    }
}

/// Checks `d_images` against `frame`: one per view, of its view's size, finite.
fn check_d_images(frame: &Frame, d_images: &[Image]) -> Result<()> {
    if d_images.len() != frame.view_count() {
        return Err(Error::ViewCountMismatch {
            what: "image gradients",
            views: frame.view_count(),
            got: d_images.len(),
        });
    }
    for ((width, height), d_image) in frame.view_sizes().into_iter().zip(d_images) {
        d_image.expect_size("image gradient", width, height)?;
        if let Some(p) = d_image.data().iter().position(|g| !g.is_finite()) {
            return Err(Error::InvalidSettings(format!("image gradient has a non-finite value at pixel {p}")));
        }
    }
    Ok(())
}
