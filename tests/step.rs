//! `Renderer::squared_error_step` (render + squared error + backward in one call) against the same
//! three calls made separately, on the CPU and, where there is an adapter, on the GPU, whose loss
//! stage keeps the images on the device.

mod common;

use common::gpu::gpu_or_skip;
use diffsil::{loss, shapes, Camera, Error, Image, Mesh, Orbit, RenderSettings, Renderer, Targets, Vec3};

fn cameras() -> Vec<Camera> {
    vec![
        Orbit { azimuth: 0.0, elevation: 0.2, distance: 3.0, fov_y: 45f32.to_radians(), ..Orbit::default() }
            .camera(48, 40),
        Orbit { azimuth: 1.7, elevation: -0.3, distance: 3.2, fov_y: 40f32.to_radians(), ..Orbit::default() }
            .camera(33, 57),
    ]
}

fn mesh() -> Mesh {
    shapes::blob(24, 48)
}

/// Targets: the mesh moved a little, rendered on the CPU.
fn targets(mesh: &Mesh, cameras: &[Camera], shift: Vec3) -> Targets {
    let moved: Vec<Vec3> = mesh.positions().iter().map(|p| *p + shift).collect();
    let moved = Mesh::with_topology(moved, mesh.topology().clone()).unwrap();
    let frame = Renderer::new(RenderSettings::default()).unwrap().render(&moved, cameras).unwrap();
    Targets::new(frame.images().to_vec()).unwrap()
}

/// render, `loss::squared_error` per view, backward: (loss, per-view losses, gradient).
fn separately(
    renderer: &mut Renderer,
    mesh: &Mesh,
    cameras: &[Camera],
    targets: &Targets,
) -> (f64, Vec<f64>, Vec<Vec3>) {
    let frame = renderer.render(mesh, cameras).unwrap();
    let mut losses = Vec::new();
    let mut grads = Vec::new();
    for (image, target) in frame.images().iter().zip(targets.images()) {
        let l2 = loss::squared_error(image, target).unwrap();
        losses.push(l2.value);
        grads.push(l2.grad);
    }
    let gradient = renderer.backward(&frame, &grads).unwrap();
    (losses.iter().sum(), losses, gradient)
}

fn relative(a: &[Vec3], b: &[Vec3]) -> f64 {
    let diff: f64 = a.iter().zip(b).map(|(x, y)| (*x - *y).length_squared() as f64).sum::<f64>().sqrt();
    let norm: f64 = b.iter().map(|y| y.length_squared() as f64).sum::<f64>().sqrt();
    diff / norm.max(1e-30)
}

#[test]
fn cpu_step_equals_render_loss_backward() {
    let (mesh, cameras) = (mesh(), cameras());
    let targets = targets(&mesh, &cameras, Vec3::new(0.04, -0.03, 0.0));
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let step = renderer.squared_error_step(&mesh, &cameras, &targets).unwrap();
    let (loss, view_losses, gradient) = separately(&mut renderer, &mesh, &cameras, &targets);
    assert!(loss > 0.0);
    assert_eq!(step.loss, loss);
    assert_eq!(step.view_losses, view_losses);
    assert_eq!(step.gradient, gradient);
    assert_eq!(step.stats.len(), 2);
}

#[test]
fn gpu_step_equals_render_loss_backward() {
    let Some(ctx) = gpu_or_skip("gpu_step_equals_render_loss_backward") else { return };
    let (mesh, cameras) = (mesh(), cameras());
    let mut gpu = Renderer::with_gpu_context(RenderSettings::default(), ctx).unwrap();
    let mut cpu = Renderer::new(RenderSettings::default()).unwrap();
    for (k, shift) in [Vec3::new(0.04, -0.03, 0.0), Vec3::new(-0.05, 0.02, 0.03)].into_iter().enumerate() {
        // New targets each round: the GPU must upload them again.
        let targets = targets(&mesh, &cameras, shift);
        let step = gpu.squared_error_step(&mesh, &cameras, &targets).unwrap();
        let again = gpu.squared_error_step(&mesh, &cameras, &targets).unwrap();
        assert_eq!(step, again, "round {k}: two GPU steps differ");
        // The same gradient bits as the GPU's render + CPU loss + GPU backward.
        let (loss, view_losses, gradient) = separately(&mut gpu, &mesh, &cameras, &targets);
        assert_eq!(step.gradient, gradient, "round {k}");
        for (a, b) in step.view_losses.iter().zip(&view_losses) {
            assert!((a - b).abs() <= 1e-5 * b.abs(), "round {k}: view loss {a} vs {b}");
        }
        assert!((step.loss - loss).abs() <= 1e-5 * loss, "round {k}: loss {} vs {loss}", step.loss);
        // And the CPU backend's step.
        let reference = cpu.squared_error_step(&mesh, &cameras, &targets).unwrap();
        let rel = relative(&step.gradient, &reference.gradient);
        assert!(rel <= 1e-5, "round {k}: GPU vs CPU gradient {rel:.3e}");
        assert_eq!(
            step.stats.iter().map(|s| s.candidate_edges).collect::<Vec<_>>(),
            reference.stats.iter().map(|s| s.candidate_edges).collect::<Vec<_>>()
        );
    }
}

#[test]
fn gpu_step_after_another_frame_uses_its_own_targets() {
    let Some(ctx) = gpu_or_skip("gpu_step_after_another_frame_uses_its_own_targets") else { return };
    let (mesh, cameras) = (mesh(), cameras());
    let mut gpu = Renderer::with_gpu_context(RenderSettings::default(), ctx).unwrap();
    let targets = targets(&mesh, &cameras, Vec3::new(0.03, 0.0, 0.0));
    let first = gpu.squared_error_step(&mesh, &cameras, &targets).unwrap();
    // A plain render and backward in between overwrite the GPU's image gradient.
    let frame = gpu.render(&mesh, &cameras).unwrap();
    let zeros: Vec<Image> = frame.images().iter().map(|i| Image::filled(i.width(), i.height(), 0.0)).collect();
    gpu.backward(&frame, &zeros).unwrap();
    let second = gpu.squared_error_step(&mesh, &cameras, &targets).unwrap();
    assert_eq!(first, second);
}

/// After a first step has sized its buffers, a step runs forward, loss and backward in one
/// submission (the `edge_grad_args` stage sizes the backward on the GPU), with the same result.
#[test]
fn gpu_steps_after_the_first_are_fused() {
    let Some(_) = gpu_or_skip("gpu_steps_after_the_first_are_fused") else { return };
    let options = diffsil::gpu::GpuOptions { profile: true, ..diffsil::gpu::GpuOptions::from_env() };
    let mut gpu = Renderer::with_backend(RenderSettings::default(), diffsil::Backend::Gpu(options)).unwrap();
    let (mesh, cameras) = (mesh(), cameras());
    let targets = targets(&mesh, &cameras, Vec3::new(0.02, 0.03, 0.0));
    let first = gpu.squared_error_step(&mesh, &cameras, &targets).unwrap();
    let second = gpu.squared_error_step(&mesh, &cameras, &targets).unwrap();
    assert_eq!(first, second);
    let stages: Vec<&str> = gpu.gpu_stage_timings().iter().map(|t| t.stage).collect();
    if stages.is_empty() {
        println!("no timestamp queries on this adapter: cannot see which stages ran");
        return;
    }
    assert!(stages.contains(&"loss") && stages.contains(&"edge_grad_args"), "{stages:?}");
    let reference =
        Renderer::new(RenderSettings::default()).unwrap().squared_error_step(&mesh, &cameras, &targets).unwrap();
    assert!(relative(&second.gradient, &reference.gradient) <= 1e-5);
}

#[test]
fn step_rejects_mismatched_targets() {
    let (mesh, cameras) = (mesh(), cameras());
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let good = targets(&mesh, &cameras, Vec3::ZERO);
    let one = Targets::new(vec![good.images()[0].clone()]).unwrap();
    assert!(matches!(
        renderer.squared_error_step(&mesh, &cameras, &one),
        Err(Error::ViewCountMismatch { views: 2, got: 1, .. })
    ));
    let swapped = Targets::new(vec![good.images()[1].clone(), good.images()[0].clone()]).unwrap();
    assert!(matches!(renderer.squared_error_step(&mesh, &cameras, &swapped), Err(Error::SizeMismatch { .. })));
    let mut bad = Image::filled(4, 4, 0.0).data().to_vec();
    bad[5] = f32::NAN;
    assert!(matches!(Targets::new(vec![Image::from_vec(4, 4, bad).unwrap()]), Err(Error::InvalidSettings(_))));
    // A perfect fit: zero loss and zero gradient.
    let step = renderer.squared_error_step(&mesh, &cameras, &good).unwrap();
    assert_eq!(step.loss, 0.0);
    assert!(step.gradient.iter().all(|g| *g == Vec3::ZERO));
}
