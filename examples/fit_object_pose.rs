//! Fits the 6-DoF pose (and optionally the scale) of a rigid mesh to silhouettes seen by
//! calibrated cameras, or (`--calibrate`) the cameras' extrinsics to silhouettes of a known object.
//!
//! ```text
//! cargo run --release --example fit_object_pose                      # built-in blob, 4 views, seed 1
//! cargo run --release --example fit_object_pose -- --views 1
//! cargo run --release --example fit_object_pose -- --mesh ../shared/assets/spot.obj --scale
//! cargo run --release --example fit_object_pose -- --evaluate 20     # median / p90 / worst of 20 starts
//! cargo run --release --example fit_object_pose -- --calibrate
//! ```
//!
//! The mesh is centred and scaled to radius 1 (its size is then 2). `--views` cameras (1 to 4) are
//! built from OpenCV calibrations (`Camera::from_opencv`: non-square pixels, principal point off
//! the centre) around it. A random ground-truth pose is drawn from the seed, its silhouettes are
//! the targets, and the fit starts from the truth turned by a random angle up to `--max-angle`
//! about a random axis and moved by up to `--max-offset` of the object's size.
//!
//! Method: Adam on the tangent of the pose ([`RigidTransform::backward`] /
//! [`RigidTransform::retract`]: rotation about the object's centre, translation, scale), the loss
//! the squared error between rendered and target silhouettes both blurred by the same Gaussian,
//! coarse to fine (σ = 8%, then 4%, 2% of the image side, then none), the learning rates decaying
//! along. `--calibrate` fits each camera's extrinsics the same way from its own silhouette
//! (`camera_gradient`), the rotation taken about the object's centre as the camera sees it.
//! Pictures go to `--out`: per view target | start | fit | difference. The last line is
//! machine-readable.

use std::path::PathBuf;
use std::time::Instant;

use clap::Parser;
use diffsil::loss::{blurred_squared_error, GaussianBlur};
use diffsil::optim::Adam;
use diffsil::random::SplitMix64;
use diffsil::{
    camera_gradient, shapes, Camera, Extrinsics, Image, Mesh, RenderSettings, Renderer, RigidGradient, RigidTransform,
    Vec3,
};
use glam::Quat;

mod common;
use common::{finite, median, BackendName};

/// Command-line options (`fit_object_pose --help`).
#[derive(Clone, Debug, Parser)]
#[command(
    name = "fit_object_pose",
    about = "Fit a rigid object's pose (or the cameras' extrinsics) to silhouettes from calibrated cameras"
)]
pub struct Options {
    /// Mesh file (.obj, .gltf, .glb) [default: the built-in blob, shapes::blob(16, 20)]
    #[arg(long, value_name = "PATH")]
    pub mesh: Option<PathBuf>,
    /// Number of calibrated cameras, 1 to 4
    #[arg(long, value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=4))]
    pub views: u32,
    /// Image side in pixels
    #[arg(long, value_name = "N", default_value_t = 64, value_parser = clap::value_parser!(u32).range(8..=4096))]
    pub resolution: u32,
    /// Adam steps per fit
    #[arg(long, value_name = "N", default_value_t = 160, value_parser = clap::value_parser!(u32).range(1..))]
    pub iterations: u32,
    /// Largest start rotation away from the truth, degrees
    #[arg(long, value_name = "DEG", default_value = "30", value_parser = finite)]
    pub max_angle: f32,
    /// Largest start offset from the truth, as a fraction of the object's size
    #[arg(long, value_name = "X", default_value = "0.2", value_parser = finite)]
    pub max_offset: f32,
    /// Fit the uniform scale too (the truth keeps scale 1; the start is off by up to ±10%)
    #[arg(long)]
    pub scale: bool,
    /// Fit the cameras' extrinsics to silhouettes of the object at a known pose instead
    #[arg(long)]
    pub calibrate: bool,
    /// Run this many seeds (seed, seed + 1, …) and print median / p90 / worst; no pictures
    #[arg(long, value_name = "N")]
    pub evaluate: Option<u32>,
    /// Seed of the ground truth and the start
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Renderer backend
    #[arg(long, value_enum, default_value_t = BackendName::Cpu)]
    pub backend: BackendName,
    /// Picture of the fit (PNG)
    #[arg(long, value_name = "PATH", default_value = "fit_object_pose.png")]
    pub out: PathBuf,
}

/// The object, the cameras and the size the errors are relative to.
pub struct Scene {
    /// The mesh, centred, radius 1.
    pub model: Mesh,
    /// The calibrated cameras.
    pub cameras: Vec<Camera>,
    /// The object's size (its bounding sphere's diameter).
    pub size: f32,
}

/// The built-in mesh: a lumpy, non-convex blob with no symmetry.
pub fn builtin_mesh() -> Mesh {
    shapes::blob(16, 20)
}

/// `views` calibrated cameras 3.2 units from the origin, spread in azimuth and elevation, each
/// from an OpenCV calibration with fy = 1.05·fx and the principal point off the centre.
pub fn calibrated_cameras(views: u32, resolution: u32) -> Vec<Camera> {
    let s = resolution as f32;
    let k = [[1.05 * s, 0.0, 0.47 * s], [0.0, 1.1 * s, 0.53 * s], [0.0, 0.0, 1.0]];
    let places = [(0.0f32, 15.0f32), (95.0, -10.0), (185.0, 35.0), (270.0, 5.0)];
    places
        .iter()
        .take(views as usize)
        .map(|&(azimuth, elevation)| {
            let (a, e) = (azimuth.to_radians(), elevation.to_radians());
            let eye = 3.2 * Vec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos());
            let pose = Camera::perspective(eye, Vec3::ZERO, 1.0, resolution, resolution).opencv_extrinsics();
            let r = pose.rotation.transpose().to_cols_array_2d();
            Camera::from_opencv(k, r, pose.translation.to_array(), resolution, resolution)
                .expect("a look-at pose is a valid calibration")
        })
        .collect()
}

impl Scene {
    /// The scene of these options.
    pub fn new(o: &Options) -> Result<Scene, diffsil::Error> {
        let mesh = match &o.mesh {
            Some(path) => common::load_mesh(path)?.0,
            None => builtin_mesh(),
        };
        Ok(Scene { model: mesh.normalized(1.0), cameras: calibrated_cameras(o.views, o.resolution), size: 2.0 })
    }
}

/// The angle of `a·bᵀ`, degrees.
pub fn rotation_error_deg(a: Vec3, b: Vec3) -> f32 {
    quat_angle_deg(Quat::from_scaled_axis(a) * Quat::from_scaled_axis(b).inverse())
}

/// The rotation angle of a unit quaternion, degrees in [0, 180].
fn quat_angle_deg(q: Quat) -> f32 {
    (2.0 * q.xyz().length().atan2(q.w.abs())).to_degrees()
}

/// A rotation turned by a uniformly random angle in `[0, max]` radians about a random axis.
fn perturbed_rotation(rotation: Vec3, max: f32, rng: &mut SplitMix64) -> Vec3 {
    let turn = Quat::from_scaled_axis(rng.unit_vector() * rng.range(0.0, max));
    (turn * Quat::from_scaled_axis(rotation)).normalize().to_scaled_axis()
}

/// Ground truth and start of one case: the truth a uniformly random rotation and a small random
/// translation, the start turned by up to `max_angle` and moved by up to `max_offset · size`.
pub fn case(o: &Options, scene: &Scene, seed: u64) -> (RigidTransform, RigidTransform) {
    let mut rng = SplitMix64::new(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x5EED);
    let truth = RigidTransform {
        rotation: perturbed_rotation(Vec3::ZERO, std::f32::consts::PI, &mut rng),
        translation: rng.unit_vector() * rng.range(0.0, 0.1),
        scale: 1.0,
    };
    let start = RigidTransform {
        rotation: perturbed_rotation(truth.rotation, o.max_angle.to_radians(), &mut rng),
        translation: truth.translation + rng.unit_vector() * rng.range(0.0, o.max_offset * scene.size),
        scale: if o.scale { rng.range(0.9, 1.1) } else { 1.0 },
    };
    (truth, start)
}

/// Blur of each stage (fraction of the image side) and its share of the steps.
const SCHEDULE: [(f32, f32); 4] = [(0.08, 0.25), (0.04, 0.25), (0.02, 0.25), (0.0, 0.25)];

/// Blur and learning-rate factor at step `i` of `n`.
fn stage(i: u32, n: u32, resolution: u32) -> (f32, f32) {
    let x = i as f32 / n as f32;
    let mut edge = 0.0;
    let mut sigma = 0.0;
    for (s, share) in SCHEDULE {
        edge += share;
        if x < edge {
            sigma = s * resolution as f32;
            break;
        }
    }
    // Cosine decay to 5%.
    (sigma, 0.05 + 0.95 * 0.5 * (1.0 + (std::f32::consts::PI * x).cos()))
}

/// Blurred squared error over all views and its image gradients.
fn blurred_loss(images: &[Image], targets: &[Image], blur: &GaussianBlur) -> Result<(f64, Vec<Image>), diffsil::Error> {
    let mut total = 0.0;
    let mut grads = Vec::with_capacity(images.len());
    for (image, target) in images.iter().zip(targets) {
        let out = blurred_squared_error(image, &blur.apply(target), blur)?;
        total += out.value;
        grads.push(out.grad);
    }
    Ok((total, grads))
}

/// Learning rates: rotation (radians), translation and scale (per unit of object size).
const LR_ROTATION: f32 = 0.04;
const LR_TRANSLATION: f32 = 0.02;

/// Fits the object's pose from `start` to the `targets` seen by `scene.cameras`.
pub fn fit_object(
    renderer: &mut Renderer,
    scene: &Scene,
    targets: &[Image],
    start: RigidTransform,
    o: &Options,
) -> Result<RigidTransform, diffsil::Error> {
    let mut pose = start;
    let mut mesh = scene.model.clone();
    let (mut rotation, mut translation) = (Adam::new(LR_ROTATION), Adam::new(LR_TRANSLATION * scene.size));
    let mut scale = Adam::new(LR_TRANSLATION);
    let (mut x_rot, mut x_t, mut x_s) = ([0f32; 3], [0f32; 3], [0f32; 1]);
    for i in 0..o.iterations {
        let (sigma, decay) = stage(i, o.iterations, o.resolution);
        let blur = GaussianBlur::new(sigma)?;
        mesh.set_positions(&pose.apply(scene.model.positions()))?;
        let frame = renderer.render(&mesh, &scene.cameras)?;
        let (_, d_images) = blurred_loss(frame.images(), targets, &blur)?;
        let world = renderer.backward(&frame, &d_images)?;
        let g = pose.backward(scene.model.positions(), &world)?;
        let before = (x_rot, x_t, x_s);
        rotation.learning_rate = LR_ROTATION * decay;
        translation.learning_rate = LR_TRANSLATION * scene.size * decay;
        scale.learning_rate = LR_TRANSLATION * decay;
        rotation.step(&mut x_rot, &g.rotation.to_array())?;
        translation.step(&mut x_t, &g.translation.to_array())?;
        if o.scale {
            scale.step(&mut x_s, &[g.scale])?;
        }
        let step = RigidGradient {
            rotation: Vec3::from(x_rot) - Vec3::from(before.0),
            translation: Vec3::from(x_t) - Vec3::from(before.1),
            scale: x_s[0] - before.2[0],
        };
        pose = pose.retract(&step);
    }
    Ok(pose)
}

/// Fits each camera's extrinsics from `start` to its target, the object at `object` fixed.
pub fn fit_cameras(
    renderer: &mut Renderer,
    scene: &Scene,
    object: &Mesh,
    targets: &[Image],
    start: &[Camera],
    o: &Options,
) -> Result<Vec<Camera>, diffsil::Error> {
    let mut cameras = start.to_vec();
    let n = cameras.len();
    let mut adam: Vec<(Adam, Adam, [f32; 3], [f32; 3])> =
        (0..n).map(|_| (Adam::new(LR_ROTATION), Adam::new(LR_TRANSLATION * scene.size), [0.0; 3], [0.0; 3])).collect();
    for i in 0..o.iterations {
        let (sigma, decay) = stage(i, o.iterations, o.resolution);
        let blur = GaussianBlur::new(sigma)?;
        let frame = renderer.render(object, &cameras)?;
        let (_, d_images) = blurred_loss(frame.images(), targets, &blur)?;
        let screen = renderer.backward_screen(&frame, &d_images)?;
        for ((camera, g2), (rot, trans, x_rot, x_t)) in cameras.iter_mut().zip(&screen).zip(&mut adam) {
            let g = camera_gradient(camera, object.positions(), g2)?;
            let pose = camera.extrinsics.expect("calibrated cameras");
            // The object is centred at the world origin, which the camera sees at c₀ = t: the
            // left perturbation exp([δ]×)·R with t fixed turns the view about c₀, the object's
            // centre, so `Extrinsics::retract` takes exactly that step.
            let before = (*x_rot, *x_t);
            rot.learning_rate = LR_ROTATION * decay;
            trans.learning_rate = LR_TRANSLATION * scene.size * decay;
            rot.step(x_rot, &g.rotation.to_array())?;
            trans.step(x_t, &g.translation.to_array())?;
            let delta = Vec3::from(*x_rot) - Vec3::from(before.0);
            let dt = Vec3::from(*x_t) - Vec3::from(before.1);
            *camera = camera.with_extrinsics(pose.retract(delta, dt));
        }
    }
    Ok(cameras)
}

/// Rotation (degrees) and translation (fraction of `size`) errors of each camera, measured as the
/// object's pose in that camera's frame.
fn camera_errors(fitted: &[Camera], truth: &[Camera], size: f32) -> Vec<(f32, f32)> {
    fitted
        .iter()
        .zip(truth)
        .map(|(f, t)| {
            let (f, t) = (f.extrinsics.unwrap(), t.extrinsics.unwrap());
            let angle = quat_angle_deg(Quat::from_mat3(&(f.rotation * t.rotation.transpose())));
            (angle, (f.translation - t.translation).length() / size)
        })
        .collect()
}

/// A camera's start: the object seen from it turned by up to `max_angle` about its own centre and
/// moved by up to `max_offset · size` (in camera axes).
fn perturbed_camera(camera: &Camera, o: &Options, size: f32, rng: &mut SplitMix64) -> Camera {
    let pose = camera.extrinsics.expect("calibrated cameras");
    let delta = rng.unit_vector() * rng.range(0.0, o.max_angle.to_radians());
    let offset = rng.unit_vector() * rng.range(0.0, o.max_offset * size);
    let moved: Extrinsics = pose.retract(delta, offset);
    camera.with_extrinsics(moved)
}

/// Result of one fit: rotation error (degrees), translation error (fraction of size), wall and
/// CPU seconds.
#[derive(Clone, Copy, Debug)]
pub struct Outcome {
    /// Rotation error, degrees (calibration: the worst camera's).
    pub rotation_deg: f32,
    /// Translation error over the object's size (calibration: the worst camera's).
    pub translation: f32,
    /// Wall-clock seconds of the fit.
    pub wall_s: f64,
    /// CPU seconds of the process during the fit (user + system, all threads), when known.
    pub cpu_s: Option<f64>,
}

/// Process CPU time (user + system) in seconds, from /proc/self/stat (Linux); `None` elsewhere.
pub fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// One case, fitted; with `pictures`, the images of target | start | fit per view.
pub fn run_case(
    renderer: &mut Renderer,
    scene: &Scene,
    o: &Options,
    seed: u64,
) -> Result<(Outcome, Vec<[Image; 3]>), diffsil::Error> {
    let (truth, start) = case(o, scene, seed);
    let mut object = scene.model.clone();
    if o.calibrate {
        let mut rng = SplitMix64::new(seed ^ 0xCA11);
        let starts: Vec<Camera> = scene.cameras.iter().map(|c| perturbed_camera(c, o, scene.size, &mut rng)).collect();
        let targets = renderer.render(&object, &scene.cameras)?.images().to_vec();
        let (cpu0, t0) = (cpu_seconds(), Instant::now());
        let fitted = fit_cameras(renderer, scene, &object, &targets, &starts, o)?;
        let (wall_s, cpu_s) = (t0.elapsed().as_secs_f64(), cpu_seconds().zip(cpu0).map(|(b, a)| b - a));
        let errors = camera_errors(&fitted, &scene.cameras, scene.size);
        let worst = errors.iter().fold((0f32, 0f32), |m, e| (m.0.max(e.0), m.1.max(e.1)));
        let before = renderer.render(&object, &starts)?.images().to_vec();
        let after = renderer.render(&object, &fitted)?.images().to_vec();
        let pictures = zip_pictures(targets, before, after);
        return Ok((Outcome { rotation_deg: worst.0, translation: worst.1, wall_s, cpu_s }, pictures));
    }
    object.set_positions(&truth.apply(scene.model.positions()))?;
    let targets = renderer.render(&object, &scene.cameras)?.images().to_vec();
    let (cpu0, t0) = (cpu_seconds(), Instant::now());
    let fitted = fit_object(renderer, scene, &targets, start, o)?;
    let (wall_s, cpu_s) = (t0.elapsed().as_secs_f64(), cpu_seconds().zip(cpu0).map(|(b, a)| b - a));
    let outcome = Outcome {
        rotation_deg: rotation_error_deg(fitted.rotation, truth.rotation),
        translation: (fitted.translation - truth.translation).length() / scene.size,
        wall_s,
        cpu_s,
    };
    object.set_positions(&start.apply(scene.model.positions()))?;
    let before = renderer.render(&object, &scene.cameras)?.images().to_vec();
    object.set_positions(&fitted.apply(scene.model.positions()))?;
    let after = renderer.render(&object, &scene.cameras)?.images().to_vec();
    Ok((outcome, zip_pictures(targets, before, after)))
}

fn zip_pictures(a: Vec<Image>, b: Vec<Image>, c: Vec<Image>) -> Vec<[Image; 3]> {
    a.into_iter().zip(b).zip(c).map(|((a, b), c)| [a, b, c]).collect()
}

/// One picture: a row per view, target | start | fit | |fit − target|, 2-pixel gaps.
pub fn sheet(rows: &[[Image; 3]]) -> Image {
    let (w, h) = (rows[0][0].width(), rows[0][0].height());
    let gap = 2;
    let (cols, n) = (4u32, rows.len() as u32);
    let (sw, sh) = (cols * w + (cols - 1) * gap, n * h + (n - 1) * gap);
    let mut out = Image::filled(sw, sh, 0.35);
    for (r, [target, start, fit]) in rows.iter().enumerate() {
        let diff: Vec<f32> = fit.data().iter().zip(target.data()).map(|(a, b)| (a - b).abs()).collect();
        for (c, data) in [target.data(), start.data(), fit.data(), &diff[..]].into_iter().enumerate() {
            let (x0, y0) = (c as u32 * (w + gap), r as u32 * (h + gap));
            for y in 0..h {
                for x in 0..w {
                    out.data_mut()[((y0 + y) * sw + x0 + x) as usize] = data[(y * w + x) as usize];
                }
            }
        }
    }
    out
}

/// The `q`-quantile (nearest rank) of a list.
fn quantile(mut v: Vec<f64>, q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1]
}

fn main() {
    let o = Options::parse();
    if let Err(e) = run(&o) {
        eprintln!("fit_object_pose: {e}");
        std::process::exit(1);
    }
}

/// Runs the example: one fit with pictures, or `--evaluate N` fits with statistics.
pub fn run(o: &Options) -> Result<(), Box<dyn std::error::Error>> {
    let scene = Scene::new(o)?;
    let mut renderer = Renderer::with_backend(RenderSettings::default(), o.backend.backend())?;
    let what = if o.calibrate { "camera extrinsics" } else { "object pose" };
    println!(
        "fitting {what}: {} view(s) at {}², {} steps, start up to {}° and {}% of the size off, backend {}",
        o.views,
        o.resolution,
        o.iterations,
        o.max_angle,
        100.0 * o.max_offset,
        renderer.backend_name()
    );
    let Some(n) = o.evaluate else {
        let (outcome, pictures) = run_case(&mut renderer, &scene, o, o.seed)?;
        diffsil::io::save_png(&sheet(&pictures), &o.out)?;
        println!("pictures (target | start | fit | difference, a row per view): {}", o.out.display());
        println!(
            "RESULT rotation_error_deg={:.4} translation_error_pct={:.4} wall_s={:.3} cpu_s={}",
            outcome.rotation_deg,
            100.0 * outcome.translation,
            outcome.wall_s,
            outcome.cpu_s.map_or("n/a".into(), |c| format!("{c:.3}"))
        );
        return Ok(());
    };
    let mut outcomes = Vec::new();
    for k in 0..n as u64 {
        let (outcome, _) = run_case(&mut renderer, &scene, o, o.seed + k)?;
        println!(
            "seed {:4}: rotation {:8.4}°  translation {:8.4}%  {:.3} s",
            o.seed + k,
            outcome.rotation_deg,
            100.0 * outcome.translation,
            outcome.wall_s
        );
        outcomes.push(outcome);
    }
    let rot: Vec<f64> = outcomes.iter().map(|x| x.rotation_deg as f64).collect();
    let tr: Vec<f64> = outcomes.iter().map(|x| 100.0 * x.translation as f64).collect();
    let wall: Vec<f64> = outcomes.iter().map(|x| x.wall_s).collect();
    let cpu: Vec<f64> = outcomes.iter().filter_map(|x| x.cpu_s).collect();
    let stats = |v: &[f64]| (median(v.to_vec()), quantile(v.to_vec(), 0.9), v.iter().copied().fold(f64::MIN, f64::max));
    let (r, t, w) = (stats(&rot), stats(&tr), stats(&wall));
    println!("rotation error °:    median {:.4}  p90 {:.4}  worst {:.4}", r.0, r.1, r.2);
    println!("translation error %: median {:.4}  p90 {:.4}  worst {:.4}", t.0, t.1, t.2);
    println!("seconds per fit:     median {:.3}  p90 {:.3}  worst {:.3}", w.0, w.1, w.2);
    let cpu_median = if cpu.is_empty() { "n/a".into() } else { format!("{:.3}", median(cpu)) };
    println!(
        "RESULT fits={n} rotation_median_deg={:.4} rotation_p90_deg={:.4} rotation_worst_deg={:.4} \
         translation_median_pct={:.4} translation_p90_pct={:.4} translation_worst_pct={:.4} \
         wall_median_s={:.3} cpu_median_s={cpu_median}",
        r.0, r.1, r.2, t.0, t.1, t.2, w.0
    );
    Ok(())
}
