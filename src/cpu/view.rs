//! One view through the CPU stages: the forward, and the backward from its state.

use glam::Vec2;

use super::{bin, coverage, edge_grad, edges, gather, resolve};
use crate::engine::BackwardStats;
use crate::mirror::{RasterParams, ScreenVertex};
use crate::scene::mesh::Topology;

/// What the forward of one view keeps for its backward.
#[derive(Clone, Debug)]
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
}

/// Forward of one view from screen vertices and their snapped positions ([`super::project::snap`], or both
/// from [`super::project::project_and_snap`]): returns the state and the image.
pub fn forward_view(
    mut params: RasterParams,
    screen: Vec<ScreenVertex>,
    snapped: Vec<[i32; 2]>,
    topology: &Topology,
) -> (ViewState, Vec<f32>) {
    let triangles = topology.triangles();
    // Coverage and the edge classification are independent: run them side by side.
    let ((summary, image), candidates) = rayon::join(
        || {
            let skip = coverage::BackFaceSkip::new(topology, &snapped);
            let mut masks = vec![0u32; params.pixel_count() * params.words_per_pixel as usize];
            let summary = coverage::coverage(&params, &snapped, triangles, skip.as_ref(), &mut masks);
            let mut image = vec![0.0; params.pixel_count()];
            resolve::resolve(&params, &masks, &mut image);
            (summary, image)
        },
        || {
            let mut orientation = vec![0i8; triangles.len()];
            edges::face_orientations(&screen, triangles, &mut orientation);
            let mut candidates = Vec::new();
            edges::edges(&orientation, topology, &mut candidates);
            candidates
        },
    );
    params.set_tile_size(bin::tile_size(&params, summary.extent_sum, summary.counted));
    (ViewState { params, screen, snapped, candidates, culled_triangles: summary.culled }, image)
}

/// Backward of one view: `∂L/∂I` (row-major) → `∂L/∂(screen vertex)`.
pub fn backward_view(state: &ViewState, topology: &Topology, d_image: &[f32]) -> (Vec<Vec2>, BackwardStats) {
    let mut slots = Vec::new();
    let stats = edge_grad::edge_grad(
        &state.params,
        &state.screen,
        &state.snapped,
        topology,
        &state.candidates,
        d_image,
        &mut slots,
    );
    let mut grads = vec![Vec2::ZERO; topology.vertex_count()];
    gather::gather(topology, &state.candidates, &slots, &mut grads);
    (grads, stats)
}
