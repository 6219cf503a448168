//! The scene and helpers of the `step` tests (`Renderer::squared_error_step`) on the CPU and GPU.

use diffsil::{loss, shapes, Camera, Mesh, Orbit, RenderSettings, Renderer, Targets, Vec3};

pub fn cameras() -> Vec<Camera> {
    vec![
        Orbit { azimuth: 0.0, elevation: 0.2, distance: 3.0, fov_y: 45f32.to_radians(), ..Orbit::default() }
            .camera(48, 40),
        Orbit { azimuth: 1.7, elevation: -0.3, distance: 3.2, fov_y: 40f32.to_radians(), ..Orbit::default() }
            .camera(33, 57),
    ]
}

pub fn mesh() -> Mesh {
    shapes::blob(24, 48)
}

/// Targets: the mesh moved a little, rendered on the CPU.
pub fn targets(mesh: &Mesh, cameras: &[Camera], shift: Vec3) -> Targets {
    let moved: Vec<Vec3> = mesh.positions().iter().map(|p| *p + shift).collect();
    let moved = Mesh::with_topology(moved, mesh.topology().clone()).unwrap();
    let frame = Renderer::new(RenderSettings::default()).unwrap().render(&moved, cameras).unwrap();
    Targets::new(frame.images().to_vec()).unwrap()
}

/// render, `loss::squared_error` per view, backward: (loss, per-view losses, gradient).
pub fn separately(
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

pub fn relative(a: &[Vec3], b: &[Vec3]) -> f64 {
    let diff: f64 = a.iter().zip(b).map(|(x, y)| (*x - *y).length_squared() as f64).sum::<f64>().sqrt();
    let norm: f64 = b.iter().map(|y| y.length_squared() as f64).sum::<f64>().sqrt();
    diff / norm.max(1e-30)
}
