//! Finite-difference checks through the camera (3D): an f64 reference projection, per-view oracles,
//! and central differences in world space.

use super::*;

/// The documented camera model in f64 (`ViewParams` docs): camera space `c = R·p + t`, depth
/// `d = −c.z`; perspective `x = cx + sx·c.x/d`, `y = cy − sy·c.y/d`; orthographic without the
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
    let (sx, sy) = (view.scale[0] as f64, view.scale[1] as f64);
    Some(DVec2::new(view.centre[0] as f64 + sx * x, view.centre[1] as f64 - sy * y))
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
