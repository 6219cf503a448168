//! The result of a forward, and views given directly in screen space.

use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::clip::ClipView;
use crate::engine::{FrameRef, FrameState, RenderStats};
use crate::mirror::{RasterParams, ViewParams};
use crate::scene::mesh::Topology;
use crate::Image;

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

/// Where a frame's vertices came from.
pub(super) enum Source {
    /// Screen-space vertices ([`crate::Renderer::render_screen`]).
    Screen,
    /// 3D positions and the cameras' projection constants ([`crate::Renderer::render`]).
    World { positions: Vec<Vec3>, views: Vec<ViewParams> },
}

/// One view of a frame rendered by an engine call of its own (a frame with clipped views).
pub(super) struct Part {
    /// The view's raster constants (one).
    pub params: Vec<RasterParams>,
    /// The engine's state of that call.
    pub state: Box<dyn FrameState>,
    /// The clipped geometry the view was rendered from (`None`: the mesh, from 3D).
    pub clip: Option<ClipView>,
}

/// The engine state of a frame whose views each have their own ([`Frame::parts`]).
pub(super) struct NoState;

impl FrameState for NoState {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn screen_vertices(&self, _view: usize) -> Option<Vec<Vec2>> {
        None
    }
}

/// The result of a forward: the images, per-view statistics, and what the backward needs.
pub struct Frame {
    pub(super) images: Vec<Image>,
    pub(super) stats: Vec<RenderStats>,
    pub(super) topology: Arc<Topology>,
    pub(super) params: Vec<RasterParams>,
    pub(super) source: Source,
    pub(super) state: Box<dyn FrameState>,
    /// `Some` when a view had triangles crossing the near or far plane: then every view was
    /// rendered by its own engine call (clipped ones from their clipped geometry), `state` is
    /// [`NoState`], and the backward goes through the parts.
    pub(super) parts: Option<Vec<Part>>,
}

impl std::fmt::Debug for Frame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Frame")
            .field("views", &self.images.len())
            .field("sizes", &self.images.iter().map(|i| (i.width(), i.height())).collect::<Vec<_>>())
            .field("vertices", &self.topology.vertex_count())
            .field("triangles", &self.topology.triangles().len())
            .field("from_3d", &matches!(self.source, Source::World { .. }))
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
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

    /// Projected vertex positions of view `view` (zero for vertices outside `near < depth < far`
    /// or beyond the coordinate limit); `None` when there is no such view. For a view with clipped
    /// triangles these are the mesh's vertices only, not the vertices clipping added.
    ///
    /// On the GPU engine, for a frame rendered from 3D input, these are computed on the CPU with
    /// the same arithmetic as the GPU's `project` stage (bit-identical; see `shaders/project.wgsl`),
    /// so no readback is needed.
    pub fn screen_vertices(&self, view: usize) -> Option<Vec<Vec2>> {
        if view >= self.view_count() {
            return None;
        }
        if let (Some(_), Source::World { positions, views }) = (&self.parts, &self.source) {
            return Some(positions.iter().map(|&p| views[view].project(p).0).collect());
        }
        match (self.state.screen_vertices(view), &self.source) {
            (Some(screen), _) => Some(screen),
            (None, Source::World { positions, views }) => {
                Some(positions.iter().map(|&p| views[view].project(p).0).collect())
            }
            (None, Source::Screen) => None,
        }
    }

    /// Width and height of each view.
    pub(super) fn view_sizes(&self) -> Vec<(u32, u32)> {
        self.images.iter().map(|i| (i.width(), i.height())).collect()
    }

    /// The frame as its engine sees it.
    pub(super) fn engine_ref(&self) -> FrameRef<'_> {
        let world = match &self.source {
            Source::World { positions, views } => Some((positions.as_slice(), views.as_slice())),
            Source::Screen => None,
        };
        FrameRef { topology: &self.topology, params: &self.params, state: self.state.as_ref(), world }
    }
}
