//! The pose prior's weight per stage: `PoseFit::run` weighs the prior by each stage's
//! `prior_scale` (the starting poses by the first stage's) and ends with `μ` itself;
//! `FitOptions` puts its `coarse_prior_scale` on the blurred stages; bad scales are errors.

use std::ops::ControlFlow;

use super::{assert_stage_rejected_before_any_step, fit_from_rest, planned};
use diffsil::pose::figure::builtin_figure;
use diffsil::pose::fit::{FitOptions, PoseFit, Schedule, Stage, StepReport};
use diffsil::pose::skin::Pose;
use diffsil::{Error, Vec3};

/// `E` of a step report with the pose prior weighted by `weight` (λ = 1e-7, no shape prior).
fn energy_with(report: &StepReport, weight: f32) -> f64 {
    report.silhouette + f64::from(1e-7f32) * report.self_intersection_surrogate + f64::from(weight) * report.pose_prior
}

/// A pose away from the rest pose, so that `E_prior > 0`.
fn bent(joints: usize) -> Pose {
    let mut pose = Pose::rest(joints);
    for (j, r) in pose.joint_rotations.iter_mut().enumerate() {
        *r = Vec3::new(0.2, -0.1, 0.05 * j as f32);
    }
    pose
}

#[test]
fn a_run_weighs_the_prior_by_each_stage_and_ends_with_mu() {
    let (mut fit, model, _) = fit_from_rest(24, 5);
    let mu = 2e-3;
    fit.set_pose_prior(mu).unwrap();
    let schedule = Schedule {
        hypothesis_steps: 2,
        stages: vec![Stage { prior_scale: 10.0, ..Stage::new(Schedule::COARSE_BLUR, 2) }, Stage::new(0.0, 3)],
        convergence: None,
    };
    let starts = [bent(model.joint_count()), Pose::rest(model.joint_count())];
    let mut seen = Vec::new();
    fit.run(&schedule, &starts, |_, progress| {
        seen.push(*progress);
        ControlFlow::Continue(())
    })
    .unwrap();
    assert_eq!(seen.len(), 2 * 2 + 2 + 3);
    for progress in &seen {
        let r = &progress.report;
        let weight = if progress.blur > 0.0 { 10.0 * mu } else { mu };
        assert!(r.pose_prior > 0.0 || progress.hypothesis == Some(1), "{progress:?}");
        let expected = energy_with(r, weight);
        assert!((r.energy - expected).abs() <= 1e-12 * expected.abs(), "{progress:?}: expected {expected}");
    }
    // The first hypothesis starts bent: its first step sees the tenfold prior.
    assert!(seen[0].report.pose_prior > 0.01);
    // After the run the prior is μ again, in the steps a caller takes and in what it reports.
    assert_eq!(fit.pose_prior(), mu);
    let after = fit.step().unwrap();
    assert!(after.pose_prior > 0.0);
    let expected = energy_with(&after, mu);
    assert!((after.energy - expected).abs() <= 1e-12 * expected.abs(), "{after:?}: expected {expected}");
}

#[test]
fn a_stage_with_a_bad_prior_scale_is_an_error_before_any_step() {
    for bad in [-1.0, f32::NAN, f32::INFINITY] {
        let (mut fit, _, _) = fit_from_rest(16, 5);
        let stage = Stage { prior_scale: bad, ..Stage::new(0.0, 1) };
        assert_stage_rejected_before_any_step(&mut fit, stage, &format!("prior scale {bad}"));
    }
}

#[test]
fn the_options_put_the_coarse_prior_scale_on_the_blurred_stages() {
    let scales = |options: &FitOptions| planned(options, |s| s.prior_scale);
    let defaults = FitOptions::default();
    assert_eq!(defaults.coarse_prior_scale, Schedule::COARSE_PRIOR_SCALE);
    assert_eq!(defaults.pose_prior, PoseFit::POSE_PRIOR);
    let s = Schedule::COARSE_PRIOR_SCALE;
    assert_eq!(scales(&defaults), [s, s, 1.0]);
    assert_eq!(scales(&FitOptions { coarse_prior_scale: 3.0, ..defaults.clone() }), [3.0, 3.0, 1.0]);
    // The default schedule itself carries the method's scale; no blur, no coarse stage.
    let schedule = Schedule::coarse_to_fine(300, 3);
    assert_eq!(schedule.stages.iter().map(|s| s.prior_scale).collect::<Vec<_>>(), [s, s, 1.0]);
    assert_eq!(scales(&FitOptions { coarse_blur: 0.0, ..defaults.clone() }), [1.0]);
    for bad in [-0.5, f32::NAN, f32::INFINITY] {
        let result = FitOptions { coarse_prior_scale: bad, ..defaults.clone() }.plan(&builtin_figure());
        assert!(matches!(result, Err(Error::InvalidSettings(_))), "{bad}: {result:?}");
    }
}
