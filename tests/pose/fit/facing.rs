//! Facings (`FitOptions::facings`, `turned_about_vertical`): a turn about the vertical keeps the
//! body's centre and moves it rigidly; the plan tries each facing's starting poses; a body facing
//! away from the model's front is fitted the right way round with `FitOptions::ANY_FACING` and
//! back to front without it; the runner-up facing's pass (`FitOptions::facing_within`).

use std::f32::consts::PI;

use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{fit, per_vertex_error, random_pose, turned_about_vertical, FitOptions};
use diffsil::pose::skin::Pose;
use diffsil::scene::mesh::bounding_box;
use diffsil::{Error, Vec3};
use glam::Quat;

use super::call::{go_on, renderer};

/// The centre of the bounding box of `points` (also used by `start.rs`).
pub(super) fn centre(points: &[Vec3]) -> Vec3 {
    let (lo, hi) = bounding_box(points).expect("points");
    (lo + hi) * 0.5
}

#[test]
fn a_turn_about_the_vertical_keeps_the_centre_and_moves_the_body_rigidly() {
    let model = builtin_figure();
    let mut pose = random_pose(&random_pose_limits(&model.skeleton), 30f32.to_radians(), 5);
    pose.translation = Vec3::new(0.3, -0.1, 1.2);
    let before = model.skin(&pose).unwrap();
    for angle in [0.7, PI / 2.0, PI, -2.0] {
        let turned = turned_about_vertical(&model, &pose, angle).unwrap();
        assert_eq!(turned.joint_rotations, pose.joint_rotations, "the joints are kept");
        let after = model.skin(&turned).unwrap();
        assert!((centre(&after) - centre(&before)).length() < 1e-5, "angle {angle}: the centre moved");
        // Every vertex is the turn of its old position plus one common offset.
        let turn = Quat::from_rotation_y(angle);
        let offset = after[0] - turn * before[0];
        for (a, b) in after.iter().zip(&before) {
            assert!((*a - turn * *b - offset).length() < 1e-5, "angle {angle}: not a turn about +y");
        }
    }
    assert_eq!(turned_about_vertical(&model, &pose, 0.0).unwrap(), pose);
    assert!(matches!(turned_about_vertical(&model, &pose, f32::NAN), Err(Error::InvalidSettings(_))));
    let short = Pose::rest(model.joint_count() - 1);
    assert!(turned_about_vertical(&model, &short, 1.0).is_err(), "a pose with a joint too few");
}

#[test]
fn a_lying_pose_turns_about_its_own_up() {
    let model = builtin_figure();
    // Stood along +z: its up is +z, and a turn about it keeps the up.
    let lying = Pose {
        orientation: Quat::from_rotation_arc(Vec3::Y, Vec3::Z).to_scaled_axis(),
        ..Pose::rest(model.joint_count())
    };
    let before = model.skin(&lying).unwrap();
    let turned = turned_about_vertical(&model, &lying, PI / 2.0).unwrap();
    let up = Quat::from_scaled_axis(turned.orientation) * Vec3::Y;
    assert!((up - Vec3::Z).length() < 1e-5, "{up}");
    let after = model.skin(&turned).unwrap();
    let turn = Quat::from_rotation_z(PI / 2.0);
    let offset = after[0] - turn * before[0];
    for (a, b) in after.iter().zip(&before) {
        assert!((*a - turn * *b - offset).length() < 1e-5, "not a turn about +z");
    }
}

#[test]
fn the_plan_tries_every_facing_with_every_starting_pose() {
    let model = builtin_figure();
    let one = FitOptions::default();
    let (schedule, starts) = one.plan(&model).unwrap();
    let facings = vec![0.0, PI];
    let two = FitOptions { facings: facings.clone(), ..FitOptions::default() };
    let (schedule2, starts2) = two.plan(&model).unwrap();
    assert_eq!(schedule2, schedule, "each facing's starting poses take the steps they take alone");
    assert_eq!(starts2.len(), 2 * starts.len());
    assert_eq!(starts2[..starts.len()], starts[..], "facing 0 is the initial pose's");
    let turned = turned_about_vertical(&model, &starts[0], PI).unwrap();
    for (a, b) in starts2[starts.len()..].iter().zip(&starts) {
        assert_eq!(a.joint_rotations, b.joint_rotations);
        assert_eq!((a.orientation, a.translation), (turned.orientation, turned.translation));
    }

    let bad = FitOptions { facings: vec![0.0, f32::INFINITY], ..FitOptions::default() };
    let e = bad.validate().unwrap_err().to_string();
    assert!(e.contains("facing"), "{e}");
    let unblurred = FitOptions { facings, coarse_blur: 0.0, ..FitOptions::default() };
    let e = unblurred.plan(&model).unwrap_err().to_string();
    assert!(e.contains("hypothesis phase"), "{e}");
}

#[test]
fn a_body_facing_away_is_fitted_the_right_way_round_from_any_facing() {
    let model = builtin_figure();
    let mut truth = random_pose(&random_pose_limits(&model.skeleton), 20f32.to_radians(), 3);
    truth.orientation.y += PI;
    let (model, cameras, targets) = super::call::views_of(&truth, 64);
    let truth_vertices = model.skin(&truth).unwrap();
    let run = |facings: Vec<f32>| {
        let options = FitOptions { steps: 300, facings, ..FitOptions::default() };
        let fitted = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &options, go_on).unwrap();
        (fitted.facing, per_vertex_error(&fitted.fit.vertices().unwrap(), &truth_vertices))
    };
    let (facing, error) = run(FitOptions::ANY_FACING.to_vec());
    let (front, front_error) = run(Vec::new());
    assert_eq!((facing, front), (PI, 0.0), "the facing kept");
    assert!(error < 0.3 * front_error, "per-vertex error {error:.4} from any facing, {front_error:.4} from the front");
}

/// `FitOptions::facing_within`: the runner-up facing's pass runs where its energy after the
/// first steps is within the bound (here any), its steps follow the first pass's, and the
/// lower end is kept. The built-in figure facing the model's front, 120 steps: at 32² the
/// phase takes its back for its front (so it does at 48², and turned away it takes the front
/// for the back), and the pass from the runner-up, kept, fits it the right way round; at 40²
/// the phase tells them apart, the runner-up's pass ends higher and the fit is left exactly
/// where the first pass ended (the same vertices as with the bound at 0, where it never runs).
#[test]
fn the_runner_up_facing_runs_its_own_pass_and_the_lower_end_is_kept() {
    let model = builtin_figure();
    let truth = random_pose(&random_pose_limits(&model.skeleton), 20f32.to_radians(), 3);
    let truth_vertices = model.skin(&truth).unwrap();
    for (resolution, mistaken) in [(32, true), (40, false)] {
        let (model, cameras, targets) = super::call::views_of(&truth, resolution);
        let run = |facing_within: f64| {
            let options = FitOptions {
                steps: 120,
                facings: vec![0.0, PI],
                facing_within,
                restart_arm_swing: 0.0,
                thinned_restarts: Vec::new(),
                thinned_final_run: false,
                polish_steps: 0,
                ..FitOptions::default()
            };
            let (mut calls, mut last) = (0u32, 0u32);
            let fitted = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &options, |_, progress| {
                calls += 1;
                last = progress.step;
                std::ops::ControlFlow::Continue(())
            })
            .unwrap();
            (fitted, calls, last)
        };
        let (alone, _, _) = run(0.0);
        assert!(alone.facing_run.is_none(), "{resolution}²: a bound of 0 never runs the runner-up");
        assert_eq!(alone.facing, if mistaken { PI } else { 0.0 }, "{resolution}²: the phase's facing");
        let (mut fitted, calls, last) = run(1e9);
        let runner = fitted.facing_run.clone().expect("the runner-up's pass ran");
        assert_eq!(runner.facing, PI - alone.facing, "{resolution}²: the other facing");
        assert!(runner.ratio >= 1.0, "{resolution}²: {}", runner.ratio);
        assert_eq!((calls, last), (fitted.steps(), fitted.steps()), "{resolution}²: every step reported, in order");
        assert!(fitted.steps() > alone.steps());
        let (first, end) = (runner.first_energy, runner.energy.unwrap());
        assert_eq!(runner.kept, mistaken, "{resolution}²: {first:.3e} the first pass, {end:.3e} the runner-up's");
        assert_eq!(fitted.facing, 0.0, "{resolution}²: the facing kept");
        let error = |f: &diffsil::pose::fit::PoseFit| per_vertex_error(&f.vertices().unwrap(), &truth_vertices);
        if mistaken {
            assert_eq!(fitted.fit.energy().unwrap(), end);
            let (kept, first_pass) = (error(&fitted.fit), error(&alone.fit));
            assert!(kept < 0.1 * first_pass, "per-vertex error {kept:.4} kept, {first_pass:.4} the first pass's");
        } else {
            assert_eq!(fitted.fit.vertices().unwrap(), alone.fit.vertices().unwrap(), "put back where it ended");
        }
    }
    for bad in [f64::NAN, -1.0, f64::INFINITY] {
        let options = FitOptions { facing_within: bad, ..FitOptions::default() };
        assert!(matches!(options.validate(), Err(Error::InvalidSettings(_))), "{bad}");
    }
}

/// A cancel in a run from the runner-up pass's crossed legs leaves that pass at the lowest of its
/// other runs (as every pass ends), so its end is still compared with the first pass's
/// (`PassReport::ended`) and the fit ends at the lower of the two.
#[test]
fn a_runner_up_pass_cancelled_in_its_crossed_legs_keeps_its_end() {
    let model = builtin_figure();
    let truth = random_pose(&random_pose_limits(&model.skeleton), 20f32.to_radians(), 3);
    let (model, cameras, targets) = super::call::views_of(&truth, 32);
    let options = FitOptions {
        steps: 120,
        facings: vec![0.0, PI],
        facing_within: 1e9,
        crossed_legs_within: 1e9,
        restart_arm_swing: 0.0,
        thinned_restarts: Vec::new(),
        thinned_final_run: false,
        polish_steps: 0,
        ..FitOptions::default()
    };
    let run = |cancel_at: u32| {
        fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &options, |_, progress| {
            if progress.step == cancel_at {
                std::ops::ControlFlow::Break(())
            } else {
                std::ops::ControlFlow::Continue(())
            }
        })
        .unwrap()
    };
    let whole = run(u32::MAX);
    let runner = whole.facing_run.as_ref().expect("the runner-up's pass ran");
    let crossed = runner.pass.crossed_legs.as_ref().expect("its crossed legs looked at");
    assert!(!crossed.runs.is_empty(), "runs from its crossed legs");
    // The second step of the runner-up pass's first run from its crossed legs.
    let cancel_at = whole.first.steps() + runner.pass.report.steps + 2;
    let mut cancelled = run(cancel_at);
    let runner = cancelled.facing_run.clone().expect("the runner-up's pass ran");
    assert!(runner.pass.cancelled() && runner.pass.ended(), "cancelled in its crossed legs, its own run ended");
    let end = runner.energy.expect("the pass's end has an energy");
    assert_eq!(
        runner.kept,
        end < runner.first_energy,
        "{end:.3e} against the first pass's {:.3e}",
        runner.first_energy
    );
    let lower = end.min(runner.first_energy);
    assert_eq!(cancelled.fit.energy().unwrap(), lower, "the fit ends at the lower of the two passes' ends");
    assert!(cancelled.restart.is_none() && cancelled.polish.is_none(), "nothing runs after a cancel");
}
