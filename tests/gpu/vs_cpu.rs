//! The GPU backend against the CPU backend, on the scenes of `common::scenes` and on seeded random
//! scenes: images bit-identical, vertex gradients equal within 1e-5 relative to the gradient's
//! norm; the GPU gradient against finite differences of the exact-area oracle; determinism; the
//! 1024² two-triangle quad; bin-capacity growth; several views of different sizes in one frame.
//!
//! 3D input is compared bit for bit too: the `project` stage repeats the CPU's operations in
//! order, with every product kept out of FMA fusion and the divisions correctly rounded in
//! software (`div_rn`), and Vulkan rounds f32 additions and multiplications correctly, so the
//! screen vertices — and hence the images — are identical on any conforming device. The mean
//! absolute difference (which the issue allows up to 1e-6) is asserted as well, and measured.
//!
//! Run on lavapipe with `WGPU_BACKEND=vulkan DIFFSIL_REQUIRE_GPU=1 cargo test --release --test gpu vs_cpu`
//! (`--nocapture` prints the measured differences).

use std::sync::Arc;

use crate::common::fd::{self, Rng};
use crate::common::gpu::gpu_or_skip;
use crate::common::scenes::{self, Scene2d, Scene3d};
use diffsil::{Camera, Frame, Image, Mesh, Orbit, RenderSettings, Renderer, ScreenView, Topology, Vec2, Vec3};

fn gpu_renderer(name: &str, settings: RenderSettings) -> Option<Renderer> {
    let ctx = gpu_or_skip(name)?;
    Some(Renderer::with_gpu_context(settings, ctx).expect("GPU renderer"))
}

fn random_weights(frame: &Frame, rng: &mut Rng) -> Vec<Image> {
    frame
        .images()
        .iter()
        .map(|i| Image::from_vec(i.width(), i.height(), rng.weights((i.width() * i.height()) as usize)).unwrap())
        .collect()
}

/// `‖gpu − cpu‖ / ‖cpu‖` (absolute when the CPU gradient is ~0).
fn relative_2d(gpu: &[Vec<Vec2>], cpu: &[Vec<Vec2>]) -> f64 {
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for (g, c) in gpu.iter().zip(cpu) {
        assert_eq!(g.len(), c.len());
        for (a, b) in g.iter().zip(c) {
            assert!(a.is_finite(), "non-finite GPU gradient");
            diff += (*a - *b).as_dvec2().length_squared();
            norm += b.as_dvec2().length_squared();
        }
    }
    diff.sqrt() / norm.sqrt().max(1e-3)
}

fn relative_3d(gpu: &[Vec3], cpu: &[Vec3]) -> f64 {
    assert_eq!(gpu.len(), cpu.len());
    let diff: f64 = gpu.iter().zip(cpu).map(|(a, b)| (*a - *b).as_dvec3().length_squared()).sum();
    let norm: f64 = cpu.iter().map(|b| b.as_dvec3().length_squared()).sum();
    assert!(gpu.iter().all(|g| g.is_finite()), "non-finite GPU gradient");
    diff.sqrt() / norm.sqrt().max(1e-3)
}

/// What one comparison measured.
#[derive(Default, Debug)]
struct Measured {
    cases: usize,
    worst_gradient: f64,
    worst_case: String,
    differing_pixels: usize,
}

impl Measured {
    fn gradient(&mut self, case: &str, rel: f64) {
        self.cases += 1;
        if rel > self.worst_gradient {
            self.worst_gradient = rel;
            self.worst_case = case.to_string();
        }
    }
}

const GRADIENT_TOL: f64 = 1e-5;

/// Renders `views` of `topology` on both backends, compares images (bit for bit) and stats,
/// runs the backward with random `∂L/∂I`, compares gradients.
fn compare_screen(
    case: &str,
    gpu: &mut Renderer,
    cpu: &mut Renderer,
    topology: &Arc<Topology>,
    views: &[ScreenView],
    rng: &mut Rng,
    measured: &mut Measured,
) {
    let fg = gpu.render_screen(topology, views).unwrap_or_else(|e| panic!("{case}: GPU render: {e}"));
    let fc = cpu.render_screen(topology, views).unwrap();
    for (v, (ig, ic)) in fg.images().iter().zip(fc.images()).enumerate() {
        if ig != ic {
            let n = ig.data().iter().zip(ic.data()).filter(|(a, b)| a != b).count();
            let first = ig.data().iter().zip(ic.data()).position(|(a, b)| a != b).unwrap();
            panic!(
                "{case}: view {v} ({}x{}): {n} pixels differ, first at {first}: gpu {} cpu {}",
                ic.width(),
                ic.height(),
                ig.data()[first],
                ic.data()[first]
            );
        }
    }
    for (sg, sc) in fg.stats().iter().zip(fc.stats()) {
        assert_eq!(
            (sg.culled_triangles, sg.candidate_edges),
            (sc.culled_triangles, sc.candidate_edges),
            "{case}: stats"
        );
    }
    let d = random_weights(&fc, rng);
    let gg = gpu.backward_screen(&fg, &d).unwrap();
    let gc = cpu.backward_screen(&fc, &d).unwrap();
    let rel = relative_2d(&gg, &gc);
    measured.gradient(case, rel);
    assert!(rel <= GRADIENT_TOL, "{case}: gradient relative difference {rel:.3e}");
}

fn compare_world(case: &str, gpu: &mut Renderer, cpu: &mut Renderer, scene: &Scene3d, rng: &mut Rng, m: &mut Measured) {
    let fg = gpu.render(&scene.mesh, &scene.cameras).unwrap_or_else(|e| panic!("{case}: GPU render: {e}"));
    let fc = cpu.render(&scene.mesh, &scene.cameras).unwrap();
    for (ig, ic) in fg.images().iter().zip(fc.images()) {
        let mean =
            ig.data().iter().zip(ic.data()).map(|(a, b)| (a - b).abs() as f64).sum::<f64>() / ic.data().len() as f64;
        m.differing_pixels += ig.data().iter().zip(ic.data()).filter(|(a, b)| a != b).count();
        assert!(mean <= 1e-6, "{case}: mean absolute image difference {mean:.3e}");
        assert_eq!(ig, ic, "{case}: images differ (the projection is bit-exact)");
    }
    let d = random_weights(&fc, rng);
    let gg = gpu.backward(&fg, &d).unwrap();
    let gc = cpu.backward(&fc, &d).unwrap();
    let rel = relative_3d(&gg, &gc);
    m.gradient(case, rel);
    assert!(rel <= GRADIENT_TOL, "{case}: gradient relative difference {rel:.3e}");
}

#[test]
fn scenes_match_the_cpu() {
    let Some(mut gpu) = gpu_renderer("scenes_match_the_cpu", RenderSettings::default()) else { return };
    let mut cpu = Renderer::new(RenderSettings::default()).unwrap();
    let mut rng = Rng::new(11);
    let mut m = Measured::default();
    for scene in scenes::all_2d() {
        compare_screen(scene.name, &mut gpu, &mut cpu, &scene.topology(), &[scene.view()], &mut rng, &mut m);
    }
    let three_d = [
        scenes::icosphere_3d(),
        scenes::torus_fold_3d(),
        scenes::blob_3d(),
        scenes::two_spheres_3d(),
        scenes::open_patch_3d(),
        scenes::hemisphere_3d(),
    ];
    for scene in &three_d {
        compare_world(scene.name, &mut gpu, &mut cpu, scene, &mut rng, &mut m);
    }
    // Several views of different sizes and projections in one frame.
    let mut multi = scenes::torus_fold_3d();
    multi.cameras = scenes::orbit_cameras(3, 0.3, 40, 32);
    multi.cameras.extend(scenes::orthographic_cameras(2, 1.1, 17, 29));
    compare_world("torus, 5 views", &mut gpu, &mut cpu, &multi, &mut rng, &mut m);
    // Other settings: F = 1, 3, 16 and non-default pixel values.
    for settings in [
        RenderSettings { supersample: 1, inside: 1.0, outside: 0.0 },
        RenderSettings { supersample: 3, inside: 0.3, outside: -1.7 },
        RenderSettings { supersample: 16, inside: 2.5, outside: 0.25 },
    ] {
        let mut gpu = Renderer::with_gpu_context(settings, gpu_or_skip("scenes_match_the_cpu").unwrap()).unwrap();
        let mut cpu = Renderer::new(settings).unwrap();
        for scene in [scenes::quad(), scenes::two_spheres(), scenes::diamond_on_grid()] {
            let case = format!("{} F={}", scene.name, settings.supersample);
            compare_screen(&case, &mut gpu, &mut cpu, &scene.topology(), &[scene.view()], &mut rng, &mut m);
        }
    }
    println!("scenes: {} cases, worst gradient difference {:.3e} ({})", m.cases, m.worst_gradient, m.worst_case);
}

// -------------------------------------------------------------------------------------------------
// Random scenes
// -------------------------------------------------------------------------------------------------

/// A random 2D scene: triangles of mixed sizes (some larger than the screen, some partly off it,
/// some with vertices on pixel borders or sample positions, some degenerate), with shared
/// vertices so that contour, boundary and non-manifold edges all occur.
fn random_scene_2d(rng: &mut Rng, k: usize) -> (Vec<Vec2>, Vec<[u32; 3]>, u32, u32) {
    let width = 1 + (rng.next_u64() % 64) as u32;
    let height = if rng.uniform() < 0.3 { width } else { 1 + (rng.next_u64() % 64) as u32 };
    let (w, h) = (width as f64, height as f64);
    let vertex_count = 3 + (rng.next_u64() % 40) as usize;
    let scale = match k % 4 {
        0 => 0.15,
        1 => 0.5,
        2 => 1.5,
        _ => 4.0,
    };
    let mut vertices: Vec<Vec2> = (0..vertex_count)
        .map(|_| {
            let (cx, cy) = (rng.range(-0.3, 1.3) * w, rng.range(-0.3, 1.3) * h);
            let r = scale * w.max(h) * rng.uniform();
            let a = rng.range(0.0, std::f64::consts::TAU);
            let mut p = Vec2::new((cx + r * a.cos()) as f32, (cy + r * a.sin()) as f32);
            match rng.next_u64() % 8 {
                0 => p = p.round(),               // pixel corners / borders
                1 => p = (p * 8.0).round() / 8.0, // sample positions for several F
                2 => p.x = p.x.round(),
                _ => {}
            }
            p
        })
        .collect();
    if rng.uniform() < 0.1 {
        // A duplicated vertex position (zero-length edge) and a collinear triple.
        vertices[1] = vertices[0];
        vertices[2] = (vertices[0] + vertices[0]) * 0.5;
    }
    let triangle_count = 1 + (rng.next_u64() % 50) as usize;
    let triangles = (0..triangle_count)
        .map(|_| {
            let i = (rng.next_u64() % vertex_count as u64) as u32;
            // Mostly nearby indices, so that triangles share edges.
            let near = |rng: &mut Rng| (i + 1 + (rng.next_u64() % 4) as u32) % vertex_count as u32;
            let j = near(rng);
            let mut l = near(rng);
            if rng.uniform() < 0.3 {
                l = (rng.next_u64() % vertex_count as u64) as u32;
            }
            [i, j, l]
        })
        .collect();
    (vertices, triangles, width, height)
}

#[test]
fn random_screen_scenes_match_the_cpu() {
    let mut rng = Rng::new(2024);
    let mut m = Measured::default();
    let mut renderers: Vec<(Renderer, Renderer)> = Vec::new();
    for (f, inside, outside) in [(4, 1.0, 0.0), (1, 1.0, 0.0), (2, 0.7, 0.1), (5, 1.0, 0.0), (8, -1.0, 0.5)] {
        let settings = RenderSettings { supersample: f, inside, outside };
        let Some(gpu) = gpu_renderer("random_screen_scenes_match_the_cpu", settings) else { return };
        renderers.push((gpu, Renderer::new(settings).unwrap()));
    }
    for k in 0..240 {
        let (gpu, cpu) = &mut renderers[k % 5];
        let (vertices, triangles, width, height) = random_scene_2d(&mut rng, k);
        let topology = Arc::new(Topology::new(vertices.len(), triangles).unwrap());
        let mut views = vec![ScreenView { vertices: vertices.clone(), width, height }];
        if k % 7 == 0 {
            // More views of the same topology, other sizes and positions, in the same frame.
            for _ in 0..2 {
                let shift = Vec2::new(rng.range(-5.0, 5.0) as f32, rng.range(-5.0, 5.0) as f32);
                let (w2, h2) = (1 + (rng.next_u64() % 48) as u32, 1 + (rng.next_u64() % 48) as u32);
                views.push(ScreenView {
                    vertices: vertices.iter().map(|v| *v + shift).collect(),
                    width: w2,
                    height: h2,
                });
            }
        }
        let case = format!(
            "random 2D #{k} ({} tris, {} views, F={})",
            topology.triangles().len(),
            views.len(),
            gpu.settings().supersample
        );
        compare_screen(&case, gpu, cpu, &topology, &views, &mut rng, &mut m);
    }
    println!(
        "random 2D: {} scenes, images identical, worst gradient difference {:.3e} ({})",
        m.cases, m.worst_gradient, m.worst_case
    );
}

#[test]
fn random_world_scenes_match_the_cpu() {
    let Some(mut gpu) = gpu_renderer("random_world_scenes_match_the_cpu", RenderSettings::default()) else { return };
    let mut cpu = Renderer::new(RenderSettings::default()).unwrap();
    let mut rng = Rng::new(77);
    let mut m = Measured::default();
    let meshes = [
        diffsil::shapes::icosphere(2),
        scenes::transformed(&diffsil::shapes::blob(10, 12), |p| 0.8 * p),
        scenes::transformed(&scenes::torus(1.0, 0.35, 16, 8), |p| scenes::rotate_x(p, 1.0)),
        scenes::grid_patch(6, |x, y| 0.3 * (2.0 * x).sin() * y),
        scenes::merged(&[
            diffsil::shapes::icosphere(1),
            scenes::transformed(&diffsil::shapes::icosphere(1), |p| 0.5 * p + Vec3::new(0.6, 0.2, 0.8)),
        ]),
    ];
    for k in 0..40 {
        let mesh = &meshes[k % meshes.len()];
        let views = 1 + (rng.next_u64() % 3) as usize;
        let cameras: Vec<Camera> = (0..views)
            .map(|_| {
                let (w, h) = (4 + (rng.next_u64() % 60) as u32, 4 + (rng.next_u64() % 60) as u32);
                let az = rng.range(0.0, std::f64::consts::TAU) as f32;
                let el = rng.range(-1.2, 1.2) as f32;
                // Sometimes close enough that the mesh is larger than the screen or crosses the
                // near plane (culled triangles).
                let dist = [3.2, 1.6, 1.05][(rng.next_u64() % 3) as usize];
                let mut cam = Orbit {
                    target: Vec3::new(0.05, -0.02, 0.03),
                    azimuth: az,
                    elevation: el,
                    distance: dist,
                    fov_y: 0.9,
                }
                .camera(w, h);
                if rng.uniform() < 0.25 {
                    cam = Camera::orthographic(cam.eye, cam.target, rng.range(1.0, 4.0) as f32, w, h);
                }
                cam.near = if dist < 1.1 { 0.3 } else { cam.near };
                cam
            })
            .collect();
        let scene = Scene3d { name: "random 3D", mesh: mesh.clone(), cameras };
        compare_world(&format!("random 3D #{k}"), &mut gpu, &mut cpu, &scene, &mut rng, &mut m);
    }
    println!(
        "random 3D: {} scenes, {} differing pixels, worst gradient difference {:.3e} ({})",
        m.cases, m.differing_pixels, m.worst_gradient, m.worst_case
    );
}

// -------------------------------------------------------------------------------------------------
// Finite differences, determinism, large triangles, capacity
// -------------------------------------------------------------------------------------------------

/// The GPU's screen-space gradient of `Σ w·I` for a 2D scene, flattened.
fn gpu_gradient_2d(gpu: &mut Renderer, scene: &Scene2d, weights: &[f32]) -> Vec<f64> {
    let frame = gpu.render_screen(&scene.topology(), &[scene.view()]).unwrap();
    let d = Image::from_vec(scene.width, scene.height, weights.to_vec()).unwrap();
    let grads = gpu.backward_screen(&frame, &[d]).unwrap();
    grads[0].iter().flat_map(|g| [g.x as f64, g.y as f64]).collect()
}

#[test]
fn gpu_gradient_matches_finite_differences_of_the_exact_area() {
    let settings = RenderSettings::default();
    let Some(mut gpu) = gpu_renderer("gpu_gradient_matches_finite_differences_of_the_exact_area", settings) else {
        return;
    };
    for scene in [scenes::icosphere(), scenes::torus_fold(), scenes::two_spheres()] {
        let mut rng = Rng::new(5);
        let weights = rng.weights((scene.width * scene.height) as usize);
        let analytic = gpu_gradient_2d(&mut gpu, &scene, &weights);
        let oracle = fd::OracleLoss::of_scene(&scene, settings, weights);
        let reference = fd::fd_gradient_2d(&oracle, &scene.vertices, fd::H_2D);
        let diff: f64 = analytic.iter().zip(&reference).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
        let norm: f64 = reference.iter().map(|b| b * b).sum::<f64>().sqrt();
        println!("{}: GPU vs finite differences: relative {:.3e} (‖g_fd‖ {norm:.3})", scene.name, diff / norm);
        assert!(norm > 1e-3, "{}: the reference gradient is ~0", scene.name);
        assert!(diff / norm <= 1e-3, "{}: relative error {:.3e}", scene.name, diff / norm);
    }
}

#[test]
fn gpu_runs_are_bit_identical() {
    let Some(mut gpu) = gpu_renderer("gpu_runs_are_bit_identical", RenderSettings::default()) else { return };
    let scene = scenes::torus_fold_3d();
    let mut cameras = scenes::orbit_cameras(3, 0.2, 48, 40);
    cameras.push(scene.cameras[0]);
    let mut rng = Rng::new(8);
    let mut reference: Option<(Vec<Image>, Vec<u32>)> = None;
    let mut other = Renderer::with_gpu_context(RenderSettings::default(), gpu_or_skip("determinism").unwrap()).unwrap();
    let d: Vec<Image> = cameras
        .iter()
        .map(|c| Image::from_vec(c.width, c.height, rng.weights((c.width * c.height) as usize)).unwrap())
        .collect();
    for run in 0..4 {
        // Alternate renderers, and interleave another frame so that buffers are reused.
        let r = if run % 2 == 0 { &mut gpu } else { &mut other };
        let frame = r.render(&scene.mesh, &cameras).unwrap();
        let _ = r.render(&diffsil::shapes::icosphere(1), &cameras[..1]).unwrap();
        let grads = r.backward(&frame, &d).unwrap();
        let bits: Vec<u32> = grads.iter().flat_map(|g| g.to_array().map(f32::to_bits)).collect();
        match &reference {
            None => reference = Some((frame.images().to_vec(), bits)),
            Some((images, reference_bits)) => {
                assert_eq!(frame.images(), &images[..], "run {run}: images differ");
                assert_eq!(&bits, reference_bits, "run {run}: gradient bits differ");
            }
        }
    }
}

#[test]
fn full_screen_quad_at_1024() {
    let settings = RenderSettings::default();
    let Some(mut gpu) = gpu_renderer("full_screen_quad_at_1024", settings) else { return };
    let mut cpu = Renderer::new(settings).unwrap();
    let mut rng = Rng::new(1024);
    let mut m = Measured::default();
    // Two triangles covering the whole 1024² screen, corners off-screen, and a slightly smaller
    // quad whose silhouette crosses the image.
    for (name, corners) in [
        (
            "full-screen quad",
            [Vec2::new(-3.3, -2.1), Vec2::new(1030.7, -5.2), Vec2::new(1027.9, 1031.4), Vec2::new(-6.1, 1026.3)],
        ),
        (
            "crossing quad",
            [Vec2::new(13.3, 22.1), Vec2::new(1000.7, 5.2), Vec2::new(1017.9, 1001.4), Vec2::new(6.1, 986.3)],
        ),
    ] {
        let topology = Arc::new(Topology::new(4, vec![[0, 1, 2], [0, 2, 3]]).unwrap());
        let view = ScreenView { vertices: corners.to_vec(), width: 1024, height: 1024 };
        compare_screen(name, &mut gpu, &mut cpu, &topology, &[view], &mut rng, &mut m);
    }
    println!("1024² quads: worst gradient difference {:.3e}", m.worst_gradient);
}

#[test]
fn bin_capacity_grows_and_triangles_larger_than_the_screen() {
    // A fan of large triangles over a 300² image needs far more bin entries than 4 per
    // triangle: the first forward overflows the initial capacity and must be redone.
    let settings = RenderSettings::default();
    let Some(mut gpu) = gpu_renderer("bin_capacity_grows_and_triangles_larger_than_the_screen", settings) else {
        return;
    };
    let mut cpu = Renderer::new(settings).unwrap();
    let mut vertices = vec![Vec2::new(150.3, 149.7)];
    let triangles: Vec<[u32; 3]> = (0..24).map(|k| [0, k + 1, (k + 1) % 24 + 1]).collect();
    for k in 0..24 {
        let a = k as f32 * std::f32::consts::TAU / 24.0;
        vertices.push(Vec2::new(150.3 + 400.0 * a.cos(), 149.7 + 390.0 * a.sin()));
    }
    let mut rng = Rng::new(3);
    let mut m = Measured::default();
    let topology = Arc::new(Topology::new(vertices.len(), triangles).unwrap());
    let view = ScreenView { vertices, width: 300, height: 300 };
    compare_screen("big fan", &mut gpu, &mut cpu, &topology, &[view], &mut rng, &mut m);
    let mesh = Mesh::new(
        vec![Vec3::new(-9.0, -9.0, 0.0), Vec3::new(9.0, -9.0, 0.0), Vec3::new(0.0, 9.0, 0.0)],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let scene = Scene3d { name: "huge", mesh, cameras: vec![scenes::default_camera(200, 150)] };
    compare_world("huge triangle", &mut gpu, &mut cpu, &scene, &mut rng, &mut m);
}

/// Many triangles in one small area (1-pixel tiles with thousands of triangles each): correct on a real GPU; on llvmpipe, which ends every
/// loop of a shader invocation after 65,535 iterations in total, either correct or an explicit
/// `Error::GpuLimit` — never a silently truncated result.
#[test]
fn dense_tiles_are_correct_or_a_gpu_limit_error() {
    let settings = RenderSettings::default();
    let Some(mut gpu) = gpu_renderer("dense_tiles_are_correct_or_a_gpu_limit_error", settings) else { return };
    let mut cpu = Renderer::new(settings).unwrap();
    let mut rng = Rng::new(99);
    for count in [2_000usize, 6_000, 40_000] {
        // `count` small triangles scattered over a 12×12-pixel square, all in one tile.
        let mut vertices = Vec::with_capacity(3 * count);
        for _ in 0..count {
            let c = Vec2::new(rng.range(2.0, 14.0) as f32, rng.range(2.0, 14.0) as f32);
            for _ in 0..3 {
                vertices.push(c + Vec2::new(rng.range(-1.5, 1.5) as f32, rng.range(-1.5, 1.5) as f32));
            }
        }
        let triangles: Vec<[u32; 3]> = (0..count as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
        let topology = Arc::new(Topology::new(vertices.len(), triangles).unwrap());
        let view = ScreenView { vertices, width: 16, height: 16 };
        match gpu.render_screen(&topology, std::slice::from_ref(&view)) {
            Ok(frame) => {
                let reference = cpu.render_screen(&topology, std::slice::from_ref(&view)).unwrap();
                assert_eq!(frame.images(), reference.images(), "{count} triangles");
                let d = random_weights(&reference, &mut rng);
                match gpu.backward_screen(&frame, &d) {
                    Ok(g) => {
                        let c = cpu.backward_screen(&reference, &d).unwrap();
                        let rel = relative_2d(&g, &c);
                        assert!(rel <= GRADIENT_TOL, "{count} triangles: gradient difference {rel:.3e}");
                    }
                    Err(e) => assert!(matches!(e, diffsil::Error::GpuLimit { .. }), "{count}: {e}"),
                }
            }
            Err(e) => {
                let adapter = gpu.adapter().unwrap();
                assert!(matches!(e, diffsil::Error::GpuLimit { .. }), "{count}: {e}");
                assert!(adapter.name.contains("llvmpipe"), "only llvmpipe has the loop limit: {e}");
                println!("{count} triangles in one tile on {}: {e}", adapter.name);
            }
        }
    }
}
