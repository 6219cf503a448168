//! The CPU backend: one function per stage, each the twin of the WGSL shader of the same name
//! (see ARCHITECTURE.md), parallel with rayon where it pays.
//!
//! Forward: [`project`](project::project) and [`snap`](project::snap) (one pass,
//! [`project_and_snap`](project::project_and_snap), for 3D input) → [`coverage`](coverage::coverage)
//! → [`resolve`](resolve::resolve), side by side with
//! [`face_orientations`](edges::face_orientations) → [`edges`](edges::edges).
//! Backward: [`edge_grad`](edge_grad::edge_grad) (which bins, with [`bin::bin_tiles`], only the cells
//! its segments need, over a [`bin::CellGrid`] finer than the tiles when the triangles are smaller
//! than a pixel) → [`gather`](gather::gather).
//!
//! The engine keeps the states of dropped frames and refills their buffers ([`render_view`]),
//! and keeps the backward's buffers per view ([`BackwardScratch`]), so a loop of steps allocates
//! only what it returns.
//!
//! The forward chooses the tile size (as [`bin::choose_tile_size`] does, from the extents the
//! coverage pass adds up) but builds no tile lists: only the backward uses them, and only in the
//! tiles a silhouette segment with a non-zero `∂L/∂I` crosses.
//!
//! Where the CPU departs from the WGSL stages' shape for speed, the result is the same bit for bit
//! (tested): coverage fills the masks from the view's contour ([`coverage::contour`]) instead of
//! drawing every triangle, and writes every triangle's snapped box for the backward; `edge_grad`
//! lists occluders only for the cells it needs and stops on hidden segments; `gather` scatters
//! the candidates' slots instead of reading every edge's.

pub mod bin;
pub mod coverage;
pub mod edge_grad;
pub mod edges;
mod engine;
pub mod gather;
pub mod project;
pub mod resolve;
mod view;

pub use engine::CpuEngine;
pub use view::{backward_view, forward_view, render_view, BackwardScratch, ViewState};
