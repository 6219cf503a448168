//! Finite-difference checks of the renderer's analytic gradients against the exact-area oracle.
//!
//! The loss is `L = Σ w_ij · I(i, j)` with fixed random weights `w` (seeded), so `∂L/∂I = w`. The
//! analytic gradient comes from `Renderer::backward_screen` (2D) or `Renderer::backward` (3D); the
//! reference is central differences of `L` evaluated on `oracle::exact_image` (f64), which is the
//! ideal image the backward differentiates (ARCHITECTURE.md, *The method* and *Data path*).
//!
//! **2D.** Vertices are `f32`. Each difference quotient uses actually representable values placed
//! exactly symmetrically about the vertex ([`symmetric_pair`]) and divides by the actual step
//! `x₊ − x₋`, so rounding adds no error at all and the step can be small. The default step is
//! `2⁻¹⁴ ≈ 6e-5` px rather than 1e-3 px: `L` is only piecewise smooth, and a larger step
//! straddles its kinks — an edge passing exactly through pixel corners (error O(h) per corner), or
//! a sliver face seen nearly edge-on whose free vertex lies within 1e-3 px of a contour (the
//! `two_spheres` scene has one at 3.6e-4 px). With 1e-3 px those scenes measure 5e-4 and 1e-2.
//!
//! **3D.** The reference moves world points in `f64` and maps them to the screen with its own
//! implementation of the documented camera model ([`project_f64`], from the camera's
//! `ViewParams`): a vertex lands at the renderer's own `f32` screen point plus the `f64`
//! projection's difference, so the differences are taken around exactly the point the analytic
//! gradient is evaluated at (with the `f64` points themselves as base, near-degenerate slivers of
//! the bunny gave 3e-4 of spurious error), while the derivative of the map is the independent
//! `f64` one — the camera Jacobian is checked. The oracle takes `f32`, and that rounding (≤ ½ ulp
//! ≈ 1e-6 px) would swamp a small step, so each evaluation is corrected to first order:
//! `L(s) ≈ L(round(s)) − g₂ · (round(s) − s)`, with `g₂` the 2D finite-difference gradient of the
//! oracle at the base point (a reference quantity: nothing from the renderer is used). The step
//! moves a typical vertex by `h` pixels.
//!
//! **Cost.** A single-vertex difference is evaluated on a window ([`VertexDelta`]): moving vertex
//! `v` changes only the pixels its incident triangles touch, and those depend only on the
//! triangles overlapping them, so the oracle runs on that window and subset. A difference where
//! every vertex moves is summed over the pixels a possible silhouette edge touches
//! ([`OracleLoss::loss_difference`]); every other pixel is wholly covered or wholly empty in both
//! states. `tests/cpu/gradients.rs` checks both shortcuts against whole-image evaluations.
//!
//! Reported errors: `‖g − g_fd‖ / ‖g_fd‖` over the full vertex gradient, and `|D − D_fd| / |D_fd|`
//! for directional derivatives along random directions (all vertices move; directions nearly
//! orthogonal to the gradient, where a relative error means nothing, are redrawn).

#![allow(dead_code)]

use std::fmt;

use diffsil::reference::oracle::exact_image;
use diffsil::{Image, RenderSettings, Renderer, Vec2, Vec3, ViewParams};
use glam::{DVec2, DVec3};

pub use super::rng::Rng;
use super::scenes::{Scene2d, Scene3d};

/// `Σ w · image` in f64.
pub fn weighted_sum(image: &[f64], weights: &[f32]) -> f64 {
    image.iter().zip(weights).map(|(&i, &w)| i * w as f64).sum()
}

/// Result of one finite-difference check.
#[derive(Clone, Debug)]
pub struct Check {
    /// Scene name.
    pub name: String,
    /// `‖g − g_fd‖ / ‖g_fd‖` over all vertex coordinates (`None`: not computed).
    pub full: Option<f64>,
    /// `‖g_fd‖` (or, without a full gradient, the norm of the directional derivatives).
    pub fd_norm: f64,
    /// Largest `|g − g_fd|` of one coordinate.
    pub max_abs: f64,
    /// `|D − D_fd| / |D_fd|` per random direction.
    pub directions: Vec<f64>,
    /// Coordinates compared.
    pub coordinates: usize,
}

impl Check {
    /// The largest relative error of all.
    pub fn worst(&self) -> f64 {
        self.directions.iter().copied().fold(self.full.unwrap_or(0.0), f64::max)
    }

    /// Panics unless every relative error is at most `tol` and the gradient is not trivially zero.
    pub fn assert_within(&self, tol: f64) {
        assert!(
            self.fd_norm > 1e-3,
            "{}: the reference gradient is ~0 ({}): the scene tests nothing",
            self.name,
            self.fd_norm
        );
        assert!(
            self.full.is_none_or(|e| e <= tol) && self.directions.iter().all(|&e| e <= tol),
            "{}: relative error above {tol}: {self}",
            self.name
        );
    }
}

impl fmt::Display for Check {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.full {
            Some(full) => write!(
                f,
                "{:<16} full {full:.2e} (‖g_fd‖ {:.3}, max abs {:.1e}, {} coords)  directions",
                self.name, self.fd_norm, self.max_abs, self.coordinates
            )?,
            None => write!(f, "{:<16} ({} coords)  directions", self.name, self.coordinates)?,
        }
        for e in &self.directions {
            write!(f, " {e:.2e}")?;
        }
        Ok(())
    }
}

/// Default 2D step in pixels, `2⁻¹⁴` (see the module docs).
pub const H_2D: f64 = 1.0 / 16384.0;

/// Smallest 2D step for `g₂` (the rounding compensation of 3D checks): `2⁻¹⁸` px, about two ulps
/// of a coordinate in `[32, 64)` (the steps must stay representable).
pub const H_G2: f64 = 1.0 / 262144.0;

/// Default 3D step: the pixels a world step moves a typical vertex by.
pub const H_3D_PX: f64 = 1.0 / 16384.0;

/// Options of a finite-difference check.
#[derive(Clone, Copy, Debug)]
pub struct FdOptions {
    /// Step: pixels in 2D; in 3D, the pixels a world step should move a vertex by.
    pub h: f64,
    /// Number of random directions.
    pub directions: usize,
    /// Seed of the weights and directions.
    pub seed: u64,
    /// Renderer settings (F does not matter for the backward; inside/outside do).
    pub settings: RenderSettings,
}

impl Default for FdOptions {
    fn default() -> Self {
        FdOptions { h: H_2D, directions: 3, seed: 1, settings: RenderSettings::default() }
    }
}

/// Compares full and directional derivatives: `analytic` per coordinate, `fd` per coordinate,
/// and per direction the pair (analytic, reference).
fn summarise(name: &str, analytic: &[f64], fd: &[f64], directions: Vec<(f64, f64)>) -> Check {
    let diff = analytic.iter().zip(fd).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
    let fd_norm = fd.iter().map(|b| b * b).sum::<f64>().sqrt();
    let max_abs = analytic.iter().zip(fd).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    Check {
        name: name.to_string(),
        full: Some(if fd_norm > 0.0 { diff / fd_norm } else { diff }),
        fd_norm,
        max_abs,
        directions: directions.iter().map(|&(a, r)| (a - r).abs() / r.abs().max(1e-300)).collect(),
        coordinates: analytic.len(),
    }
}

/// Draws a direction whose analytic directional derivative is not tiny (at least 0.3 of the
/// typical `‖g‖/√n` of a random direction), so that a relative error is meaningful.
fn direction_for(rng: &mut Rng, grad: &[f64]) -> Vec<f64> {
    let n = grad.len();
    let norm = grad.iter().map(|g| g * g).sum::<f64>().sqrt();
    for _ in 0..100 {
        let u = rng.direction(n);
        let d: f64 = u.iter().zip(grad).map(|(a, b)| a * b).sum();
        if d.abs() >= 0.3 * norm / (n as f64).sqrt() {
            return u;
        }
    }
    rng.direction(n)
}

mod coincident;
mod screen;
mod world;

// Not every test binary uses both.
#[allow(unused_imports)]
pub use coincident::*;
#[allow(unused_imports)]
pub use screen::*;
#[allow(unused_imports)]
pub use world::*;
