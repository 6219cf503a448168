//! The learning-rate ramp of a stage (`Stage::warmup`): a run's first steps of the stage take the
//! ramped rates and then the fit's own, bit for bit as steps taken by hand; the rate is the
//! fit's again after the run; `FitOptions` puts its `warmup` on the unblurred stage only.

use std::ops::ControlFlow;

use super::{fit_from_rest, planned};
use diffsil::pose::fit::{FitOptions, Schedule, Stage};
use diffsil::pose::skin::Pose;
use diffsil::Vec3;

#[test]
fn a_stage_ramps_the_learning_rate_over_its_warmup_then_takes_the_fits_own() {
    let (mut by_run, model, _) = fit_from_rest(24, 4);
    let (mut by_hand, _, _) = fit_from_rest(24, 4);
    let mut start = Pose::rest(model.joint_count());
    start.joint_rotations[3] = Vec3::new(0.3, 0.0, -0.2);
    let rate = by_run.learning_rate();
    let schedule =
        Schedule { hypothesis_steps: 0, stages: vec![Stage { warmup: 2, ..Stage::new(0.0, 4) }], convergence: None };
    by_run.run(&schedule, std::slice::from_ref(&start), |_, _| ControlFlow::Continue(())).unwrap();
    assert_eq!(by_run.learning_rate(), rate);
    by_hand.restart(&start).unwrap();
    for k in 0..4u32 {
        let ramped = if k < 2 { rate * (k + 1) as f32 / 3.0 } else { rate };
        by_hand.set_learning_rate(ramped).unwrap();
        by_hand.step().unwrap();
    }
    assert_eq!(by_run.pose(), by_hand.pose());
    // Without the ramp the first step moves further: the ramp is not a no-op.
    let (mut plain, _, _) = fit_from_rest(24, 4);
    plain.restart(&start).unwrap();
    plain.set_learning_rate(rate).unwrap();
    for _ in 0..4 {
        plain.step().unwrap();
    }
    assert_ne!(plain.pose(), by_hand.pose());
}

#[test]
fn the_options_put_the_warmup_on_the_unblurred_stage_only() {
    let warmups = |options: &FitOptions| planned(options, |s| s.warmup);
    let defaults = FitOptions::default();
    assert_eq!(warmups(&defaults), [0, 0, 0]);
    let ramped = FitOptions { warmup: 10, ..defaults };
    assert_eq!(warmups(&ramped), [0, 0, 10]);
    assert_eq!(warmups(&FitOptions { coarse_blur: 0.0, ..ramped }), [0]);
    assert!(Schedule::coarse_to_fine(300, 3).stages.iter().all(|s| s.warmup == 0));
}
