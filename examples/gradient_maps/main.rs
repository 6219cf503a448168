//! Per-pixel gradient images `∂I(i,j)/∂t` for three motions of a mesh's silhouette (paper Fig. 6),
//! by diffsil's analytic backward and by central finite differences of the exact covered area.
//!
//! ```text
//! cargo run --release --example gradient_maps                        # built-in blob, 128²
//! cargo run --release --example gradient_maps -- --mesh ../shared/assets/stanford-bunny.obj
//! cargo run --release --example gradient_maps -- --help
//! ```
//!
//! The mesh is normalised (bounding-box centre at the origin, farthest vertex at distance 1) and
//! seen by a perspective camera at distance 2.7 (fov 50°). Its projected vertices `p` are then
//! moved in the image plane with velocity fields `v(p)` (pixel units, `c` the image centre):
//!
//! - **translate right** `v = (1, 0)`: `t` in pixels;
//! - **rotate anticlockwise** (as seen on screen, y down) about the view axis through `c`:
//!   `v = (p_y − c_y, −(p_x − c_x))`, `t` in radians;
//! - **scale up** about `c`: `v = p − c`, `t` the logarithm of the scale factor.
//!
//! For each motion the derivative of every pixel, `∂I(i,j)/∂t = Σ_k ∂I(i,j)/∂p_k · v_k`, is computed
//! (a) from diffsil's analytic backward ([`analytic_maps`]) and (b) by central differences of
//! [`diffsil::reference::oracle::exact_coverage_f64`] ([`finite_difference_map`]). Pictures go to `--out`: a
//! sheet `gradient_maps.png` (rows: motions; columns: silhouette, analytic, finite difference,
//! difference, on one blue–white–red scale per row) and each map as its own PNG. The cosine
//! similarity and relative error of (a) against (b) are printed per motion.
//!
//! This file is also compiled into `tests/examples/gradient_maps.rs`, which checks its functions.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use clap::Parser;
use diffsil::reference::oracle;
use diffsil::{shapes, Image, Mesh, Orbit, RenderSettings, Renderer, ScreenView, Topology};
use glam::{DVec2, Vec2};

#[path = "../common/mod.rs"]
mod common;
mod sheet;
pub use common::BackendName;
use common::{elevation, finite};
use sheet::write_pictures;
pub use sheet::{diverging, SheetRow};

/// Command-line options (`gradient_maps --help`).
#[derive(Clone, Debug, PartialEq, Parser)]
#[command(
    name = "gradient_maps",
    about = "Per-pixel gradient images dI(i,j)/dt for three motions of a silhouette (translate right, \
             rotate anticlockwise about the view axis, scale up), by diffsil's analytic backward and \
             by central finite differences of the exact covered area (paper Fig. 6)",
    after_help = "\
Output: DIR/gradient_maps.png (rows: translate, rotate, scale; columns: silhouette, analytic,
finite difference, analytic − finite difference; blue < 0 < red, one scale per row, shared by
the three maps of the row), DIR/silhouette.png and DIR/<motion>_<analytic|fd|difference>.png;
on stdout, per motion, the cosine similarity and relative error of analytic against finite
difference."
)]
pub struct Options {
    /// .obj, .gltf or .glb to render, normalised to radius 1 [default: the built-in lumpy blob,
    /// diffsil::shapes::blob(24, 48)]
    #[arg(long, value_name = "PATH")]
    pub mesh: Option<PathBuf>,
    /// Image side in pixels, 8 to 1024; the analytic maps need about
    /// (2·longest projected edge + 3)² backward passes
    #[arg(long, value_name = "N", default_value_t = 128, value_parser = clap::value_parser!(u32).range(8..=1024))]
    pub resolution: u32,
    /// Camera azimuth about +y, degrees
    #[arg(long, value_name = "DEG", default_value_t = 30.0, value_parser = finite, allow_negative_numbers = true)]
    pub azimuth: f32,
    /// Camera elevation, degrees, strictly between -90 and 90
    #[arg(long, value_name = "DEG", default_value_t = 20.0, value_parser = elevation, allow_negative_numbers = true)]
    pub elevation: f32,
    /// The backend of the forward and of the analytic backward
    #[arg(long, value_name = "NAME", value_enum, default_value_t = BackendName::Cpu)]
    pub backend: BackendName,
    /// Where the PNGs go
    #[arg(long, value_name = "DIR", default_value = "gradient_maps_out")]
    pub out: PathBuf,
}

impl Default for Options {
    /// The options of a command line without any.
    fn default() -> Self {
        Options::parse_from(["gradient_maps"])
    }
}

/// The built-in mesh: a closed, lumpy, non-convex blob whose contour folds over itself.
pub fn builtin_mesh() -> Mesh {
    shapes::blob(24, 48)
}

/// A motion of the projected vertices in the image plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    /// `v = (1, 0)`: `t` in pixels.
    TranslateRight,
    /// `v = (p_y − c_y, −(p_x − c_x))`: anticlockwise as seen on screen (y down), `t` in radians.
    RotateAnticlockwise,
    /// `v = p − c`: `t` is the logarithm of the scale factor.
    ScaleUp,
}

impl Motion {
    /// The three motions, in the order of the sheet's rows.
    pub const ALL: [Motion; 3] = [Motion::TranslateRight, Motion::RotateAnticlockwise, Motion::ScaleUp];

    /// Short name, used in file names.
    pub fn name(self) -> &'static str {
        match self {
            Motion::TranslateRight => "translate",
            Motion::RotateAnticlockwise => "rotate",
            Motion::ScaleUp => "scale",
        }
    }

    /// What `t` is, for the sheet and stdout.
    pub fn title(self) -> &'static str {
        match self {
            Motion::TranslateRight => "translate right, t in pixels",
            Motion::RotateAnticlockwise => "rotate anticlockwise, t in radians",
            Motion::ScaleUp => "scale up, t = log scale",
        }
    }

    /// Velocity `∂p/∂t` of a point `p` (pixels) for the image centre `centre`.
    pub fn velocity(self, p: DVec2, centre: DVec2) -> DVec2 {
        let d = p - centre;
        match self {
            Motion::TranslateRight => DVec2::new(1.0, 0.0),
            Motion::RotateAnticlockwise => DVec2::new(d.y, -d.x),
            Motion::ScaleUp => d,
        }
    }
}

/// A mesh projected once into a square image: the 2D problem whose gradient maps are drawn.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The mesh's topology.
    pub topology: Arc<Topology>,
    /// Projected vertex positions, pixels (x right, y down).
    pub screen: Vec<Vec2>,
    /// Image side, pixels.
    pub resolution: u32,
}

impl Scene {
    /// Normalises `mesh` to radius 1 and projects it with a perspective camera (fov 50°) at
    /// distance 2.7 from the origin, at `azimuth` and `elevation` (degrees). Every vertex lands
    /// inside the image (a sphere of radius 1 at that distance subtends 21.7° of the 25°
    /// half-field); errors if one does not.
    pub fn new(mesh: &Mesh, resolution: u32, azimuth: f32, elevation: f32) -> Result<Scene, String> {
        let mesh = mesh.normalized(1.0);
        let orbit = Orbit { azimuth: azimuth.to_radians(), elevation: elevation.to_radians(), ..Orbit::default() };
        let camera = orbit.camera(resolution, resolution);
        camera.validate().map_err(|e| e.to_string())?;
        let params = camera.params();
        let mut screen = Vec::with_capacity(mesh.positions().len());
        for (k, p) in mesh.positions().iter().enumerate() {
            let (s, valid) = params.project(*p);
            if !valid {
                return Err(format!("vertex {k} is clipped by the camera: the scene cannot be drawn"));
            }
            screen.push(s);
        }
        Ok(Scene { topology: mesh.topology().clone(), screen, resolution })
    }

    /// The image centre, pixels: the centre of rotation and scaling.
    pub fn centre(&self) -> DVec2 {
        DVec2::splat(0.5 * self.resolution as f64)
    }

    /// The velocity of every vertex under `motion`.
    pub fn velocities(&self, motion: Motion) -> Vec<DVec2> {
        let c = self.centre();
        self.screen.iter().map(|p| motion.velocity(p.as_dvec2(), c)).collect()
    }

    /// The exact covered area of each pixel, row-major (the ideal image of the scene).
    pub fn exact_coverage(&self) -> Vec<f64> {
        let vertices: Vec<DVec2> = self.screen.iter().map(|p| p.as_dvec2()).collect();
        oracle::exact_coverage_f64(&vertices, self.topology.triangles(), self.resolution, self.resolution)
    }
}

/// The analytic gradient maps of a scene.
#[derive(Clone, Debug)]
pub struct AnalyticMaps {
    /// The rendered silhouette (F = 4).
    pub silhouette: Image,
    /// One map per velocity field, row-major: `∂I(i,j)/∂t`.
    pub maps: Vec<Vec<f64>>,
    /// Backward passes used (the seed lattice's `stride_x · stride_y`).
    pub passes: u32,
}

/// The pixels whose value may depend on each vertex: the bounding box, in whole pixels, of the
/// vertex and the other ends of its edges, grown by one pixel on each side and clipped to the
/// image (`[column_lo, column_hi, row_lo, row_hi]`, inclusive), or `None` when it misses the image
/// or the vertex has no edge.
///
/// The backward gives a vertex a gradient only through its edges, and an edge only through the
/// pixels its segment crosses: those lie in this box (the extra pixel covers a segment lying on
/// a pixel border, which counts half to each side).
pub fn footprints(screen: &[Vec2], topology: &Topology, resolution: u32) -> Vec<Option<[u32; 4]>> {
    let last = resolution as i64 - 1;
    (0..topology.vertex_count())
        .map(|v| {
            let edges = topology.vertex_edges(v);
            if edges.is_empty() {
                return None;
            }
            let (mut lo, mut hi) = (screen[v], screen[v]);
            for &e in edges {
                let [a, b] = topology.edges()[e as usize];
                let other = screen[if a as usize == v { b } else { a } as usize];
                lo = lo.min(other);
                hi = hi.max(other);
            }
            let (c0, c1) = ((lo.x.floor() as i64 - 1).max(0), (hi.x.floor() as i64 + 1).min(last));
            let (r0, r1) = ((lo.y.floor() as i64 - 1).max(0), (hi.y.floor() as i64 + 1).min(last));
            (c0 <= c1 && r0 <= r1).then_some([c0 as u32, c1 as u32, r0 as u32, r1 as u32])
        })
        .collect()
}

/// `∂I(i,j)/∂t` of every pixel for each velocity field, from diffsil's analytic backward
/// ([`Renderer::backward_screen`], on whichever backend `renderer` runs), exactly, in few passes.
///
/// # Why this is exact, and how it avoids one backward pass per pixel
///
/// The per-pixel derivative along a velocity field is a forward-mode (Jacobian–vector) product
/// `J v`, with `J = ∂I/∂p` (pixels × vertex coordinates); the backward computes reverse-mode
/// products `sᵀ J` for a seed image `s = ∂L/∂I`. A one-hot seed per pixel would give the rows of
/// `J` one by one: exact, but `W·H` passes. `J` is sparse, though: vertex `k` reaches only the
/// pixels of its [`footprints`] box `B_k`. Seed instead with the indicator of a lattice of pixels,
/// every `sx`-th column and `sy`-th row at an offset, where `sx`, `sy` are the largest footprint
/// width and height: each `B_k` then holds at most one seeded pixel `q_k`, so the backward's
/// gradient of vertex `k` is exactly `∂I(q_k)/∂p_k` (the other seeded pixels contribute exact
/// zeros). Summing `∂I(q_k)/∂p_k · v_k` into pixel `q_k` over all vertices and all `sx·sy` lattice
/// offsets gives `J v` for every pixel. This is the Curtis–Powell–Reid compression of a sparse
/// Jacobian (Griewank & Walther, *Evaluating Derivatives*, ch. 8), with the structure known in
/// advance from the geometry. The floating-point operations per (edge, pixel) are the same as with
/// one-hot seeds, so the maps equal those bit for bit (a test checks it), and several velocity
/// fields share the passes.
///
/// Passes: about `(2ℓ + 3)²` for a longest projected edge of `ℓ` pixels, e.g. ~400 for the
/// built-in blob at 128², independent of the image size once edges are short.
///
/// Errors if the renderer fails, or if a vertex gets a gradient outside its footprint (which
/// would mean the sparsity assumption above is wrong; it never happens in the tests).
pub fn analytic_maps(
    renderer: &mut Renderer,
    scene: &Scene,
    velocities: &[Vec<DVec2>],
    progress: bool,
) -> Result<AnalyticMaps, Box<dyn std::error::Error>> {
    let n = scene.resolution;
    let size = n as usize;
    let view = ScreenView { vertices: scene.screen.clone(), width: n, height: n };
    let frame = renderer.render_screen(&scene.topology, &[view])?;
    let boxes = footprints(&scene.screen, &scene.topology, n);
    let stride_x = boxes.iter().flatten().map(|b| b[1] - b[0] + 1).max().unwrap_or(1);
    let stride_y = boxes.iter().flatten().map(|b| b[3] - b[2] + 1).max().unwrap_or(1);
    let passes = stride_x * stride_y;
    let mut maps = vec![vec![0.0f64; size * size]; velocities.len()];
    let bar = if progress { indicatif::ProgressBar::new(passes as u64) } else { indicatif::ProgressBar::hidden() };
    bar.set_style(indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} backward passes").expect("template"));
    let mut seed = Image::filled(n, n, 0.0);
    for oy in 0..stride_y {
        for ox in 0..stride_x {
            let lattice = |set: f32, seed: &mut Image| {
                for i in (oy..n).step_by(stride_y as usize) {
                    for j in (ox..n).step_by(stride_x as usize) {
                        seed.data_mut()[i as usize * size + j as usize] = set;
                    }
                }
            };
            lattice(1.0, &mut seed);
            let grads = renderer.backward_screen(&frame, std::slice::from_ref(&seed))?;
            lattice(0.0, &mut seed);
            for (k, g) in grads[0].iter().enumerate() {
                if *g == Vec2::ZERO {
                    continue;
                }
                let outside =
                    || format!("vertex {k} has a gradient outside its footprint: the lattice seeds are not exact");
                let [c0, c1, r0, r1] = boxes[k].ok_or_else(outside)?;
                // The seeded column and row inside the box: the first ≥ c0 (r0) on the lattice.
                let column = c0 + (ox + stride_x - c0 % stride_x) % stride_x;
                let row = r0 + (oy + stride_y - r0 % stride_y) % stride_y;
                if column > c1 || row > r1 {
                    return Err(outside().into());
                }
                let pixel = row as usize * size + column as usize;
                for (map, v) in maps.iter_mut().zip(velocities) {
                    map[pixel] += g.as_dvec2().dot(v[k]);
                }
            }
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    Ok(AnalyticMaps { silhouette: frame.images()[0].clone(), maps, passes })
}

/// `∂I(i,j)/∂t` of every pixel by a central difference of the exact covered area
/// ([`oracle::exact_coverage_f64`]), with the vertices moved by `±h·v`, `h` chosen so that the
/// fastest vertex moves `displacement` pixels. The vertices move in `f64`, so no rounding of the
/// moved positions spoils the quotient; with `displacement = 1e-4` its error is ~1e-8 (the area's
/// `~1e-12` rounding over the step, and the step's curvature term).
pub fn finite_difference_map(scene: &Scene, velocity: &[DVec2], displacement: f64) -> Vec<f64> {
    let n = scene.resolution;
    let fastest = velocity.iter().map(|v| v.length()).fold(0.0, f64::max);
    if fastest == 0.0 {
        return vec![0.0; n as usize * n as usize];
    }
    let h = displacement / fastest;
    let moved = |sign: f64| -> Vec<f64> {
        let vertices: Vec<DVec2> =
            scene.screen.iter().zip(velocity).map(|(p, v)| p.as_dvec2() + sign * h * *v).collect();
        oracle::exact_coverage_f64(&vertices, scene.topology.triangles(), n, n)
    };
    let (plus, minus) = (moved(1.0), moved(-1.0));
    // I = p0 + (p1 − p0)·area with the default p1 = 1, p0 = 0.
    let s = RenderSettings::default();
    let scale = (s.inside - s.outside) as f64;
    plus.iter().zip(&minus).map(|(a, b)| scale * (a - b) / (2.0 * h)).collect()
}

/// How well two maps agree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Agreement {
    /// `⟨a, b⟩ / (|a| |b|)`; 1 when both are zero, 0 when only one is.
    pub cosine: f64,
    /// `|a − b| / |b|` (Euclidean norms over all pixels); 0 when both are zero.
    pub relative_error: f64,
    /// `max |a − b|` over pixels.
    pub max_difference: f64,
    /// `max(|a|, |b|)` over pixels: the colour scale of the row.
    pub scale: f64,
}

/// Compares `a` (analytic) with `b` (reference). Never NaN for finite input.
pub fn agreement(a: &[f64], b: &[f64]) -> Agreement {
    let (mut ab, mut aa, mut bb, mut dd, mut max_difference, mut scale) = (0.0f64, 0.0f64, 0.0, 0.0, 0.0f64, 0.0f64);
    for (&x, &y) in a.iter().zip(b) {
        ab += x * y;
        aa += x * x;
        bb += y * y;
        dd += (x - y) * (x - y);
        max_difference = max_difference.max((x - y).abs());
        scale = scale.max(x.abs()).max(y.abs());
    }
    let cosine = match (aa > 0.0, bb > 0.0) {
        (true, true) => ab / (aa.sqrt() * bb.sqrt()),
        (false, false) => 1.0,
        _ => 0.0,
    };
    let relative_error = if bb > 0.0 {
        (dd / bb).sqrt()
    } else if aa > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    Agreement { cosine, relative_error, max_difference, scale }
}

/// Pixels *away from the silhouette*: the pixel and its (up to 8) neighbours are all uncovered,
/// or all fully covered (exact coverage within `1e-9` of 0, resp. 1). No visible silhouette segment
/// crosses such a pixel, so its analytic derivative must be exactly zero.
pub fn away_from_silhouette(coverage: &[f64], resolution: u32) -> Vec<bool> {
    let n = resolution as i64;
    let at = |i: i64, j: i64| coverage[(i * n + j) as usize];
    let mut away = vec![false; coverage.len()];
    for i in 0..n {
        for j in 0..n {
            let (mut empty, mut full) = (true, true);
            for di in -1..=1 {
                for dj in -1..=1 {
                    let (y, x) = (i + di, j + dj);
                    if (0..n).contains(&y) && (0..n).contains(&x) {
                        empty &= at(y, x) <= 1e-9;
                        full &= at(y, x) >= 1.0 - 1e-9;
                    }
                }
            }
            away[(i * n + j) as usize] = empty || full;
        }
    }
    away
}

fn main() {
    let o = Options::parse();
    if let Err(e) = run(&o) {
        eprintln!("gradient_maps: {e}");
        std::process::exit(1);
    }
}

fn run(o: &Options) -> Result<(), Box<dyn std::error::Error>> {
    let (mesh, name) = match &o.mesh {
        Some(path) => common::load_mesh(path)?,
        None => (builtin_mesh(), "built-in blob".to_string()),
    };
    let scene = Scene::new(&mesh, o.resolution, o.azimuth, o.elevation)?;
    let mut renderer = Renderer::with_backend(RenderSettings::default(), o.backend.backend())?;
    println!(
        "{name}: {} vertices, {} triangles; {n}x{n}, F = 4, azimuth {}°, elevation {}°; backend {}",
        mesh.positions().len(),
        mesh.triangles().len(),
        o.azimuth,
        o.elevation,
        renderer.backend_name(),
        n = o.resolution,
    );

    let velocities: Vec<Vec<DVec2>> = Motion::ALL.iter().map(|m| scene.velocities(*m)).collect();
    let start = Instant::now();
    let analytic = analytic_maps(&mut renderer, &scene, &velocities, true)?;
    println!(
        "analytic maps: {} backward passes (lattice seeds, see analytic_maps), {:.2} s",
        analytic.passes,
        start.elapsed().as_secs_f64()
    );
    let start = Instant::now();
    let fd: Vec<Vec<f64>> = velocities.iter().map(|v| finite_difference_map(&scene, v, 1e-4)).collect();
    println!(
        "finite differences: central, fastest vertex moved ±1e-4 px, exact-area oracle in f64, {:.2} s",
        start.elapsed().as_secs_f64()
    );

    let away = away_from_silhouette(&scene.exact_coverage(), o.resolution);
    let away_count = away.iter().filter(|&&a| a).count();
    println!("| motion | cosine similarity | relative error | max |a - b| | scale (max |map|) | non-zero analytic pixels away from the silhouette |");
    println!("|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    for ((motion, a), b) in Motion::ALL.iter().zip(&analytic.maps).zip(&fd) {
        let agreement = agreement(a, b);
        let stray = a.iter().zip(&away).filter(|(v, &away)| away && **v != 0.0).count();
        println!(
            "| {} | {:.9} | {:.2e} | {:.2e} | {:.3e} | {stray} of {away_count} |",
            motion.title(),
            agreement.cosine,
            agreement.relative_error,
            agreement.max_difference,
            agreement.scale
        );
        rows.push(SheetRow { motion: *motion, analytic: a, finite_difference: b, agreement });
    }
    let title = format!("dI/dt per pixel, {name}, {n}x{n}, F = 4", n = o.resolution);
    write_pictures(&o.out, &analytic, &rows, &title)?;
    println!(
        "wrote {}/gradient_maps.png (rows: motions; columns: silhouette, analytic, finite difference, \
         analytic - fd; blue < 0 < red) and the single maps",
        o.out.display()
    );
    Ok(())
}
