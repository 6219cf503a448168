//! Calibrated cameras and gradients to parameters on the GPU against the CPU: a pinhole camera with
//! non-square pixels and an off-centre principal point renders the CPU's image bit for bit (the
//! `project` stage's separate x and y scales), and `camera_gradient` / `RigidTransform::backward`
//! fed from a GPU `squared_error_step` agree with the same chain fed from the CPU (within 1e-5 of
//! the gradient's norm, as the vertex gradients do).
//!
//! Run on lavapipe with `WGPU_BACKEND=vulkan DIFFSIL_REQUIRE_GPU=1 cargo test --test gpu params`.

use crate::common::gpu::gpu_or_skip;
use diffsil::{
    camera_gradient, shapes, Camera, CameraGradient, Mesh, RenderSettings, Renderer, RigidGradient, RigidTransform,
    Targets, Vec3,
};

/// Two calibrated cameras (K with fx ≠ fy, principal point off-centre) around the origin.
fn cameras() -> Vec<Camera> {
    [Vec3::new(0.4, 0.5, 2.9), Vec3::new(-2.6, 0.3, 1.1)]
        .iter()
        .map(|&eye| {
            let pose = Camera::perspective(eye, Vec3::ZERO, 0.9, 48, 40).opencv_extrinsics();
            let k = [[44.0, 0.0, 21.3], [0.0, 51.0, 22.8], [0.0, 0.0, 1.0]];
            let r = pose.rotation.transpose().to_cols_array_2d();
            Camera::from_opencv(k, r, pose.translation.to_array(), 48, 40).unwrap()
        })
        .collect()
}

fn posed(model: &Mesh, transform: &RigidTransform) -> Mesh {
    let mut mesh = model.clone();
    mesh.set_positions(&transform.apply(model.positions())).unwrap();
    mesh
}

/// Every component of the rigid and per-camera gradients, flattened.
fn flatten(rigid: &RigidGradient, cams: &[CameraGradient]) -> Vec<f64> {
    let mut out: Vec<f64> =
        rigid.rotation.to_array().into_iter().chain(rigid.translation.to_array()).map(f64::from).collect();
    out.push(rigid.scale as f64);
    for c in cams {
        out.extend(
            c.rotation.to_array().into_iter().chain(c.translation.to_array()).chain(c.intrinsics()).map(f64::from),
        );
    }
    out
}

fn parameter_gradients(
    renderer: &mut Renderer,
    model: &Mesh,
    transform: &RigidTransform,
    targets: &Targets,
) -> Vec<f64> {
    let mesh = posed(model, transform);
    let cams = cameras();
    let step = renderer.squared_error_step(&mesh, &cams, targets).unwrap();
    let rigid = transform.backward(model.positions(), &step.gradient).unwrap();
    let per_camera: Vec<CameraGradient> = cams
        .iter()
        .zip(&step.screen_gradients)
        .map(|(c, g)| camera_gradient(c, mesh.positions(), g).unwrap())
        .collect();
    flatten(&rigid, &per_camera)
}

#[test]
fn pinhole_images_and_parameter_gradients_match_the_cpu() {
    let Some(ctx) = gpu_or_skip("pinhole_images_and_parameter_gradients_match_the_cpu") else { return };
    let settings = RenderSettings::default();
    let mut gpu = Renderer::with_gpu_context(settings, ctx).unwrap();
    let mut cpu = Renderer::new(settings).unwrap();
    let model = shapes::blob(12, 14).normalized(0.8);
    let truth =
        RigidTransform { rotation: Vec3::new(0.1, 0.2, 0.0), translation: Vec3::new(0.05, 0.0, 0.0), scale: 1.0 };
    let target_frame = cpu.render(&posed(&model, &truth), &cameras()).unwrap();
    let gpu_frame = gpu.render(&posed(&model, &truth), &cameras()).unwrap();
    assert_eq!(gpu_frame.images(), target_frame.images(), "pinhole images differ between GPU and CPU");
    let targets = Targets::new(target_frame.images().to_vec()).unwrap();
    let start =
        RigidTransform { rotation: Vec3::new(-0.2, 0.3, 0.1), translation: Vec3::new(0.0, 0.1, -0.1), scale: 0.9 };
    let (g, c) = (
        parameter_gradients(&mut gpu, &model, &start, &targets),
        parameter_gradients(&mut cpu, &model, &start, &targets),
    );
    let norm = c.iter().map(|v| v * v).sum::<f64>().sqrt();
    let diff = g.iter().zip(&c).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
    println!("GPU vs CPU parameter gradients: relative difference {:.2e} over {} components", diff / norm, c.len());
    assert!(norm > 1.0, "the parameter gradient is trivially small ({norm})");
    assert!(diff / norm < 1e-5, "GPU vs CPU parameter gradients: {diff} / {norm}\n{g:?}\n{c:?}");
}
