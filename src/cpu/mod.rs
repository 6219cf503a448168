//! The CPU backend: one function per stage, each the twin of the WGSL shader of the same name
//! (see ARCHITECTURE.md), parallel with rayon where it pays.
//!
//! Forward: [`project`](project::project) and [`snap`](project::snap) (one pass,
//! [`project_and_snap`](project::project_and_snap), for 3D input) → [`coverage`](coverage::coverage)
//! → [`resolve`](resolve::resolve), with [`face_orientations`](edges::face_orientations) →
//! [`edges`](edges::edges) computed in coverage's passes over the faces and the edges
//! ([`coverage_and_edges`](coverage::coverage_and_edges): each face's vertex indices and each
//! edge's faces are read once for both stages).
//! Backward: [`edge_grad`](edge_grad::edge_grad) (which finds the visible parts of the silhouette
//! segments from the view's contour, [`edge_grad::contour`], rather than from triangles binned
//! near them) → [`gather`](gather::gather).
//!
//! The engine keeps the states of dropped frames and refills their buffers ([`render_view`]),
//! and keeps the backward's buffers per view ([`BackwardScratch`]), so a loop of steps allocates
//! only what it returns.
//!
//! The forward chooses the tile size (as [`bin::choose_tile_size`] does, from the extents the
//! coverage pass adds up) but builds no tile lists, and neither does the backward: [`bin::bin`],
//! the twin of the WGSL `bin` stages, serves the tests (the triangle reference of `edge_grad`'s).
//!
//! Where the CPU departs from the WGSL stages' shape for speed, the result is the same (tested):
//! bit for bit where coverage fills the masks from the view's contour ([`coverage::contour`])
//! instead of drawing every triangle, and where `gather` scatters the candidates' slots instead
//! of reading every edge's; `edge_grad` finds the covered parts of a segment from the contour
//! edges that cross it ([`edge_grad::contour`]) instead of scanning the triangles binned near it,
//! the same covered points with interval ends that can differ by a rounding of the last bit
//! (see [`edge_grad::edge_grad`]).

pub mod bin;
pub mod coverage;
pub mod edge_grad;
pub mod edges;
mod engine;
pub mod gather;
pub(crate) mod isa;
pub mod project;
pub mod resolve;
mod view;

pub use engine::CpuEngine;
pub use view::{backward_view, forward_view, render_view, BackwardScratch, ViewState};
