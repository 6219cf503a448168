//! The forward pass: supersampled coverage converges to the exact-area image as F grows, pixel
//! values stay within [p0, p1], image sizes and pixel values are honoured, and results are
//! bit-for-bit deterministic, run after run and whatever the thread count.

use crate::common::scenes::{self, Scene2d};
use diffsil::reference::oracle::{exact_coverage, exact_image};
use diffsil::{Camera, Frame, Image, RenderSettings, Renderer, Vec2, Vec3};

fn settings(supersample: u32) -> RenderSettings {
    RenderSettings { supersample, ..RenderSettings::default() }
}

fn render_2d(scene: &Scene2d, settings: RenderSettings) -> Image {
    let mut renderer = Renderer::new(settings).unwrap();
    let frame = renderer.render_screen(&scene.topology(), &[scene.view()]).unwrap();
    frame.images()[0].clone()
}

fn mean_abs_error(image: &Image, exact: &[f64]) -> f64 {
    image.data().iter().zip(exact).map(|(&a, &b)| (a as f64 - b).abs()).sum::<f64>() / exact.len() as f64
}

fn max_abs_error(image: &Image, exact: &[f64]) -> f64 {
    image.data().iter().zip(exact).map(|(&a, &b)| (a as f64 - b).abs()).fold(0.0, f64::max)
}

#[test]
fn converges_to_exact_area_as_f_grows() {
    // Two scenes: the icosphere of the gradient tests, and the same at 48² for more edge pixels.
    let mut big = scenes::icosphere_3d();
    big.cameras = vec![scenes::default_camera(48, 48)];
    for scene in [scenes::icosphere(), big.screen(0, "icosphere_48")] {
        let exact = exact_coverage(&scene.vertices, &scene.triangles, scene.width, scene.height);
        let edge_pixels = exact.iter().filter(|&&c| c > 0.0 && c < 1.0).count();
        println!("{} ({}x{}, {} partly covered pixels)", scene.name, scene.width, scene.height, edge_pixels);
        println!("   F   mean |I - I_exact|   max |I - I_exact|   e(1)/e(F)");
        let mut errors = Vec::new();
        for f in [1, 2, 4, 8, 16] {
            let image = render_2d(&scene, settings(f));
            let (mean, max) = (mean_abs_error(&image, &exact), max_abs_error(&image, &exact));
            errors.push(mean);
            println!("  {f:2}   {mean:.3e}            {max:.3e}           {:.1}", errors[0] / mean);
        }
        for k in 1..errors.len() {
            assert!(errors[k] < errors[k - 1], "{}: error does not decrease from F to 2F: {errors:?}", scene.name);
        }
        assert!(
            errors[0] / errors[4] >= 4.0,
            "{}: e(1)/e(16) = {:.2} < 4: {errors:?}",
            scene.name,
            errors[0] / errors[4]
        );
    }
}

/// Tolerance for "exact" pixel values: one missing sample at F = 16 is 1/256; 1e-6 only allows
/// float rounding in `resolve` (see `full_and_empty_pixels_are_exactly_inside_and_outside`).
const EXACT: f64 = 1e-6;

#[test]
fn pixel_aligned_shapes_are_exact_for_every_f() {
    // Edges along pixel borders: every sample is decided the same way as the exact area.
    let scene = scenes::square_on_grid();
    let exact = exact_image(&scene.vertices, &scene.triangles, scene.width, scene.height, 1.0, 0.0);
    for f in 1..=16 {
        let image = render_2d(&scene, settings(f));
        assert!(max_abs_error(&image, &exact) <= EXACT, "F = {f}: {}", max_abs_error(&image, &exact));
    }
}

#[test]
fn shared_edge_through_samples_neither_drops_nor_doubles() {
    // A square split along a diagonal that passes exactly through samples (x − y = 0 holds at
    // sample (a, a) of every pixel on it): the top-left rule gives each such sample to exactly one
    // triangle, so the union is exactly the square, with either diagonal and either winding.
    let corners = vec![Vec2::new(2.0, 2.0), Vec2::new(10.0, 2.0), Vec2::new(10.0, 10.0), Vec2::new(2.0, 10.0)];
    for triangles in
        [vec![[0, 1, 2], [0, 2, 3]], vec![[0, 2, 1], [0, 3, 2]], vec![[1, 2, 3], [1, 3, 0]], vec![[1, 3, 2], [3, 1, 0]]]
    {
        let scene = Scene2d { name: "split_square", vertices: corners.clone(), triangles, width: 12, height: 12 };
        for f in 1..=16 {
            let image = render_2d(&scene, settings(f));
            for i in 0..12 {
                for j in 0..12 {
                    let expected = if (2..10).contains(&i) && (2..10).contains(&j) { 1.0 } else { 0.0 };
                    let got = image.get(i, j) as f64;
                    assert!(
                        (got - expected).abs() <= EXACT,
                        "F = {f}, pixel ({i}, {j}) = {got}, {:?}",
                        scene.triangles
                    );
                }
            }
        }
    }
}

#[test]
fn images_stay_within_inside_and_outside() {
    for scene in scenes::all_2d() {
        for s in PIXEL_VALUES {
            for f in [1, 4, 11] {
                let image = render_2d(&scene, RenderSettings { supersample: f, ..s });
                let (lo, hi) = (s.inside.min(s.outside), s.inside.max(s.outside));
                let bad = image.data().iter().find(|&&v| !(v.is_finite() && v >= lo && v <= hi));
                assert!(bad.is_none(), "{} F = {f}: value {bad:?} outside [{lo}, {hi}]", scene.name);
            }
        }
    }
}

/// (p1, p0) pairs the forward tests use.
const PIXEL_VALUES: [RenderSettings; 3] = [
    RenderSettings { supersample: 4, inside: 1.0, outside: 0.0 },
    RenderSettings { supersample: 4, inside: 0.2, outside: 0.9 },
    RenderSettings { supersample: 4, inside: -2.5, outside: 4.0 },
];

#[test]
fn full_and_empty_pixels_are_exactly_inside_and_outside() {
    // A pixel with all F² samples covered is exactly p1, one with none exactly p0, for every F.
    let scene = scenes::square_on_grid(); // pixels (3..13, 4..15) fully covered
    for s in PIXEL_VALUES {
        for f in 1..=16 {
            let image = render_2d(&scene, RenderSettings { supersample: f, ..s });
            assert_eq!(image.get(0, 0), s.outside, "F = {f}, (p1, p0) = ({}, {}): empty pixel", s.inside, s.outside);
            assert_eq!(image.get(8, 9), s.inside, "F = {f}, (p1, p0) = ({}, {}): full pixel", s.inside, s.outside);
        }
    }
}

#[test]
fn custom_inside_outside_values() {
    // I = p0 + (p1 − p0)·coverage with the same coverage for any (p1, p0).
    let scene = scenes::torus_fold();
    let coverage = render_2d(&scene, settings(4));
    let custom = RenderSettings { supersample: 4, inside: 0.2, outside: 0.9 };
    let image = render_2d(&scene, custom);
    for (&c, &v) in coverage.data().iter().zip(image.data()) {
        let expected = 0.9 + (0.2 - 0.9) * c;
        assert!((v - expected).abs() <= 1e-6, "{v} vs {expected}");
    }
    assert!(coverage.data().contains(&1.0) && coverage.data().contains(&0.0));
    // And it converges to the exact image with those values.
    let exact = exact_image(&scene.vertices, &scene.triangles, scene.width, scene.height, 0.2, 0.9);
    let fine = render_2d(&scene, RenderSettings { supersample: 16, ..custom });
    assert!(mean_abs_error(&fine, &exact) < 0.7 * 0.01, "{}", mean_abs_error(&fine, &exact));
}

#[test]
fn non_square_images() {
    // Wide and tall views of the same mesh: each matches the exact image of its own projection
    // (a transposed or stretched image would not).
    let mesh = scenes::blob_3d().mesh;
    for (w, h) in [(48, 20), (20, 48), (37, 23)] {
        let camera = scenes::default_camera(w, h);
        let mut renderer = Renderer::new(settings(8)).unwrap();
        let frame = renderer.render(&mesh, &[camera]).unwrap();
        let image = &frame.images()[0];
        assert_eq!((image.width(), image.height()), (w, h));
        let scene = scenes::Scene3d { name: "blob", mesh: mesh.clone(), cameras: vec![camera] }.screen(0, "blob");
        let exact = exact_image(&scene.vertices, &scene.triangles, w, h, 1.0, 0.0);
        let (mean, max) = (mean_abs_error(image, &exact), max_abs_error(image, &exact));
        assert!(mean < 0.01 && max < 0.2, "{w}x{h}: mean {mean}, max {max}");
        // Square pixels: the projected sphere-like blob is about as wide as it is tall.
        let covered_rows = (0..h).filter(|&i| (0..w).any(|j| image.get(i, j) > 0.5)).count();
        let covered_cols = (0..w).filter(|&j| (0..h).any(|i| image.get(i, j) > 0.5)).count();
        if w.min(h) >= 23 {
            assert!(
                (covered_rows as f64 / covered_cols as f64 - 1.0).abs() < 0.25,
                "{covered_rows} rows vs {covered_cols} cols"
            );
        }
    }
}

// ---- determinism -------------------------------------------------------------------------------

/// A frame big enough that every parallel stage splits its work: an icosphere of 5120 triangles
/// (7680 edges) in three 128² views, forward and backward of an L2 loss. Returns the bits of the
/// images and of the 3D and 2D gradients.
fn run_once() -> Vec<u32> {
    let mesh = diffsil::shapes::icosphere(4);
    let mesh = scenes::transformed(&mesh, |p| Vec3::new(p.x * 1.1, p.y * 0.8 + 0.3 * p.x * p.x, p.z));
    let cameras: Vec<Camera> = scenes::orbit_cameras(3, 0.25, 128, 128);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame: Frame = renderer.render(&mesh, &cameras).unwrap();
    let shifted = scenes::transformed(&mesh, |p| p + Vec3::new(0.05, -0.03, 0.0));
    let targets = renderer.render(&shifted, &cameras).unwrap();
    let (_, d_images) = diffsil::loss::squared_error_views(frame.images(), targets.images()).unwrap();
    let grads = renderer.backward(&frame, &d_images).unwrap();
    let grads_2d = renderer.backward_screen(&frame, &d_images).unwrap();
    assert!(grads.iter().any(|g| *g != Vec3::ZERO));
    let mut bits: Vec<u32> = frame.images().iter().flat_map(|i| i.data().iter().map(|v| v.to_bits())).collect();
    bits.extend(grads.iter().flat_map(|g| g.to_array().map(f32::to_bits)));
    bits.extend(grads_2d.iter().flatten().flat_map(|g| g.to_array().map(f32::to_bits)));
    bits
}

#[test]
fn deterministic_run_after_run() {
    let first = run_once();
    for _ in 0..2 {
        assert!(run_once() == first, "a second run gave different bits");
    }
}

#[test]
fn deterministic_whatever_the_thread_count() {
    let in_pool = |n: usize| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap().install(run_once);
    let one = in_pool(1);
    for n in [2, 3, 8] {
        assert!(in_pool(n) == one, "{n} threads gave different bits from 1 thread");
    }
}

/// A frame of several views (of different sizes) holds, view by view and bit for bit, what
/// one-view frames give: the images, and the screen-space gradients of the backward. The CPU
/// backend runs the views side by side; this pins their order.
#[test]
fn views_of_one_frame_equal_one_view_frames() {
    let mesh = diffsil::shapes::icosphere(3);
    let mut cameras = scenes::orbit_cameras(3, 0.4, 40, 32);
    cameras.push(scenes::orbit_cameras(1, 2.0, 24, 36)[0]);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let d_image = |c: &Camera| {
        let data = (0..c.width * c.height).map(|i| ((i * 37 % 101) as f32 - 50.0) / 50.0).collect();
        Image::from_vec(c.width, c.height, data).unwrap()
    };
    let frame = renderer.render(&mesh, &cameras).unwrap();
    let d_images: Vec<Image> = cameras.iter().map(d_image).collect();
    let grads = renderer.backward_screen(&frame, &d_images).unwrap();
    assert_eq!(frame.images().len(), cameras.len());
    for (k, camera) in cameras.iter().enumerate() {
        let single = renderer.render(&mesh, &[*camera]).unwrap();
        assert_eq!(single.images()[0], frame.images()[k], "image of view {k}");
        let single_grads = renderer.backward_screen(&single, &[d_image(camera)]).unwrap();
        assert_eq!(single_grads[0], grads[k], "screen gradients of view {k}");
        assert!(grads[k].iter().any(|g| *g != Vec2::ZERO), "view {k} has a gradient");
    }
}
