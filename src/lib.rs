//! # diffsil — differentiable silhouette rendering with exact analytical gradients
//!
//! diffsil renders the silhouette of a triangle mesh — each pixel's value is the fraction of its
//! area the projected mesh covers — and returns the *exact* derivative of that covered area
//! with respect to the mesh's vertices, in closed form (Wu, Jiang, Yu 2020, *Analytical
//! derivatives for differentiable renderer: 3D pose estimation by silhouette consistency*). No
//! blur, no sampling noise, no approximated gradient; the same answer, bit for bit, on every run.
//! It runs on the CPU (Rust, parallel with rayon) and on any GPU wgpu drives (WGSL compute
//! shaders), with the same API.
//!
//! # Quick start
//!
//! Render a mesh, compare it with a target silhouette, differentiate, and take Adam steps on a
//! translation of the mesh:
//!
//! ```
//! use diffsil::optim::Adam;
//! use diffsil::{loss, shapes, Camera, Mesh, RenderSettings, Renderer, Vec3};
//!
//! // A mesh: built in, or from a file with `diffsil::io::gltf::load_mesh("bunny.obj")?`
//! // (.obj, .gltf, .glb).
//! let mesh = shapes::icosphere(2);
//! // A 64×64 perspective camera at (0, 0, 4) looking at the origin, vertical fov 0.8 rad.
//! let camera = Camera::perspective(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 0.8, 64, 64);
//! let mut renderer = Renderer::new(RenderSettings::default())?; // CPU backend, F = 4
//!
//! // The target: the silhouette of the same mesh moved by (0.1, 0.05, 0).
//! let moved = |t: Vec3| Mesh::with_topology(
//!     mesh.positions().iter().map(|p| *p + t).collect(),
//!     mesh.topology().clone(), // shared: no rebuild of the edge tables
//! );
//! let target = renderer.render(&moved(Vec3::new(0.1, 0.05, 0.0))?, &[camera])?.images()[0].clone();
//!
//! let mut t = [0.0f32; 3];
//! let mut adam = Adam::new(0.01);
//! let mut losses = Vec::new();
//! for _ in 0..10 {
//!     let frame = renderer.render(&moved(Vec3::from(t))?, &[camera])?; // forward: one image per camera
//!     let l2 = loss::squared_error(&frame.images()[0], &target)?;       // L and ∂L/∂I
//!     let grad: Vec<Vec3> = renderer.backward(&frame, &[l2.grad])?;   // ∂L/∂(3D vertex)
//!     let d_t: Vec3 = grad.iter().sum();                               // every vertex moves with t
//!     adam.step(&mut t, &d_t.to_array())?;                             // one Adam step
//!     losses.push(l2.value);
//! }
//! assert!(losses[9] < 0.1 * losses[0], "{losses:?}");
//! # Ok::<(), diffsil::Error>(())
//! ```
//!
//! Several cameras go into one [`Renderer::render`] call and their gradients add up in
//! [`Renderer::backward`]. Many meshes of one topology (poses, people, frames) go into one
//! [`Renderer::render_batch`] / [`Renderer::squared_error_step_batch`] call as [`Instance`]s,
//! each with its own cameras: one GPU submission for the whole batch. For a custom projection or a 2D problem, [`Renderer::render_screen`]
//! takes pixel coordinates per vertex and [`Renderer::backward_screen`] returns `∂L/∂(2D vertex)`.
//!
//! # What is computed
//!
//! Pixel `(i, j)` (row `i`, column `j`) covers the square `[j, j+1] × [i, i+1]` of screen space
//! (x right, y down). Its value is `I = p0 + (p1 − p0)·area(U ∩ pixel)`, `U` the union of the
//! projected triangles (whatever their winding), `p1` = [`RenderSettings::inside`], `p0` =
//! [`RenderSettings::outside`].
//!
//! - The **forward** estimates the area with `F×F` samples per pixel
//!   ([`RenderSettings::supersample`], default 4) on an exact fixed-point grid.
//! - The **backward** differentiates the exact area (the `F → ∞` limit). For each visible piece
//!   of a silhouette edge `va → vb` inside a pixel — the edge clipped to the pixel keeps the
//!   parameters `[sa, sb]` of `va + s·(vb − va)`; `L` is its length and `n` its unit normal
//!   pointing out of the silhouette —
//!
//!   ```text
//!   ∂I/∂va = (p1 − p0)·L·n·[(sb − sa) − (sb² − sa²)/2]
//!   ∂I/∂vb = (p1 − p0)·L·n·(sb² − sa²)/2
//!   ```
//!
//!   ([`reference::closed_form`]; the paper's Eqs. 12–16 in a simpler form). Only edges that can lie on the
//!   silhouette take part (open boundary edges and contour edges, whose adjacent faces lie on one
//!   side), and only where the outside of the edge is not covered by another triangle: an edge
//!   *inside* the silhouette gets an exact zero. The tests check every gradient against central
//!   differences of an exact-area [`reference::oracle`].
//!
//! # Engines
//!
//! [`Renderer::with_backend`] takes a [`Backend`]: [`Backend::Cpu`] (also [`Renderer::new`]),
//! `Backend::Gpu` (WGSL on wgpu, feature `gpu`; adapter from `DIFFSIL_ADAPTER` / `WGPU_BACKEND`
//! with `gpu::GpuOptions::from_env`), or [`Backend::Auto`] (a hardware GPU if there is one, else
//! the CPU). [`Renderer::backend_name`] says which one runs. Both give the same images (bit for
//! bit) and the same gradients (to `f32` rounding), deterministically: no float atomics anywhere.
//! The CPU engine ([`cpu`]) has one function per stage, each the twin of the WGSL shader of the
//! same name; `ARCHITECTURE.md` in the repository has the stage table.
//!
//! # Features
//!
//! - `gpu` (default): the WGSL engine on wgpu ([`Backend`]`::Gpu`, the `gpu` module).
//! - `pose` (default): skinning, the built-in figure, the self-intersection penalty, pose fitting
//!   (the `pose` module) and glTF/GLB files (`io::gltf`).
//!
//! `default-features = false` leaves the CPU renderer, the losses, Adam, OBJ/PNG files and the
//! references, without wgpu, naga, gltf or obvhs.
//!
//! # The public API
//!
//! | where | what |
//! |---|---|
//! | crate root | [`Renderer`], [`RenderSettings`], [`Backend`], [`Frame`], [`ScreenView`], [`Targets`], [`Step`], [`Instance`], [`BatchFrame`], [`RenderStats`], [`BackwardStats`], [`StageTiming`]; [`Camera`], [`Extrinsics`], [`Orbit`], [`Projection`]; [`RigidTransform`], [`RigidGradient`], [`CameraGradient`], [`camera_gradient`]; [`ViewParams`], [`Mesh`], [`Topology`], [`Image`]; [`Error`], [`Result`], [`COORD_LIMIT`]; [`Vec2`], [`Vec3`] |
//! | [`scene`] | [`scene::camera`], [`scene::mesh`], [`scene::image`], [`shapes`] (icosphere, blob) |
//! | [`loss`], [`optim`] | squared error (paper Eq. 18), soft IoU, blurred squared error, each with `∂L/∂I`; Adam |
//! | [`io`] | OBJ loading, PNG images and targets, welding; `io::gltf` (feature `pose`): glTF/GLB static and skinned meshes |
//! | `pose` (feature `pose`) | `pose::skin` (linear-blend skinning and its backward), `pose::figure` (a built-in 24-joint figure), `pose::self_intersection` (paper Eq. 19), `pose::fit` (pose fitting, paper §4) |
//! | [`reference`](mod@reference) | the per-segment closed form and the exact-area oracle |
//! | [`random`] | a seeded generator for reproducible scenes |
//! | [`cpu`], `gpu`, [`mirror`] | the two engines' stages and the buffer layouts they share with WGSL |
//!
//! # Errors
//!
//! Everything that can fail returns [`Result`] with an [`Error`] that says what was wrong and
//! what to do; bad input (non-finite vertices, out-of-range indices, mismatched sizes, invalid
//! cameras) is an error, never a panic, and degenerate geometry (zero-area triangles, zero-length
//! edges, vertices behind the camera) gives no NaN.
//!
//! # Examples
//!
//! `cargo run --release --example NAME -- --help` for each: `fit_pose` (the paper's pose
//! fitting), `render` (a silhouette PNG, timings, memory), `gradient_maps` (per-pixel gradient
//! images, analytic against finite differences, the paper's Fig. 6) and `silhouette` (a quick
//! gradient check).
#![warn(missing_docs)]
#![cfg_attr(docsrs, feature(doc_cfg))]

// Layers, bottom to top: every module imports only from the ones above it in this list.
pub mod cpu;
mod engine;
mod error;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod io;
pub mod loss;
pub mod mirror;
pub mod optim;
#[cfg(feature = "pose")]
pub mod pose;
pub mod random;
pub mod reference;
mod render;
pub mod scene;

pub use engine::StageTiming;
pub use error::{Error, Result};
pub use mirror::{ViewParams, COORD_LIMIT};
pub use render::batch::{BatchFrame, Instance};
pub use render::params::{camera_gradient, CameraGradient, RigidGradient, RigidTransform};
pub use render::{
    frame_bytes, Backend, BackwardStats, Frame, RenderSettings, RenderStats, Renderer, ScreenView, Step, Targets,
    MAX_FRAME_BYTES, MAX_PIXEL_VALUE,
};
pub use scene::camera::{Camera, Extrinsics, Projection};
pub use scene::image::{Image, PixelRect};
pub use scene::mesh::{Mesh, Topology};
pub use scene::orbit::Orbit;
pub use scene::shapes;

/// The README's Rust code, compiled and run by `cargo test` as doctests.
#[cfg(all(doctest, feature = "pose"))]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// Re-exported math types used in the API.
pub use glam::{Mat3, Vec2, Vec3};
