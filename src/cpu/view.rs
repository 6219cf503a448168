//! One view through the CPU stages: the forward, and the backward from its state.

use glam::Vec2;

use super::{bin, coverage, edge_grad, gather, resolve};
use crate::engine::BackwardStats;
use crate::mirror::{EdgeGrad, RasterParams, ScreenVertex};
use crate::scene::mesh::Topology;

/// What the forward of one view keeps for its backward. Its buffers can be reused by the next
/// forward ([`render_view`]): the CPU engine keeps the states of dropped frames for that.
#[derive(Clone, Debug, Default)]
pub struct ViewState {
    /// Raster constants (with the tile size the `bin` stage chose).
    pub params: RasterParams,
    /// Projected vertices.
    pub screen: Vec<ScreenVertex>,
    /// Projected vertices snapped to the fixed-point grid.
    pub snapped: Vec<[i32; 2]>,
    /// Candidate edges `(edge, side)` from the `edges` stage, in edge order.
    pub candidates: Vec<(u32, i32)>,
    /// Triangles culled because a vertex was clipped.
    pub culled_triangles: u32,
    /// The sample masks of the forward (the backward does not read them: the CPU engine takes them
    /// back for its next forward as soon as the forward ends, and a frame keeps none).
    pub masks: Vec<u32>,
    /// The face orientations of the forward (kept, like `masks`, for reuse).
    pub orientation: Vec<i8>,
    /// The buffers of the coverage pass (kept, like `masks`, for reuse).
    pub contour: coverage::ContourScratch,
}

/// Forward of one view from screen vertices and their snapped positions ([`super::project::snap`], or both
/// from [`super::project::project_and_snap`]): returns the state and the image.
pub fn forward_view(
    params: RasterParams,
    screen: Vec<ScreenVertex>,
    snapped: Vec<[i32; 2]>,
    topology: &Topology,
) -> (ViewState, Vec<f32>) {
    let mut state = ViewState { screen, snapped, ..ViewState::default() };
    let image = render_view(params, &mut state, topology);
    (state, image)
}

/// [`forward_view`] into a state whose `screen` and `snapped` hold the view's vertices: fills the
/// rest of it, reusing its buffers (those of an earlier forward, when the sizes repeat nothing is
/// allocated but the returned image), and returns the image.
pub fn render_view(mut params: RasterParams, state: &mut ViewState, topology: &Topology) -> Vec<f32> {
    let triangles = topology.triangles();
    let ViewState { screen, snapped, candidates, masks, orientation, contour, .. } = state;
    // Every mask word is written by the coverage pass: resizing keeps the old values without
    // clearing them.
    masks.resize(params.pixel_count() * params.words_per_pixel as usize, 0);
    // Coverage and the edge classification in the same two passes over the mesh.
    orientation.resize(triangles.len(), 0);
    let edges = coverage::EdgesStage { screen, orientation, candidates };
    let summary = coverage::coverage_and_edges(&params, snapped, topology, masks, contour, edges);
    let mut image = vec![0.0; params.pixel_count()];
    resolve::resolve(&params, masks, &mut image);
    params.set_tile_size(bin::tile_size(&params, summary.extent_sum, summary.counted));
    state.params = params;
    state.culled_triangles = summary.culled;
    image
}

/// The buffers of [`backward_view`], kept from call to call (the CPU engine keeps one per view):
/// a loop of steps allocates only the gradients it returns.
#[derive(Clone, Debug, Default)]
pub struct BackwardScratch {
    /// The `edge_grad` stage's contour bands and per-task buffers.
    edge_grad: edge_grad::EdgeGradScratch,
    /// One gradient slot per candidate edge.
    slots: Vec<EdgeGrad>,
}

/// Backward of one view: `∂L/∂I` (row-major) → `∂L/∂(screen vertex)`, with `scratch`'s buffers.
pub fn backward_view(
    state: &ViewState,
    topology: &Topology,
    d_image: &[f32],
    scratch: &mut BackwardScratch,
) -> (Vec<Vec2>, BackwardStats) {
    let stats = edge_grad::edge_grad(
        &state.params,
        &state.screen,
        &state.orientation,
        topology,
        &state.candidates,
        d_image,
        &mut scratch.slots,
        &mut scratch.edge_grad,
    );
    let mut grads = vec![Vec2::ZERO; topology.vertex_count()];
    gather::scatter(topology, &state.candidates, &scratch.slots, &mut grads);
    (grads, stats)
}
