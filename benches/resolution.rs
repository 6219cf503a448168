//! One optimisation step's cost against resolution (paper Table 3): projection, forward, L2 loss
//! against the silhouette of the mesh shifted by 0.05, backward to 3D vertices.
//!
//! Scene (fixed so figures compare across tools): the mesh normalised so its bounding-box centre
//! is at the origin and its farthest vertex at distance 1, a perspective camera at (0, 0, 2.7)
//! looking at the origin, up +y, vertical fov 50°, F = 4, one view. The mesh is the Stanford bunny
//! when `DIFFSIL_ASSETS` points at a folder holding `stanford-bunny.obj`, otherwise a procedural
//! blob of about the same size (69,168 triangles). After criterion's report the bench prints a
//! table of median milliseconds per iteration.

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use diffsil::gpu::GpuOptions;
use diffsil::{loss, shapes, Backend, Camera, Image, Mesh, RenderSettings, Renderer, Vec3};

const RESOLUTIONS: [u32; 7] = [16, 32, 64, 128, 256, 512, 1024];

/// The benchmark mesh and its name.
fn bench_mesh() -> (Mesh, String) {
    if let Ok(dir) = std::env::var("DIFFSIL_ASSETS") {
        let path = std::path::Path::new(&dir).join("stanford-bunny.obj");
        match diffsil::io::load_obj(&path) {
            Ok(mesh) => return (mesh.normalized(1.0), "Stanford bunny".to_string()),
            Err(e) => eprintln!("DIFFSIL_ASSETS is set but the bunny did not load ({e}); using the procedural blob"),
        }
    } else {
        eprintln!("DIFFSIL_ASSETS is not set: benchmarking the procedural blob (set DIFFSIL_ASSETS=../shared/assets for the bunny)");
    }
    (shapes::blob(132, 264).normalized(1.0), "procedural blob".to_string())
}

fn camera(resolution: u32) -> Camera {
    Camera::perspective(Vec3::new(0.0, 0.0, 2.7), Vec3::ZERO, 50f32.to_radians(), resolution, resolution)
}

/// A ready-to-run step: the mesh, the target image for this resolution, and a renderer.
struct Step {
    mesh: Mesh,
    target: Image,
    renderer: Renderer,
    camera: Camera,
}

impl Step {
    /// A step on `backend`, or `None` (with the reason printed) when that backend cannot run it,
    /// e.g. no GPU adapter, or a device limit.
    fn new(mesh: &Mesh, resolution: u32, backend: &Backend) -> Option<Step> {
        let attempt = || -> diffsil::Result<Step> {
            let mut renderer = Renderer::with_backend(RenderSettings::default(), backend.clone())?;
            let camera = camera(resolution);
            let shifted: Vec<Vec3> = mesh.positions().iter().map(|p| *p + Vec3::new(0.05, 0.0, 0.0)).collect();
            let shifted = Mesh::with_topology(shifted, mesh.topology().clone())?;
            let target = renderer.render(&shifted, &[camera])?.images()[0].clone();
            let mut step = Step { mesh: mesh.clone(), target, renderer, camera };
            step.try_run()?;
            Ok(step)
        };
        attempt().map_err(|e| eprintln!("{backend:?} at {resolution}²: skipped ({e})")).ok()
    }

    fn try_run(&mut self) -> diffsil::Result<Vec<Vec3>> {
        let frame = self.renderer.render(&self.mesh, &[self.camera])?;
        let l2 = loss::squared_error(&frame.images()[0], &self.target)?;
        self.renderer.backward(&frame, &[l2.grad])
    }

    fn run(&mut self) -> Vec<Vec3> {
        self.try_run().expect("the step ran once already")
    }
}

fn median_ms(step: &mut Step) -> f64 {
    let mut times = Vec::new();
    let start = Instant::now();
    while times.len() < 5 || (start.elapsed() < Duration::from_secs(2) && times.len() < 200) {
        let t = Instant::now();
        std::hint::black_box(step.run());
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// The backends to compare: the CPU, and the GPU when an adapter opens (on a machine whose only
/// adapter is a software one, lavapipe, set `DIFFSIL_ADAPTER=vulkan` or `llvmpipe` to include it).
fn backends() -> Vec<(&'static str, Backend)> {
    let mut backends = vec![("cpu", Backend::Cpu)];
    let gpu = Backend::Gpu(GpuOptions::from_env());
    match Renderer::with_backend(RenderSettings::default(), gpu.clone()) {
        Ok(r) => {
            eprintln!("GPU series on {}", r.backend_name());
            backends.push(("gpu", gpu));
        }
        Err(e) => eprintln!("no GPU series: {e}"),
    }
    backends
}

fn resolution(c: &mut Criterion) {
    let (mesh, name) = bench_mesh();
    let backends = backends();
    for (label, backend) in &backends {
        let mut group = c.benchmark_group(format!("forward+backward/{label}/{name}"));
        group.sample_size(10).measurement_time(Duration::from_secs(2)).warm_up_time(Duration::from_millis(500));
        for res in RESOLUTIONS {
            let Some(mut step) = Step::new(&mesh, res, backend) else { continue };
            group.bench_with_input(BenchmarkId::from_parameter(format!("{res}x{res}")), &res, |b, _| {
                b.iter(|| step.run())
            });
        }
        group.finish();
    }

    println!("\nms per forward + backward (median), {name}, {} triangles, F = 4, one view", mesh.triangles().len());
    let gpu = backends.len() > 1;
    println!(
        "{}",
        if gpu {
            "| resolution | CPU ms | GPU ms | GPU / CPU |\n|---|---|---|---|"
        } else {
            "| resolution | CPU ms |\n|---|---|"
        }
    );
    for res in RESOLUTIONS {
        let cpu = Step::new(&mesh, res, &Backend::Cpu).map(|mut s| median_ms(&mut s));
        let cell = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.2}"));
        if gpu {
            let g = Step::new(&mesh, res, &backends[1].1).map(|mut s| median_ms(&mut s));
            let ratio = cpu.zip(g).map_or("n/a".to_string(), |(c, g)| format!("{:.1}", g / c));
            println!("| {res}² | {} | {} | {ratio} |", cell(cpu), cell(g));
        } else {
            println!("| {res}² | {} |", cell(cpu));
        }
    }
}

criterion_group!(benches, resolution);
criterion_main!(benches);
