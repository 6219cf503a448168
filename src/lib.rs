//! # diffsil — differentiable silhouette rendering with exact analytical gradients
//!
//! (Crate docs are being written; see README.md.)
#![warn(missing_docs)]

pub mod camera;
pub mod closed_form;
pub mod cpu;
mod error;
pub mod figure;
pub mod fit;
pub mod gltf_io;
pub mod gpu;
mod image;
pub mod io;
pub mod layout;
pub mod loss;
pub mod mesh;
pub mod optim;
pub mod oracle;
mod render;
pub mod self_intersection;
pub mod shapes;
pub mod skin;

pub use camera::{Camera, Projection, ViewParams};
pub use error::{Error, Result};
pub use image::Image;
pub use mesh::{Mesh, Topology};
pub use render::{Backend, BackwardStats, Frame, RenderSettings, RenderStats, Renderer, ScreenView, Step, Targets};

/// Largest |pixel coordinate| a projected vertex may have; farther vertices are treated like
/// vertices behind the camera (their triangles are culled). Keeps fixed-point coverage exact in
/// 32-bit integers on the GPU.
pub const COORD_LIMIT: f32 = 1_048_576.0;

/// Re-exported math types used in the API.
pub use glam::{Vec2, Vec3};
