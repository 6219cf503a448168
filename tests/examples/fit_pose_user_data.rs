//! `fit_pose` on the user's own masks and cameras (`--targets`, `--cameras`): written here from a
//! known posed figure seen by three OpenCV cameras (or exported by `--export`), then fitted through
//! the example's command line and functions.

#[path = "../../examples/fit_pose/user_data.rs"]
#[allow(dead_code)]
mod user_data;

use std::path::{Path, PathBuf};

use clap::Parser;
use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::random_pose;
use diffsil::pose::skin::Pose;
use diffsil::{Camera, Mesh, RenderSettings, Renderer, Vec3};
use serde_json::{json, Value};

use crate::fit_pose::example;

/// Width and height of the test's masks (not square, so that a swap shows).
const SIZE: (u32, u32) = (40, 32);

/// Three OpenCV cameras (`K`, `R` rows, `t`, as JSON) on a ring around `mesh`, looking at its
/// centre, framing its height in about 3/4 of the image height, `size` pixels.
fn opencv_cameras(mesh: &Mesh, size: (u32, u32)) -> Vec<Value> {
    let (lo, hi) = mesh.bounds().expect("a mesh with vertices");
    let (width, height) = size;
    let (centre, extent) = ((lo + hi) / 2.0, (hi - lo).max_element());
    let distance = 3.0 * extent;
    let focal = 0.75 * height as f32 * distance / extent;
    (0..3)
        .map(|k| {
            let azimuth = (k as f32 * 120.0 + 20.0).to_radians();
            let eye = centre + distance * Vec3::new(azimuth.sin(), 0.3, azimuth.cos()).normalize();
            // OpenCV camera axes: z forward, x right, y down.
            let z = (centre - eye).normalize();
            let x = z.cross(Vec3::Y).normalize();
            let y = z.cross(x);
            let t = [-x.dot(eye), -y.dot(eye), -z.dot(eye)];
            json!({
                "width": width, "height": height,
                "K": [[focal, 0.0, (width as f32 - 1.0) / 2.0 + 0.7], [0.0, focal * 1.05, (height as f32 - 1.0) / 2.0], [0.0, 0.0, 1.0]],
                "R": [x.to_array(), y.to_array(), z.to_array()],
                "t": t,
                "far": 100.0,
            })
        })
        .collect()
}

/// Writes the masks of the built-in figure in a random pose and `cameras.json` into a fresh
/// folder, [`SIZE`]; returns the mask paths and the JSON path.
fn write_user_data() -> (Vec<PathBuf>, PathBuf) {
    write_user_data_at(SIZE, Vec3::ZERO, 0.0)
}

/// [`write_user_data`] with masks of `size` pixels, the figure (and the cameras about it) moved
/// by `offset` in the world, and turned by `turn` radians more about the vertical.
fn write_user_data_at(size: (u32, u32), offset: Vec3, turn: f32) -> (Vec<PathBuf>, PathBuf) {
    let dir = crate::common::files::temp_dir();
    let model = builtin_figure();
    let rest = Pose::rest(model.joint_count());
    let rest = Mesh::with_topology(
        model.skin(&rest).unwrap().iter().map(|p| *p + offset).collect(),
        model.mesh.topology().clone(),
    )
    .unwrap();
    let specs = opencv_cameras(&rest, size);
    let cameras: Vec<Camera> = specs
        .iter()
        .map(|c| {
            let m = |key: &str| serde_json::from_value::<[[f32; 3]; 3]>(c[key].clone()).unwrap();
            let t = serde_json::from_value::<[f32; 3]>(c["t"].clone()).unwrap();
            Camera::from_opencv(m("K"), m("R"), t, size.0, size.1).unwrap()
        })
        .collect();
    let mut truth = random_pose(&random_pose_limits(&model.skeleton), 20f32.to_radians(), 3);
    truth.orientation.y += turn;
    let posed = model.skin(&truth).unwrap().iter().map(|p| *p + offset).collect();
    let posed = Mesh::with_topology(posed, model.mesh.topology().clone()).unwrap();
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let images = renderer.render(&posed, &cameras).unwrap().images().to_vec();
    let masks: Vec<PathBuf> = images
        .iter()
        .enumerate()
        .map(|(k, image)| {
            assert!(image.data().iter().filter(|v| **v > 0.5).count() > 40, "view {k} sees the figure");
            let path = dir.join(format!("mask{k}.png"));
            diffsil::io::save_png(image, &path).unwrap();
            path
        })
        .collect();
    let json = dir.join("cameras.json");
    std::fs::write(&json, serde_json::to_string_pretty(&specs).unwrap()).unwrap();
    (masks, json)
}

fn user_options(masks: &[PathBuf], cameras: &Path, extra: &[&str]) -> example::Options {
    let list = masks.iter().map(|p| p.to_str().unwrap()).collect::<Vec<_>>().join(",");
    let args = ["fit_pose", "--figure", "--targets", &list, "--cameras", cameras.to_str().unwrap()];
    example::Options::try_parse_from(args.iter().copied().chain(extra.iter().copied())).unwrap()
}

#[test]
fn fits_the_users_masks_and_cameras_and_saves_the_result() {
    let (masks, cameras) = write_user_data();
    let out = crate::common::files::temp_dir();
    let o = user_options(&masks, &cameras, &["--save", "--iterations", "60", "--out", out.to_str().unwrap()]);
    let (model, _) = example::load_model(&o).unwrap();
    let outcome = example::fit_user_data(&model, &o).unwrap();
    assert_eq!((outcome.before.len(), outcome.after.len()), (3, 3));
    let mean = |v: &[(f64, f64)]| (v.iter().map(|x| x.0).sum::<f64>() / 3.0, v.iter().map(|x| x.1).sum::<f64>() / 3.0);
    let ((iou0, e0), (iou1, e1)) = (mean(&outcome.before), mean(&outcome.after));
    assert!(iou1 > iou0 + 0.05 && iou1 > 0.75, "mean IoU {iou0:.3} -> {iou1:.3}");
    assert!(e1 < 0.6 * e0, "mean E_sl {e0:.3e} -> {e1:.3e}");
    assert!(outcome.energy.is_finite() && outcome.steps > 0);
    for k in 0..3 {
        assert!(out.join(format!("view{k}.png")).is_file());
    }
    let obj = diffsil::io::load_obj(out.join("fitted.obj")).unwrap();
    assert_eq!(obj.positions().len(), model.vertex_count());
    let glb = match diffsil::io::gltf::load_gltf(out.join("fitted.glb")).unwrap() {
        diffsil::io::gltf::Model::Static(mesh) => mesh,
        diffsil::io::gltf::Model::Skinned(skinned) => skinned.mesh,
    };
    assert_eq!(glb.positions().len(), model.vertex_count());
    let (pose, betas) = Pose::from_json(&std::fs::read_to_string(out.join("fitted_pose.json")).unwrap()).unwrap();
    assert!(betas.is_empty());
    // The saved pose is the fitted one: skinning it gives the saved meshes' vertices (the OBJ
    // reader may order them differently), and it is not the rest pose.
    let skinned = model.skin(&pose).unwrap();
    for mesh in [&obj, &glb] {
        for b in mesh.positions() {
            let nearest = skinned.iter().map(|a| (*a - *b).length()).fold(f32::MAX, f32::min);
            assert!(nearest < 1e-4, "{b} is {nearest} from the skinned pose");
        }
    }
    assert_ne!(pose, Pose::rest(model.joint_count()));
    // The command line runs the same path to the end.
    example::run(&o).unwrap();
}

/// Masks at a camera's resolution are fitted where the subject is about `--fit-height` pixels
/// tall (downsampled with their cameras), and reported at their own size.
#[test]
fn large_masks_are_fitted_downsampled_and_reported_at_their_own_size() {
    // The figure about 3/4 of 224 pixels tall: downsampled 2x (to 140 x 112) for 64 pixels.
    let (masks, cameras) = write_user_data_at((280, 224), Vec3::ZERO, 0.0);
    let out = crate::common::files::temp_dir();
    let o = user_options(&masks, &cameras, &["--iterations", "60", "--out", out.to_str().unwrap()]);
    assert_eq!(o.fit_height, diffsil::pose::fit::FIT_SUBJECT_HEIGHT);
    let (model, _) = example::load_model(&o).unwrap();
    let outcome = example::fit_user_data(&model, &o).unwrap();
    assert_eq!((outcome.factor, outcome.fit_size), (2, (140, 112)));
    // Downsampled, a mask's boundary error is a fraction of a pixel: the surface offset is
    // fitted, not the outline (`FitOptions::for_downsampled`), unless the options say otherwise.
    let (d, a) = outcome.nuisances;
    assert!(d != 0.0 && a == 0.0, "inflation {d}, outline {a}");
    let args = ["--iterations", "30", "--inflation", "false", "--outline", "true", "--out", out.to_str().unwrap()];
    let (d, a) = example::fit_user_data(&model, &user_options(&masks, &cameras, &args)).unwrap().nuisances;
    assert!(d == 0.0 && a != 0.0, "given: inflation {d}, outline {a}");
    let given = example::downsampled_nuisances(&user_options(&masks, &cameras, &["--outline", "true"]), 2);
    assert_eq!((given.inflation, given.outline), (Some(true), Some(true)));
    let kept = example::downsampled_nuisances(&o, 1);
    assert_eq!((kept.inflation, kept.outline), (Some(false), Some(true)));
    let mean = |v: &[(f64, f64)]| v.iter().map(|x| x.0).sum::<f64>() / 3.0;
    let (iou0, iou1) = (mean(&outcome.before), mean(&outcome.after));
    assert!(iou1 > iou0 + 0.05 && iou1 > 0.75, "mean IoU at 280 x 224 {iou0:.3} -> {iou1:.3}");
    // The pictures are the masks' own size: 3 x 2 images of 280 x 224, 4 pixels apart.
    let sheet = diffsil::io::load_png_target(out.join("view0.png"), diffsil::io::TargetMode::Coverage).unwrap();
    assert_eq!((sheet.width(), sheet.height()), (3 * 280 + 2 * 4, 2 * 224 + 4));
    // `--fit-height 0`: the masks' own resolution.
    let o = user_options(&masks, &cameras, &["--iterations", "3", "--fit-height", "0", "--out", out.to_str().unwrap()]);
    let outcome = example::fit_user_data(&model, &o).unwrap();
    assert_eq!((outcome.factor, outcome.fit_size), (1, (280, 224)));
    assert_eq!(outcome.nuisances.0, 0.0, "as they are, the outline and not the surface offset");
}

/// `masks` and `cameras` (as `write_user_data` writes them) placed at `offset` in larger empty
/// images of `size`, the cameras' principal points moved to match, in a fresh folder.
fn padded(masks: &[PathBuf], cameras: &Path, size: (u32, u32), offset: (u32, u32)) -> (Vec<PathBuf>, PathBuf) {
    let dir = crate::common::files::temp_dir();
    let mut specs: Vec<Value> = serde_json::from_str(&std::fs::read_to_string(cameras).unwrap()).unwrap();
    let paths = masks
        .iter()
        .zip(&mut specs)
        .enumerate()
        .map(|(k, (path, spec))| {
            let mask = diffsil::io::load_png_target(path, diffsil::io::TargetMode::Coverage).unwrap();
            let mut big = diffsil::Image::filled(size.0, size.1, 0.0);
            for i in 0..mask.height() {
                for j in 0..mask.width() {
                    big.data_mut()[((i + offset.1) * size.0 + j + offset.0) as usize] = mask.get(i, j);
                }
            }
            let path = dir.join(format!("mask{k}.png"));
            diffsil::io::save_png(&big, &path).unwrap();
            spec["K"][0][2] = json!(spec["K"][0][2].as_f64().unwrap() + offset.0 as f64);
            spec["K"][1][2] = json!(spec["K"][1][2].as_f64().unwrap() + offset.1 as f64);
            (spec["width"], spec["height"]) = (json!(size.0), json!(size.1));
            path
        })
        .collect();
    let json = dir.join("cameras.json");
    std::fs::write(&json, serde_json::to_string_pretty(&specs).unwrap()).unwrap();
    (paths, json)
}

/// Masks where the subject is small (the test's 40 x 32 masks placed in 160 x 128 empty ones)
/// are fitted in windows about it (`subject_windows`), where the figure fills its frame as in the
/// masks it came from, and end about as close to the truth; `--no-crop` fits the whole masks.
#[test]
fn a_small_subject_is_fitted_in_windows_about_it() {
    let (masks, cameras) = write_user_data();
    let (big, big_cameras) = padded(&masks, &cameras, (160, 128), (70, 41));
    let out = crate::common::files::temp_dir();
    let model = builtin_figure();
    let fit = |masks: &[PathBuf], cameras: &Path, iterations: &str, extra: &[&str]| {
        let args = [&["--iterations", iterations, "--facing", "0", "--out", out.to_str().unwrap()], extra].concat();
        example::fit_user_data(&model, &user_options(masks, cameras, &args)).unwrap()
    };
    let (framed, small) = (fit(&masks, &cameras, "60", &[]), fit(&big, &big_cameras, "60", &[]));
    assert!(!framed.cropped && framed.fit_size == SIZE, "the test's masks are fitted as they are");
    assert!(small.cropped, "a window about the subject");
    let side = small.fit_size.0;
    assert!(small.fit_size == (side, side) && side < 64 && 4 * side <= 3 * 128, "window {:?}", small.fit_size);
    let mean = |v: &[(f64, f64)]| v.iter().map(|x| x.0).sum::<f64>() / 3.0;
    let (framed_iou, small_iou) = (mean(&framed.after), mean(&small.after));
    assert!(small_iou > framed_iou - 0.03, "mean IoU {small_iou:.3} in windows, {framed_iou:.3} framed");
    let whole = fit(&big, &big_cameras, "3", &["--no-crop"]);
    assert!(!whole.cropped && whole.fit_size == (160, 128));
}

/// Calibrated cameras put the world's origin anywhere: the figure standing far from where it
/// was built (out of every view there) is fitted from the point where the masks' centres meet,
/// and missed from its rest position (`--no-placement`).
#[test]
fn the_fit_starts_where_the_masks_place_the_body() {
    let (masks, cameras) = write_user_data_at(SIZE, Vec3::new(4.0, 0.0, -3.0), 0.0);
    let out = crate::common::files::temp_dir();
    let fit = |extra: &[&str]| {
        let args = [&["--iterations", "60", "--out", out.to_str().unwrap()], extra].concat();
        let o = user_options(&masks, &cameras, &args);
        let (model, _) = example::load_model(&o).unwrap();
        let outcome = example::fit_user_data(&model, &o).unwrap();
        let mean = |v: &[(f64, f64)]| v.iter().map(|x| x.0).sum::<f64>() / 3.0;
        (mean(&outcome.before), mean(&outcome.after), outcome.height_ratio)
    };
    let (placed0, placed1, ratio) = fit(&[]);
    // The figure's own masks: the subject as tall as the model, or a little less (posed).
    assert!(ratio.is_some_and(|r| (0.5..=1.5).contains(&r)), "{ratio:?}");
    assert!(placed0 > 0.2 && placed1 > 0.75, "placed: mean IoU {placed0:.3} -> {placed1:.3}");
    let (rest0, rest1, ratio) = fit(&["--no-placement"]);
    assert!(rest0 == 0.0 && rest1 < 0.5, "from the rest position: mean IoU {rest0:.3} -> {rest1:.3}");
    assert_eq!(ratio, None);
    // Cameras in millimetres for a model in metres: the subject looks a thousand times too tall.
    let mut specs: Vec<Value> = serde_json::from_str(&std::fs::read_to_string(&cameras).unwrap()).unwrap();
    for spec in &mut specs {
        let t: Vec<f64> = serde_json::from_value(spec["t"].clone()).unwrap();
        spec["t"] = json!(t.iter().map(|x| x * 1000.0).collect::<Vec<_>>());
        spec["far"] = json!(1e6);
    }
    let millimetres = cameras.with_file_name("millimetres.json");
    std::fs::write(&millimetres, serde_json::to_string(&specs).unwrap()).unwrap();
    let o = user_options(&masks, &millimetres, &["--iterations", "3", "--out", out.to_str().unwrap()]);
    let (model, _) = example::load_model(&o).unwrap();
    let ratio = example::fit_user_data(&model, &o).unwrap().height_ratio.unwrap();
    assert!(ratio > 500.0, "{ratio}");
}

/// A figure facing away from the model's front: fitted facing the other way from the model's
/// facing (`--facing 0`), and found with `--facing 180` and with `--facing auto` (the default).
#[test]
fn facing_turns_the_start_or_is_found() {
    let (masks, cameras) = write_user_data_at(SIZE, Vec3::ZERO, std::f32::consts::PI);
    let model = builtin_figure();
    let mut truth = random_pose(&random_pose_limits(&model.skeleton), 20f32.to_radians(), 3);
    truth.orientation.y += std::f32::consts::PI;
    let truth = model.skin(&truth).unwrap();
    let error = |extra: &[&str]| {
        let out = crate::common::files::temp_dir();
        let args = [&["--iterations", "120", "--save", "--out", out.to_str().unwrap()], extra].concat();
        example::fit_user_data(&model, &user_options(&masks, &cameras, &args)).unwrap();
        let (pose, _) = Pose::from_json(&std::fs::read_to_string(out.join("fitted_pose.json")).unwrap()).unwrap();
        diffsil::pose::fit::per_vertex_error(&model.skin(&pose).unwrap(), &truth)
    };
    let (facing, front, auto) = (error(&["--facing", "180"]), error(&["--facing", "0"]), error(&[]));
    assert!(facing < 0.3 * front, "per-vertex error {facing:.4} turned, {front:.4} from the front");
    assert!(auto < 0.3 * front, "per-vertex error {auto:.4} from any facing, {front:.4} from the front");
}

/// Cameras calibrated in a world whose up is not +y: +z (a target that lay on the floor) and
/// −y (upside down). The figure, upright along +y in its own frame, is stood along the cameras'
/// up by `--up auto` (the default) and fitted; kept along +y (`--up +y`) upside down, it misses.
#[test]
fn the_world_up_is_read_from_the_cameras() {
    let (masks, cameras) = write_user_data_at(SIZE, Vec3::ZERO, 0.0);
    let model = builtin_figure();
    let truth = model.skin(&random_pose(&random_pose_limits(&model.skeleton), 20f32.to_radians(), 3)).unwrap();
    // The fit's per-vertex error with the same masks seen in the world X' = Q X, against the
    // truth there.
    let error = |q: glam::Mat3, extra: &[&str]| {
        let specs = user_data::load_cameras(&cameras).unwrap();
        let specs: Vec<Camera> = specs.iter().map(|c| c.in_world(q, Vec3::ZERO)).collect();
        let turned = cameras.with_file_name(format!("turned{}.json", extra.len()));
        std::fs::write(&turned, user_data::cameras_json(&specs).unwrap()).unwrap();
        let out = crate::common::files::temp_dir();
        // The facing given: the built-in figure at this size is not told front from back.
        let args =
            [&["--iterations", "120", "--facing", "0", "--save", "--out", out.to_str().unwrap()], extra].concat();
        example::fit_user_data(&model, &user_options(&masks, &turned, &args)).unwrap();
        let (pose, _) = Pose::from_json(&std::fs::read_to_string(out.join("fitted_pose.json")).unwrap()).unwrap();
        let truth: Vec<Vec3> = truth.iter().map(|p| q * *p).collect();
        diffsil::pose::fit::per_vertex_error(&model.skin(&pose).unwrap(), &truth)
    };
    let z_up = glam::Mat3::from_cols(Vec3::X, Vec3::Z, Vec3::NEG_Y);
    assert_eq!(z_up * Vec3::Y, Vec3::Z);
    let z = error(z_up, &[]);
    assert!(z < 0.015, "per-vertex error {z:.4} stood along +z");
    let upside_down = glam::Mat3::from_diagonal(Vec3::new(1.0, -1.0, -1.0));
    let (auto, kept) = (error(upside_down, &[]), error(upside_down, &["--up", "+y"]));
    assert!(auto < 0.3 * kept, "per-vertex error {auto:.4} stood along -y, {kept:.4} along +y");
    let o = example::Options::try_parse_from(["fit_pose", "--targets", "a.png", "--cameras", "c.json", "--up", "+w"]);
    assert!(o.unwrap_err().to_string().contains("use auto, +x"));
}

/// `--export` writes the example's own targets, their cameras and the ground truth, also in a
/// world turned and moved as a calibration's may be (`--world-up`, `--world-offset`); the
/// cameras render the truth to the masks again, and fitted back with `--targets`, `--cameras`
/// and `--truth` they report the fit's per-vertex error.
#[test]
fn exported_targets_fit_back_with_their_truth() {
    let model = builtin_figure();
    let args = ["fit_pose", "--figure", "--resolution", "40", "--views", "irregular", "--seed", "5", "--turn", "30"];
    let export = |world: &[&str]| {
        let dir = crate::common::files::temp_dir();
        let all = [&args[..], world, &["--export", dir.to_str().unwrap()]].concat();
        example::run(&example::Options::try_parse_from(all).unwrap()).unwrap();
        let masks: Vec<PathBuf> = (0..4).map(|k| dir.join(format!("mask{k}.png"))).collect();
        let cameras = user_data::load_cameras(&dir.join("cameras.json")).unwrap();
        let targets = user_data::load_targets(&masks, &cameras, None).unwrap();
        let (truth, shape) = Pose::from_json(&std::fs::read_to_string(dir.join("truth.json")).unwrap()).unwrap();
        let posed = model.skin_shaped(&truth, &shape).unwrap();
        let mesh = Mesh::with_topology(posed.clone(), model.mesh.topology().clone()).unwrap();
        let rendered = Renderer::new(RenderSettings::default()).unwrap().render(&mesh, &cameras).unwrap();
        for (render, target) in rendered.images().iter().zip(&targets) {
            let worst = render.data().iter().zip(target.data()).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
            assert!(worst < 0.003, "{world:?}: the cameras render the truth {worst} off its masks (8-bit PNG)");
        }
        (dir, masks, posed)
    };
    let (dir, masks, posed) = export(&[]);
    let mut seed_truth = random_pose(&random_pose_limits(&model.skeleton), 30f32.to_radians(), 5);
    seed_truth = diffsil::pose::fit::turned_about_vertical(&model, &seed_truth, 30f32.to_radians()).unwrap();
    let seed_posed = model.skin(&seed_truth).unwrap();
    assert!(posed.iter().zip(&seed_posed).all(|(a, b)| (*a - *b).length() < 1e-5), "the truth is the seed's, turned");
    // In a world whose up is +z and whose origin is elsewhere: the same body there.
    let (_, _, moved) = export(&["--world-up", "+z", "--world-offset", "2,0.5,-1"]);
    let q = glam::Mat3::from_cols(Vec3::X, Vec3::Z, Vec3::NEG_Y);
    let offset = Vec3::new(2.0, 0.5, -1.0);
    assert!(moved.iter().zip(&posed).all(|(a, b)| (*a - (q * *b + offset)).length() < 1e-4));

    let cameras_path = dir.join("cameras.json");
    let out = crate::common::files::temp_dir();
    let truth_path = dir.join("truth.json");
    let extra =
        ["--truth", truth_path.to_str().unwrap(), "--iterations", "60", "--save", "--out", out.to_str().unwrap()];
    let outcome = example::fit_user_data(&model, &user_options(&masks, &cameras_path, &extra)).unwrap();
    let (fitted, _) = Pose::from_json(&std::fs::read_to_string(out.join("fitted_pose.json")).unwrap()).unwrap();
    let error = diffsil::pose::fit::per_vertex_error(&model.skin(&fitted).unwrap(), &posed);
    assert_eq!(outcome.error_m, Some(error));
    // A truth that is not a pose, and the options that do not go together.
    std::fs::write(&truth_path, "{}").unwrap();
    let Err(e) = example::fit_user_data(&model, &user_options(&masks, &cameras_path, &extra)) else {
        panic!("a truth that is not a pose was read")
    };
    let e = e.to_string();
    assert!(e.starts_with("--truth") && e.contains("truth.json"), "{e}");
    for other in [&["--targets", "a.png"][..], &["--seeds", "1-3"], &["--motion", "0"], &["--ablation", "2"]] {
        let args = [&["fit_pose", "--export", "d"][..], other].concat();
        assert!(example::Options::try_parse_from(args).is_err(), "--export with {other:?}");
    }
    assert!(example::Options::try_parse_from(["fit_pose", "--truth", "t.json"]).is_err());
    assert!(example::Options::try_parse_from(["fit_pose", "--world-up", "+z"]).is_err(), "only with --export");
    for bad in [["--world-up", "+w"], ["--world-offset", "1,2"]] {
        assert!(example::Options::try_parse_from([&["fit_pose", "--export", "d"][..], &bad[..]].concat()).is_err());
    }
}

/// `--as-user-data` fits the example's own targets as `--targets` fits the user's: from the
/// masks and cameras alone. Hardened by `--threshold` (as `--export` then writes them: 0 and
/// 255 only), seen from a non-square irregular rig in a world turned and moved
/// (`--world-up`, `--world-offset`) where the model's rest pose is out of every view: placed
/// and stood along the cameras' up it fits, from the rest position (`--no-placement`) it
/// does not.
#[test]
fn as_user_data_fits_the_own_targets_from_the_masks_and_cameras_alone() {
    let args = [
        "fit_pose",
        "--figure",
        "--resolution",
        "48x40",
        "--views",
        "irregular",
        "--seed",
        "5",
        "--turn",
        "30",
        "--threshold",
        "0.5",
        "--world-up",
        "+z",
        "--world-offset",
        "2,0.5,-1",
    ];
    let dir = crate::common::files::temp_dir();
    example::run(
        &example::Options::try_parse_from([&args[..], &["--export", dir.to_str().unwrap()]].concat()).unwrap(),
    )
    .unwrap();
    for k in 0..4 {
        let mask =
            diffsil::io::load_png_target(dir.join(format!("mask{k}.png")), diffsil::io::TargetMode::Coverage).unwrap();
        assert_eq!((mask.width(), mask.height()), (48, 40));
        assert!(mask.data().iter().all(|v| *v == 0.0 || *v == 1.0), "mask {k} is not hard");
        assert!(mask.data().iter().filter(|v| **v == 1.0).count() > 40, "mask {k} sees the figure");
    }
    let model = builtin_figure();
    // The facing given: the built-in figure at this size and in 60 steps is not told front from
    // back (`facing_turns_the_start_or_is_found` finds it at 120 steps).
    let outcome = |extra: &[&str]| {
        let all = [&args[..], &["--as-user-data", "--iterations", "60", "--facing", "0"], extra].concat();
        example::fit_seed(&model, &example::Options::try_parse_from(all).unwrap(), false, true).unwrap()
    };
    let placed_fit = outcome(&[]);
    let (placed, unplaced) = (placed_fit.error_m, outcome(&["--no-placement"]).error_m);
    assert!(placed < 0.03 && placed < 0.2 * unplaced, "per-vertex error {placed:.4} placed, {unplaced:.4} unplaced");
    // The same fit as the exported files give `--targets` (hard masks and f32 cameras survive
    // PNG and JSON unchanged): the same error, to the bit.
    let masks: Vec<PathBuf> = (0..4).map(|k| dir.join(format!("mask{k}.png"))).collect();
    let truth = dir.join("truth.json");
    let out = crate::common::files::temp_dir();
    let extra = ["--threshold", "0.5", "--iterations", "60", "--facing", "0", "--truth", truth.to_str().unwrap()];
    let o = user_options(&masks, &dir.join("cameras.json"), &[&extra[..], &["--out", out.to_str().unwrap()]].concat());
    let from_files = example::fit_user_data(&model, &o).unwrap();
    assert_eq!(from_files.error_m, Some(placed), "--as-user-data and the exported files fit alike");
    // The final line's IoU is the mean of the report's per view.
    let mean_after = from_files.after.iter().map(|a| a.0).sum::<f64>() / 4.0;
    assert_eq!(placed_fit.mean_iou, mean_after);
    assert!(mean_after > 0.8, "mean IoU {mean_after}");
    // What goes with it and what does not.
    let parse =
        |extra: &[&str]| example::Options::try_parse_from([&["fit_pose", "--as-user-data"][..], extra].concat());
    assert!(parse(&["--world-up", "0,0.766,0.643"]).is_ok());
    assert!(parse(&["--world-up", "0,0,0"]).unwrap_err().to_string().contains("other than 0,0,0"));
    assert!(parse(&["--export", "d"]).is_err());
    assert!(parse(&["--targets", "a.png", "--cameras", "c.json"]).is_err());
    assert!(example::Options::try_parse_from(["fit_pose", "--no-placement"]).is_err(), "only with masks alone");
}

#[test]
fn bad_user_data_are_clear_errors() {
    let (masks, cameras) = write_user_data();
    let error = |o: &example::Options| example::run(o).unwrap_err().to_string();

    let e = error(&user_options(&masks[..2], &cameras, &[]));
    assert!(e.contains("2 masks for 3 cameras"), "{e}");

    let mut specs: Vec<Value> = serde_json::from_str(&std::fs::read_to_string(&cameras).unwrap()).unwrap();
    specs[1]["width"] = json!(SIZE.0 + 1);
    let wrong_size = cameras.with_file_name("wrong_size.json");
    std::fs::write(&wrong_size, serde_json::to_string(&specs).unwrap()).unwrap();
    let e = error(&user_options(&masks, &wrong_size, &[]));
    assert!(e.contains("mask1.png") && e.contains("40×32") && e.contains("camera 1 renders 41×32"), "{e}");

    let malformed = cameras.with_file_name("malformed.json");
    std::fs::write(&malformed, "[{\"width\": 40,").unwrap();
    let e = error(&user_options(&masks, &malformed, &[]));
    assert!(e.contains("malformed.json") && e.contains("not valid JSON"), "{e}");

    for (key, value, says) in [
        ("K", json!([[10.0, 1.0, 20.0], [0.0, 10.0, 16.0], [0.0, 0.0, 1.0]]), "no skew"),
        ("R", json!([[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "orthonormal"),
        ("R", json!([[1.0, 0.0], [0.0, 1.0]]), "\"R\" must be 3 rows of 3 numbers"),
        ("t", json!([0.0, "x", 1.0]), "\"t\" must be 3 numbers"),
        ("distCoeffs", json!([0.1, -0.02, 0.0, 0.0, 0.0]), "undistort the masks first"),
        ("dist", json!("none"), "undistort the masks first"),
    ] {
        let mut bad = specs.clone();
        bad[1]["width"] = json!(SIZE.0);
        bad[2][key] = value;
        let path = cameras.with_file_name("bad.json");
        std::fs::write(&path, serde_json::to_string(&bad).unwrap()).unwrap();
        let e = error(&user_options(&masks, &path, &[]));
        assert!(e.contains("bad.json: camera 2:") && e.contains(says), "{key}: {e}");
    }

    // Masks with no subject in any view (black, or nothing left at the threshold).
    let black: Vec<PathBuf> = (0..3).map(|k| cameras.with_file_name(format!("black{k}.png"))).collect();
    for path in &black {
        diffsil::io::save_png(&diffsil::Image::filled(SIZE.0, SIZE.1, 0.0), path).unwrap();
    }
    let e = error(&user_options(&black, &cameras, &[]));
    assert!(e.contains("every mask is empty: no view shows the subject"), "{e}");
    let e = error(&user_options(&masks, &cameras, &["--threshold", "1"]));
    assert!(e.contains("every mask is empty once hardened at --threshold 1"), "{e}");
    let white: Vec<PathBuf> = (0..3).map(|k| cameras.with_file_name(format!("white{k}.png"))).collect();
    for path in &white {
        diffsil::io::save_png(&diffsil::Image::filled(SIZE.0, SIZE.1, 1.0), path).unwrap();
    }
    let e = error(&user_options(&white, &cameras, &[]));
    assert!(e.contains("every mask is covered everywhere: no view shows an outline"), "{e}");
    // One view covered everywhere (a close-up) is not refused on its own.
    let one_white = [white[0].clone(), masks[1].clone(), masks[2].clone()];
    assert!(user_data::load_targets(&one_white, &user_data::load_cameras(&cameras).unwrap(), None).is_ok());

    // Zero distortion coefficients are no distortion.
    let mut undistorted = specs.clone();
    undistorted[1]["width"] = json!(SIZE.0);
    undistorted[0]["dist"] = json!([0.0, 0.0, 0.0, 0.0, 0.0]);
    let path = cameras.with_file_name("undistorted.json");
    std::fs::write(&path, serde_json::to_string(&undistorted).unwrap()).unwrap();
    assert_eq!(user_data::load_cameras(&path).unwrap(), user_data::load_cameras(&cameras).unwrap());

    // The two options come together.
    let e = example::Options::try_parse_from(["fit_pose", "--targets", "a.png"]).unwrap_err().to_string();
    assert!(e.contains("--cameras"), "{e}");
    let e = example::Options::try_parse_from(["fit_pose", "--cameras", "c.json"]).unwrap_err().to_string();
    assert!(e.contains("--targets"), "{e}");
    // One frame of a motion needs the motion.
    let e = example::Options::try_parse_from(["fit_pose", "--frame", "3"]).unwrap_err().to_string();
    assert!(e.contains("--motion"), "{e}");
}

#[test]
fn masks_load_as_coverage_or_thresholded() {
    let (masks, cameras) = write_user_data();
    let cameras = user_data::load_cameras(&cameras).unwrap();
    assert_eq!(cameras.len(), 3);
    assert!(cameras.iter().all(|c| (c.width, c.height, c.far) == (SIZE.0, SIZE.1, 100.0) && c.near == 0.01));
    let soft = user_data::load_targets(&masks, &cameras, None).unwrap();
    let hard = user_data::load_targets(&masks, &cameras, Some(0.5)).unwrap();
    let edge = |image: &diffsil::Image| image.data().iter().filter(|v| **v > 0.0 && **v < 1.0).count();
    assert!(edge(&soft[0]) > 10, "anti-aliased edges are kept as coverage");
    assert_eq!(edge(&hard[0]), 0, "thresholded: 0 or 1 only");
    for (s, h) in soft[0].data().iter().zip(hard[0].data()) {
        assert_eq!(*h, if *s > 0.5 { 1.0 } else { 0.0 });
    }
    // The figure's masks are not taken for inverted ones, their inversions are; a subject cut
    // off by the bottom edge is not either.
    assert!(hard.iter().all(|m| !user_data::looks_inverted(m)));
    let inverted = diffsil::Image::from_vec(SIZE.0, SIZE.1, hard[0].data().iter().map(|v| 1.0 - v).collect()).unwrap();
    assert!(user_data::looks_inverted(&inverted));
    let mut cropped = diffsil::Image::filled(SIZE.0, SIZE.1, 0.0);
    for i in SIZE.1 / 2..SIZE.1 {
        for j in 10..30 {
            cropped.data_mut()[(i * SIZE.0 + j) as usize] = 1.0;
        }
    }
    assert!(!user_data::looks_inverted(&cropped));
    let (iou, energy) = user_data::agreement(&soft[0], &soft[0]);
    assert_eq!((iou, energy), (1.0, 0.0));
    let (iou, energy) = user_data::agreement(&hard[0], &diffsil::Image::filled(SIZE.0, SIZE.1, 0.0));
    assert_eq!(iou, 0.0);
    let ones = hard[0].data().iter().filter(|v| **v == 1.0).count() as f64;
    assert!((energy - ones / f64::from(SIZE.0 * SIZE.1)).abs() < 1e-12);
}
