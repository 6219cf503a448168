//! `fit_pose` on its own targets: the imperfect masks (a dilation grows a silhouette by one
//! pixel, an erosion shrinks it by one, a flip changes the asked-for fraction of pixels and
//! nothing else), the default model and method, and the rigs (`--views`). The user-data path
//! (`--targets`, `--export`, `--as-user-data`) is in `fit_pose_user_data.rs`.

#[path = "../../examples/fit_pose/masks.rs"]
#[allow(dead_code)]
mod masks;

use diffsil::Image;
use masks::{apply, MaskNoise};

/// A 12×12 image with a 4×4 square of ones at rows and columns 4..8.
fn square() -> Image {
    let mut image = Image::filled(12, 12, 0.0);
    for i in 4..8 {
        for j in 4..8 {
            image.data_mut()[i * 12 + j] = 1.0;
        }
    }
    image
}

fn count(image: &Image) -> usize {
    image.data().iter().filter(|v| **v == 1.0).count()
}

#[test]
fn dilate_and_erode_move_the_outline_by_one_pixel() {
    let image = square();
    let fat = apply(MaskNoise::Dilate, &image, 0.0, 1);
    assert_eq!(count(&fat), 36, "a 6×6 square");
    assert_eq!((fat.get(3, 3), fat.get(8, 8), fat.get(2, 2)), (1.0, 1.0, 0.0));
    let thin = apply(MaskNoise::Erode, &image, 0.0, 1);
    assert_eq!(count(&thin), 4, "a 2×2 square");
    assert_eq!((thin.get(5, 5), thin.get(4, 4)), (1.0, 0.0));
    assert_eq!(apply(MaskNoise::None, &image, 0.5, 1), image);
}

#[test]
fn flip_changes_about_the_fraction_asked_for() {
    let image = Image::filled(100, 100, 0.0);
    let flipped = apply(MaskNoise::Flip, &image, 0.02, 7);
    let changed = count(&flipped);
    assert!((150..=250).contains(&changed), "{changed} of 10,000 pixels flipped");
    assert_eq!(flipped, apply(MaskNoise::Flip, &image, 0.02, 7), "same seed, same pixels");
    assert_ne!(flipped, apply(MaskNoise::Flip, &image, 0.02, 8));
}

#[allow(dead_code)]
#[path = "../../examples/fit_pose/main.rs"]
pub(crate) mod example;

use clap::Parser;
use diffsil::pose::figure::builtin_figure;

#[test]
fn the_default_model_is_the_makehuman_body_and_figure_picks_the_procedural_one() {
    let parse = |args: &[&str]| example::Options::try_parse_from(args.iter().copied());
    let (body, name) = example::load_model(&parse(&["fit_pose"]).unwrap()).unwrap();
    assert_eq!(
        (body.joint_count(), body.vertex_count(), body.shape_count(), name.as_str()),
        (31, 7000, 10, "makehuman-body-7k")
    );
    let (figure, name) = example::load_model(&parse(&["fit_pose", "--figure"]).unwrap()).unwrap();
    assert_eq!((figure.joint_count(), name.as_str()), (builtin_figure().joint_count(), "builtin-figure"));
    let e = parse(&["fit_pose", "--figure", "--model", "body.glb"]).unwrap_err().to_string();
    assert!(e.contains("--model"), "{e}");
}

// The cameras of the example's own targets (`--views`).

#[path = "../../examples/fit_pose/rig.rs"]
mod rig;

#[test]
fn the_rings_are_the_librarys_and_an_irregular_rig_is_drawn_from_the_seed_and_frames_the_model() {
    use diffsil::pose::fit::{framing_orbit, framing_ring, RAISED_ELEVATION_DEG};
    use rig::{cameras, Layout};
    let rest = builtin_figure().mesh;
    assert_eq!(cameras(Layout::Level, &rest, 4, (32, 32), 9), (framing_ring(&rest, 4, 32, 0.0), String::new()));
    let raised = framing_ring(&rest, 3, 32, RAISED_ELEVATION_DEG.to_radians());
    assert_eq!(cameras(Layout::Raised, &rest, 3, (32, 32), 9), (raised, String::new()));
    let (rig, description) = cameras(Layout::Irregular, &rest, 5, (32, 32), 9);
    assert_eq!(rig.len(), 5);
    assert_eq!(rig, cameras(Layout::Irregular, &rest, 5, (32, 32), 9).0, "the same seed, the same rig");
    assert_ne!(rig, cameras(Layout::Irregular, &rest, 5, (32, 32), 10).0);
    let lines: Vec<String> = description.lines().map(str::to_owned).collect();
    assert_eq!(lines.len(), 5, "{lines:?}");
    let ring = framing_orbit(&rest, 0.0);
    for (k, (camera, line)) in rig.iter().zip(&lines).enumerate() {
        // Seen from the ring's centre (the rig's aim is at most 5% of the distance off it): each
        // camera within 25° (and the aim's 3.3°) of its place on the ring, 0°–30° above it, no
        // nearer than the ring, and every vertex of the model in view.
        let d = camera.eye - ring.target;
        let place = std::f32::consts::TAU * k as f32 / 5.0;
        let offset = ((d.x.atan2(d.z) - place).to_degrees() + 540.0).rem_euclid(360.0) - 180.0;
        assert!(offset.abs() <= 28.3, "camera {k}: {offset}° off its place on the ring");
        let elevation = (d.y / d.length()).asin().to_degrees();
        assert!((-3.3..=33.3).contains(&elevation), "camera {k}: elevation {elevation}°");
        assert!(d.length() >= 0.95 * ring.distance, "camera {k}: {} against {}", d.length(), ring.distance);
        let view = camera.params();
        for &p in rest.positions() {
            let (screen, valid) = view.project(p);
            assert!(valid && screen.min_element() > 0.0 && screen.max_element() < 32.0, "camera {k}: {p} at {screen}");
        }
        assert!(line.starts_with(&format!("camera {k}: azimuth ")), "{line}");
    }
    // Another size (a camera's 3:2 and 2:3): the same rig, the image widened or narrowed about
    // the same centre (the body framed in the vertical field of view), in every layout.
    for layout in [Layout::Level, Layout::Raised, Layout::Irregular] {
        let square = cameras(layout, &rest, 5, (32, 32), 9).0;
        for (width, height) in [(48, 32), (32, 48)] {
            let sized = cameras(layout, &rest, 5, (width, height), 9).0;
            for (camera, square) in sized.iter().zip(&square) {
                assert_eq!((camera.width, camera.height), (width, height));
                assert_eq!((camera.eye, camera.target), (square.eye, square.target));
                let scale = height as f32 / 32.0;
                for &p in rest.positions().iter().step_by(7) {
                    let (a, b) = (square.params().project(p).0, camera.params().project(p).0);
                    let expected =
                        (a - glam::Vec2::splat(16.0)) * scale + glam::Vec2::new(width as f32, height as f32) / 2.0;
                    assert!((b - expected).length() < 1e-3, "{layout:?} {width}x{height}: {p} at {b}, not {expected}");
                }
            }
        }
    }
}

#[test]
fn plain_is_the_papers_descent_and_the_default_is_the_librarys_method() {
    use diffsil::pose::fit::FitOptions;
    let parse = |args: &[&str]| example::fit_options(&example::Options::try_parse_from(args.iter().copied()).unwrap());
    let plain = parse(&["fit_pose", "--plain"]);
    assert_eq!(
        (plain.coarse_blur, plain.pose_prior, plain.swap_steps, plain.crossed_legs_within, plain.restart_arm_swing),
        (0.0, 0.0, 0, 0.0, 0.0),
        "no blur, prior, swap test, crossed legs or restart"
    );
    assert!(plain.thinned_restarts.is_empty() && !plain.thinned_final_run, "no restarts for thinned targets either");
    assert_eq!(parse(&["fit_pose"]), FitOptions::default());
    assert_eq!(parse(&["fit_pose", "--restart-arm-swing", "0"]).restart_arm_swing, 0.0);
    assert!(parse(&["fit_pose", "--no-thinned-restarts"]).thinned_restarts.is_empty());
    let no_final = parse(&["fit_pose", "--no-thinned-final-run"]);
    assert_eq!(no_final, FitOptions { thinned_final_run: false, ..FitOptions::default() });
}

/// The final line's `mean_iou`: the fitted silhouettes' IoU with the targets, each view's at 0.5,
/// averaged; low where nothing was fitted, near 1 after a fit.
#[test]
fn a_fit_reports_how_its_silhouettes_match_the_targets() {
    let model = builtin_figure();
    let outcome = |iterations: &str| {
        let args = ["fit_pose", "--figure", "--resolution", "32", "--seed", "2", "--iterations", iterations];
        example::fit_seed(&model, &example::Options::try_parse_from(args).unwrap(), false, true).unwrap()
    };
    let (none, fitted) = (outcome("0"), outcome("150"));
    assert!(fitted.mean_iou > 0.85 && fitted.mean_iou <= 1.0, "after the fit: {}", fitted.mean_iou);
    assert!(none.mean_iou < fitted.mean_iou - 0.05, "unfitted {} against fitted {}", none.mean_iou, fitted.mean_iou);
}
