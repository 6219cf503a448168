//! One optimisation step's cost against resolution (paper Table 3): projection, forward, L2 loss
//! against the silhouette of the mesh shifted by 0.05, backward to 3D vertices — one
//! `Renderer::squared_error_step`, which on the GPU keeps the images and the loss on the device.
//!
//! Scene (fixed so figures compare across tools): the mesh normalised so its bounding-box centre
//! is at the origin and its farthest vertex at distance 1, a perspective camera at (0, 0, 2.7)
//! looking at the origin, up +y, vertical fov 50°, F = 4, one view. The mesh is the Stanford bunny
//! when `DIFFSIL_ASSETS` points at a folder holding `stanford-bunny.obj`, otherwise a procedural
//! blob of about the same size (69,168 triangles). After criterion's report the bench prints a
//! table of milliseconds per iteration: the median and the fastest of up to 200 steps (on a
//! shared machine the fastest moves less from run to run than the median).

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use diffsil::gpu::GpuOptions;
use diffsil::{shapes, Backend, Camera, Mesh, RenderSettings, Renderer, Targets, Vec3};

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
    targets: Targets,
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
            let targets = Targets::new(renderer.render(&shifted, &[camera])?.images().to_vec())?;
            let mut step = Step { mesh: mesh.clone(), targets, renderer, camera };
            step.try_run()?;
            Ok(step)
        };
        attempt().map_err(|e| eprintln!("{backend:?} at {resolution}²: skipped ({e})")).ok()
    }

    fn try_run(&mut self) -> diffsil::Result<Vec<Vec3>> {
        Ok(self.renderer.squared_error_step(&self.mesh, &[self.camera], &self.targets)?.gradient)
    }

    fn run(&mut self) -> Vec<Vec3> {
        self.try_run().expect("the step ran once already")
    }
}

/// The median and the fastest of up to 200 timed steps (at least 5, about 2 s), in ms.
fn step_ms(step: &mut Step) -> (f64, f64) {
    let mut times = Vec::new();
    let start = Instant::now();
    while times.len() < 5 || (start.elapsed() < Duration::from_secs(2) && times.len() < 200) {
        let t = Instant::now();
        std::hint::black_box(step.run());
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], times[0])
}

/// The backends to compare: the CPU, and the GPU when an adapter opens (the one
/// `GpuOptions::from_env` picks: the best hardware GPU, else a software one such as lavapipe;
/// `DIFFSIL_ADAPTER` picks another).
fn backends() -> Vec<(&'static str, Backend)> {
    let mut backends = vec![("cpu", Backend::Cpu)];
    // Profiling (DIFFSIL_GPU_PROFILE) adds waits: time without it, profile separately below.
    let gpu = Backend::Gpu(GpuOptions { profile: false, ..GpuOptions::from_env() });
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

    println!(
        "\nms per forward + backward (median / fastest step), {name}, {} triangles, F = 4, one view",
        mesh.triangles().len()
    );
    let gpu = backends.len() > 1;
    println!(
        "{}",
        if gpu {
            "| resolution | CPU ms | GPU ms | GPU / CPU (medians) |\n|---|---|---|---|"
        } else {
            "| resolution | CPU ms |\n|---|---|"
        }
    );
    let cell = |v: Option<(f64, f64)>| v.map_or("n/a".to_string(), |(m, f)| format!("{m:.2} / {f:.2}"));
    for res in RESOLUTIONS {
        let cpu = Step::new(&mesh, res, &Backend::Cpu).map(|mut s| step_ms(&mut s));
        if gpu {
            let g = Step::new(&mesh, res, &backends[1].1).map(|mut s| step_ms(&mut s));
            let ratio = cpu.zip(g).map_or("n/a".to_string(), |(c, g)| format!("{:.1}", g.0 / c.0));
            println!("| {res}² | {} | {} | {ratio} |", cell(cpu), cell(g));
        } else {
            println!("| {res}² | {} |", cell(cpu));
        }
    }
}

/// With `DIFFSIL_GPU_PROFILE=1`: the GPU time of each stage at every resolution, from timestamp
/// queries (one step after two warm-up steps).
fn gpu_stage_profile(mesh: &Mesh) {
    let options = GpuOptions::from_env();
    if !options.profile {
        return;
    }
    let backend = Backend::Gpu(options);
    println!("\nGPU stage times (µs, timestamp queries), one step");
    for res in RESOLUTIONS {
        let Some(mut step) = Step::new(mesh, res, &backend) else { continue };
        step.run();
        step.run();
        let wall = Instant::now();
        step.run();
        let wall = wall.elapsed().as_secs_f64() * 1e6;
        let timings = step.renderer.gpu_stage_timings();
        if timings.is_empty() {
            println!("no timestamp queries on this adapter");
            return;
        }
        let total: f64 = timings.iter().filter(|t| !t.stage.starts_with("host")).map(|t| t.microseconds).sum();
        let stages: Vec<String> = timings.iter().map(|t| format!("{} {:.0}", t.stage, t.microseconds)).collect();
        println!("{res}²: wall {wall:.0}, GPU total {total:.0}: {}", stages.join(", "));
    }
}

fn profile(_: &mut Criterion) {
    gpu_stage_profile(&bench_mesh().0);
}

criterion_group!(benches, resolution, profile);
criterion_main!(benches);
