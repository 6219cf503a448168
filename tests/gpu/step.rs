//! `Renderer::squared_error_step` (render + squared error + backward in one call) against the same
//! three calls made separately, on the CPU and, where there is an adapter, on the GPU, whose loss
//! stage keeps the images on the device.
//!
//! Here: the GPU; the CPU's are in `tests/cpu`, the shared scene in `common::step`.

use crate::common::gpu::gpu_or_skip;
use crate::common::step::{cameras, mesh, relative, separately, targets};
use diffsil::{Image, RenderSettings, Renderer, Vec3};

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
