//! The scene of the batch tests (`Renderer::render_batch`, `backward_batch`,
//! `squared_error_step_batch`) on the CPU and GPU: instances of one blob, each moved, squashed
//! and turned its own way, each seen by its own cameras (one to three, of different sizes).

use diffsil::{shapes, Camera, Image, Instance, Mesh, Orbit, RenderSettings, Renderer, Targets, Vec3};

use super::rng::Rng;

/// `count` instances of one topology (the same `Arc`) and their cameras.
pub fn scene(count: usize, seed: u64) -> (Vec<Mesh>, Vec<Vec<Camera>>) {
    let base = shapes::blob(16, 32);
    let mut rng = Rng::new(seed);
    let mut meshes = Vec::with_capacity(count);
    let mut cameras = Vec::with_capacity(count);
    for i in 0..count {
        let shift = Vec3::new(rng.range(-0.2, 0.2) as f32, rng.range(-0.2, 0.2) as f32, rng.range(-0.2, 0.2) as f32);
        let squash = rng.range(0.7, 1.2) as f32;
        let (s, c) = (rng.range(-0.6, 0.6) as f32).sin_cos();
        let positions: Vec<Vec3> = base
            .positions()
            .iter()
            .map(|p| Vec3::new(c * p.x + s * p.z, squash * p.y, -s * p.x + c * p.z) + shift)
            .collect();
        meshes.push(Mesh::with_topology(positions, base.topology().clone()).unwrap());
        let views = 1 + i % 3;
        cameras.push(
            (0..views)
                .map(|k| {
                    let orbit = Orbit {
                        azimuth: rng.range(-3.0, 3.0) as f32,
                        elevation: rng.range(-0.5, 0.5) as f32,
                        distance: rng.range(2.6, 3.4) as f32,
                        ..Orbit::default()
                    };
                    orbit.camera(20 + 7 * k as u32 + i as u32 % 4, 24 - 3 * k as u32)
                })
                .collect(),
        );
    }
    (meshes, cameras)
}

/// The instances of `meshes` seen by `cameras`.
pub fn instances<'a>(meshes: &'a [Mesh], cameras: &'a [Vec<Camera>]) -> Vec<Instance<'a>> {
    meshes.iter().zip(cameras).map(|(mesh, cameras)| Instance { mesh, cameras }).collect()
}

/// Targets for each instance: its mesh moved by (0.05, −0.03, 0), rendered on the CPU.
pub fn targets(meshes: &[Mesh], cameras: &[Vec<Camera>]) -> Vec<Targets> {
    let mut cpu = Renderer::new(RenderSettings::default()).unwrap();
    meshes
        .iter()
        .zip(cameras)
        .map(|(mesh, cameras)| {
            let moved: Vec<Vec3> = mesh.positions().iter().map(|p| *p + Vec3::new(0.05, -0.03, 0.0)).collect();
            let moved = Mesh::with_topology(moved, mesh.topology().clone()).unwrap();
            Targets::new(cpu.render(&moved, cameras).unwrap().images().to_vec()).unwrap()
        })
        .collect()
}

/// A random `∂L/∂I` for every view of every instance.
pub fn image_gradients(cameras: &[Vec<Camera>], seed: u64) -> Vec<Vec<Image>> {
    let mut rng = Rng::new(seed);
    cameras
        .iter()
        .map(|cameras| {
            cameras
                .iter()
                .map(|c| {
                    let data = (0..c.width * c.height).map(|_| rng.range(-1.0, 1.0) as f32).collect();
                    Image::from_vec(c.width, c.height, data).unwrap()
                })
                .collect()
        })
        .collect()
}
