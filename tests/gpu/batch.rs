//! Batches on the GPU engine: a batch is one frame (every view of every instance in each
//! dispatch, one submission). It equals one call per instance on the GPU (images and gradients
//! bit for bit: each view's arithmetic does not depend on the other views of its frame) and the
//! CPU engine's batch (images bit for bit, gradients to f32 rounding as in `vs_cpu.rs`), with
//! different cameras, and a different number of them, per instance.
//!
//! Here: the GPU; the CPU's are in `tests/cpu/batch.rs`, the scene in `common::batch`.

use crate::common::batch::{image_gradients, instances, scene, targets};
use crate::common::gpu::gpu_or_skip;
use crate::common::step::relative;
use diffsil::mirror::MAX_VIEWS;
use diffsil::{Camera, Error, Instance, Mesh, Orbit, RenderSettings, RenderStats, Renderer, Targets};

fn gpu(name: &str) -> Option<Renderer> {
    gpu_or_skip(name).map(|ctx| Renderer::with_gpu_context(RenderSettings::default(), ctx).unwrap())
}

#[test]
fn gpu_batch_equals_separate_gpu_calls_and_the_cpu_batch() {
    let Some(mut gpu) = gpu("gpu_batch_equals_separate_gpu_calls_and_the_cpu_batch") else { return };
    let mut cpu = Renderer::new(RenderSettings::default()).unwrap();
    for count in [1, 3, 8] {
        let (meshes, cameras) = scene(count, 40 + count as u64);
        let batch = instances(&meshes, &cameras);
        let d_images = image_gradients(&cameras, 3 + count as u64);
        let frame = gpu.render_batch(&batch).unwrap();
        let grads = gpu.backward_batch(&frame, &d_images).unwrap();
        let cpu_frame = cpu.render_batch(&batch).unwrap();
        let cpu_grads = cpu.backward_batch(&cpu_frame, &d_images).unwrap();
        for (i, (mesh, cams)) in meshes.iter().zip(&cameras).enumerate() {
            let case = format!("B = {count}, instance {i}");
            assert_eq!(frame.images(i), cpu_frame.images(i), "{case}: GPU and CPU batch images differ");
            assert_eq!(counts(frame.stats(i)), counts(cpu_frame.stats(i)), "{case}: culled or candidate counts differ");
            let single = gpu.render(mesh, cams).unwrap();
            assert_eq!(frame.images(i), single.images(), "{case}: batch and single GPU images differ");
            let grad = gpu.backward(&single, &d_images[i]).unwrap();
            assert_eq!(grads[i], grad, "{case}: batch and single GPU gradient bits differ");
            let rel = relative(&grads[i], &cpu_grads[i]);
            assert!(rel <= 1e-5, "{case}: GPU vs CPU batch gradient {rel:.3e}");
        }

        // The fused step: the same as a step per instance on the GPU, and as the CPU's.
        let targets = targets(&meshes, &cameras);
        let refs: Vec<&Targets> = targets.iter().collect();
        let steps = gpu.squared_error_step_batch(&batch, &refs).unwrap();
        let again = gpu.squared_error_step_batch(&batch, &refs).unwrap();
        assert_eq!(steps, again, "B = {count}: two batch steps differ");
        let cpu_steps = cpu.squared_error_step_batch(&batch, &refs).unwrap();
        for (i, ((mesh, cams), t)) in meshes.iter().zip(&cameras).zip(&targets).enumerate() {
            let case = format!("B = {count}, instance {i}");
            let single = gpu.squared_error_step(mesh, cams, t).unwrap();
            assert_eq!(steps[i], single, "{case}: batch and single GPU step differ");
            let rel = relative(&steps[i].gradient, &cpu_steps[i].gradient);
            assert!(rel <= 1e-5, "{case}: GPU vs CPU step gradient {rel:.3e}");
            let loss = cpu_steps[i].loss;
            assert!((steps[i].loss - loss).abs() <= 1e-5 * loss, "{case}: loss {} vs {loss}", steps[i].loss);
        }
    }
}

/// Culled triangles and candidate edges per view (the engines' tile sizes differ).
fn counts(stats: &[RenderStats]) -> Vec<(u32, u32)> {
    stats.iter().map(|s| (s.culled_triangles, s.candidate_edges)).collect()
}

/// 64 instances × 4 views fill a GPU frame (`MAX_VIEWS` = 256); one view more is an error.
#[test]
fn gpu_batch_of_max_views() {
    let Some(mut gpu) = gpu("gpu_batch_of_max_views") else { return };
    let (meshes, _) = scene(65, 9);
    let ring: Vec<Camera> =
        (0..4).map(|k| Orbit { azimuth: k as f32 * 1.5, distance: 3.0, ..Orbit::default() }.camera(12, 12)).collect();
    let cameras = vec![ring.clone(); 65];
    let batch = instances(&meshes[..64], &cameras[..64]);
    assert_eq!(64 * 4, MAX_VIEWS);
    let frame = gpu.render_batch(&batch).unwrap();
    let mut cpu = Renderer::new(RenderSettings::default()).unwrap();
    for i in [0, 31, 63] {
        assert_eq!(frame.images(i), cpu.render(&meshes[i], &ring).unwrap().images(), "instance {i}");
    }
    let too_many = instances(&meshes, &cameras);
    match gpu.render_batch(&too_many) {
        Err(Error::TooManyViews { views: 260, max: MAX_VIEWS }) => {}
        other => panic!("65 × 4 views: {other:?}"),
    }
    let one = vec![ring[0]];
    let mut over = batch.clone();
    over.push(Instance { mesh: &meshes[64], cameras: &one });
    assert!(matches!(gpu.render_batch(&over), Err(Error::TooManyViews { views: 257, .. })));
}

/// A batch frame differentiated after another forward (its buffers reused) runs its forward
/// again, with each view's instance; a CPU batch frame is an error on the GPU.
#[test]
fn gpu_batch_backward_after_another_forward() {
    let Some(mut gpu) = gpu("gpu_batch_backward_after_another_forward") else { return };
    let (meshes, cameras) = scene(3, 21);
    let batch = instances(&meshes, &cameras);
    let d_images = image_gradients(&cameras, 2);
    let frame = gpu.render_batch(&batch).unwrap();
    let first = gpu.backward_batch(&frame, &d_images).unwrap();
    // Another shape (two instances), then the same shape with the instances' positions swapped.
    gpu.render_batch(&batch[1..]).unwrap();
    assert_eq!(gpu.backward_batch(&frame, &d_images).unwrap(), first);
    let swapped: Vec<Mesh> = vec![meshes[1].clone(), meshes[0].clone(), meshes[2].clone()];
    gpu.render_batch(&instances(&swapped, &cameras)).unwrap();
    assert_eq!(gpu.backward_batch(&frame, &d_images).unwrap(), first);
    let mut cpu = Renderer::new(RenderSettings::default()).unwrap();
    let cpu_frame = cpu.render_batch(&batch).unwrap();
    assert!(matches!(gpu.backward_batch(&cpu_frame, &d_images), Err(Error::InvalidFrame(_))));
    assert!(matches!(cpu.backward_batch(&frame, &d_images), Err(Error::InvalidFrame(_))));
}
