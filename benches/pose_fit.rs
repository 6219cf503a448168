//! One step of the pose fit (`fit::PoseFit::step`) on the built-in figure, the workload of the
//! `fit_pose` example: skinning, forward + blurred loss + backward over 4 views at 64², F = 4, the
//! self-intersection check (which runs beside the render), the skinning backward and an Adam
//! step, on the CPU backend. The step is measured twice: with the check at every step
//! (`PoseFit`'s default), and with a check every
//! [`FitOptions::INTERSECTION_INTERVAL`]-th step, the steps between reusing its gradient, as the
//! library's fit (`fit::fit`, and so the example) runs it. Two of its parts are measured alone
//! beside it: the renderer's forward + loss + backward of the 4 views
//! (`Renderer::squared_error_step`, rest pose against the targets), and the self-intersection
//! check.
//!
//! The targets are the silhouettes of the random pose of seed 1; the fit starts at the rest pose
//! and keeps stepping through criterion's iterations, so the figures are those of a fit under way.

use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{framing_cameras, random_pose, FitOptions, FitSettings, PoseFit};
use diffsil::pose::self_intersection::SelfIntersectionChecker;
use diffsil::{Mesh, RenderSettings, Renderer, Targets};

const VIEWS: u32 = 4;
const RESOLUTION: u32 = 64;

fn pose_fit(c: &mut Criterion) {
    let model = builtin_figure();
    let limits = random_pose_limits(&model.skeleton);
    let truth = random_pose(&limits, 30f32.to_radians(), 1);
    let truth_vertices = model.skin(&truth).expect("the figure skins");
    let truth_mesh = Mesh::with_topology(truth_vertices.clone(), model.mesh.topology().clone()).expect("valid mesh");
    let cameras = framing_cameras(&model.mesh, VIEWS, RESOLUTION);
    let mut renderer = Renderer::new(RenderSettings::default()).expect("the CPU backend opens");
    let targets = renderer.render(&truth_mesh, &cameras).expect("targets render").images().to_vec();
    let mut views = Renderer::new(RenderSettings::default()).expect("the CPU backend opens");
    let view_targets = Targets::new(targets.clone()).expect("valid targets");
    let view_cameras = cameras.clone();
    let [mut fit, mut fit_as_library] =
        [1, FitOptions::INTERSECTION_INTERVAL].map(|interval| new_fit(&model, &cameras, &targets, interval));

    let mut group = c.benchmark_group("pose_fit/builtin figure");
    group.sample_size(20).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_millis(500));
    group.bench_function(format!("step ({VIEWS} views at {RESOLUTION}²)"), |b| {
        b.iter(|| fit.step().expect("the step runs"))
    });
    group.bench_function(format!("step, checked as fit::fit ({VIEWS} views at {RESOLUTION}²)"), |b| {
        b.iter(|| fit_as_library.step().expect("the step runs"))
    });
    group.bench_function(format!("render + loss + backward ({VIEWS} views at {RESOLUTION}²)"), |b| {
        b.iter(|| views.squared_error_step(&model.mesh, &view_cameras, &view_targets).expect("the step runs").loss)
    });
    let mut checker = SelfIntersectionChecker::new(model.mesh.topology());
    group.bench_function("self-intersection check", |b| {
        b.iter(|| checker.check(&truth_vertices).expect("the check runs").surrogate)
    });
    group.finish();
}

/// One step of the fit of the MakeHuman body (7k vertices, 31 joints) in the same setting, when
/// `DIFFSIL_ASSETS` names the folder holding `makehuman-body-7k.glb` (skipped otherwise).
fn body_fit(c: &mut Criterion) {
    let Some(path) =
        std::env::var_os("DIFFSIL_ASSETS").map(|d| std::path::PathBuf::from(d).join("makehuman-body-7k.glb"))
    else {
        eprintln!("pose_fit: DIFFSIL_ASSETS unset, skipping the MakeHuman body");
        return;
    };
    let Ok(diffsil::io::gltf::Model::Skinned(model)) = diffsil::io::gltf::load_gltf(&path) else {
        eprintln!("pose_fit: {} is not a skinned model here, skipping it", path.display());
        return;
    };
    let limits = random_pose_limits(&model.skeleton);
    let truth = random_pose(&limits, 30f32.to_radians(), 1);
    let rest = model.posed_mesh(&diffsil::pose::skin::Pose::rest(model.joint_count())).expect("the body skins");
    let cameras = framing_cameras(&rest, VIEWS, RESOLUTION);
    let mut renderer = Renderer::new(RenderSettings::default()).expect("the CPU backend opens");
    let targets = renderer
        .render(&model.posed_mesh(&truth).expect("the body skins"), &cameras)
        .expect("targets render")
        .images()
        .to_vec();
    let parts = Parts::new(&model, &truth, &cameras, &targets);
    let [mut fit, mut fit_as_library] =
        [1, FitOptions::INTERSECTION_INTERVAL].map(|interval| new_fit(&model, &cameras, &targets, interval));
    let mut group = c.benchmark_group("pose_fit/makehuman-body-7k");
    group.sample_size(10).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_millis(500));
    group.bench_function(format!("step ({VIEWS} views at {RESOLUTION}²)"), |b| {
        b.iter(|| fit.step().expect("the step runs"))
    });
    group.bench_function(format!("step, checked as fit::fit ({VIEWS} views at {RESOLUTION}²)"), |b| {
        b.iter(|| fit_as_library.step().expect("the step runs"))
    });
    parts.bench(&mut group);
    group.finish();
}

/// A fit of `model` from its rest pose to `targets`, with the pose prior of the library's fit and
/// a self-intersection check every `interval`-th step.
fn new_fit(
    model: &diffsil::pose::skin::SkinnedMesh,
    cameras: &[diffsil::Camera],
    targets: &[diffsil::Image],
    interval: u32,
) -> PoseFit {
    let renderer = Renderer::new(RenderSettings::default()).expect("the CPU backend opens");
    let mut fit = PoseFit::new(model.clone(), cameras.to_vec(), targets.to_vec(), renderer, FitSettings::default())
        .expect("valid fit");
    fit.set_pose_prior(PoseFit::POSE_PRIOR).expect("valid prior");
    fit.set_intersection_interval(interval).expect("a valid interval");
    fit
}

/// The parts of one step of the MakeHuman body's fit, each alone, at a pose between the rest
/// pose and the target's (so that the silhouettes disagree along their contours, as in a fit).
struct Parts {
    model: diffsil::pose::skin::SkinnedMesh,
    pose: diffsil::pose::skin::Pose,
    mesh: Mesh,
    cameras: Vec<diffsil::Camera>,
    targets: Vec<diffsil::Image>,
    renderer: Renderer,
}

impl Parts {
    fn new(
        model: &diffsil::pose::skin::SkinnedMesh,
        truth: &diffsil::pose::skin::Pose,
        cameras: &[diffsil::Camera],
        targets: &[diffsil::Image],
    ) -> Parts {
        let params: Vec<f32> = truth.to_params().iter().map(|t| 0.5 * t).collect();
        let pose = diffsil::pose::skin::Pose::from_params(&params, model.joint_count()).expect("a valid pose");
        let mesh = model.posed_mesh(&pose).expect("the body skins");
        let renderer = Renderer::new(RenderSettings::default()).expect("the CPU backend opens");
        Parts { model: model.clone(), pose, mesh, cameras: cameras.to_vec(), targets: targets.to_vec(), renderer }
    }

    /// Skinning, render forward, loss (sharp and blurred), render backward with the chain to
    /// 3D, skinning backward and the self-intersection check.
    fn bench(mut self, group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>) {
        use diffsil::loss::{blurred_squared_error, GaussianBlur};
        let Parts { model, pose, mesh, cameras, targets, renderer } = &mut self;
        group.bench_function("part: skinning", |b| b.iter(|| model.skin_shaped_with_cache(pose, &[]).expect("skins")));
        group.bench_function(format!("part: render forward ({VIEWS} views)"), |b| {
            b.iter(|| renderer.render(mesh, cameras).expect("renders"))
        });
        let frame = renderer.render(mesh, cameras).expect("renders");
        let sharp = GaussianBlur::identity();
        let blur = GaussianBlur::new(0.06 * RESOLUTION as f32).expect("a valid blur");
        let blurred_targets: Vec<diffsil::Image> = targets.iter().map(|t| blur.apply(t)).collect();
        let loss = |blur: &GaussianBlur, targets: &[diffsil::Image]| -> Vec<diffsil::Image> {
            frame
                .images()
                .iter()
                .zip(targets)
                .map(|(image, target)| blurred_squared_error(image, target, blur).expect("loss").grad)
                .collect()
        };
        group.bench_function(format!("part: loss ({VIEWS} views, sharp)"), |b| b.iter(|| loss(&sharp, targets)));
        group.bench_function(format!("part: loss ({VIEWS} views, blur 6%)"), |b| {
            b.iter(|| loss(&blur, &blurred_targets))
        });
        let d_images = loss(&sharp, targets);
        group.bench_function(format!("part: render backward + 3D chain ({VIEWS} views)"), |b| {
            b.iter(|| renderer.backward(&frame, &d_images).expect("backward"))
        });
        let d_vertices = renderer.backward(&frame, &d_images).expect("backward");
        let (_, cache) = model.skin_shaped_with_cache(pose, &[]).expect("skins");
        group.bench_function("part: skinning backward", |b| {
            b.iter(|| model.backward_with_shape(&cache, &d_vertices).expect("backward"))
        });
        let mut checker = SelfIntersectionChecker::new(mesh.topology());
        group.bench_function("part: self-intersection check", |b| {
            b.iter(|| checker.check(mesh.positions()).expect("the check runs").surrogate)
        });
    }
}

criterion_group!(benches, pose_fit, body_fit);
criterion_main!(benches);
