//! The public rendering API: settings, the renderer, frames and their backward.

use std::sync::Arc;

use glam::{Vec2, Vec3};

use crate::camera::{Camera, ViewParams};
use crate::cpu;
use crate::cpu::edge_grad::SegmentStats;
use crate::layout::{RasterParams, ScreenVertex};
use crate::mesh::{Mesh, Topology};
use crate::{Error, Image, Result};

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

enum Source {
    Screen,
    World { positions: Vec<Vec3>, views: Vec<ViewParams> },
}

/// The result of a forward: the images, per-view statistics, and what the backward needs.
pub struct Frame {
    images: Vec<Image>,
    stats: Vec<RenderStats>,
    topology: Arc<Topology>,
    source: Source,
    views: Vec<cpu::ViewState>,
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
    pub fn screen_vertices(&self, view: usize) -> Vec<Vec2> {
        self.views[view].screen.iter().map(|s| Vec2::from(s.position)).collect()
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
pub struct Renderer {
    settings: RenderSettings,
    last_backward: Vec<BackwardStats>,
}

impl Renderer {
    /// A renderer on the CPU backend. Errors if the settings are invalid.
    pub fn new(settings: RenderSettings) -> Result<Renderer> {
        RasterParams::new(1, 1, settings.supersample, settings.inside, settings.outside)?;
        Ok(Renderer { settings, last_backward: Vec::new() })
    }

    /// The settings.
    pub fn settings(&self) -> RenderSettings {
        self.settings
    }

    /// Renders `mesh` from each camera. Images may differ in size per camera.
    pub fn render(&mut self, mesh: &Mesh, cameras: &[Camera]) -> Result<Frame> {
        let mut views = Vec::with_capacity(cameras.len());
        let mut screens = Vec::with_capacity(cameras.len());
        for camera in cameras {
            camera.validate()?;
            let view = camera.params();
            let params = self.raster_params(camera.width, camera.height)?;
            let mut screen = vec![ScreenVertex::default(); mesh.positions().len()];
            cpu::project::project(&view, mesh.positions(), &mut screen);
            views.push(view);
            screens.push((params, screen));
        }
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
            screens.push((params, screen));
        }
        Ok(self.forward(topology.clone(), screens, Source::Screen))
    }

    fn raster_params(&self, width: u32, height: u32) -> Result<RasterParams> {
        let s = self.settings;
        RasterParams::new(width, height, s.supersample, s.inside, s.outside)
    }

    fn forward(
        &mut self,
        topology: Arc<Topology>,
        screens: Vec<(RasterParams, Vec<ScreenVertex>)>,
        source: Source,
    ) -> Frame {
        let mut images = Vec::with_capacity(screens.len());
        let mut stats = Vec::with_capacity(screens.len());
        let mut views = Vec::with_capacity(screens.len());
        for (params, screen) in screens {
            let (state, image) = cpu::forward_view(params, screen, &topology);
            stats.push(RenderStats {
                culled_triangles: state.culled_triangles,
                candidate_edges: state.sides.iter().filter(|&&s| s != 0).count() as u32,
                tile_size: state.params.tile_size,
            });
            images.push(Image::from_vec(params.width, params.height, image).expect("image sized by the raster"));
            views.push(state);
        }
        Frame { images, stats, topology, source, views }
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
        let mut out = Vec::with_capacity(d_images.len());
        self.last_backward.clear();
        for (state, d_image) in frame.views.iter().zip(d_images) {
            d_image.expect_size("image gradient", state.params.width, state.params.height)?;
            if let Some(p) = d_image.data().iter().position(|g| !g.is_finite()) {
                return Err(Error::InvalidSettings(format!("image gradient has a non-finite value at pixel {p}")));
            }
            let (grads, stats) = cpu::backward_view(state, &frame.topology, d_image.data());
            self.last_backward.push(stats);
            out.push(grads);
        }
        Ok(out)
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
        let mut grads = vec![Vec3::ZERO; positions.len()];
        for (view, g2) in views.iter().zip(&screen_grads) {
            for ((g, p), d) in grads.iter_mut().zip(positions).zip(g2) {
                if *d != Vec2::ZERO {
                    let [jx, jy] = view.jacobian(*p);
                    *g += jx * d.x + jy * d.y;
                }
            }
        }
        Ok(grads)
    }

    /// Segment counts of the last backward, per view.
    pub fn last_backward_stats(&self) -> &[BackwardStats] {
        &self.last_backward
    }
}
