//! Near/far clipping on the GPU engine against the CPU engine, on the clipping scenes of
//! `tests/cpu/clip_scenes.rs`: images and statistics bit for bit (clipping runs on the host and
//! the clipped views render from screen space), 3D gradients within 1e-5 relative (the GPU's
//! `edge_grad` runs in float-float), and `squared_error_step` (one engine call per view when a
//! view is clipped, each with its own targets) against the GPU's render + loss + backward and the
//! CPU's step.

use diffsil::{loss, Image, Mesh, RenderSettings, RenderStats, Renderer, Targets, Vec3};

use super::clip_scenes;
use crate::common::fd::Rng;
use crate::common::gpu::gpu_or_skip;

/// The statistics both engines agree on (the tile size is each engine's own choice).
fn counts(stats: &[RenderStats]) -> Vec<(u32, u32, u32)> {
    stats.iter().map(|s| (s.culled_triangles, s.clipped_triangles, s.candidate_edges)).collect()
}

/// `‖a − b‖ / ‖b‖`.
fn relative(a: &[Vec3], b: &[Vec3]) -> f64 {
    assert_eq!(a.len(), b.len());
    assert!(a.iter().all(|g| g.is_finite()), "non-finite GPU gradient");
    let diff: f64 = a.iter().zip(b).map(|(x, y)| (*x - *y).as_dvec3().length_squared()).sum();
    let norm: f64 = b.iter().map(|y| y.as_dvec3().length_squared()).sum();
    diff.sqrt() / norm.sqrt().max(1e-3)
}

#[test]
fn gpu_clipped_scenes_match_the_cpu() {
    let Some(ctx) = gpu_or_skip("gpu_clipped_scenes_match_the_cpu") else { return };
    let mut gpu = Renderer::with_gpu_context(RenderSettings::default(), ctx).unwrap();
    let mut cpu = Renderer::new(RenderSettings::default()).unwrap();
    for scene in clip_scenes::all(40) {
        // The clipped view beside a plain one of the same mesh.
        let mut plain = scene.camera;
        plain.near = plain.near.min(0.01);
        plain.far = 1000.0;
        let cameras = [scene.camera, plain];
        let (fg, fc) = (gpu.render(&scene.mesh, &cameras).unwrap(), cpu.render(&scene.mesh, &cameras).unwrap());
        assert!(fc.stats()[0].clipped_triangles > 0, "{}: nothing clipped", scene.name);
        assert_eq!(counts(fg.stats()), counts(fc.stats()), "{}: statistics", scene.name);
        assert_eq!(fg.images(), fc.images(), "{}: images differ", scene.name);
        let d: Vec<Image> = cameras
            .iter()
            .map(|c| Image::from_vec(c.width, c.height, Rng::new(11).weights((c.width * c.height) as usize)).unwrap())
            .collect();
        let (gg, gc) = (gpu.backward(&fg, &d).unwrap(), cpu.backward(&fc, &d).unwrap());
        let rel = relative(&gg, &gc);
        println!("{:<22} GPU vs CPU gradient {rel:.2e}", scene.name);
        assert!(rel <= 1e-5, "{}: gradient relative difference {rel:.3e}", scene.name);
        assert!(gc.iter().any(|g| *g != Vec3::ZERO));
        // Same bits twice on the GPU.
        let again = gpu.render(&scene.mesh, &cameras).unwrap();
        assert_eq!(again.images(), fg.images());
        assert_eq!(gpu.backward(&again, &d).unwrap(), gg, "{}: a second GPU backward differs", scene.name);
    }
}

#[test]
fn gpu_clipped_step_equals_render_loss_backward() {
    let Some(ctx) = gpu_or_skip("gpu_clipped_step_equals_render_loss_backward") else { return };
    let mut gpu = Renderer::with_gpu_context(RenderSettings::default(), ctx).unwrap();
    let mut cpu = Renderer::new(RenderSettings::default()).unwrap();
    let scene = clip_scenes::camera_in_box(32);
    let mut other = clip_scenes::icosphere_close_up(32).camera;
    other.near = 0.01;
    let cameras = [scene.camera, other, clip_scenes::floor_quad(24).camera];
    for shift in [Vec3::new(0.07, -0.05, 0.1), Vec3::new(-0.04, 0.03, -0.2)] {
        let shifted =
            Mesh::new(scene.mesh.positions().iter().map(|p| *p + shift).collect(), scene.mesh.triangles().to_vec())
                .unwrap();
        let targets = Targets::new(cpu.render(&shifted, &cameras).unwrap().images().to_vec()).unwrap();
        let step = gpu.squared_error_step(&scene.mesh, &cameras, &targets).unwrap();
        let again = gpu.squared_error_step(&scene.mesh, &cameras, &targets).unwrap();
        assert_eq!(step, again, "two GPU steps differ");
        assert!(step.stats[0].clipped_triangles > 0 && step.stats[2].clipped_triangles > 0);
        // The GPU's render + CPU loss + GPU backward: the same gradient bits.
        let frame = gpu.render(&scene.mesh, &cameras).unwrap();
        let (l, d) = loss::squared_error_views(frame.images(), targets.images()).unwrap();
        assert_eq!(step.gradient, gpu.backward(&frame, &d).unwrap());
        assert!((step.loss - l).abs() <= 1e-5 * l, "loss {} vs {l}", step.loss);
        assert_eq!(step.stats, frame.stats());
        // The CPU's step.
        let reference = cpu.squared_error_step(&scene.mesh, &cameras, &targets).unwrap();
        let rel = relative(&step.gradient, &reference.gradient);
        assert!(rel <= 1e-5, "GPU vs CPU step gradient {rel:.3e}");
        assert_eq!(counts(&step.stats), counts(&reference.stats));
        assert!(step.screen_gradients[0].is_empty() && !step.screen_gradients[1].is_empty());
    }
}
