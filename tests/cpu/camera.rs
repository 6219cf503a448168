//! Camera models and gradients to parameters: `Camera::from_opencv` and `Camera::pinhole` against a
//! hand-computed projection, their validation, and `camera_gradient` / `RigidTransform::backward`
//! against central differences of the exact-area oracle (`tests/common/fd/`).
//!
//! The references move parameters in `f64` and turn each move into the world points that the
//! *base* camera maps to the same screen points (a camera move is a world move seen from a fixed
//! camera), so the oracle, its rounding compensation and the `f64` projection of
//! `tests/common/fd/world.rs` are reused unchanged.

use crate::common::fd::{Rng, ViewReference, H_2D};
use crate::common::scenes::{blob_3d, torus_fold_3d, Scene3d};
use diffsil::{
    camera_gradient, Camera, Error, Extrinsics, Image, Mat3, PixelRect, Projection, RenderSettings, Renderer,
    RigidTransform, Vec2, Vec3,
};
use glam::{DMat3, DQuat, DVec3};

const K: [[f32; 3]; 3] = [[100.0, 0.0, 30.0], [0.0, 80.0, 20.0], [0.0, 0.0, 1.0]];
/// 90° about the camera's z axis (rows).
const R: [[f32; 3]; 3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
const T: [f32; 3] = [0.5, -0.25, 4.0];

#[test]
fn from_opencv_matches_a_hand_computed_projection() {
    let camera = Camera::from_opencv(K, R, T, 64, 48).unwrap();
    // p = (0.5, 1, 1): R·p = (−1, 0.5, 1), c = (−0.5, 0.25, 5); OpenCV u = 100·(−0.1) + 30 = 20,
    // v = 80·0.05 + 20 = 24; diffsil adds half a pixel: (20.5, 24.5).
    let (s, valid) = camera.params().project(Vec3::new(0.5, 1.0, 1.0));
    assert!(valid);
    assert!((s - Vec2::new(20.5, 24.5)).length() < 1e-4, "{s}");
    // p = (1, 2, 0): c = (−1.5, 0.75, 4): u = −37.5 + 30.5 = −7, v = 15 + 20.5 = 35.5 (off the
    // image on the left, still a valid projection).
    let (s, valid) = camera.params().project(Vec3::new(1.0, 2.0, 0.0));
    assert!(valid);
    assert!((s - Vec2::new(-7.0, 35.5)).length() < 1e-4, "{s}");
    // Behind the camera (c.z = 4 + p.z < 0).
    assert!(!camera.params().project(Vec3::new(0.0, 0.0, -5.0)).1);
    // The camera centre −Rᵀt and the look-at description agree with the pose.
    let centre = camera.extrinsics.unwrap().centre();
    assert!((centre - Vec3::new(0.25, 0.5, -4.0)).length() < 1e-6, "{centre}");
    assert_eq!(camera.eye, centre);
    assert_eq!(camera.intrinsics(), [100.0, 80.0, 30.5, 20.5]);
}

#[test]
fn pinhole_with_a_perspective_cameras_intrinsics_is_that_camera_bit_for_bit() {
    let eye = Vec3::new(0.3, 0.4, 2.7);
    let perspective = Camera::perspective(eye, Vec3::ZERO, 0.8, 48, 40);
    let [fx, fy, cx, cy] = perspective.intrinsics();
    assert_eq!((fx, cx, cy), (fy, 24.0, 20.0));
    let pinhole = Camera::pinhole(eye, Vec3::ZERO, Vec2::new(fx, fy), Vec2::new(cx, cy), 48, 40);
    assert_eq!(pinhole.params(), perspective.params());
}

#[test]
fn from_opencv_of_a_look_at_cameras_pose_projects_like_it() {
    let look_at = Camera::perspective(Vec3::new(1.0, 0.7, 2.5), Vec3::new(0.1, 0.0, 0.0), 0.9, 50, 30);
    let pose = look_at.opencv_extrinsics();
    let [fx, fy, cx, cy] = look_at.intrinsics();
    let k = [[fx, 0.0, cx - 0.5], [0.0, fy, cy - 0.5], [0.0, 0.0, 1.0]];
    let r = pose.rotation.transpose().to_cols_array_2d();
    let calibrated = Camera::from_opencv(k, r, pose.translation.to_array(), 50, 30).unwrap();
    let mut rng = Rng::new(3);
    for _ in 0..50 {
        let p = Vec3::new(rng.uniform() as f32, rng.uniform() as f32, rng.uniform() as f32) - 0.5;
        let (a, b) = (look_at.params().project(p), calibrated.params().project(p));
        assert!(a.1 && b.1);
        assert!((a.0 - b.0).length() < 1e-4, "{} vs {}", a.0, b.0);
    }
}

#[test]
fn bad_calibrations_are_clear_errors() {
    let bad = |k: [[f32; 3]; 3], r: [[f32; 3]; 3], t: [f32; 3]| match Camera::from_opencv(k, r, t, 64, 48) {
        Err(Error::InvalidCamera(message)) => message,
        other => panic!("expected InvalidCamera, got {other:?}"),
    };
    let mut k = K;
    k[0][0] = f32::NAN;
    assert!(bad(k, R, T).contains("finite"));
    let mut k = K;
    k[0][1] = 0.5;
    assert!(bad(k, R, T).contains("skew"));
    let mut k = K;
    k[1][1] = -80.0;
    assert!(bad(k, R, T).contains("fx, fy > 0"));
    let mut r = R;
    r[0][0] = 0.1;
    assert!(bad(K, r, T).contains("not orthonormal"));
    let mut r = R;
    r[2][2] = -1.0;
    assert!(bad(K, r, T).contains("reflection"));
    assert!(bad(K, R, [0.0, f32::INFINITY, 1.0]).contains("finite"));
    assert!(matches!(Camera::from_opencv(K, R, T, 0, 48), Err(Error::InvalidResolution { .. })));
    let mut pinhole = Camera::pinhole(Vec3::Z * 3.0, Vec3::ZERO, Vec2::new(50.0, 50.0), Vec2::new(5.0, 5.0), 10, 10);
    pinhole.projection = Projection::Pinhole { fx: 50.0, fy: 0.0, cx: 5.0, cy: 5.0 };
    assert!(matches!(pinhole.validate(), Err(Error::InvalidCamera(_))));
    let skewed = Extrinsics { rotation: Mat3::from_diagonal(Vec3::new(1.0, 1.0, 1.001)), translation: Vec3::ZERO };
    assert!(matches!(skewed.validate(), Err(Error::InvalidCamera(_))));
}

/// A calibrated camera with non-square pixels and an off-centre principal point, looking at the
/// origin from `eye`.
fn calibrated_camera(eye: Vec3, size: u32) -> Camera {
    let look_at = Camera::perspective(eye, Vec3::new(0.05, -0.03, 0.0), 0.9, size, size);
    let pose = look_at.opencv_extrinsics();
    let s = size as f32;
    let k = [[0.95 * s, 0.0, 0.45 * s], [0.0, 1.1 * s, 0.56 * s], [0.0, 0.0, 1.0]];
    Camera::from_opencv(k, pose.rotation.transpose().to_cols_array_2d(), pose.translation.to_array(), size, size)
        .unwrap()
}

/// `Σ w·I` of view 0 as a function of world points, its oracle reference, and the analytic
/// gradients: `(reference, ∂L/∂(screen vertex), ∂L/∂(world vertex))`.
fn view_and_gradients(scene: &Scene3d, seed: u64) -> (ViewReference, Vec<Vec2>, Vec<Vec3>) {
    let camera = scene.cameras[0];
    let weights = Rng::new(seed).weights((camera.width * camera.height) as usize);
    let settings = RenderSettings::default();
    let mut renderer = Renderer::new(settings).unwrap();
    let frame = renderer.render(&scene.mesh, &scene.cameras).unwrap();
    let d = [Image::from_vec(camera.width, camera.height, weights.clone()).unwrap()];
    let screen = renderer.backward_screen(&frame, &d).unwrap().remove(0);
    let world = renderer.backward(&frame, &d).unwrap();
    (ViewReference::new(scene, 0, weights, settings, false, H_2D), screen, world)
}

fn relative(analytic: f64, fd: f64) -> f64 {
    (analytic - fd).abs() / fd.abs()
}

/// Central difference of the view's loss along a one-parameter family of world points.
fn central(reference: &ViewReference, eps: f64, points: impl Fn(f64) -> Vec<DVec3>) -> f64 {
    reference.loss_difference(&points(eps), &points(-eps)) / (2.0 * eps)
}

#[test]
fn camera_gradient_matches_finite_differences_of_the_oracle() {
    let eye = Vec3::new(0.4, 0.5, 2.9);
    let orthographic = |size| Camera::orthographic(eye, Vec3::new(0.05, -0.03, 0.0), 2.4, size, size);
    let cases = [
        (blob_3d(), calibrated_camera(eye, 32)),
        (torus_fold_3d(), calibrated_camera(eye, 40)),
        (blob_3d(), orthographic(32)),
    ];
    for (scene, camera) in cases {
        let scene = Scene3d { cameras: vec![camera], ..scene };
        let perspective = !matches!(camera.projection, Projection::Orthographic { .. });
        let (reference, screen, _) = view_and_gradients(&scene, 11);
        let analytic = camera_gradient(&camera, scene.mesh.positions(), &screen).unwrap();
        let pose = camera.opencv_extrinsics();
        let (r, t) = (pose.rotation.as_dmat3(), pose.translation.as_dvec3());
        let r_inv = r.inverse();
        let [fx, fy, cx, cy] = camera.intrinsics().map(f64::from);
        let base: Vec<DVec3> = scene.mesh.positions().iter().map(|p| p.as_dvec3()).collect();
        // World points that the base camera sees where the camera moved by (δ, dt, dK) sees `base`.
        let moved = |delta: DVec3, dt: DVec3, dk: [f64; 4]| -> Vec<DVec3> {
            let rot = DMat3::from_quat(DQuat::from_scaled_axis(delta)) * r;
            base.iter()
                .map(|&p| {
                    let c = rot * p + t + dt;
                    let z = if perspective { c.z } else { 1.0 };
                    let (u, v) = ((fx + dk[0]) * c.x / z + cx + dk[2], (fy + dk[1]) * c.y / z + cy + dk[3]);
                    let seen = DVec3::new((u - cx) * z / fx, (v - cy) * z / fy, c.z);
                    r_inv * (seen - t)
                })
                .collect()
        };
        let e = DVec3::X;
        let axes = [e, DVec3::Y, DVec3::Z];
        let mut errors = Vec::new();
        for (k, axis) in axes.iter().enumerate() {
            let fd_rot = central(&reference, 1e-5, |s| moved(*axis * s, DVec3::ZERO, [0.0; 4]));
            errors.push(("rotation", k, analytic.rotation[k] as f64, fd_rot));
            let fd_t = central(&reference, 1e-5, |s| moved(DVec3::ZERO, *axis * s, [0.0; 4]));
            errors.push(("translation", k, analytic.translation[k] as f64, fd_t));
        }
        for k in 0..4 {
            let fd_k = central(&reference, 1e-3, |s| {
                let mut dk = [0.0; 4];
                dk[k] = s;
                moved(DVec3::ZERO, DVec3::ZERO, dk)
            });
            errors.push(("intrinsic", k, analytic.intrinsics()[k] as f64, fd_k));
        }
        if !perspective {
            // Depth does not move an orthographic image: ∂L/∂t.z is exactly zero.
            let i = errors.iter().position(|e| e.0 == "translation" && e.1 == 2).unwrap();
            let (_, _, a, fd) = errors.remove(i);
            assert!(a == 0.0 && fd.abs() < 1e-6, "orthographic ∂L/∂t.z: analytic {a}, fd {fd}");
        }
        let worst = errors.iter().map(|e| relative(e.2, e.3)).fold(0.0, f64::max);
        println!(
            "{} ({}): camera parameters, worst relative error {worst:.2e} over {}",
            scene.name,
            if perspective { "pinhole" } else { "orthographic" },
            errors.len()
        );
        for (what, k, a, fd) in errors {
            assert!(fd.abs() > 1e-3, "{}: {what} {k}: the derivative is trivially zero ({fd})", scene.name);
            assert!(relative(a, fd) < 1e-3, "{}: {what} {k}: analytic {a} vs fd {fd}", scene.name);
        }
    }
}

#[test]
fn rigid_transform_gradient_matches_finite_differences_of_the_oracle() {
    for scene in [blob_3d(), torus_fold_3d()] {
        let size = scene.cameras[0].width;
        let model: Vec<Vec3> = scene.mesh.positions().to_vec();
        let transform =
            RigidTransform { rotation: Vec3::new(0.3, -0.2, 0.4), translation: Vec3::new(0.1, -0.05, 0.2), scale: 0.9 };
        let mut mesh = scene.mesh.clone();
        mesh.set_positions(&transform.apply(&model)).unwrap();
        let scene = Scene3d { mesh, cameras: vec![calibrated_camera(Vec3::new(-0.3, 0.6, 2.8), size)], ..scene };
        let (reference, _, world) = view_and_gradients(&scene, 12);
        let analytic = transform.backward(&model, &world).unwrap();
        let r = transform.matrix().as_dmat3();
        let (t, s) = (transform.translation.as_dvec3(), transform.scale as f64);
        // The renderer's own f32 points at the base, moved by the f64 difference of the transform.
        let base: Vec<DVec3> = scene.mesh.positions().iter().map(|p| p.as_dvec3()).collect();
        let f64_base: Vec<DVec3> = model.iter().map(|p| s * (r * p.as_dvec3()) + t).collect();
        let moved = |delta: DVec3, dt: DVec3, ds: f64| -> Vec<DVec3> {
            let rot = DMat3::from_quat(DQuat::from_scaled_axis(delta)) * r;
            model
                .iter()
                .enumerate()
                .map(|(v, p)| base[v] + ((s + ds) * (rot * p.as_dvec3()) + t + dt - f64_base[v]))
                .collect()
        };
        let mut checks = Vec::new();
        for (k, axis) in [DVec3::X, DVec3::Y, DVec3::Z].iter().enumerate() {
            checks.push((
                "rotation",
                k,
                analytic.rotation[k],
                central(&reference, 1e-5, |e| moved(*axis * e, DVec3::ZERO, 0.0)),
            ));
            checks.push((
                "translation",
                k,
                analytic.translation[k],
                central(&reference, 1e-5, |e| moved(DVec3::ZERO, *axis * e, 0.0)),
            ));
        }
        checks.push(("scale", 0, analytic.scale, central(&reference, 1e-5, |e| moved(DVec3::ZERO, DVec3::ZERO, e))));
        let worst = checks.iter().map(|e| relative(e.2 as f64, e.3)).fold(0.0, f64::max);
        println!("{}: rigid transform, worst relative error {worst:.2e} over {}", scene.name, checks.len());
        for (what, k, a, fd) in checks {
            assert!(fd.abs() > 1e-3, "{}: {what} {k}: the derivative is trivially zero ({fd})", scene.name);
            assert!(relative(a as f64, fd) < 1e-3, "{}: {what} {k}: analytic {a} vs fd {fd}", scene.name);
        }
    }
}

#[test]
fn retract_takes_the_step_the_gradient_describes() {
    // A first-order step along −g lowers a linear function of the points by ≈ η·|g|².
    let model: Vec<Vec3> = diffsil::shapes::icosphere(1).positions().to_vec();
    let transform = RigidTransform { rotation: Vec3::new(0.2, 0.1, -0.3), translation: Vec3::X, scale: 1.2 };
    let w: Vec<Vec3> = model.iter().enumerate().map(|(i, p)| Vec3::new(p.y, (i % 3) as f32, -p.x)).collect();
    let loss = |t: &RigidTransform| -> f64 { t.apply(&model).iter().zip(&w).map(|(p, w)| p.dot(*w) as f64).sum() };
    let g = transform.backward(&model, &w).unwrap();
    let eta = 1e-3f32;
    let step = diffsil::RigidGradient {
        rotation: -eta * g.rotation,
        translation: -eta * g.translation,
        scale: -eta * g.scale,
    };
    let predicted =
        eta as f64 * (g.rotation.length_squared() + g.translation.length_squared() + g.scale * g.scale) as f64;
    let actual = loss(&transform) - loss(&transform.retract(&step));
    assert!(relative(actual, predicted) < 2e-2, "decrease {actual} vs predicted {predicted}");
}

// Downsampling: `Camera::downsampled` with `Image::downsampled`. F×F samples of each pixel of a
// `k`-times finer image, averaged over `k × k` pixels, sit exactly where the (k·F)² samples of the
// coarse pixel sit, so a render downsampled is the render of the downsampled camera at k·F, up to
// the samples within a snap of an edge (the forward snaps vertices to a fixed-point grid of each
// image's own pixels, so the two grids differ).

/// The blob seen by one camera of each projection (look-at perspective, pinhole and OpenCV
/// cameras), at `width × height`.
fn downsampling_cameras(width: u32, height: u32) -> Vec<Camera> {
    let (eye, target) = (Vec3::new(0.3, 0.4, 3.0), Vec3::new(0.05, -0.02, 0.0));
    vec![
        Camera::perspective(eye, target, 0.9, width, height),
        Camera::pinhole(
            eye,
            target,
            Vec2::new(1.1, 0.9) * width as f32,
            Vec2::new(0.47, 0.55) * Vec2::new(width as f32, height as f32),
            width,
            height,
        ),
        Camera::from_opencv(
            [
                [0.9 * width as f32, 0.0, 0.52 * width as f32],
                [0.0, 0.95 * width as f32, 0.46 * height as f32],
                [0.0, 0.0, 1.0],
            ],
            R,
            [0.1, -0.05, 3.2],
            width,
            height,
        )
        .unwrap(),
    ]
}

/// The coverage of `mesh` seen by `cameras` at F = `supersample`.
fn coverage(mesh: &diffsil::Mesh, cameras: &[Camera], supersample: u32) -> Vec<Image> {
    let mut renderer = Renderer::new(RenderSettings { supersample, ..RenderSettings::default() }).unwrap();
    renderer.render(mesh, cameras).unwrap().images().to_vec()
}

#[test]
fn a_downsampled_render_is_the_downsampled_cameras_render() {
    let mesh = blob_3d().mesh;
    // 2 and 4 divide 48 × 40; 4 leaves a partial block of 70 × 45 (the margins cut, and the
    // perspective camera becomes a pinhole); 3 is not a power of two.
    for (width, height, factor) in [(48, 40, 2), (48, 40, 4), (70, 45, 4), (70, 45, 3), (61, 50, 3)] {
        let cameras = downsampling_cameras(width, height);
        let fine = coverage(&mesh, &cameras, 4);
        let small: Vec<Camera> = cameras.iter().map(|c| c.downsampled(factor).unwrap()).collect();
        let coarse = coverage(&mesh, &small, 4 * factor);
        for (view, (fine, coarse)) in fine.iter().zip(&coarse).enumerate() {
            let down = fine.downsampled(factor).unwrap();
            assert_eq!((down.width(), down.height()), (width / factor, height / factor));
            assert_eq!((coarse.width(), coarse.height()), (width / factor, height / factor));
            let inside = coarse.data().iter().filter(|v| **v > 0.5).count();
            assert!(inside > 10 && inside < coarse.data().len(), "view {view} sees the blob's outline");
            let samples = (4 * factor).pow(2) as f32;
            let differences: Vec<f32> =
                down.data().iter().zip(coarse.data()).map(|(a, b)| (a - b).abs()).filter(|d| *d > 0.0).collect();
            let worst = differences.iter().copied().fold(0.0, f32::max);
            assert!(worst <= 2.5 / samples, "{width}x{height} by {factor}, view {view}: {worst}");
            // Only where an edge passes, about a sample at most.
            let outline = coarse.data().iter().filter(|v| **v > 0.0 && **v < 1.0).count();
            let total: f32 = differences.iter().sum();
            assert!(total <= outline as f32 / samples, "{width}x{height} by {factor}, view {view}: {differences:?}");
        }
    }
    // Orthographic cameras: kept where the factor divides the sides.
    let ortho = Camera::orthographic(Vec3::new(0.2, 0.1, 3.0), Vec3::ZERO, 2.4, 48, 40);
    let down = ortho.downsampled(4).unwrap();
    assert_eq!(down.projection, ortho.projection);
    let (fine, coarse) = (coverage(&mesh, &[ortho], 4), coverage(&mesh, &[down], 16));
    let down = fine[0].downsampled(4).unwrap();
    let worst = down.data().iter().zip(coarse[0].data()).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
    assert!(worst <= 2.5 / 256.0, "{worst}");
}

#[test]
fn downsampling_keeps_the_pose_and_scales_the_intrinsics() {
    let camera = Camera::from_opencv(K, R, T, 64, 48).unwrap();
    let small = camera.downsampled(4).unwrap();
    assert_eq!(
        (small.extrinsics, small.eye, small.near, small.far),
        (camera.extrinsics, camera.eye, camera.near, camera.far)
    );
    // (fx, fy, cx, cy) = (100, 80, 30.5, 20.5) in diffsil's pixels, divided by 4.
    assert_eq!(small.intrinsics(), [25.0, 20.0, 7.625, 5.125]);
    // A perspective camera whose sides the factor does not divide: a pinhole with the old image
    // centre divided by the factor, not the new centre.
    let perspective = Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.9, 70, 45);
    let small = perspective.downsampled(4).unwrap();
    let [f, _, _, _] = perspective.intrinsics();
    assert_eq!(small.projection, Projection::Pinhole { fx: f / 4.0, fy: f / 4.0, cx: 8.75, cy: 5.625 });
    assert_eq!((small.width, small.height), (17, 11));
    // Factor 1 changes nothing.
    assert_eq!(camera.downsampled(1).unwrap(), camera);
    assert_eq!(perspective.downsampled(1).unwrap(), perspective);
}

#[test]
fn bad_downsampling_factors_are_errors() {
    let camera = Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.9, 70, 45);
    let image = Image::filled(70, 45, 0.5);
    for factor in [0, 46, 71, u32::MAX] {
        assert!(matches!(camera.downsampled(factor), Err(Error::InvalidSettings(_))), "camera by {factor}");
        assert!(matches!(image.downsampled(factor), Err(Error::InvalidSettings(_))), "image by {factor}");
    }
    // The largest factor leaves one pixel.
    assert_eq!(image.downsampled(45).unwrap(), Image::filled(1, 1, 0.5));
    assert_eq!((camera.downsampled(45).unwrap().width, camera.downsampled(45).unwrap().height), (1, 1));
    let ortho = Camera::orthographic(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 2.0, 70, 45);
    let e = ortho.downsampled(4).unwrap_err().to_string();
    assert!(e.contains("orthographic") && e.contains("divide"), "{e}");
    assert!(ortho.downsampled(5).is_ok());
}

#[test]
fn a_downsampled_image_averages_its_blocks() {
    // 5 × 3 by 2: two blocks, the last column and row left out.
    let data: Vec<f32> = (0..15).map(|v| v as f32).collect();
    let image = Image::from_vec(5, 3, data).unwrap();
    let down = image.downsampled(2).unwrap();
    assert_eq!((down.width(), down.height()), (2, 1));
    assert_eq!(down.data(), &[(0.0 + 1.0 + 5.0 + 6.0) / 4.0, (2.0 + 3.0 + 7.0 + 8.0) / 4.0]);
    assert_eq!(image.downsampled(1).unwrap(), image);
    // Sums in f64: a block of values an f32 sum would round loses nothing.
    let big = Image::from_vec(2, 2, vec![1e8, 1.0, 1.0, 1.0]).unwrap();
    assert_eq!(big.downsampled(2).unwrap().data(), &[((1e8 + 3.0) / 4.0) as f32]);
}

// Cropping: `Camera::cropped` with `Image::cropped`.

/// A render's window is the render of the cropped camera: the same coverage to the sample (the
/// crop moves the image by whole pixels, so the snapped vertices and the samples move with it),
/// for look-at perspective (off-centre: a pinhole), pinhole and OpenCV cameras, and a centred
/// band of full height that keeps the perspective and orthographic projections.
#[test]
fn a_cropped_render_is_the_cropped_cameras_render() {
    let mesh = blob_3d().mesh;
    let rects = [
        PixelRect { x: 7, y: 5, width: 30, height: 22 },
        PixelRect { x: 0, y: 0, width: 48, height: 40 },
        PixelRect { x: 20, y: 13, width: 1, height: 1 },
    ];
    for rect in rects {
        let cameras = downsampling_cameras(48, 40);
        let full = coverage(&mesh, &cameras, 4);
        let cropped: Vec<Camera> = cameras.iter().map(|c| c.cropped(rect).unwrap()).collect();
        for (camera, crop) in cameras.iter().zip(&cropped) {
            assert_eq!((crop.width, crop.height), (rect.width, rect.height));
            assert_eq!(
                (crop.extrinsics, crop.eye, crop.near, crop.far),
                (camera.extrinsics, camera.eye, camera.near, camera.far)
            );
        }
        let windows = coverage(&mesh, &cropped, 4);
        for (view, (full, window)) in full.iter().zip(&windows).enumerate() {
            assert_eq!(&full.cropped(rect).unwrap(), window, "{rect:?}, view {view}");
        }
    }
    let centred = PixelRect { x: 8, y: 0, width: 32, height: 40 };
    let perspective = Camera::perspective(Vec3::new(0.3, 0.4, 3.0), Vec3::ZERO, 0.9, 48, 40);
    assert_eq!(perspective.cropped(centred).unwrap().projection, perspective.projection);
    let ortho = Camera::orthographic(Vec3::new(0.2, 0.1, 3.0), Vec3::ZERO, 2.4, 48, 40);
    let crop = ortho.cropped(centred).unwrap();
    assert_eq!(crop.projection, ortho.projection);
    let (full, window) = (coverage(&mesh, &[ortho], 4), coverage(&mesh, &[crop], 4));
    assert_eq!(full[0].cropped(centred).unwrap(), window[0]);
}

#[test]
fn bad_crops_are_errors() {
    let camera = Camera::from_opencv(K, R, T, 64, 48).unwrap();
    let image = Image::filled(64, 48, 0.5);
    let bad = [
        PixelRect { x: 0, y: 0, width: 0, height: 10 },
        PixelRect { x: 0, y: 0, width: 10, height: 0 },
        PixelRect { x: 60, y: 0, width: 5, height: 10 },
        PixelRect { x: 0, y: 40, width: 10, height: 9 },
        PixelRect { x: u32::MAX, y: 0, width: 2, height: 2 },
        PixelRect { x: 0, y: 1, width: 2, height: u32::MAX },
    ];
    for rect in bad {
        assert!(matches!(camera.cropped(rect), Err(Error::InvalidSettings(_))), "camera {rect:?}");
        assert!(matches!(image.cropped(rect), Err(Error::InvalidSettings(_))), "image {rect:?}");
    }
    let whole = PixelRect { x: 0, y: 0, width: 64, height: 48 };
    assert_eq!(image.cropped(whole).unwrap(), image);
    assert_eq!(camera.cropped(whole).unwrap(), camera);
    // (fx, fy, cx, cy) = (100, 80, 30.5, 20.5): the principal point moved by the corner.
    let corner = camera.cropped(PixelRect { x: 10, y: 4, width: 30, height: 30 }).unwrap();
    assert_eq!(corner.intrinsics(), [100.0, 80.0, 20.5, 16.5]);
    let ortho = Camera::orthographic(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 2.0, 64, 48);
    for rect in [PixelRect { x: 1, y: 0, width: 62, height: 47 }, PixelRect { x: 0, y: 0, width: 62, height: 48 }] {
        let e = ortho.cropped(rect).unwrap_err().to_string();
        assert!(e.contains("orthographic") && e.contains("centred"), "{e}");
    }
}
