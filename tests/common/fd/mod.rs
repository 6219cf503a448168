//! Finite-difference checks of the renderer's analytic gradients against the exact-area oracle.
//!
//! The loss is `L = Σ w_ij · I(i, j)` with fixed random weights `w` (seeded), so `∂L/∂I = w`. The
//! analytic gradient comes from `Renderer::backward_screen` (2D) or `Renderer::backward` (3D); the
//! reference is central differences of `L` evaluated on `oracle::exact_image` (f64), which is the
//! ideal image the backward differentiates (DESIGN.md §1–§3).
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
//! states. `tests/gradients.rs` checks both shortcuts against whole-image evaluations.
//!
//! Reported errors: `‖g − g_fd‖ / ‖g_fd‖` over the full vertex gradient, and `|D − D_fd| / |D_fd|`
//! for directional derivatives along random directions (all vertices move; directions nearly
//! orthogonal to the gradient, where a relative error means nothing, are redrawn).

#![allow(dead_code)]

use std::fmt;

use diffsil::reference::oracle::exact_image;
use diffsil::{Image, RenderSettings, Renderer, Vec2, Vec3, ViewParams};
use glam::{DVec2, DVec3};

use super::scenes::{Scene2d, Scene3d};

/// A tiny seeded PRNG (xorshift64*), so tests need no extra dependency.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed (any value, zero included).
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03 | 1)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in `[0, 1)`.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// `n` loss weights uniform in `[-1, 1]` (as f32, so `∂L/∂I` is exactly representable).
    pub fn weights(&mut self, n: usize) -> Vec<f32> {
        (0..n).map(|_| self.range(-1.0, 1.0) as f32).collect()
    }

    /// A random unit vector of dimension `n` (normalised uniform cube sample).
    pub fn direction(&mut self, n: usize) -> Vec<f64> {
        let v: Vec<f64> = (0..n).map(|_| self.range(-1.0, 1.0)).collect();
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.into_iter().map(|x| x / norm).collect()
    }
}

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

// -------------------------------------------------------------------------------------------------
// 2D
// -------------------------------------------------------------------------------------------------

/// The analytic screen-space gradient of `Σ w·I` for a 2D scene, flattened `[x0, y0, x1, ...]`.
pub fn analytic_2d(scene: &Scene2d, vertices: &[Vec2], weights: &[f32], settings: RenderSettings) -> Vec<f64> {
    let mut renderer = Renderer::new(settings).expect("valid settings");
    let frame = renderer.render_screen(&scene.topology(), &[scene.view_with(vertices.to_vec())]).expect("render");
    let d_image = Image::from_vec(scene.width, scene.height, weights.to_vec()).expect("weights sized");
    let grads = renderer.backward_screen(&frame, &[d_image]).expect("backward");
    grads[0].iter().flat_map(|g| [g.x as f64, g.y as f64]).collect()
}

/// Representable `f32` values `x₊ ≈ x + s`, `x₋ ≈ x − s` placed *exactly* symmetrically about `x`
/// (`x₊ − x = x − x₋`). The point moving away from zero is rounded, the other one is its mirror
/// image, which is representable (a multiple of `ulp(x)` of smaller magnitude). Symmetry matters
/// where `L` has a kink (an edge exactly on a pixel border): there the central difference is the
/// mean of the one-sided slopes only for a symmetric step.
pub fn symmetric_pair(x: f32, s: f64) -> (f32, f32) {
    let x64 = x as f64;
    let away = if x64 >= 0.0 { s.abs() } else { -s.abs() };
    let outer = (x64 + away) as f32;
    let inner = (2.0 * x64 - outer as f64) as f32;
    assert_eq!(outer as f64 - x64, x64 - inner as f64, "asymmetric step at {x}");
    if (s >= 0.0) == (away >= 0.0) {
        (outer, inner)
    } else {
        (inner, outer)
    }
}

/// The weighted exact-area loss of one image: `Σ w · exact_image(vertices, triangles)`.
#[derive(Clone, Debug)]
pub struct OracleLoss {
    /// Triangles (those with a clipped vertex already removed).
    pub triangles: Vec<[u32; 3]>,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// `p1`.
    pub inside: f32,
    /// `p0`.
    pub outside: f32,
    /// `∂L/∂I`, row-major.
    pub weights: Vec<f32>,
    incident: Vec<Vec<u32>>,
}

impl OracleLoss {
    /// The loss of `triangles` over `vertex_count` vertices in a `width × height` image.
    pub fn new(
        vertex_count: usize,
        triangles: Vec<[u32; 3]>,
        width: u32,
        height: u32,
        settings: RenderSettings,
        weights: Vec<f32>,
    ) -> OracleLoss {
        let mut incident = vec![Vec::new(); vertex_count];
        for (t, tri) in triangles.iter().enumerate() {
            for &v in tri {
                if !incident[v as usize].contains(&(t as u32)) {
                    incident[v as usize].push(t as u32);
                }
            }
        }
        OracleLoss { triangles, width, height, inside: settings.inside, outside: settings.outside, weights, incident }
    }

    /// The loss of a 2D scene.
    pub fn of_scene(scene: &Scene2d, settings: RenderSettings, weights: Vec<f32>) -> OracleLoss {
        OracleLoss::new(scene.vertices.len(), scene.triangles.clone(), scene.width, scene.height, settings, weights)
    }

    /// `L` at these vertex positions (whole image).
    pub fn loss(&self, vertices: &[Vec2]) -> f64 {
        let image = exact_image(vertices, &self.triangles, self.width, self.height, self.inside, self.outside);
        weighted_sum(&image, &self.weights)
    }

    /// `L(plus) − L(minus)` summed over the pixels that a possible silhouette edge (any edge but
    /// an interior one, see [`silhouette_vertices`]) touches in either state. Every other pixel is
    /// wholly inside or wholly outside the union in both states, hence equal in both, so this is
    /// the whole difference, at a fraction of the cost on big meshes.
    pub fn loss_difference(&self, plus: &[Vec2], minus: &[Vec2]) -> f64 {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut mask = vec![false; w * h];
        for vs in [plus, minus] {
            for [a, b] in silhouette_edges(&self.triangles, vs) {
                let (p, q) = (vs[a as usize], vs[b as usize]);
                let (lo, hi) = (p.min(q), p.max(q));
                let x0 = (lo.x.floor().max(0.0) as usize).min(w);
                let x1 = (hi.x.ceil().max(0.0) as usize).min(w);
                let y0 = (lo.y.floor().max(0.0) as usize).min(h);
                let y1 = (hi.y.ceil().max(0.0) as usize).min(h);
                for i in y0..y1.max(y0 + 1).min(h) {
                    for j in x0..x1.max(x0 + 1).min(w) {
                        mask[i * w + j] = true;
                    }
                }
            }
        }
        let touches_mask = |t: &[u32; 3]| {
            [plus, minus].iter().any(|vs| {
                let p = t.map(|i| vs[i as usize]);
                let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
                let x0 = (lo.x.floor().max(0.0) as usize).min(w);
                let x1 = (hi.x.ceil().max(0.0) as usize).min(w);
                let y0 = (lo.y.floor().max(0.0) as usize).min(h);
                let y1 = (hi.y.ceil().max(0.0) as usize).min(h);
                (y0..y1).any(|i| (x0..x1).any(|j| mask[i * w + j]))
            })
        };
        let subset: Vec<[u32; 3]> = self.triangles.iter().copied().filter(|t| touches_mask(t)).collect();
        let masked_sum = |vs: &[Vec2]| -> f64 {
            let image = exact_image(vs, &subset, self.width, self.height, self.inside, self.outside);
            (0..w * h).filter(|&k| mask[k]).map(|k| image[k] * self.weights[k] as f64).sum()
        };
        masked_sum(plus) - masked_sum(minus)
    }

    /// Triangles incident to vertex `v`.
    pub fn incident(&self, v: usize) -> &[u32] {
        &self.incident[v]
    }
}

/// Single-vertex differences `L(plus) − L(minus)` around fixed base positions, where only vertex
/// `v` differs between `plus` and `minus`. Computed on the window of pixels the incident
/// triangles of `v` can touch, with only the triangles overlapping that window (found through a
/// grid of base bounding boxes): the other pixels are equal in both, and no other triangle
/// reaches the window's pixels. Exact, and much cheaper than two whole-image evaluations.
#[derive(Clone, Debug)]
pub struct VertexDelta {
    base: Vec<Vec2>,
    cell: f32,
    columns: usize,
    rows: usize,
    grid: Vec<Vec<u32>>,
}

impl VertexDelta {
    /// The index of `oracle`'s triangles at the base positions `base`.
    pub fn new(oracle: &OracleLoss, base: &[Vec2]) -> VertexDelta {
        let cell = 4.0f32;
        let columns = (oracle.width as f32 / cell).ceil() as usize;
        let rows = (oracle.height as f32 / cell).ceil() as usize;
        let mut grid = vec![Vec::new(); columns * rows];
        for (t, tri) in oracle.triangles.iter().enumerate() {
            let p = tri.map(|i| base[i as usize]);
            let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
            if hi.x < 0.0 || hi.y < 0.0 || lo.x > oracle.width as f32 || lo.y > oracle.height as f32 {
                continue; // off-image: touches no pixel
            }
            let c0 = ((lo.x / cell).floor().max(0.0) as usize).min(columns - 1);
            let c1 = ((hi.x / cell).floor().max(0.0) as usize).min(columns - 1);
            let r0 = ((lo.y / cell).floor().max(0.0) as usize).min(rows - 1);
            let r1 = ((hi.y / cell).floor().max(0.0) as usize).min(rows - 1);
            for r in r0..=r1 {
                for c in c0..=c1 {
                    grid[r * columns + c].push(t as u32);
                }
            }
        }
        VertexDelta { base: base.to_vec(), cell, columns, rows, grid }
    }

    /// `L(base with v at plus) − L(base with v at minus)`.
    pub fn delta(&self, oracle: &OracleLoss, v: usize, plus: Vec2, minus: Vec2) -> f64 {
        let incident = oracle.incident(v);
        if incident.is_empty() {
            return 0.0;
        }
        let at = |i: u32, pv: Vec2| if i as usize == v { pv } else { self.base[i as usize] };
        let bbox = |t: u32, pv: Vec2| {
            let p = oracle.triangles[t as usize].map(|i| at(i, pv));
            (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]))
        };
        let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        for &t in incident {
            for pv in [plus, minus] {
                let (a, b) = bbox(t, pv);
                lo = lo.min(a);
                hi = hi.max(b);
            }
        }
        // Pixel window [x0, x1) × [y0, y1): every pixel the incident triangles touch.
        let x0 = (lo.x.floor() as i64).clamp(0, oracle.width as i64);
        let x1 = (hi.x.ceil() as i64).clamp(0, oracle.width as i64);
        let y0 = (lo.y.floor() as i64).clamp(0, oracle.height as i64);
        let y1 = (hi.y.ceil() as i64).clamp(0, oracle.height as i64);
        if x0 >= x1 || y0 >= y1 {
            return 0.0;
        }
        let (wlo, whi) = (Vec2::new(x0 as f32, y0 as f32), Vec2::new(x1 as f32, y1 as f32));
        let cell_of = |x: f32, n: usize| ((x / self.cell).floor().max(0.0) as usize).min(n - 1);
        let mut candidates: Vec<u32> = incident.to_vec();
        for r in cell_of(wlo.y, self.rows)..=cell_of(whi.y, self.rows) {
            for c in cell_of(wlo.x, self.columns)..=cell_of(whi.x, self.columns) {
                for &t in &self.grid[r * self.columns + c] {
                    let (a, b) = bbox(t, self.base[v]);
                    if a.x <= whi.x && a.y <= whi.y && b.x >= wlo.x && b.y >= wlo.y {
                        candidates.push(t);
                    }
                }
            }
        }
        candidates.sort_unstable();
        candidates.dedup();
        // Local vertex numbering for the subset.
        let mut globals: Vec<u32> = candidates.iter().flat_map(|&t| oracle.triangles[t as usize]).collect();
        globals.sort_unstable();
        globals.dedup();
        let local = |i: u32| globals.binary_search(&i).expect("subset vertex") as u32;
        let triangles: Vec<[u32; 3]> = candidates.iter().map(|&t| oracle.triangles[t as usize].map(local)).collect();
        // Evaluate on the window alone, in coordinates shifted by the window's integer origin.
        // The shift is exact for every vertex at or right/below of the origin (v and its
        // neighbours among them); a far vertex of another triangle may round, identically in
        // both evaluations, which only moves the point the difference is taken at by ~1e-7 px.
        let (ww, wh) = ((x1 - x0) as u32, (y1 - y0) as u32);
        let origin = Vec2::new(x0 as f32, y0 as f32);
        let window_sum = |pv: Vec2| -> f64 {
            let vertices: Vec<Vec2> = globals.iter().map(|&i| at(i, pv) - origin).collect();
            let image = exact_image(&vertices, &triangles, ww, wh, oracle.inside, oracle.outside);
            let mut sum = 0.0;
            for i in 0..wh as i64 {
                for j in 0..ww as i64 {
                    let k = ((i + y0) * oracle.width as i64 + j + x0) as usize;
                    sum += image[(i * ww as i64 + j) as usize] * oracle.weights[k] as f64;
                }
            }
            sum
        };
        window_sum(plus) - window_sum(minus)
    }
}

/// Finite-difference reference of the full screen-space gradient of `oracle` at `vertices`,
/// flattened, with step `h` pixels.
pub fn fd_gradient_2d(oracle: &OracleLoss, vertices: &[Vec2], h: f64) -> Vec<f64> {
    fd_gradient_2d_subset(oracle, vertices, h, &vec![true; vertices.len()])
}

/// [`fd_gradient_2d`] for the vertices with `keep[v]`, zero for the others.
pub fn fd_gradient_2d_subset(oracle: &OracleLoss, vertices: &[Vec2], h: f64, keep: &[bool]) -> Vec<f64> {
    use rayon::prelude::*;
    let index = VertexDelta::new(oracle, vertices);
    let per_vertex: Vec<[f64; 2]> = (0..vertices.len())
        .into_par_iter()
        .map(|v| {
            if !keep[v] {
                return [0.0; 2];
            }
            [0, 1].map(|c| {
                let (mut plus, mut minus) = (vertices[v], vertices[v]);
                (plus[c], minus[c]) = symmetric_pair(vertices[v][c], h);
                index.delta(oracle, v, plus, minus) / (plus[c] as f64 - minus[c] as f64)
            })
        })
        .collect();
    per_vertex.into_iter().flatten().collect()
}

/// Edges that may lie on the silhouette, by a reference rule independent of the renderer: every
/// edge except those with exactly two faces strictly on opposite sides.
pub fn silhouette_edges(triangles: &[[u32; 3]], vertices: &[Vec2]) -> Vec<[u32; 2]> {
    use std::collections::HashMap;
    let mut sides: HashMap<(u32, u32), Vec<f64>> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b, w) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let (a, b) = (a.min(b), a.max(b));
            let (pa, pb, pw) =
                (vertices[a as usize].as_dvec2(), vertices[b as usize].as_dvec2(), vertices[w as usize].as_dvec2());
            sides.entry((a, b)).or_default().push((pb - pa).perp_dot(pw - pa));
        }
    }
    let mut edges: Vec<[u32; 2]> =
        sides.into_iter().filter(|(_, c)| !(c.len() == 2 && c[0] * c[1] < 0.0)).map(|((a, b), _)| [a, b]).collect();
    edges.sort_unstable();
    edges
}

/// Vertices of [`silhouette_edges`].
pub fn silhouette_vertices(triangles: &[[u32; 3]], vertices: &[Vec2]) -> Vec<bool> {
    let mut keep = vec![false; vertices.len()];
    for [a, b] in silhouette_edges(triangles, vertices) {
        keep[a as usize] = true;
        keep[b as usize] = true;
    }
    keep
}

/// The full 2D check of `scene`: analytic vs finite differences, full gradient and directions.
pub fn check_2d(scene: &Scene2d, options: FdOptions) -> Check {
    let mut rng = Rng::new(options.seed);
    let weights = rng.weights((scene.width * scene.height) as usize);
    let analytic = analytic_2d(scene, &scene.vertices, &weights, options.settings);
    let oracle = OracleLoss::of_scene(scene, options.settings, weights);
    let fd = fd_gradient_2d(&oracle, &scene.vertices, options.h);
    let n = analytic.len();
    let directions = (0..options.directions)
        .map(|_| {
            // Each coordinate moves by about h (RMS), all at once.
            let u = direction_for(&mut rng, &analytic);
            let (mut plus, mut minus) = (scene.vertices.clone(), scene.vertices.clone());
            for (v, p) in scene.vertices.iter().enumerate() {
                for c in 0..2 {
                    let s = u[2 * v + c] * options.h * (n as f64).sqrt();
                    (plus[v][c], minus[v][c]) = symmetric_pair(p[c], s);
                }
            }
            let dl = oracle.loss(&plus) - oracle.loss(&minus);
            // Analytic prediction for the representable perturbation actually applied.
            let predicted: f64 =
                (0..n).map(|k| analytic[k] * (plus[k / 2][k % 2] as f64 - minus[k / 2][k % 2] as f64)).sum();
            (predicted, dl)
        })
        .collect();
    summarise(scene.name, &analytic, &fd, directions)
}

// -------------------------------------------------------------------------------------------------
// 3D
// -------------------------------------------------------------------------------------------------

/// The documented camera model in f64 (`ViewParams` docs): camera space `c = R·p + t`, depth
/// `d = −c.z`; perspective `x = cx + s·c.x/d`, `y = cy − s·c.y/d`; orthographic without the
/// division. `None` when the point is outside `near < d < far`.
pub fn project_f64(view: &ViewParams, p: DVec3) -> Option<DVec2> {
    let row = |r: [f32; 4]| (DVec3::new(r[0] as f64, r[1] as f64, r[2] as f64), r[3] as f64);
    let (r0, t0) = row(view.row0);
    let (r1, t1) = row(view.row1);
    let (r2, t2) = row(view.row2);
    let c = DVec3::new(r0.dot(p) + t0, r1.dot(p) + t1, r2.dot(p) + t2);
    let depth = -c.z;
    if !(depth > view.near as f64 && depth < view.far as f64) {
        return None;
    }
    let (x, y) = if view.perspective == 1 { (c.x / depth, c.y / depth) } else { (c.x, c.y) };
    let s = view.scale as f64;
    Some(DVec2::new(view.centre[0] as f64 + s * x, view.centre[1] as f64 - s * y))
}

/// The reference loss of one view of a 3D scene, with its rounding compensation.
#[derive(Clone, Debug)]
pub struct ViewReference {
    /// The camera's projection constants.
    pub view: ViewParams,
    /// The oracle loss of this view (triangles with a clipped vertex removed).
    pub oracle: OracleLoss,
    /// The 2D finite-difference gradient of `oracle` at the base screen points.
    pub g2: Vec<DVec2>,
    /// Base screen points and their triangle index.
    pub index: VertexDelta,
    /// World positions and their f64 projections at the base point.
    base_world: Vec<DVec3>,
    base_f64: Vec<DVec2>,
    /// The renderer's own `f32` screen points at the base point.
    base_f32: Vec<Vec2>,
}

impl ViewReference {
    /// The reference of view `view`; `g₂` is computed with step `h2` pixels for every vertex, or
    /// (`only_silhouette`) for the vertices of [`silhouette_vertices`] only, zero elsewhere (for big
    /// meshes: a vertex on no possible silhouette edge has a zero derivative anyway).
    pub fn new(
        scene: &Scene3d,
        view: usize,
        weights: Vec<f32>,
        settings: RenderSettings,
        only_silhouette: bool,
        h2: f64,
    ) -> ViewReference {
        let camera = scene.cameras[view];
        let params = camera.params();
        // The base screen points are the renderer's own f32 projections, so that the differences
        // are taken around exactly the point the analytic gradient is evaluated at; a
        // perturbation moves them by the f64 projection's difference (same derivative).
        let base_world: Vec<DVec3> = scene.mesh.positions().iter().map(|p| p.as_dvec3()).collect();
        let base: Vec<Option<(DVec2, Vec2)>> = scene
            .mesh
            .positions()
            .iter()
            .map(|&p| {
                let (s32, valid) = params.project(p);
                project_f64(&params, p.as_dvec3()).filter(|_| valid).map(|s64| (s64, s32))
            })
            .collect();
        let triangles: Vec<[u32; 3]> =
            scene.mesh.triangles().iter().copied().filter(|t| t.iter().all(|&i| base[i as usize].is_some())).collect();
        let oracle = OracleLoss::new(base.len(), triangles, camera.width, camera.height, settings, weights);
        let base_f64: Vec<DVec2> = base.iter().map(|b| b.map_or(DVec2::ZERO, |b| b.0)).collect();
        let rounded: Vec<Vec2> = base.iter().map(|b| b.map_or(Vec2::ZERO, |b| b.1)).collect();
        let g2 = if only_silhouette {
            let keep = silhouette_vertices(&oracle.triangles, &rounded);
            fd_gradient_2d_subset(&oracle, &rounded, h2, &keep)
        } else {
            fd_gradient_2d(&oracle, &rounded, h2)
        };
        let g2 = g2.chunks(2).map(|c| DVec2::new(c[0], c[1])).collect();
        let index = VertexDelta::new(&oracle, &rounded);
        ViewReference { view: params, oracle, g2, index, base_world, base_f64, base_f32: rounded }
    }

    /// Screen point of world point `p` of vertex `v`: the renderer's base point moved by the f64
    /// projection's difference. (Test scenes keep every vertex in front of the camera.)
    fn project_one(&self, v: usize, p: DVec3) -> DVec2 {
        if p == self.base_world[v] {
            return self.base_f32[v].as_dvec2();
        }
        let s = project_f64(&self.view, p).expect("test vertices stay in front of the camera");
        self.base_f32[v].as_dvec2() + (s - self.base_f64[v])
    }

    /// Screen points of world points.
    fn project(&self, positions: &[DVec3]) -> Vec<DVec2> {
        positions.iter().enumerate().map(|(v, &p)| self.project_one(v, p)).collect()
    }

    /// First-order correction for handing `round(s)` instead of `s` to the oracle: `−g₂·(round(s) − s)`.
    fn compensation(&self, v: usize, s: DVec2) -> f64 {
        -self.g2[v].dot(round(s).as_dvec2() - s)
    }

    /// `L` of this view at world positions (whole image), rounding-compensated.
    pub fn loss(&self, positions: &[DVec3]) -> f64 {
        let screen = self.project(positions);
        let rounded: Vec<Vec2> = screen.iter().map(|&s| round(s)).collect();
        self.oracle.loss(&rounded) + screen.iter().enumerate().map(|(v, &s)| self.compensation(v, s)).sum::<f64>()
    }

    /// `L(plus) − L(minus)` of this view for two sets of world positions, rounding-compensated,
    /// summed over the silhouette pixels only ([`OracleLoss::loss_difference`]).
    pub fn loss_difference(&self, plus: &[DVec3], minus: &[DVec3]) -> f64 {
        let (sp, sm) = (self.project(plus), self.project(minus));
        let rp: Vec<Vec2> = sp.iter().map(|&s| round(s)).collect();
        let rm: Vec<Vec2> = sm.iter().map(|&s| round(s)).collect();
        let compensation: f64 = (0..sp.len()).map(|v| self.compensation(v, sp[v]) - self.compensation(v, sm[v])).sum();
        self.oracle.loss_difference(&rp, &rm) + compensation
    }

    /// `L(plus) − L(minus)` of this view when only vertex `v` moves (to world points `plus` and
    /// `minus`), rounding-compensated.
    pub fn delta_one_vertex(&self, v: usize, plus: DVec3, minus: DVec3) -> f64 {
        let (sp, sm) = (self.project_one(v, plus), self.project_one(v, minus));
        self.index.delta(&self.oracle, v, round(sp), round(sm)) + self.compensation(v, sp) - self.compensation(v, sm)
    }
}

fn round(s: DVec2) -> Vec2 {
    Vec2::new(s.x as f32, s.y as f32)
}

/// The analytic world-space gradient of `Σ_views Σ w·I`, flattened `[x0, y0, z0, x1, ...]`.
pub fn analytic_3d(scene: &Scene3d, weights: &[Vec<f32>], settings: RenderSettings) -> Vec<f64> {
    let mut renderer = Renderer::new(settings).expect("valid settings");
    let frame = renderer.render(&scene.mesh, &scene.cameras).expect("render");
    let d_images: Vec<Image> = scene
        .cameras
        .iter()
        .zip(weights)
        .map(|(c, w)| Image::from_vec(c.width, c.height, w.clone()).expect("weights sized"))
        .collect();
    let grads: Vec<Vec3> = renderer.backward(&frame, &d_images).expect("backward");
    grads.iter().flat_map(|g| [g.x as f64, g.y as f64, g.z as f64]).collect()
}

/// World step that moves a typical vertex of the first view by about `h_px` pixels: `h_px` over
/// the median pixels-per-world-unit of the camera Jacobian.
pub fn world_step(scene: &Scene3d, h_px: f64) -> f64 {
    let view = scene.cameras[0].params();
    let mut gains: Vec<f64> = scene
        .mesh
        .positions()
        .iter()
        .map(|&p| {
            let [jx, jy] = view.jacobian(p);
            ((jx.length_squared() + jy.length_squared()) as f64 / 3.0).sqrt()
        })
        .collect();
    gains.sort_by(f64::total_cmp);
    h_px / gains[gains.len() / 2]
}

/// The full 3D check of `scene` (all views, gradients summed): analytic vs central differences
/// of the exact-area oracle through an f64 projection, full gradient and random directions.
/// `options.h` is in pixels (see [`world_step`]).
pub fn check_3d(scene: &Scene3d, options: FdOptions) -> Check {
    let mut rng = Rng::new(options.seed);
    let weights: Vec<Vec<f32>> = scene.cameras.iter().map(|c| rng.weights((c.width * c.height) as usize)).collect();
    let analytic = analytic_3d(scene, &weights, options.settings);
    let views: Vec<ViewReference> = (0..scene.cameras.len())
        .map(|k| ViewReference::new(scene, k, weights[k].clone(), options.settings, false, options.h))
        .collect();
    let h = world_step(scene, options.h);
    let base: Vec<DVec3> = scene.mesh.positions().iter().map(|p| p.as_dvec3()).collect();
    let n = analytic.len();
    let fd: Vec<f64> = {
        use rayon::prelude::*;
        let per_vertex: Vec<[f64; 3]> = (0..base.len())
            .into_par_iter()
            .map(|v| {
                [0, 1, 2].map(|c| {
                    let (mut plus, mut minus) = (base[v], base[v]);
                    plus[c] += h;
                    minus[c] -= h;
                    let dl: f64 = views.iter().map(|r| r.delta_one_vertex(v, plus, minus)).sum();
                    dl / (plus[c] - minus[c])
                })
            })
            .collect();
        per_vertex.into_iter().flatten().collect()
    };
    let directions = (0..options.directions)
        .map(|_| {
            // Each coordinate moves by about h (RMS), all at once.
            let u = direction_for(&mut rng, &analytic);
            let scale = h * (n as f64).sqrt();
            let shift = |sign: f64| -> Vec<DVec3> {
                base.iter()
                    .enumerate()
                    .map(|(v, p)| *p + sign * scale * DVec3::new(u[3 * v], u[3 * v + 1], u[3 * v + 2]))
                    .collect()
            };
            let (plus, minus) = (shift(1.0), shift(-1.0));
            let dl: f64 = views.iter().map(|r| r.loss(&plus) - r.loss(&minus)).sum();
            let predicted: f64 = analytic.iter().zip(&u).map(|(g, d)| g * d).sum();
            (predicted, dl / (2.0 * scale))
        })
        .collect();
    summarise(scene.name, &analytic, &fd, directions)
}

/// Directional derivatives only (for big meshes): analytic `g·u` vs central differences of the
/// rounding-compensated oracle loss along `directions` random world directions, each coordinate
/// moving by about `options.h` pixels (RMS). `g₂` for the compensation is computed on the
/// silhouette vertices only.
pub fn check_3d_directions(scene: &Scene3d, options: FdOptions) -> Check {
    let mut rng = Rng::new(options.seed);
    let weights: Vec<Vec<f32>> = scene.cameras.iter().map(|c| rng.weights((c.width * c.height) as usize)).collect();
    let analytic = analytic_3d(scene, &weights, options.settings);
    let views: Vec<ViewReference> = (0..scene.cameras.len())
        .map(|k| ViewReference::new(scene, k, weights[k].clone(), options.settings, true, options.h.max(H_G2)))
        .collect();
    let h = world_step(scene, options.h);
    let base: Vec<DVec3> = scene.mesh.positions().iter().map(|p| p.as_dvec3()).collect();
    let n = analytic.len();
    let mut references = Vec::new();
    let directions: Vec<(f64, f64)> = (0..options.directions)
        .map(|_| {
            let u = direction_for(&mut rng, &analytic);
            let scale = h * (n as f64).sqrt();
            let shift = |sign: f64| -> Vec<DVec3> {
                base.iter()
                    .enumerate()
                    .map(|(v, p)| *p + sign * scale * DVec3::new(u[3 * v], u[3 * v + 1], u[3 * v + 2]))
                    .collect()
            };
            let (plus, minus) = (shift(1.0), shift(-1.0));
            let dl: f64 = views.iter().map(|r| r.loss_difference(&plus, &minus)).sum();
            let predicted: f64 = analytic.iter().zip(&u).map(|(g, d)| g * d).sum();
            references.push(dl / (2.0 * scale));
            (predicted, dl / (2.0 * scale))
        })
        .collect();
    Check {
        name: scene.name.to_string(),
        full: None,
        fd_norm: references.iter().map(|d| d * d).sum::<f64>().sqrt(),
        max_abs: 0.0,
        directions: directions.iter().map(|&(a, r)| (a - r).abs() / r.abs().max(1e-300)).collect(),
        coordinates: n,
    }
}
