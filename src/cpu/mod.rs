//! The CPU backend: one function per stage, each the twin of the WGSL shader of the same name
//! (DESIGN.md §4), parallel with rayon where it pays.
//!
//! Forward: [`project`](project::project) and [`snap`](project::snap) (one pass,
//! [`project_and_snap`](project::project_and_snap), for 3D input) → [`coverage`](coverage::coverage)
//! → [`resolve`](resolve::resolve), side by side with
//! [`face_orientations`](edges::face_orientations) → [`edges`](edges::edges).
//! Backward: [`edge_grad`](edge_grad::edge_grad) (which bins, with [`bin::bin_tiles`], only the tiles
//! its segments need) → [`gather`](gather::gather).
//!
//! The forward chooses the tile size (as [`bin::choose_tile_size`] does, from the extents the
//! coverage pass adds up) but builds no tile lists: only the backward uses them, and only in the
//! tiles a silhouette segment with a non-zero `∂L/∂I` crosses.
//!
//! Where the CPU departs from the WGSL stages' shape for speed, the result is the same bit for bit
//! (tested): coverage skips back faces it can prove redundant ([`coverage::BackFaceSkip`]) and
//! draws from per-band (or, for small images, per-task) lists rather than tile lists; `edge_grad`
//! lists occluders only for the tiles it needs and stops on hidden segments; `gather` scatters
//! the candidates' slots instead of reading every edge's.

pub mod bin;
pub mod coverage;
pub mod edge_grad;
pub mod edges;
pub mod gather;
pub mod project;
pub mod resolve;

use glam::Vec2;

use crate::layout::{RasterParams, ScreenVertex};
use crate::mesh::Topology;
use edge_grad::SegmentStats;

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

/// Forward of one view from screen vertices and their snapped positions ([`project::snap`], or both
/// from [`project::project_and_snap`]): returns the state and the image.
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
pub fn backward_view(state: &ViewState, topology: &Topology, d_image: &[f32]) -> (Vec<Vec2>, SegmentStats) {
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
