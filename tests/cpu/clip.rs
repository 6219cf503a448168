//! Near/far clipping (`render/clip.rs`): triangles crossing a camera's near or far plane are
//! drawn clipped, and the backward is the exact derivative of the exact area of the clipped
//! geometry. Checked against an independent `f64` clipper feeding the exact-area oracle
//! (`reference::clip`): images within the F = 4 sampling error, gradients against central
//! differences of the oracle (≤ 1e-3 relative).

use diffsil::{Camera, Error, Image, Mesh, RenderSettings, Renderer, Targets, Vec3};
use glam::DVec3;

use super::clip_scenes::{self as scenes, ClipScene};
use crate::common::fd::Rng;

/// World step of the central differences: about 1e-4 px on these scenes, far above the `f64`
/// rounding of the oracle (~1e-12 / h) and small against the kinks of the area.
const H: f64 = 1e-5;

/// `Σ w·I` of the reference image at `positions`.
fn reference_loss(scene: &ClipScene, positions: &[DVec3], weights: &[f32]) -> f64 {
    let image = scenes::reference_image(&scene.camera, positions, &scene.mesh, RenderSettings::default());
    image.iter().zip(weights).map(|(i, &w)| i * w as f64).sum()
}

/// Relative error `‖g − g_fd‖/‖g_fd‖` of the renderer's 3D gradient against central
/// differences of the reference, and `‖g_fd‖`.
fn fd_check(scene: &ClipScene, seed: u64) -> (f64, f64) {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let weights = Rng::new(seed).weights((w * h) as usize);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let analytic = scenes::analytic(&mut renderer, scene, &weights);
    let base = scenes::positions_f64(&scene.mesh);
    let (mut diff, mut norm) = (0.0, 0.0);
    for v in 0..base.len() {
        for axis in 0..3 {
            let mut plus = base.clone();
            let mut minus = base.clone();
            plus[v][axis] += H;
            minus[v][axis] -= H;
            let fd = (reference_loss(scene, &plus, &weights) - reference_loss(scene, &minus, &weights)) / (2.0 * H);
            let a = analytic[v][axis] as f64;
            diff += (a - fd) * (a - fd);
            norm += fd * fd;
        }
    }
    (diff.sqrt() / norm.sqrt().max(1e-300), norm.sqrt())
}

fn assert_fd(scene: &ClipScene) {
    let (rel, norm) = fd_check(scene, 7);
    println!("{:<22} relative error {rel:.2e} (‖g_fd‖ {norm:.3})", scene.name);
    assert!(norm > 1e-2, "{}: the reference gradient is ~0 ({norm}): the scene tests nothing", scene.name);
    assert!(rel <= 1e-3, "{}: relative error {rel:.3e} above 1e-3", scene.name);
}

fn render(scene: &ClipScene) -> (Image, diffsil::RenderStats) {
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame = renderer.render(&scene.mesh, &[scene.camera]).unwrap();
    (frame.images()[0].clone(), frame.stats()[0])
}

#[test]
fn images_match_the_oracle_of_the_clipped_geometry() {
    for scene in scenes::all(48) {
        let (image, stats) = render(&scene);
        assert!(stats.clipped_triangles > 0, "{}: nothing was clipped", scene.name);
        let exact = scenes::reference_image(
            &scene.camera,
            &scenes::positions_f64(&scene.mesh),
            &scene.mesh,
            Default::default(),
        );
        let errors: Vec<f64> = image.data().iter().zip(&exact).map(|(&a, b)| (a as f64 - b).abs()).collect();
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        let max = errors.iter().copied().fold(0.0, f64::max);
        let covered = exact.iter().filter(|&&e| e > 0.5).count();
        println!("{:<22} {stats:?} mean {mean:.2e} max {max:.3}", scene.name);
        assert!(covered > 40 && covered < exact.len() - 40, "{}: the silhouette has no outline in view", scene.name);
        // F = 4: 16 samples a pixel; a straight edge misses at most about a quarter of a pixel.
        assert!(mean < 0.01 && max <= 0.3, "{}: mean {mean:.3e}, max {max:.3}", scene.name);
    }
}

#[test]
fn culling_alone_would_lose_the_clipped_triangles() {
    // What the renderer did before clipping: triangles with a vertex outside (near, far) dropped.
    // Here that loses much of the image, so the comparison above really tests clipping (except
    // where the clip outline lies inside the silhouette, which is the point of that scene).
    for scene in scenes::all(48).into_iter().filter(|s| s.name != "icosphere_near_inside") {
        let (image, _) = render(&scene);
        let view = scene.camera.params();
        let kept: Vec<[u32; 3]> = scene
            .mesh
            .triangles()
            .iter()
            .copied()
            .filter(|t| t.iter().all(|&v| view.project(scene.mesh.positions()[v as usize]).1))
            .collect();
        let culled = Mesh::new(scene.mesh.positions().to_vec(), kept).unwrap();
        let exact_culled =
            scenes::reference_image(&scene.camera, &scenes::positions_f64(&culled), &culled, Default::default());
        let worst = image.data().iter().zip(&exact_culled).map(|(&a, b)| (a as f64 - b).abs()).fold(0.0, f64::max);
        assert!(worst > 0.9, "{}: culling and clipping give the same image", scene.name);
    }
}

#[test]
fn gradient_of_camera_in_box_matches_finite_differences() {
    assert_fd(&scenes::camera_in_box(40));
}

#[test]
fn gradient_of_icosphere_close_up_matches_finite_differences() {
    assert_fd(&scenes::icosphere_close_up(32));
}

#[test]
fn gradient_of_icosphere_cut_inside_its_silhouette_matches_finite_differences() {
    assert_fd(&scenes::icosphere_near_inside(32));
}

#[test]
fn gradient_of_far_plane_cut_matches_finite_differences() {
    assert_fd(&scenes::blob_far(32));
}

#[test]
fn gradient_of_floor_quad_matches_finite_differences() {
    assert_fd(&scenes::floor_quad(40));
}

#[test]
fn gradient_of_orthographic_near_cut_matches_finite_differences() {
    assert_fd(&scenes::orthographic_half(32));
}

#[test]
fn shared_clipped_edge_leaves_no_crack() {
    // Both triangles of the quad cross the near plane and share their diagonal: every pixel the
    // clipped quad covers wholly is exactly inside, and the diagonal adds no gradient of its own
    // (its two sides are covered).
    let scene = scenes::floor_quad(64);
    let (image, stats) = render(&scene);
    assert_eq!(stats.clipped_triangles, 2);
    assert_eq!(stats.culled_triangles, 0);
    // The outline only: two side edges, the far edge, and the clip line (one piece per triangle).
    // Were the diagonal's new vertex not shared, its two halves would be open boundaries too.
    assert_eq!(stats.candidate_edges, 5);
    let exact =
        scenes::reference_image(&scene.camera, &scenes::positions_f64(&scene.mesh), &scene.mesh, Default::default());
    let full: Vec<usize> = (0..exact.len()).filter(|&p| exact[p] == 1.0).collect();
    assert!(full.len() > 300, "the quad covers too little: {}", full.len());
    for &p in &full {
        assert_eq!(image.data()[p], 1.0, "pixel {p} inside the clipped quad is not covered");
    }
    // A ∂L/∂I on the inside pixels only: an interior edge must contribute nothing.
    let mut d = vec![0f32; exact.len()];
    for &p in &full {
        d[p] = 1.0;
    }
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame = renderer.render(&scene.mesh, &[scene.camera]).unwrap();
    let grads = renderer.backward(&frame, &[Image::from_vec(64, 64, d).unwrap()]).unwrap();
    // Inside pixels stay inside under a small motion: the exact derivative is 0 for pixels not
    // touched by the outline; only pixels on the outline can move.
    let weights: Vec<f32> = (0..exact.len()).map(|p| if exact[p] == 1.0 { 1.0 } else { 0.0 }).collect();
    let base = scenes::positions_f64(&scene.mesh);
    for v in 0..4 {
        for axis in 0..3 {
            let (mut plus, mut minus) = (base.clone(), base.clone());
            plus[v][axis] += H;
            minus[v][axis] -= H;
            let fd = (reference_loss(&scene, &plus, &weights) - reference_loss(&scene, &minus, &weights)) / (2.0 * H);
            assert!(
                (grads[v][axis] as f64 - fd).abs() <= 1e-3 * (1.0 + fd.abs()),
                "vertex {v} axis {axis}: {} vs {fd}",
                grads[v][axis]
            );
        }
    }
}

/// Images and gradients of two clipped views and one plain one, as bits.
fn clipped_run() -> Vec<u32> {
    let scene = scenes::icosphere_close_up(48);
    let mut plain = scene.camera;
    plain.near = 0.01;
    let cameras = [scene.camera, plain, scenes::blob_far(40).camera];
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame = renderer.render(&scene.mesh, &cameras).unwrap();
    let d: Vec<Image> = cameras
        .iter()
        .map(|c| Image::from_vec(c.width, c.height, Rng::new(3).weights((c.width * c.height) as usize)).unwrap())
        .collect();
    let grads = renderer.backward(&frame, &d).unwrap();
    assert!(grads.iter().any(|g| *g != Vec3::ZERO));
    let mut bits: Vec<u32> = frame.images().iter().flat_map(|i| i.data().iter().map(|v| v.to_bits())).collect();
    bits.extend(grads.iter().flat_map(|g| g.to_array().map(f32::to_bits)));
    bits
}

#[test]
fn clipping_is_deterministic_whatever_the_thread_count() {
    let in_pool = |n: usize| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap().install(clipped_run);
    let one = in_pool(1);
    assert!(clipped_run() == clipped_run(), "a second run gave different bits");
    for n in [2, 3] {
        assert!(in_pool(n) == one, "{n} threads gave different bits from 1 thread");
    }
}

#[test]
fn a_frame_with_clipped_views_holds_what_one_view_frames_give() {
    let scene = scenes::icosphere_close_up(40);
    let mut plain = scene.camera;
    plain.near = 0.01;
    let cameras = [plain, scene.camera];
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame = renderer.render(&scene.mesh, &cameras).unwrap();
    assert_eq!(frame.stats()[0].clipped_triangles, 0);
    assert!(frame.stats()[1].clipped_triangles > 0);
    let d: Vec<Image> = cameras.iter().map(|_| Image::from_vec(40, 40, Rng::new(5).weights(1600)).unwrap()).collect();
    let grads = renderer.backward(&frame, &d).unwrap();
    let mut sum = vec![Vec3::ZERO; grads.len()];
    for (k, camera) in cameras.iter().enumerate() {
        let single = renderer.render(&scene.mesh, &[*camera]).unwrap();
        assert_eq!(single.images()[0], frame.images()[k], "image of view {k}");
        assert_eq!(single.stats()[0], frame.stats()[k], "stats of view {k}");
        let g = renderer.backward(&single, &[d[k].clone()]).unwrap();
        for (s, g) in sum.iter_mut().zip(g) {
            *s += g;
        }
    }
    assert_eq!(sum, grads, "the 3D gradient is the views' sum, in view order");
}

#[test]
fn squared_error_step_equals_render_loss_backward_with_clipping() {
    let scene = scenes::camera_in_box(32);
    let mut other = scenes::icosphere_close_up(32).camera;
    other.near = 0.01;
    let cameras = [scene.camera, other];
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let shifted = Mesh::new(
        scene.mesh.positions().iter().map(|p| *p + Vec3::new(0.07, -0.05, 0.1)).collect(),
        scene.mesh.triangles().to_vec(),
    )
    .unwrap();
    let targets = Targets::new(renderer.render(&shifted, &cameras).unwrap().images().to_vec()).unwrap();
    let step = renderer.squared_error_step(&scene.mesh, &cameras, &targets).unwrap();
    let frame = renderer.render(&scene.mesh, &cameras).unwrap();
    let (loss, d) = diffsil::loss::squared_error_views(frame.images(), targets.images()).unwrap();
    let grads = renderer.backward(&frame, &d).unwrap();
    assert_eq!(step.gradient, grads);
    assert!((step.loss - loss).abs() <= 1e-9 * loss.abs().max(1.0));
    assert_eq!(step.stats, frame.stats());
    assert!(step.stats[0].clipped_triangles > 0 && step.loss > 0.0);
    // The clipped view has no per-vertex screen gradient; the plain one keeps its own.
    assert!(step.screen_gradients[0].is_empty());
    assert_eq!(step.screen_gradients[1].len(), scene.mesh.positions().len());
    let err = diffsil::camera_gradient(&cameras[0], scene.mesh.positions(), &step.screen_gradients[0]).unwrap_err();
    assert!(matches!(err, Error::LengthMismatch { got: 0, .. }), "{err}");
    assert!(diffsil::camera_gradient(&cameras[1], scene.mesh.positions(), &step.screen_gradients[1]).is_ok());
    // The screen-space backward refuses a frame with clipped views.
    let err = renderer.backward_screen(&frame, &d).unwrap_err();
    assert!(matches!(err, Error::InvalidFrame(_)), "{err}");
}

/// A camera at the origin looking down −z (identity rotation): depth = −z exactly.
fn axis_camera(near: f32, far: f32) -> Camera {
    let mut camera = Camera::perspective(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 1.2, 32, 32);
    camera.near = near;
    camera.far = far;
    camera
}

#[test]
fn triangles_wholly_behind_are_culled_and_counted() {
    let camera = axis_camera(0.5, 100.0);
    // One triangle wholly behind the near plane, one lying in it, one in front.
    let mesh = Mesh::new(
        vec![
            Vec3::new(-1.0, -1.0, -0.2),
            Vec3::new(1.0, -1.0, -0.3),
            Vec3::new(0.0, 1.0, 0.4),
            Vec3::new(-1.0, -1.0, -0.5),
            Vec3::new(1.0, -1.0, -0.5),
            Vec3::new(0.0, 1.0, -0.5),
            Vec3::new(-0.5, -0.5, -2.0),
            Vec3::new(0.5, -0.5, -2.0),
            Vec3::new(0.0, 0.5, -1.0),
        ],
        vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]],
    )
    .unwrap();
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame = renderer.render(&mesh, &[camera]).unwrap();
    assert_eq!(frame.stats()[0].culled_triangles, 2);
    assert_eq!(frame.stats()[0].clipped_triangles, 0);
    // Only the front triangle is drawn.
    let front = Mesh::new(mesh.positions()[6..].to_vec(), vec![[0, 1, 2]]).unwrap();
    assert_eq!(frame.images()[0], renderer.render(&front, &[camera]).unwrap().images()[0]);
}

#[test]
fn all_three_behind_draws_nothing() {
    let camera = axis_camera(0.5, 100.0);
    let mesh = Mesh::new(
        vec![Vec3::new(-1.0, -1.0, 1.0), Vec3::new(1.0, -1.0, -0.1), Vec3::new(0.0, 1.0, -0.49)],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame = renderer.render(&mesh, &[camera]).unwrap();
    assert_eq!((frame.stats()[0].culled_triangles, frame.stats()[0].clipped_triangles), (1, 0));
    assert!(frame.images()[0].data().iter().all(|&v| v == 0.0));
    let grads = renderer.backward(&frame, &[Image::filled(32, 32, 1.0)]).unwrap();
    assert!(grads.iter().all(|g| *g == Vec3::ZERO));
}

#[test]
fn a_vertex_exactly_on_the_near_plane_is_drawn() {
    // Depth exactly `near` is outside `near < depth < far`, so before clipping this triangle
    // was culled; its polygon is the whole triangle.
    let camera = axis_camera(0.5, 100.0);
    let mesh = Mesh::new(
        vec![Vec3::new(-0.3, -0.2, -0.5), Vec3::new(0.6, -0.4, -1.5), Vec3::new(0.1, 0.5, -1.2)],
        vec![[0, 1, 2]],
    )
    .unwrap();
    assert!(!camera.params().project(mesh.positions()[0]).1, "the vertex is exactly on the plane");
    let scene = ClipScene { name: "on_plane", mesh, camera };
    let (image, stats) = render(&scene);
    assert_eq!((stats.clipped_triangles, stats.culled_triangles), (1, 0));
    let exact = scenes::reference_image(&camera, &scenes::positions_f64(&scene.mesh), &scene.mesh, Default::default());
    let max = image.data().iter().zip(&exact).map(|(&a, b)| (a as f64 - b).abs()).fold(0.0, f64::max);
    assert!(exact.iter().sum::<f64>() > 20.0 && max <= 0.3, "max {max}");
    assert_fd(&scene);
}

#[test]
fn a_clipped_vertex_beyond_the_coordinate_limit_culls_its_triangle() {
    // With near = 1e-6 the crossing of the long edge projects ~1e7 px off-centre: not drawable.
    let camera = axis_camera(1e-6, 100.0);
    let mesh = Mesh::new(
        vec![Vec3::new(-0.3, -0.2, -1.0), Vec3::new(0.4, -0.3, -1.0), Vec3::new(30.0, 0.1, 1.0)],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame = renderer.render(&mesh, &[camera]).unwrap();
    assert_eq!((frame.stats()[0].culled_triangles, frame.stats()[0].clipped_triangles), (1, 0));
    assert!(frame.images()[0].data().iter().all(|&v| v == 0.0));
    let grads = renderer.backward(&frame, &[Image::filled(32, 32, 1.0)]).unwrap();
    assert!(grads.iter().all(|g| g.is_finite() && *g == Vec3::ZERO));
}

#[test]
fn errors_are_unchanged_on_clipped_frames() {
    let scene = scenes::floor_quad(24);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame = renderer.render(&scene.mesh, &[scene.camera]).unwrap();
    assert!(frame.stats()[0].clipped_triangles > 0);
    let mut bad = Image::filled(24, 24, 0.0);
    bad.data_mut()[5] = f32::NAN;
    assert!(matches!(renderer.backward(&frame, &[bad]), Err(Error::InvalidSettings(_))));
    assert!(matches!(renderer.backward(&frame, &[]), Err(Error::ViewCountMismatch { .. })));
    assert!(matches!(renderer.backward(&frame, &[Image::filled(8, 8, 0.0)]), Err(Error::SizeMismatch { .. })));
    // Non-finite input is refused where it enters, as before.
    let mut positions = scene.mesh.positions().to_vec();
    positions[0].x = f32::NAN;
    assert!(matches!(
        Mesh::new(positions, scene.mesh.triangles().to_vec()),
        Err(Error::NonFiniteVertex { vertex: 0, .. })
    ));
    let mut camera = scene.camera;
    camera.near = f32::NAN;
    assert!(renderer.render(&scene.mesh, &[camera]).is_err());
    // Vertices so far away that camera space overflows: culled, no NaN.
    let huge = Mesh::new(
        vec![Vec3::new(0.0, -0.5, -1.0), Vec3::new(1.0, -0.5, -1.0), Vec3::new(0.0, -0.5, 3.0e38)],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let frame = renderer.render(&huge, &[scene.camera]).unwrap();
    assert!(frame.images()[0].data().iter().all(|v| v.is_finite()));
    let grads = renderer.backward(&frame, &[Image::filled(24, 24, 1.0)]).unwrap();
    assert!(grads.iter().all(|g| g.is_finite()));
}

/// The Stanford bunny from `$DIFFSIL_ASSETS` (normalised to radius 1) seen from 1.5 away with
/// near = 1.0: the near plane cuts its front. Directional derivatives (every vertex moves by up to
/// `h` per coordinate along a seeded random direction) against central differences of the
/// reference; the step is small because the bunny has sliver faces within ~1e-5 px of a contour.
#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn bunny_close_up_matches_finite_differences() {
    let dir = std::env::var_os("DIFFSIL_ASSETS").expect("set DIFFSIL_ASSETS to the folder holding the test meshes");
    let path = std::path::PathBuf::from(dir).join("stanford-bunny.obj");
    let mesh = diffsil::io::load_obj(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).normalized(1.0);
    let mut camera =
        Camera::perspective(Vec3::new(0.1, 0.15, 1.5), Vec3::new(0.0, 0.05, 0.0), 70f32.to_radians(), 64, 64);
    camera.near = 1.0;
    let scene = ClipScene { name: "bunny_close_up", mesh, camera };
    let (image, stats) = render(&scene);
    let base = scenes::positions_f64(&scene.mesh);
    let exact = scenes::reference_image(&scene.camera, &base, &scene.mesh, Default::default());
    let mean = image.data().iter().zip(&exact).map(|(&a, b)| (a as f64 - b).abs()).sum::<f64>() / exact.len() as f64;
    println!("bunny close-up: {stats:?}, mean image error {mean:.2e}");
    assert!(stats.clipped_triangles > 100 && mean < 0.01, "{stats:?} mean {mean}");
    let weights = Rng::new(21).weights(64 * 64);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let analytic = scenes::analytic(&mut renderer, &scene, &weights);
    let h = 1e-7;
    let mut rng = Rng::new(22);
    // A direction uniform in [−1, 1]³ per vertex has E[D²] = ‖g‖²/3; one nearly orthogonal to the
    // gradient (|D| below 0.3 of that) is redrawn, where a relative error means nothing.
    let norm = analytic.iter().map(|g| g.as_dvec3().length_squared()).sum::<f64>().sqrt();
    for k in 0..3 {
        let (u, a) = (0..100)
            .map(|_| {
                let u: Vec<DVec3> = (0..base.len())
                    .map(|_| DVec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)))
                    .collect();
                let a: f64 = analytic.iter().zip(&u).map(|(g, d)| g.as_dvec3().dot(*d)).sum();
                (u, a)
            })
            .find(|(_, a)| a.abs() >= 0.3 * norm / 3f64.sqrt())
            .expect("a direction along the gradient");
        let moved = |s: f64| -> Vec<DVec3> { base.iter().zip(&u).map(|(p, d)| *p + s * *d).collect() };
        let fd =
            (reference_loss(&scene, &moved(h), &weights) - reference_loss(&scene, &moved(-h), &weights)) / (2.0 * h);
        let rel = (a - fd).abs() / fd.abs();
        println!("bunny close-up direction {k}: analytic {a:.6e}, reference {fd:.6e}, relative error {rel:.2e}");
        assert!(fd.abs() > 1e-2 && rel <= 1e-3, "direction {k}: {a} vs {fd} ({rel:.3e})");
    }
}

#[test]
fn one_renderer_over_many_clipped_scenes_renders_each_as_a_fresh_one() {
    // The renderer reuses clipped topologies while a view's clipped triangle list stays the same:
    // a different list (another scene, or the same mesh moved) must get its own.
    let mut shared = Renderer::new(RenderSettings::default()).unwrap();
    let mut scenes_and_moved = Vec::new();
    for scene in scenes::all(32) {
        let mut moved = scene.clone();
        moved.camera.near *= 1.05;
        moved.camera.far *= 0.97;
        scenes_and_moved.push(scene);
        scenes_and_moved.push(moved);
    }
    for round in 0..2 {
        for scene in &scenes_and_moved {
            let (fresh, stats) = render(scene);
            let frame = shared.render(&scene.mesh, &[scene.camera]).unwrap();
            assert_eq!(frame.stats()[0], stats, "{} round {round}", scene.name);
            assert_eq!(frame.images()[0], fresh, "{} round {round}: image differs from a fresh renderer's", scene.name);
        }
    }
}
