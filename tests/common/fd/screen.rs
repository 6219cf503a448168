//! Finite-difference checks in screen space (2D): the exact-area oracle's loss and its central
//! differences, per vertex and along random directions.

use super::*;

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
