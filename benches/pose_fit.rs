//! One step of the pose fit (`fit::PoseFit::step`) on the built-in figure, the workload of the
//! `fit_pose` example: skinning, forward + blurred loss + backward over 4 views at 64², F = 4, the
//! self-intersection check (which runs beside the render), the skinning backward and an Adam
//! step, on the CPU backend. Two of its parts are measured alone beside it: the renderer's
//! forward + loss + backward of the 4 views (`Renderer::squared_error_step`, rest pose against
//! the targets), and the self-intersection check.
//!
//! The targets are the silhouettes of the random pose of seed 1; the fit starts at the rest pose
//! and keeps stepping through criterion's iterations, so the figures are those of a fit under way.

use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{framing_cameras, random_pose, FitSettings, PoseFit};
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
    let mut fit = PoseFit::new(model.clone(), cameras, targets, renderer, FitSettings::default()).expect("valid fit");
    fit.set_pose_prior(PoseFit::POSE_PRIOR).expect("valid prior");

    let mut group = c.benchmark_group("pose_fit/builtin figure");
    group.sample_size(20).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_millis(500));
    group.bench_function(format!("step ({VIEWS} views at {RESOLUTION}²)"), |b| {
        b.iter(|| fit.step().expect("the step runs"))
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
    let mut fit = PoseFit::new(model, cameras, targets, renderer, FitSettings::default()).expect("valid fit");
    fit.set_pose_prior(PoseFit::POSE_PRIOR).expect("valid prior");
    let mut group = c.benchmark_group("pose_fit/makehuman-body-7k");
    group.sample_size(10).measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_millis(500));
    group.bench_function(format!("step ({VIEWS} views at {RESOLUTION}²)"), |b| {
        b.iter(|| fit.step().expect("the step runs"))
    });
    group.finish();
}

criterion_group!(benches, pose_fit, body_fit);
criterion_main!(benches);
