//! The bad-input table of `tests/cpu/bad_input.rs` on the GPU backend: every invalid input is the
//! same `Error` as on the CPU backend (same message), and every degenerate input renders the same
//! image (bit for bit), the same statistics and the same gradients (to 1e-5) — without NaN.
//!
//! Run on lavapipe with `WGPU_BACKEND=vulkan DIFFSIL_REQUIRE_GPU=1 cargo test --test gpu bad_input::`.

use std::sync::Arc;

use crate::common::gpu::gpu_or_skip;
use crate::common::scenes;
use diffsil::{
    Camera, Error, Frame, Image, Mesh, RenderSettings, RenderStats, Renderer, Result, ScreenView, Topology, Vec2, Vec3,
};

/// A CPU and a GPU renderer with the same settings.
struct Both {
    cpu: Renderer,
    gpu: Renderer,
}

fn both(name: &str, settings: RenderSettings) -> Option<Both> {
    let ctx = gpu_or_skip(name)?;
    Some(Both { cpu: Renderer::new(settings).unwrap(), gpu: Renderer::with_gpu_context(settings, ctx).unwrap() })
}

fn ones(frame: &Frame) -> Vec<Image> {
    frame.images().iter().map(|i| Image::filled(i.width(), i.height(), 1.0)).collect()
}

fn weights(frame: &Frame, seed: u64) -> Vec<Image> {
    let mut rng = crate::common::fd::Rng::new(seed);
    frame
        .images()
        .iter()
        .map(|i| Image::from_vec(i.width(), i.height(), rng.weights((i.width() * i.height()) as usize)).unwrap())
        .collect()
}

fn assert_close_2d(case: &str, gpu: &[Vec2], cpu: &[Vec2]) {
    assert_eq!(gpu.len(), cpu.len(), "{case}");
    assert!(gpu.iter().all(|g| g.is_finite()), "{case}: non-finite GPU gradient");
    let norm = cpu.iter().map(|g| g.length_squared()).sum::<f32>().sqrt();
    let diff = gpu.iter().zip(cpu).map(|(a, b)| (*a - *b).length_squared()).sum::<f32>().sqrt();
    assert!(diff <= 1e-5 * norm.max(1e-3), "{case}: |gpu - cpu| = {diff}, |cpu| = {norm}\n{gpu:?}\n{cpu:?}");
    for (a, b) in gpu.iter().zip(cpu) {
        if *b == Vec2::ZERO {
            assert!(a.length() <= 1e-6 * norm.max(1.0), "{case}: GPU {a} where the CPU has exactly zero");
        }
    }
}

fn assert_close_3d(case: &str, gpu: &[Vec3], cpu: &[Vec3]) {
    assert_eq!(gpu.len(), cpu.len(), "{case}");
    assert!(gpu.iter().all(|g| g.is_finite()), "{case}: non-finite GPU gradient");
    let norm = cpu.iter().map(|g| g.length_squared()).sum::<f32>().sqrt();
    let diff = gpu.iter().zip(cpu).map(|(a, b)| (*a - *b).length_squared()).sum::<f32>().sqrt();
    assert!(diff <= 1e-5 * norm.max(1e-3), "{case}: |gpu - cpu| = {diff}, |cpu| = {norm}");
    for (a, b) in gpu.iter().zip(cpu) {
        if *b == Vec3::ZERO {
            assert!(a.length() <= 1e-6 * norm.max(1.0), "{case}: GPU {a} where the CPU has exactly zero");
        }
    }
}

fn assert_frames_equal(case: &str, gpu: &Frame, cpu: &Frame) {
    assert_eq!(gpu.images(), cpu.images(), "{case}: images differ");
    let strip =
        |s: &[RenderStats]| -> Vec<(u32, u32)> { s.iter().map(|s| (s.culled_triangles, s.candidate_edges)).collect() };
    assert_eq!(strip(gpu.stats()), strip(cpu.stats()), "{case}: stats differ");
    assert!(gpu.images().iter().all(|i| i.data().iter().all(|v| v.is_finite())), "{case}: non-finite pixel");
}

/// Both errors, with the same message.
fn assert_same_error<T>(case: &str, gpu: Result<T>, cpu: Result<T>) -> Error {
    let (Err(g), Err(c)) = (gpu, cpu) else { panic!("{case}: expected errors from both backends") };
    assert_eq!(g.to_string(), c.to_string(), "{case}");
    g
}

impl Both {
    /// Screen-space render + backward with `∂L/∂I` from `d` on both; compares everything.
    fn screen(
        &mut self,
        case: &str,
        topology: &Arc<Topology>,
        views: &[ScreenView],
        seed: Option<u64>,
    ) -> Vec<Vec<Vec2>> {
        let (fg, fc) =
            (self.gpu.render_screen(topology, views).unwrap(), self.cpu.render_screen(topology, views).unwrap());
        assert_frames_equal(case, &fg, &fc);
        let d = match seed {
            Some(seed) => weights(&fc, seed),
            None => ones(&fc),
        };
        let (gg, gc) = (self.gpu.backward_screen(&fg, &d).unwrap(), self.cpu.backward_screen(&fc, &d).unwrap());
        for (g, c) in gg.iter().zip(&gc) {
            assert_close_2d(case, g, c);
        }
        gg
    }

    fn screen_one(&mut self, case: &str, vertices: Vec<Vec2>, triangles: Vec<[u32; 3]>, w: u32, h: u32) -> Vec<Vec2> {
        let topology = Arc::new(Topology::new(vertices.len(), triangles).unwrap());
        self.screen(case, &topology, &[ScreenView { vertices, width: w, height: h }], None).remove(0)
    }

    /// 3D render + backward on both; compares everything. Returns the GPU frame and gradient.
    fn world(&mut self, case: &str, mesh: &Mesh, cameras: &[Camera], seed: Option<u64>) -> (Frame, Vec<Vec3>) {
        let (fg, fc) = (self.gpu.render(mesh, cameras).unwrap(), self.cpu.render(mesh, cameras).unwrap());
        assert_frames_equal(case, &fg, &fc);
        let d = match seed {
            Some(seed) => weights(&fc, seed),
            None => ones(&fc),
        };
        let (gg, gc) = (self.gpu.backward(&fg, &d).unwrap(), self.cpu.backward(&fc, &d).unwrap());
        assert_close_3d(case, &gg, &gc);
        (fg, gg)
    }
}

fn camera(width: u32, height: u32) -> Camera {
    Camera::perspective(Vec3::new(0.2, 0.1, 3.0), Vec3::ZERO, 0.9, width, height)
}

fn tri_mesh() -> Mesh {
    Mesh::new(vec![Vec3::new(-0.6, -0.5, 0.0), Vec3::new(0.7, -0.4, 0.1), Vec3::new(0.1, 0.6, -0.1)], vec![[0, 1, 2]])
        .unwrap()
}

#[test]
fn gpu_invalid_input_gives_the_cpu_errors() {
    let Some(mut b) = both("gpu_invalid_input_gives_the_cpu_errors", RenderSettings::default()) else { return };
    let mesh = tri_mesh();
    let topology = mesh.topology().clone();
    // NaN / inf screen vertices.
    for bad in [Vec2::new(3.0, f32::NAN), Vec2::new(f32::INFINITY, 1.0)] {
        let view = ScreenView { vertices: vec![Vec2::ZERO, bad, Vec2::ONE], width: 8, height: 8 };
        let e = assert_same_error(
            "non-finite vertex",
            b.gpu.render_screen(&topology, std::slice::from_ref(&view)),
            b.cpu.render_screen(&topology, &[view]),
        );
        assert!(matches!(e, Error::NonFiniteVertex { vertex: 1, .. }));
    }
    // Out-of-range index: rejected when the topology is built, before any backend.
    assert!(matches!(Topology::new(3, vec![[0, 1, 3]]), Err(Error::IndexOutOfRange { .. })));
    // Resolution 0 and too large.
    for (w, h) in [(0, 16), (16, 0), (0, 0), (100_000, 16)] {
        let e =
            assert_same_error("resolution", b.gpu.render(&mesh, &[camera(w, h)]), b.cpu.render(&mesh, &[camera(w, h)]));
        assert!(matches!(e, Error::InvalidResolution { .. }));
        let view = ScreenView { vertices: vec![Vec2::ZERO; 3], width: w, height: h };
        assert_same_error(
            "resolution (screen)",
            b.gpu.render_screen(&topology, std::slice::from_ref(&view)),
            b.cpu.render_screen(&topology, &[view]),
        );
    }
    // F = 0, F = 17, non-finite pixel values: rejected by the constructor on every backend.
    for settings in [
        RenderSettings { supersample: 0, ..RenderSettings::default() },
        RenderSettings { supersample: 17, ..RenderSettings::default() },
        RenderSettings { supersample: 4, inside: f32::NAN, outside: 0.0 },
    ] {
        let gpu = Renderer::with_gpu_context(settings, gpu_or_skip("settings").unwrap()).map(|_| ());
        assert_same_error("settings", gpu, Renderer::new(settings).map(|_| ()));
        let gpu = Renderer::with_backend(settings, diffsil::Backend::Gpu(Default::default())).map(|_| ());
        assert_same_error("settings (with_backend)", gpu, Renderer::new(settings).map(|_| ()));
    }
    // Vertex count mismatch.
    let view = ScreenView { vertices: vec![Vec2::ZERO; 2], width: 8, height: 8 };
    let e = assert_same_error(
        "vertex count",
        b.gpu.render_screen(&topology, std::slice::from_ref(&view)),
        b.cpu.render_screen(&topology, &[view]),
    );
    assert!(matches!(e, Error::LengthMismatch { expected: 3, got: 2, .. }));
    // Gradient image of the wrong size, wrong count, non-finite; backward() of a screen frame.
    let cams = [camera(32, 24), camera(8, 12)];
    let (fg, fc) = (b.gpu.render(&mesh, &cams).unwrap(), b.cpu.render(&mesh, &cams).unwrap());
    for bad in [Image::filled(24, 32, 1.0), Image::filled(32, 25, 1.0)] {
        let d = [bad, Image::filled(8, 12, 1.0)];
        let e = assert_same_error("gradient size", b.gpu.backward(&fg, &d), b.cpu.backward(&fc, &d));
        assert!(matches!(e, Error::SizeMismatch { expected_width: 32, expected_height: 24, .. }));
        assert_same_error("gradient size (screen)", b.gpu.backward_screen(&fg, &d), b.cpu.backward_screen(&fc, &d));
    }
    for count in [0, 1, 3] {
        let d: Vec<Image> = (0..count).map(|_| Image::filled(32, 24, 1.0)).collect();
        let e = assert_same_error("gradient count", b.gpu.backward(&fg, &d), b.cpu.backward(&fc, &d));
        assert!(matches!(e, Error::ViewCountMismatch { views: 2, .. }));
    }
    for bad in [f32::NAN, f32::INFINITY] {
        let mut d = ones(&fc);
        d[1].data_mut()[37] = bad;
        assert_same_error("non-finite gradient", b.gpu.backward(&fg, &d), b.cpu.backward(&fc, &d));
    }
    let s = scenes::triangle();
    let (fg, fc) = (
        b.gpu.render_screen(&s.topology(), &[s.view()]).unwrap(),
        b.cpu.render_screen(&s.topology(), &[s.view()]).unwrap(),
    );
    let e = assert_same_error(
        "backward of a screen frame",
        b.gpu.backward(&fg, &ones(&fg)),
        b.cpu.backward(&fc, &ones(&fc)),
    );
    assert!(matches!(e, Error::InvalidFrame(_)));
    // A frame of the other backend is refused, not misread.
    assert!(matches!(b.gpu.backward_screen(&fc, &ones(&fc)), Err(Error::InvalidFrame(_))));
    assert!(matches!(b.cpu.backward_screen(&fg, &ones(&fg)), Err(Error::InvalidFrame(_))));
}

#[test]
fn gpu_degenerate_geometry_matches_the_cpu() {
    let Some(mut b) = both("gpu_degenerate_geometry_matches_the_cpu", RenderSettings::default()) else { return };
    // Zero-area triangle, alone and next to a regular one.
    let line = vec![Vec2::new(2.0, 2.0), Vec2::new(10.0, 6.0), Vec2::new(18.0, 10.0)];
    let g = b.screen_one("zero area", line.clone(), vec![[0, 1, 2]], 20, 14);
    assert!(g.iter().all(|g| *g == Vec2::ZERO));
    let mut vertices = scenes::triangle().vertices;
    vertices.extend(line);
    let g = b.screen_one("zero area + triangle", vertices, vec![[0, 1, 2], [3, 4, 5]], 24, 24);
    assert!(g[3..].iter().all(|g| *g == Vec2::ZERO));
    // Edge-on in 3D.
    let edge_on = Mesh::new(
        vec![Vec3::new(-0.5, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.0, -1.0)],
        vec![[0, 1, 2]],
    )
    .unwrap();
    b.world("edge-on", &edge_on, &[Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.9, 16, 16)], None);
    // Zero-length edges: coincident vertices, a repeated index, a point triangle, 3D.
    let base = scenes::triangle().vertices;
    let mut v = base.clone();
    v.push(base[2]);
    let g = b.screen_one("coincident vertices", v, vec![[0, 1, 2], [1, 2, 3]], 24, 24);
    assert_eq!(g[3], Vec2::ZERO);
    b.screen_one("repeated index", base.clone(), vec![[0, 1, 2], [1, 2, 2]], 24, 24);
    b.screen_one("point triangle", vec![Vec2::splat(5.5); 3], vec![[0, 1, 2]], 12, 12);
    let degenerate = Mesh::new(vec![Vec3::ZERO, Vec3::X * 0.5], vec![[0, 1, 1], [0, 0, 0]]).unwrap();
    b.world("repeated index 3D", &degenerate, &[camera(16, 16)], None);
    // Duplicate triangles, and a closed mesh with every face twice.
    let s = scenes::triangle();
    for triangles in [vec![[0, 1, 2], [0, 1, 2]], vec![[0, 1, 2], [2, 1, 0], [1, 2, 0]]] {
        b.screen_one("duplicates", s.vertices.clone(), triangles, 24, 24);
    }
    let sphere = diffsil::shapes::icosphere(1);
    let doubled: Vec<[u32; 3]> = sphere.triangles().iter().flat_map(|&t| [t, [t[0], t[2], t[1]]]).collect();
    let twice = Mesh::new(sphere.positions().to_vec(), doubled).unwrap();
    b.world("doubled sphere", &twice, &[camera(24, 24)], Some(3));
}

#[test]
fn gpu_clipping_and_empty_meshes_match_the_cpu() {
    let settings = RenderSettings { supersample: 4, inside: 1.0, outside: 0.25 };
    let Some(mut b) = both("gpu_clipping_and_empty_meshes_match_the_cpu", settings) else { return };
    // A vertex behind the camera.
    let sphere = diffsil::shapes::icosphere(2);
    let cam = Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.9, 32, 32);
    let mut positions = sphere.positions().to_vec();
    positions[0] = Vec3::new(0.3, 0.2, 5.0);
    let mesh = Mesh::with_topology(positions, sphere.topology().clone()).unwrap();
    let (frame, g) = b.world("vertex behind", &mesh, &[cam], Some(9));
    let incident = mesh.triangles().iter().filter(|t| t.contains(&0)).count() as u32;
    assert_eq!((frame.stats()[0].clipped_triangles, frame.stats()[0].culled_triangles), (incident, 0));
    assert_ne!(g[0], Vec3::ZERO, "the vertex behind moves its clipped triangles");
    // The eye inside the mesh.
    let inside = Camera::perspective(Vec3::new(0.1, 0.0, 0.2), Vec3::new(0.0, 0.0, -1.0), 1.2, 16, 16);
    b.world("eye inside", &sphere, &[inside], None);
    // A screen vertex beyond the coordinate limit.
    let s = scenes::quad();
    let mut vertices = s.vertices.clone();
    vertices[1] = Vec2::new(1.0e7, 3.0);
    let g = b.screen("beyond the coordinate limit", &s.topology(), &[s.view_with(vertices)], None);
    assert_eq!(g[0][1], Vec2::ZERO);
    // Empty meshes (no triangles; no vertices at all).
    for mesh in [Mesh::new(vec![], vec![]).unwrap(), Mesh::new(vec![Vec3::ZERO, Vec3::X], vec![]).unwrap()] {
        let (frame, g) = b.world("empty mesh", &mesh, &[camera(16, 12)], None);
        assert!(frame.images()[0].data().iter().all(|&v| v == 0.25));
        assert!(g.iter().all(|g| *g == Vec3::ZERO));
    }
    let empty = Arc::new(Topology::new(0, vec![]).unwrap());
    let g = b.screen("empty screen", &empty, &[ScreenView { vertices: vec![], width: 5, height: 7 }], None);
    assert_eq!(g, vec![Vec::<Vec2>::new()]);
    // No views at all.
    let frame = b.gpu.render(&sphere, &[]).unwrap();
    assert_eq!(frame.view_count(), 0);
    assert!(b.gpu.backward(&frame, &[]).unwrap().iter().all(|g| *g == Vec3::ZERO));
}

// ---------------------------------------------------------------------------------------------
// Limits (issue 13): errors naming the count or size and the limit, before any device work.

#[test]
fn gpu_limits_name_the_view_count_and_the_software_adapter() {
    let Some(ctx) = gpu_or_skip("gpu_limits_name_the_view_count_and_the_software_adapter") else { return };
    let software = ctx.adapter().device_type == wgpu::DeviceType::Cpu;
    let mut gpu = Renderer::with_gpu_context(RenderSettings::default(), ctx).unwrap();
    let s = scenes::triangle();
    let views: Vec<ScreenView> =
        (0..257).map(|_| ScreenView { vertices: s.vertices.clone(), width: 4, height: 4 }).collect();
    let message = gpu.render_screen(&s.topology(), &views).unwrap_err().to_string();
    for word in ["257 views", "at most 256", "batches"] {
        assert!(message.contains(word), "`{message}` should mention `{word}`");
    }
    // 2048² at F = 4 takes a minute on lavapipe: refused at once on a software adapter.
    let start = std::time::Instant::now();
    let big = ScreenView { vertices: s.vertices.clone(), width: 2048, height: 2048 };
    if software {
        match gpu.render_screen(&s.topology(), std::slice::from_ref(&big)) {
            Err(e @ Error::GpuLimit { .. }) => {
                let message = e.to_string();
                for word in ["software GPU adapter", "CPU engine", "DIFFSIL_SOFTWARE_GPU_ANY_SIZE", "67108864"] {
                    assert!(message.contains(word), "`{message}` should mention `{word}`");
                }
            }
            other => panic!("expected a GpuLimit error on a software adapter, got {other:?}"),
        }
        assert!(start.elapsed().as_secs_f64() < 2.0, "refused after {:?}", start.elapsed());
    } else {
        println!("hardware adapter: 2048² renders ({:?})", gpu.render_screen(&s.topology(), &[big]).map(|_| ()));
    }
    // Beyond the memory budget: the renderer's error, before the device's own limits.
    let settings = RenderSettings { supersample: 16, ..RenderSettings::default() };
    let ctx = gpu_or_skip("gpu_limits_name_the_view_count_and_the_software_adapter").unwrap();
    let mut gpu16 = Renderer::with_gpu_context(settings, ctx).unwrap();
    let huge = ScreenView { vertices: s.vertices.clone(), width: 16384, height: 16384 };
    assert!(matches!(gpu16.render_screen(&s.topology(), &[huge]), Err(Error::MemoryLimit { .. })));
    // Small frames still render.
    assert!(gpu.render_screen(&s.topology(), &[s.view()]).is_ok());
}

#[test]
fn gpu_random_extreme_scenes_return_errors_or_finite_values() {
    use crate::common::fuzz::{env_count, fuzz_seed, run_cases, Scene};
    let Some(ctx) = gpu_or_skip("gpu_random_extreme_scenes_return_errors_or_finite_values") else { return };
    let settings = RenderSettings::default();
    let gpu = std::sync::Mutex::new(Renderer::with_gpu_context(settings, ctx).unwrap());
    let count = env_count("DIFFSIL_FUZZ_GPU_SCENES", 60);
    let seed = fuzz_seed();
    let summary = run_cases("GPU scenes", count, move |i| {
        // The GPU renderer keeps its settings: each scene runs at F = 4 with pixel values 1 / 0.
        let scene = Scene { settings, ..Scene::random(seed, i) };
        scene.check(&mut gpu.lock().unwrap_or_else(|e| e.into_inner()))
    });
    assert!(summary.ok * 4 > count, "only {} of {count} scenes rendered", summary.ok);
}
