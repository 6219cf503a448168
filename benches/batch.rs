//! Batches: one squared-error step (`Renderer::squared_error_step_batch`) for B instances of the
//! MakeHuman body (7k vertices, built in: `pose::makehuman_body`), each in its own random pose,
//! 4 views at 64², F = 4, against B separate `squared_error_step` calls, for B ∈ {1, 8, 64}: on
//! the CPU, and on the GPU when an adapter opens (the one `GpuOptions::from_env` picks; on a
//! machine with only Mesa's lavapipe that is a software adapter on the CPU, not a GPU figure).
//!
//! Criterion times each call (not on a software adapter); the table at the end gives the median time per instance of each,
//! and the ratio of batched to separate, all measured in this run.

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use diffsil::gpu::GpuOptions;
use diffsil::pose::figure::random_pose_limits;
use diffsil::pose::fit::{framing_cameras, random_pose};
use diffsil::pose::makehuman_body;
use diffsil::pose::skin::Pose;
use diffsil::{Backend, Camera, Instance, Mesh, RenderSettings, Renderer, Targets};

const VIEWS: u32 = 4;
const RESOLUTION: u32 = 64;
const SIZES: [usize; 3] = [1, 8, 64];

/// The body in 64 random poses (seeds 1–64), its cameras, and the targets: the body in the pose
/// of seed 1000, rendered on the CPU.
struct Scene {
    meshes: Vec<Mesh>,
    cameras: Vec<Camera>,
    targets: Targets,
}

fn scene() -> Scene {
    let body = makehuman_body().expect("the built-in body loads");
    let limits = random_pose_limits(&body.skeleton);
    let rest = body.posed_mesh(&Pose::rest(body.joint_count())).expect("the body skins");
    let cameras = framing_cameras(&rest, VIEWS, RESOLUTION);
    let posed = |seed| body.posed_mesh(&random_pose(&limits, 30f32.to_radians(), seed)).expect("the body skins");
    let meshes: Vec<Mesh> = (1..=64)
        .map(|seed| Mesh::with_topology(posed(seed).positions().to_vec(), rest.topology().clone()).expect("valid mesh"))
        .collect();
    let truth = Mesh::with_topology(posed(1000).positions().to_vec(), rest.topology().clone()).expect("valid mesh");
    let mut cpu = Renderer::new(RenderSettings::default()).expect("the CPU backend opens");
    let targets = Targets::new(cpu.render(&truth, &cameras).expect("targets render").images().to_vec()).expect("valid");
    Scene { meshes, cameras, targets }
}

/// One batched step of the first `b` instances.
fn try_batched(renderer: &mut Renderer, scene: &Scene, b: usize) -> diffsil::Result<f64> {
    let instances: Vec<Instance<'_>> =
        scene.meshes[..b].iter().map(|mesh| Instance { mesh, cameras: &scene.cameras }).collect();
    let steps = renderer.squared_error_step_batch(&instances, &vec![&scene.targets; b])?;
    Ok(steps.iter().map(|s| s.loss).sum())
}

fn batched(renderer: &mut Renderer, scene: &Scene, b: usize) -> f64 {
    try_batched(renderer, scene, b).expect("the batch ran once already")
}

/// `b` separate steps.
fn separate(renderer: &mut Renderer, scene: &Scene, b: usize) -> f64 {
    scene.meshes[..b]
        .iter()
        .map(|mesh| renderer.squared_error_step(mesh, &scene.cameras, &scene.targets).expect("the step runs").loss)
        .sum()
}

/// The median of `f`'s times, ms (at least 3 runs, then up to 2 s).
fn median_ms(mut f: impl FnMut() -> f64) -> f64 {
    let mut times = Vec::new();
    let start = Instant::now();
    while times.len() < 3 || (start.elapsed() < Duration::from_secs(2) && times.len() < 100) {
        let t = Instant::now();
        std::hint::black_box(f());
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// The CPU, and the GPU when an adapter opens, each with the batch sizes it runs: a software
/// adapter (lavapipe: ~7 s for one instance's step here, 250× the CPU backend) only B = 1, and in
/// the table only (criterion would take minutes).
fn renderers() -> Vec<(String, Renderer, Vec<usize>)> {
    let mut renderers = vec![(
        "cpu".to_string(),
        Renderer::new(RenderSettings::default()).expect("the CPU backend opens"),
        SIZES.to_vec(),
    )];
    let gpu = Backend::Gpu(GpuOptions { profile: false, ..GpuOptions::from_env() });
    match Renderer::with_backend(RenderSettings::default(), gpu) {
        Ok(r) => {
            let software = r.adapter().is_some_and(|a| a.device_type == wgpu::DeviceType::Cpu);
            let (label, sizes) = if software { ("gpu (software adapter)", vec![1]) } else { ("gpu", SIZES.to_vec()) };
            eprintln!("GPU series on {}", r.backend_name());
            renderers.push((label.to_string(), r, sizes));
        }
        Err(e) => eprintln!("no GPU series: {e}"),
    }
    renderers
}

fn batch(c: &mut Criterion) {
    let scene = scene();
    let mut renderers = renderers();
    for (label, renderer, sizes) in &mut renderers {
        if label.contains("software") {
            continue;
        }
        // Sizes the backend cannot run (a device limit) are left out, and said so.
        sizes.retain(|&b| {
            try_batched(renderer, &scene, b).map_err(|e| eprintln!("{label}, B = {b}: skipped ({e})")).is_ok()
        });
        let mut group = c.benchmark_group(format!("batch/{label}/makehuman-body-7k, {VIEWS} views at {RESOLUTION}²"));
        group.sample_size(10).measurement_time(Duration::from_secs(1)).warm_up_time(Duration::from_millis(300));
        for &b in sizes.iter() {
            group.throughput(Throughput::Elements(b as u64));
            group.bench_with_input(BenchmarkId::new("batched", b), &b, |bench, &b| {
                bench.iter(|| batched(renderer, &scene, b))
            });
            group.bench_with_input(BenchmarkId::new("separate", b), &b, |bench, &b| {
                bench.iter(|| separate(renderer, &scene, b))
            });
        }
        group.finish();
    }

    println!("\nms per instance (median) of one squared-error step, makehuman-body-7k, {VIEWS} views at {RESOLUTION}², F = 4");
    println!("| backend | B | batched | separate | batched / separate |\n|---|---|---|---|---|");
    for (label, renderer, sizes) in &mut renderers {
        for &b in sizes.iter() {
            let one = median_ms(|| batched(renderer, &scene, b)) / b as f64;
            let many = median_ms(|| separate(renderer, &scene, b)) / b as f64;
            println!("| {label} | {b} | {one:.2} | {many:.2} | {:.2} |", one / many);
        }
    }
}

criterion_group!(benches, batch);
criterion_main!(benches);
