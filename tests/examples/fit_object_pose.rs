//! The `fit_object_pose` example on small inputs: bad command lines are clear errors, the cameras
//! are the calibrations the help describes, the start lies within the stated perturbation, and
//! short fits — object pose from 4 views, and camera extrinsics — end much closer to the truth
//! than they start.

#[allow(dead_code)]
#[path = "../../examples/fit_object_pose.rs"]
mod example;

use clap::error::ErrorKind;
use clap::{CommandFactory, Parser};
use diffsil::{RenderSettings, Renderer};
use example::*;

fn parse(args: &[&str]) -> Result<Options, clap::Error> {
    Options::try_parse_from(std::iter::once("fit_object_pose").chain(args.iter().copied()))
}

#[test]
fn bad_command_lines_are_errors_not_panics() {
    Options::command().debug_assert();
    assert_eq!(parse(&["-h"]).unwrap_err().kind(), ErrorKind::DisplayHelp);
    for (args, says) in [
        (&["--views", "5"][..], "invalid value '5' for '--views <N>'"),
        (&["--views", "0"], "invalid value '0' for '--views <N>'"),
        (&["--max-angle", "NaN"], "finite"),
        (&["--backend", "tpu"], "[possible values: cpu, gpu, auto]"),
        (&["--foo"], "unexpected argument '--foo'"),
    ] {
        let error = parse(args).unwrap_err().to_string();
        assert!(error.contains(says), "{args:?}: {error}");
    }
}

#[test]
fn cameras_and_starts_are_what_the_help_says() {
    let o = parse(&["--views", "3", "--resolution", "32"]).unwrap();
    let scene = Scene::new(&o).unwrap();
    assert_eq!(scene.cameras.len(), 3);
    for camera in &scene.cameras {
        let [fx, fy, cx, cy] = camera.intrinsics();
        assert!(camera.extrinsics.is_some() && fx != fy && cx != 16.0 && cy != 16.0);
        // The object's centre is in view.
        let (p, valid) = camera.params().project(diffsil::Vec3::ZERO);
        assert!(valid && p.x > 0.0 && p.x < 32.0 && p.y > 0.0 && p.y < 32.0, "{p}");
    }
    for seed in 0..20 {
        let (truth, start) = case(&o, &scene, seed);
        let angle = rotation_error_deg(start.rotation, truth.rotation);
        let offset = (start.translation - truth.translation).length() / scene.size;
        assert!(angle <= 30.0 + 1e-3 && offset <= 0.2 + 1e-6, "seed {seed}: {angle}° {offset}");
    }
    assert!(rotation_error_deg(diffsil::Vec3::new(0.0, 0.0, 0.3), diffsil::Vec3::ZERO) - 0.3f32.to_degrees() < 1e-3);
}

fn short_fit(args: &[&str]) -> Outcome {
    let o = parse(args).unwrap();
    let scene = Scene::new(&o).unwrap();
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let (outcome, pictures) = run_case(&mut renderer, &scene, &o, o.seed).unwrap();
    assert_eq!(pictures.len(), o.views as usize);
    let sheet = sheet(&pictures);
    assert_eq!((sheet.width(), sheet.height()), (4 * o.resolution + 6, o.views * o.resolution + 2 * (o.views - 1)));
    outcome
}

#[test]
fn a_short_object_fit_lands_near_the_truth() {
    let outcome = short_fit(&["--resolution", "48", "--iterations", "80", "--seed", "3"]);
    assert!(outcome.rotation_deg < 3.0 && outcome.translation < 0.02, "{outcome:?}");
}

#[test]
fn a_short_calibration_lands_near_the_truth() {
    let outcome = short_fit(&[
        "--calibrate",
        "--views",
        "2",
        "--resolution",
        "48",
        "--iterations",
        "80",
        "--max-angle",
        "10",
        "--max-offset",
        "0.1",
    ]);
    assert!(outcome.rotation_deg < 3.0 && outcome.translation < 0.05, "{outcome:?}");
}
