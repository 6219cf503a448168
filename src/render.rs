//! The public rendering API: settings, the renderer and its backend, frames and their backward.

use std::sync::Arc;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::camera::{Camera, ViewParams};
use crate::cpu;
use crate::cpu::edge_grad::SegmentStats;
use crate::gpu::backend::{ForwardMode, GpuBackend, GpuFrame, Input};
use crate::gpu::{hardware_gpu_available, AdapterChoice, AdapterReport, GpuContext, GpuOptions};
use crate::layout::{RasterParams, ScreenVertex};
use crate::mesh::{Mesh, Topology};
use crate::{Error, Image, Result};

mod step;

pub use step::{Step, Targets};

/// How pixels are formed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Samples per pixel side, F (F×F samples per pixel); 1 means no anti-aliasing. 1 to 16.
    pub supersample: u32,
    /// Value inside the silhouette (p1).
    pub inside: f32,
    /// Value outside the silhouette (p0).
    pub outside: f32,
}

impl Default for RenderSettings {
    /// F = 4, inside 1, outside 0.
    fn default() -> Self {
        RenderSettings { supersample: 4, inside: 1.0, outside: 0.0 }
    }
}

/// Per-view numbers from a forward.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RenderStats {
    /// Triangles dropped because a vertex was behind the near plane, beyond the far plane or
    /// beyond [`COORD_LIMIT`](crate::COORD_LIMIT).
    pub culled_triangles: u32,
    /// Edges that may lie on the silhouette (contour, boundary or one-sided non-manifold).
    pub candidate_edges: u32,
    /// Tile side in pixels chosen for binning.
    pub tile_size: u32,
}

/// Per-view numbers from a backward.
pub type BackwardStats = SegmentStats;

/// One view given directly in screen space: 2D pixel coordinates per vertex (x right, y down).
#[derive(Clone, Debug, PartialEq)]
pub struct ScreenView {
    /// Pixel coordinates of every vertex of the topology.
    pub vertices: Vec<Vec2>,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
}

/// Which backend a [`Renderer`] runs on.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Backend {
    /// The CPU backend (Rust, parallel with rayon).
    Cpu,
    /// The WGSL backend on the GPU adapter these options choose (e.g.
    /// [`GpuOptions::from_env`]); a software adapter such as lavapipe is used when it is the one
    /// chosen. Fails with [`Error::NoAdapter`] when there is none.
    Gpu(GpuOptions),
    /// A hardware GPU when there is one, else the CPU backend: a software GPU (lavapipe,
    /// llvmpipe, SwiftShader) emulates the GPU on the CPU and is slower than the CPU backend, so
    /// it is only used when asked for, by name or backend, through `DIFFSIL_ADAPTER` (or with
    /// [`Backend::Gpu`]). If the GPU cannot be opened, the CPU backend is used.
    #[default]
    Auto,
}

enum Engine {
    Cpu,
    Gpu(Box<GpuBackend>),
}

enum Source {
    Screen,
    World { positions: Vec<Vec3>, views: Vec<ViewParams> },
}

/// One view's input to the CPU forward: raster constants, screen vertices and, when the projection
/// already made them, the snapped vertices.
type CpuView = (RasterParams, Vec<ScreenVertex>, Option<Vec<[i32; 2]>>);

/// What the backward of a frame needs, per backend.
enum FrameState {
    /// The CPU backend keeps each view's state.
    Cpu(Vec<cpu::ViewState>),
    /// The GPU backend keeps its state in GPU buffers; the frame keeps what it needs to run the
    /// forward again should those buffers have been reused since (and, for screen-space input,
    /// the screen vertices).
    Gpu { frame: GpuFrame, params: Vec<RasterParams>, screens: Vec<Vec<ScreenVertex>> },
}

/// The result of a forward: the images, per-view statistics, and what the backward needs.
pub struct Frame {
    images: Vec<Image>,
    stats: Vec<RenderStats>,
    topology: Arc<Topology>,
    source: Source,
    state: FrameState,
}

impl Frame {
    /// One image per view, in the order the views were given.
    pub fn images(&self) -> &[Image] {
        &self.images
    }

    /// Per-view statistics.
    pub fn stats(&self) -> &[RenderStats] {
        &self.stats
    }

    /// Number of views.
    pub fn view_count(&self) -> usize {
        self.images.len()
    }

    /// Projected vertex positions of view `view` (zero for clipped vertices).
    ///
    /// On the GPU backend, for a frame rendered from 3D input, these are computed on the CPU with
    /// the same arithmetic as the GPU's `project` stage (bit-identical; see `shaders/project.wgsl`),
    /// so no readback is needed.
    pub fn screen_vertices(&self, view: usize) -> Vec<Vec2> {
        match (&self.state, &self.source) {
            (FrameState::Cpu(views), _) => views[view].screen.iter().map(|s| Vec2::from(s.position)).collect(),
            (FrameState::Gpu { screens, .. }, Source::Screen) => {
                screens[view].iter().map(|s| Vec2::from(s.position)).collect()
            }
            (FrameState::Gpu { .. }, Source::World { positions, views }) => {
                positions.iter().map(|&p| views[view].project(p).0).collect()
            }
        }
    }

    /// Width and height of each view.
    fn view_sizes(&self) -> Vec<(u32, u32)> {
        self.images.iter().map(|i| (i.width(), i.height())).collect()
    }
}

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
/// The same calls run on either backend ([`Renderer::with_backend`]); the GPU backend returns the
/// same images (bit for bit for screen-space input) and the same gradients (to f32 rounding).
pub struct Renderer {
    settings: RenderSettings,
    last_backward: Vec<BackwardStats>,
    engine: Engine,
    note: Option<String>,
}

impl Renderer {
    /// A renderer on the CPU backend. Errors if the settings are invalid.
    pub fn new(settings: RenderSettings) -> Result<Renderer> {
        RasterParams::new(1, 1, settings.supersample, settings.inside, settings.outside)?;
        Ok(Renderer { settings, last_backward: Vec::new(), engine: Engine::Cpu, note: None })
    }

    /// A renderer on `backend`. Errors if the settings are invalid, or for [`Backend::Gpu`] when no
    /// adapter matches or the device or the pipelines cannot be created ([`Backend::Auto`] falls
    /// back to the CPU instead, see [`Renderer::backend_name`]).
    pub fn with_backend(settings: RenderSettings, backend: Backend) -> Result<Renderer> {
        let mut renderer = Renderer::new(settings)?;
        match backend {
            Backend::Cpu => {}
            Backend::Gpu(options) => {
                renderer.engine = Engine::Gpu(Box::new(GpuBackend::new(GpuContext::new(&options)?)?));
            }
            Backend::Auto => {
                let from_env = GpuOptions::from_env();
                let options = if from_env.adapter != AdapterChoice::Best {
                    Some(from_env)
                } else if hardware_gpu_available() {
                    Some(GpuOptions { adapter: AdapterChoice::Best, ..from_env })
                } else {
                    renderer.note = Some("no hardware GPU".into());
                    None
                };
                if let Some(options) = options {
                    match GpuContext::new(&options).and_then(GpuBackend::new) {
                        Ok(gpu) => renderer.engine = Engine::Gpu(Box::new(gpu)),
                        Err(e) => renderer.note = Some(format!("GPU unavailable: {e}")),
                    }
                }
            }
        }
        Ok(renderer)
    }

    /// A renderer on the GPU backend, on a context the caller opened.
    pub fn with_gpu_context(settings: RenderSettings, context: GpuContext) -> Result<Renderer> {
        let mut renderer = Renderer::new(settings)?;
        renderer.engine = Engine::Gpu(Box::new(GpuBackend::new(context)?));
        Ok(renderer)
    }

    /// A one-line description of the backend, for logs and examples: `cpu`, or `gpu: <adapter>`
    /// (and, for [`Backend::Auto`] on the CPU, why).
    pub fn backend_name(&self) -> String {
        match (&self.engine, &self.note) {
            (Engine::Cpu, None) => "cpu".into(),
            (Engine::Cpu, Some(note)) => format!("cpu ({note})"),
            (Engine::Gpu(gpu), _) => format!("gpu: {}", gpu.adapter()),
        }
    }

    /// The GPU adapter, on the GPU backend.
    pub fn adapter(&self) -> Option<&AdapterReport> {
        match &self.engine {
            Engine::Cpu => None,
            Engine::Gpu(gpu) => Some(gpu.adapter()),
        }
    }

    /// Whether this renderer runs on the GPU backend.
    pub fn is_gpu(&self) -> bool {
        matches!(self.engine, Engine::Gpu(_))
    }

    /// The settings.
    pub fn settings(&self) -> RenderSettings {
        self.settings
    }

    /// Renders `mesh` from each camera. Images may differ in size per camera.
    pub fn render(&mut self, mesh: &Mesh, cameras: &[Camera]) -> Result<Frame> {
        let (views, params) = step::world_views(&self.settings, cameras)?;
        if let Engine::Gpu(gpu) = &mut self.engine {
            let input = Input::World { positions: mesh.positions(), cameras: &views };
            let out = gpu.forward(mesh.topology(), &params, input, ForwardMode::Images)?;
            let source = Source::World { positions: mesh.positions().to_vec(), views };
            return gpu_frame(mesh.topology().clone(), params, out, source, Vec::new());
        }
        let screens = views
            .iter()
            .zip(params)
            .map(|(view, params)| {
                let (mut screen, mut snapped) = (Vec::new(), Vec::new());
                cpu::project::project_and_snap(view, &params, mesh.positions(), &mut screen, &mut snapped);
                (params, screen, Some(snapped))
            })
            .collect();
        let source = Source::World { positions: mesh.positions().to_vec(), views };
        Ok(self.forward(mesh.topology().clone(), screens, source))
    }

    /// Renders views given directly in screen space (a custom projection, or a 2D problem).
    pub fn render_screen(&mut self, topology: &Arc<Topology>, views: &[ScreenView]) -> Result<Frame> {
        let mut screens = Vec::with_capacity(views.len());
        for view in views {
            let params = self.raster_params(view.width, view.height)?;
            if view.vertices.len() != topology.vertex_count() {
                return Err(Error::LengthMismatch {
                    what: "screen vertices",
                    expected: topology.vertex_count(),
                    got: view.vertices.len(),
                });
            }
            if let Some(vertex) = view.vertices.iter().position(|v| !v.is_finite()) {
                let v = view.vertices[vertex];
                return Err(Error::NonFiniteVertex { vertex, value: [v.x, v.y, 0.0] });
            }
            let screen = view
                .vertices
                .iter()
                .map(|v| {
                    let valid = v.x.abs() < crate::COORD_LIMIT && v.y.abs() < crate::COORD_LIMIT;
                    ScreenVertex { position: if valid { v.to_array() } else { [0.0; 2] }, valid: valid as u32, pad: 0 }
                })
                .collect();
            screens.push((params, screen, None));
        }
        if let Engine::Gpu(gpu) = &mut self.engine {
            let (params, screens): (Vec<RasterParams>, Vec<Vec<ScreenVertex>>) =
                screens.into_iter().map(|(p, s, _)| (p, s)).unzip();
            let out = gpu.forward(topology, &params, Input::Screen(&screens), ForwardMode::Images)?;
            return gpu_frame(topology.clone(), params, out, Source::Screen, screens);
        }
        Ok(self.forward(topology.clone(), screens, Source::Screen))
    }

    fn raster_params(&self, width: u32, height: u32) -> Result<RasterParams> {
        let s = self.settings;
        RasterParams::new(width, height, s.supersample, s.inside, s.outside)
    }

    fn forward(&mut self, topology: Arc<Topology>, screens: Vec<CpuView>, source: Source) -> Frame {
        // The views are independent: they run side by side (each parallel inside too), and come
        // back in order.
        let rendered: Vec<(cpu::ViewState, Image)> = screens
            .into_par_iter()
            .map(|(params, screen, snapped)| {
                let snapped = snapped.unwrap_or_else(|| {
                    let mut snapped = vec![[0; 2]; screen.len()];
                    cpu::project::snap(&params, &screen, &mut snapped);
                    snapped
                });
                let (state, image) = cpu::forward_view(params, screen, snapped, &topology);
                (state, Image::from_vec(params.width, params.height, image).expect("image sized by the raster"))
            })
            .collect();
        let stats = rendered
            .iter()
            .map(|(state, _)| RenderStats {
                culled_triangles: state.culled_triangles,
                candidate_edges: state.candidates.len() as u32,
                tile_size: state.params.tile_size,
            })
            .collect();
        let (views, images) = rendered.into_iter().unzip();
        Frame { images, stats, topology, source, state: FrameState::Cpu(views) }
    }

    /// Backward in screen space: `∂L/∂I` per view → `∂L/∂(screen vertex)` per view.
    pub fn backward_screen(&mut self, frame: &Frame, d_images: &[Image]) -> Result<Vec<Vec<Vec2>>> {
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
        self.last_backward.clear();
        match (&mut self.engine, &frame.state) {
            (Engine::Cpu, FrameState::Cpu(views)) => {
                // Views side by side, as in the forward.
                let (out, stats): (Vec<Vec<Vec2>>, Vec<BackwardStats>) = views
                    .par_iter()
                    .zip(d_images)
                    .map(|(state, d_image)| cpu::backward_view(state, &frame.topology, d_image.data()))
                    .unzip();
                self.last_backward = stats;
                Ok(out)
            }
            (Engine::Gpu(gpu), FrameState::Gpu { frame: gpu_frame, params, screens }) => {
                let input = match &frame.source {
                    Source::Screen => Input::Screen(screens),
                    Source::World { positions, views } => Input::World { positions, cameras: views },
                };
                let d: Vec<&[f32]> = d_images.iter().map(|i| i.data()).collect();
                let (out, stats) = gpu.backward(*gpu_frame, &frame.topology, params, input, Some(&d))?;
                self.last_backward = stats;
                Ok(out)
            }
            (engine, _) => Err(Error::InvalidFrame(format!(
                "this frame was rendered by the {} backend, but this renderer runs on the {} backend: \
                 differentiate a frame with a renderer on the backend that rendered it",
                if matches!(engine, Engine::Cpu) { "GPU" } else { "CPU" },
                if matches!(engine, Engine::Cpu) { "CPU" } else { "GPU" },
            ))),
        }
    }

    /// Backward through the cameras: `∂L/∂I` per view → `∂L/∂(3D vertex)`, summed over views.
    /// The frame must come from [`Renderer::render`].
    pub fn backward(&mut self, frame: &Frame, d_images: &[Image]) -> Result<Vec<Vec3>> {
        let Source::World { positions, views } = &frame.source else {
            return Err(Error::InvalidFrame(
                "this frame was rendered from screen-space vertices: use backward_screen".into(),
            ));
        };
        let screen_grads = self.backward_screen(frame, d_images)?;
        Ok(chain_to_3d(positions, views, &screen_grads))
    }

    /// Segment counts of the last backward, per view.
    pub fn last_backward_stats(&self) -> &[BackwardStats] {
        &self.last_backward
    }

    /// GPU time of every stage of the last forward and the backward after it, in order. Empty on
    /// the CPU backend, and unless profiling was asked for ([`GpuOptions::profile`],
    /// `DIFFSIL_GPU_PROFILE=1`) on an adapter with timestamp queries.
    pub fn gpu_stage_timings(&self) -> &[crate::gpu::StageTiming] {
        match &self.engine {
            Engine::Cpu => &[],
            Engine::Gpu(gpu) => gpu.stage_timings(),
        }
    }
}

/// `∂L/∂(screen vertex)` per view → `∂L/∂(3D vertex)` through each view's projection Jacobian,
/// summed over views (in view order).
fn chain_to_3d(positions: &[Vec3], views: &[ViewParams], screen_grads: &[Vec<Vec2>]) -> Vec<Vec3> {
    let mut grads = vec![Vec3::ZERO; positions.len()];
    // Per vertex, the views in order: the same sums whatever the thread count.
    grads.par_iter_mut().with_min_len(4096).enumerate().for_each(|(v, g)| {
        for (view, g2) in views.iter().zip(screen_grads) {
            let d = g2.get(v).copied().unwrap_or(Vec2::ZERO);
            if d != Vec2::ZERO {
                let [jx, jy] = view.jacobian(positions[v]);
                *g += jx * d.x + jy * d.y;
            }
        }
    });
    grads
}

/// A [`Frame`] from a GPU forward.
fn gpu_frame(
    topology: Arc<Topology>,
    params: Vec<RasterParams>,
    out: crate::gpu::backend::ForwardOutput,
    source: Source,
    screens: Vec<Vec<ScreenVertex>>,
) -> Result<Frame> {
    let mut images = Vec::with_capacity(params.len());
    let mut stats = Vec::with_capacity(params.len());
    for (k, (p, image)) in params.iter().zip(out.images).enumerate() {
        images.push(Image::from_vec(p.width, p.height, image)?);
        stats.push(RenderStats {
            culled_triangles: out.culled[k],
            candidate_edges: out.candidates[k],
            tile_size: out.tile_sizes[k],
        });
    }
    Ok(Frame { images, stats, topology, source, state: FrameState::Gpu { frame: out.frame, params, screens } })
}
