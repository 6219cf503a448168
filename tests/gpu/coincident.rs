//! Coincident silhouette edges on the GPU: the same scenes as `tests/cpu/coincident.rs`, the
//! image bit for bit and the gradient against the CPU's, the derivative along a translation
//! against finite differences of the exact-area oracle, and the face-on cube by hand.

use diffsil::{Image, RenderSettings, Renderer, Vec3};

use crate::common::fd::{self, FdOptions, Rng};
use crate::common::gpu::gpu_or_skip;

fn gpu_renderer(name: &str) -> Option<Renderer> {
    Some(Renderer::with_gpu_context(RenderSettings::default(), gpu_or_skip(name)?).expect("GPU renderer"))
}

/// Every coincident-edge scene: GPU image ≡ CPU image, GPU gradient within 1e-5 of the CPU's
/// (float-float against f64), and the GPU's translation derivative within 1e-3 of the oracle's.
#[test]
fn coincident_edges_match_the_cpu_and_the_oracle() {
    let Some(mut gpu) = gpu_renderer("coincident_edges_match_the_cpu_and_the_oracle") else { return };
    let mut cpu = Renderer::new(RenderSettings::default()).unwrap();
    let options = FdOptions { h: 1.0 / 1024.0, ..FdOptions::default() };
    for (scene, reference) in fd::coincident_scenes() {
        let fg = gpu.render(&scene.mesh, &scene.cameras).unwrap();
        let fc = cpu.render(&scene.mesh, &scene.cameras).unwrap();
        assert_eq!(fg.images(), fc.images(), "{}: images differ", scene.name);
        let mut rng = Rng::new(options.seed);
        let weights: Vec<Vec<f32>> = scene.cameras.iter().map(|c| rng.weights((c.width * c.height) as usize)).collect();
        let d: Vec<Image> = scene
            .cameras
            .iter()
            .zip(&weights)
            .map(|(c, w)| Image::from_vec(c.width, c.height, w.clone()).unwrap())
            .collect();
        let gg = gpu.backward(&fg, &d).unwrap();
        let gc = cpu.backward(&fc, &d).unwrap();
        let diff: f64 = gg.iter().zip(&gc).map(|(a, b)| (*a - *b).as_dvec3().length_squared()).sum();
        let norm: f64 = gc.iter().map(|b| b.as_dvec3().length_squared()).sum();
        let rel = (diff / norm).sqrt();
        assert!(rel <= 1e-5, "{}: GPU gradient differs from the CPU's by {rel:.2e}", scene.name);
        let flat: Vec<f64> = gg.iter().flat_map(|g| [g.x as f64, g.y as f64, g.z as f64]).collect();
        let references = fd::translation_references(&reference, &weights, options);
        let check = fd::translation_check(&reference, &references, fd::translation_gradient(&flat), options);
        println!("{}: GPU vs CPU {rel:.2e}; {check}", scene.name);
        check.assert_within(1e-3);
    }
}

/// The cube on the GPU: `∂L/∂(translate x)` = 1024 with `∂L/∂I = 1` on column 48.
#[test]
fn face_on_cube_by_hand() {
    let Some(mut gpu) = gpu_renderer("face_on_cube_by_hand") else { return };
    let scene = fd::cube_orthographic();
    let frame = gpu.render(&scene.mesh, &scene.cameras).unwrap();
    let d: Vec<f32> = (0..64 * 64).map(|i| if i % 64 == 48 { 1.0 } else { 0.0 }).collect();
    let grads = gpu.backward(&frame, &[Image::from_vec(64, 64, d).unwrap()]).unwrap();
    let total: Vec3 = grads.iter().sum();
    assert!((total.x - 1024.0).abs() <= 1e-3, "dL/dx = {} (1024 by hand)", total.x);
    assert_eq!((total.y, total.z), (0.0, 0.0));
}
