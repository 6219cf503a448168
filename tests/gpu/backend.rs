//! The backend choice in the public API, and the GPU backend's limits: `Backend::Auto` picks a
//! hardware GPU or the CPU, a named adapter is reported, frames beyond the device's limits are
//! `Error::GpuLimit` (never a wgpu panic), and a frame is differentiated correctly even after the
//! renderer has rendered other frames (its GPU state is rebuilt).
//!
//! Run on lavapipe with `WGPU_BACKEND=vulkan DIFFSIL_REQUIRE_GPU=1 cargo test --test gpu backend::`.

use crate::common::gpu::gpu_or_skip;
use crate::common::scenes;
use diffsil::gpu::{hardware_gpu_available, GpuOptions};
use diffsil::{Backend, Camera, Error, Image, RenderSettings, Renderer, ScreenView, Vec2, Vec3};

#[test]
fn auto_takes_a_hardware_gpu_or_the_cpu() {
    if std::env::var("DIFFSIL_ADAPTER").is_ok_and(|v| !v.trim().is_empty()) {
        return; // an adapter asked for by name is used whatever it is
    }
    let renderer = Renderer::with_backend(RenderSettings::default(), Backend::Auto).unwrap();
    println!("Backend::Auto runs on: {}", renderer.backend_name());
    if hardware_gpu_available() {
        assert!(renderer.is_gpu(), "{}", renderer.backend_name());
    } else {
        assert!(!renderer.is_gpu(), "a software adapter must not be chosen automatically: {}", renderer.backend_name());
        assert!(renderer.backend_name().starts_with("cpu"));
    }
    assert_eq!(Renderer::new(RenderSettings::default()).unwrap().backend_name(), "cpu");
    assert!(Renderer::with_backend(RenderSettings::default(), Backend::Cpu).unwrap().adapter().is_none());
}

#[test]
fn adapter_searches_on_many_threads_at_once_neither_panic_nor_disagree() {
    // wgpu-hal makes a GL adapter's EGL context current on the thread that finds it and on the
    // one that drops it, and panics where it is current on another thread; the searches hold
    // one lock over both. Where GL is searched (no hardware adapter on the other backends, and
    // `WGPU_BACKEND` allowing GL: not in CI, which asks for Vulkan), this failed now and then
    // while the lock covered the search alone.
    let searches: Vec<_> =
        (0..8).map(|_| std::thread::spawn(|| (0..12).map(|_| hardware_gpu_available()).collect::<Vec<_>>())).collect();
    let answers: Vec<bool> = searches.into_iter().flat_map(|s| s.join().expect("an adapter search panicked")).collect();
    assert!(answers.iter().all(|&a| a == answers[0]), "{answers:?}");
}

#[test]
fn renderers_on_several_threads_at_once_agree_with_one_alone() {
    // Each thread opens a context of its own and renders and differentiates at the same time as
    // the others. On GL, contexts whose adapters came from one wgpu instance shared one EGL
    // context, and wgpu-hal panicked (`BadAccess`) when two threads made it current at once;
    // CI runs this on GL as well as on Vulkan.
    let Some(ctx) = gpu_or_skip("renderers_on_several_threads_at_once_agree_with_one_alone") else { return };
    let scene = scenes::torus_fold_3d();
    let alone = {
        let mut gpu = Renderer::with_gpu_context(RenderSettings::default(), ctx).unwrap();
        let frame = gpu.render(&scene.mesh, &scene.cameras).unwrap();
        let d: Vec<Image> = frame.images().iter().map(|i| Image::filled(i.width(), i.height(), 0.5)).collect();
        (frame.images().to_vec(), gpu.backward(&frame, &d).unwrap())
    };
    let threads: Vec<_> = (0..4)
        .map(|t| {
            let scene = scenes::torus_fold_3d();
            std::thread::spawn(move || {
                let ctx = gpu_or_skip("renderers_on_several_threads_at_once_agree_with_one_alone").unwrap();
                let mut gpu = Renderer::with_gpu_context(RenderSettings::default(), ctx).unwrap();
                (0..6)
                    .map(|i| {
                        let frame = gpu.render(&scene.mesh, &scene.cameras).unwrap();
                        let d: Vec<Image> =
                            frame.images().iter().map(|i| Image::filled(i.width(), i.height(), 0.5)).collect();
                        let grad = gpu.backward(&frame, &d).unwrap();
                        println!("thread {t}, round {i}: done");
                        (frame.images().to_vec(), grad)
                    })
                    .collect::<Vec<_>>()
            })
        })
        .collect();
    for thread in threads {
        for (images, grad) in thread.join().expect("a renderer on another thread panicked") {
            assert!(images == alone.0 && grad == alone.1, "a render on several threads differs from one alone");
        }
    }
}

#[test]
fn gpu_backend_reports_its_adapter() {
    if gpu_or_skip("gpu_backend_reports_its_adapter").is_none() {
        return;
    }
    let renderer = Renderer::with_backend(RenderSettings::default(), Backend::Gpu(GpuOptions::from_env())).unwrap();
    assert!(renderer.is_gpu());
    let adapter = renderer.adapter().unwrap();
    assert!(renderer.backend_name().starts_with("gpu: ") && renderer.backend_name().contains(&adapter.name));
}

#[test]
fn renderer_is_send() {
    fn assert_send<T: Send>() {}
    assert_send::<Renderer>();
    assert_send::<diffsil::Frame>();
}

#[test]
fn frames_beyond_the_device_limits_are_gpu_limit_errors() {
    let Some(ctx) = gpu_or_skip("frames_beyond_the_device_limits_are_gpu_limit_errors") else { return };
    let settings = RenderSettings { supersample: 16, ..RenderSettings::default() };
    let mut gpu = Renderer::with_gpu_context(settings, ctx).unwrap();
    let s = scenes::triangle();
    // 16384² at F = 16: 8 mask words per pixel, 8.6 GB of masks.
    let view = ScreenView { vertices: s.vertices.clone(), width: 16384, height: 16384 };
    // Beyond the renderer's memory budget, refused before any device allocation.
    match gpu.render_screen(&s.topology(), &[view]) {
        Err(e @ Error::MemoryLimit { .. }) => println!("16384² at F=16: {e}"),
        Err(e) => panic!("expected Error::MemoryLimit, got {e}"),
        Ok(_) => panic!("an 8.6 GB mask buffer cannot fit"),
    }
    // More views than one frame holds.
    let views: Vec<ScreenView> =
        (0..257).map(|_| ScreenView { vertices: s.vertices.clone(), width: 4, height: 4 }).collect();
    assert!(matches!(gpu.render_screen(&s.topology(), &views), Err(Error::TooManyViews { views: 257, max: 256 })));
    // The renderer still works afterwards.
    let frame = gpu.render_screen(&s.topology(), &[s.view()]).unwrap();
    assert!(frame.images()[0].data().iter().any(|&v| v > 0.0));
}

#[test]
fn stale_frames_are_rebuilt_before_their_backward() {
    let Some(ctx) = gpu_or_skip("stale_frames_are_rebuilt_before_their_backward") else { return };
    let mut gpu = Renderer::with_gpu_context(RenderSettings::default(), ctx).unwrap();
    let mut cpu = Renderer::new(RenderSettings::default()).unwrap();
    let a = scenes::torus_fold_3d();
    let b = scenes::blob();
    let (fa, fa_cpu) = (gpu.render(&a.mesh, &a.cameras).unwrap(), cpu.render(&a.mesh, &a.cameras).unwrap());
    // Other frames in between: another topology (2D), another size of the same mesh.
    let fb = gpu.render_screen(&b.topology(), &[b.view()]).unwrap();
    let other = [Camera::perspective(Vec3::new(0.0, 0.4, 3.0), Vec3::ZERO, 0.8, 20, 30)];
    let _ = gpu.render(&a.mesh, &other).unwrap();
    let d: Vec<Image> = fa.images().iter().map(|i| Image::filled(i.width(), i.height(), 0.7)).collect();
    let (ga, ga_cpu) = (gpu.backward(&fa, &d).unwrap(), cpu.backward(&fa_cpu, &d).unwrap());
    let norm: f32 = ga_cpu.iter().map(|g| g.length_squared()).sum::<f32>().sqrt();
    let diff: f32 = ga.iter().zip(&ga_cpu).map(|(x, y)| (*x - *y).length_squared()).sum::<f32>().sqrt();
    assert!(norm > 0.0 && diff <= 1e-5 * norm, "{diff} vs {norm}");
    let db = vec![Image::filled(b.width, b.height, 1.0)];
    let gb = gpu.backward_screen(&fb, &db).unwrap();
    assert!(gb[0].iter().any(|g| *g != Vec2::ZERO));
    // A renderer differentiates a frame of another GPU renderer by rendering it again.
    let mut second = Renderer::with_gpu_context(RenderSettings::default(), gpu_or_skip("second").unwrap()).unwrap();
    let again = second.backward(&fa, &d).unwrap();
    assert_eq!(again, ga);
}
