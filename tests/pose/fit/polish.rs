//! The polish that ends a fit (`PoseFit::polish`, `FitOptions::polish_steps`): its steps take a
//! quarter and then a tenth of the fit's rate, bit for bit as steps taken by hand; a polish that
//! ends higher puts the state back; it can be cancelled; `fit` runs it last and numbers its
//! steps after the runs'.

use std::ops::ControlFlow;

use super::call::{go_on, renderer};
use super::{fit_from_rest, scene};
use diffsil::pose::fit::{fit, FitOptions, PoseFit, POLISH_FIRST_RATE, POLISH_SECOND_RATE};
use diffsil::pose::skin::Pose;
use diffsil::Vec3;

/// A fit of the built-in figure's seed-4 silhouettes at 24², a few steps from a bent pose, so
/// that it is neither at the rest pose nor in a minimum.
fn fit_under_way() -> PoseFit {
    let (mut fit, model, _) = fit_from_rest(24, 4);
    let mut start = Pose::rest(model.joint_count());
    start.joint_rotations[3] = Vec3::new(0.3, 0.0, -0.2);
    start.joint_rotations[7] = Vec3::new(-0.2, 0.1, 0.0);
    fit.restart(&start).unwrap();
    for _ in 0..5 {
        fit.step().unwrap();
    }
    fit
}

#[test]
fn the_polish_steps_at_a_quarter_then_a_tenth_of_the_rate() {
    let mut polished = fit_under_way();
    let mut by_hand = fit_under_way();
    let rate = polished.learning_rate();
    let before = polished.energy().unwrap();
    let mut seen = Vec::new();
    let report = polished
        .polish(7, |_, p| {
            seen.push((p.step, p.hypothesis, p.blur));
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(seen, (1..=7).map(|k| (k, None, 0.0)).collect::<Vec<_>>());
    assert_eq!(polished.learning_rate(), rate, "the fit's rate again after");
    // Three steps (7 / 2, rounded down) at a quarter, four at a tenth.
    for k in 0..7 {
        let factor = if k < 3 { POLISH_FIRST_RATE } else { POLISH_SECOND_RATE };
        by_hand.set_learning_rate(rate * factor).unwrap();
        by_hand.step().unwrap();
    }
    let after = by_hand.energy().unwrap();
    assert!(after < before, "the case polishes: {before} → {after}");
    assert_eq!(report.steps, 7);
    assert!(report.kept && !report.cancelled);
    assert_eq!((report.energy_before, report.energy_after), (before, after));
    assert_eq!(polished.pose(), by_hand.pose());
    assert_eq!(polished.energy().unwrap(), after);
}

#[test]
fn a_polish_that_ends_higher_puts_the_state_back() {
    let mut fit = fit_under_way();
    // A rate so large that a quarter of it throws the limbs about.
    fit.set_learning_rate(40.0).unwrap();
    let (pose, energy) = (fit.pose(), fit.energy().unwrap());
    let report = fit.polish(4, go_on).unwrap();
    assert!(report.energy_after > report.energy_before, "{report:?}");
    assert!(!report.kept);
    assert_eq!(report.energy_before, energy);
    assert_eq!(fit.pose(), pose, "back where it started, bit for bit");
    assert_eq!(fit.energy().unwrap(), energy);
    assert_eq!(fit.learning_rate(), 40.0);
}

#[test]
fn a_cancelled_polish_stops_its_steps_and_keeps_the_lower_end() {
    let mut fit = fit_under_way();
    let before = fit.energy().unwrap();
    let report = fit.polish(10, |_, p| if p.step == 2 { ControlFlow::Break(()) } else { ControlFlow::Continue(()) });
    let report = report.unwrap();
    assert_eq!(report.steps, 2);
    assert!(report.cancelled);
    assert_eq!(report.energy_before, before);
    assert!(fit.energy().unwrap() <= before);
    assert_eq!(fit.energy().unwrap(), if report.kept { report.energy_after } else { before });
}

#[test]
fn fit_polishes_last_and_numbers_the_polish_steps_after_the_runs() {
    let run = |polish_steps: u32| {
        let (model, cameras, targets, _) = scene(24, 5);
        let options = FitOptions { steps: 40, polish_steps, ..FitOptions::default() };
        let mut progress = Vec::new();
        let fitted = fit(model, cameras, targets, renderer(), &options, |_, p| {
            progress.push(*p);
            ControlFlow::Continue(())
        })
        .unwrap();
        (fitted, progress)
    };
    let (mut plain, plain_progress) = run(0);
    assert!(plain.polish.is_none());
    let (mut polished, progress) = run(6);
    let report = polished.polish.expect("the polish ran");
    assert_eq!(report.steps, 6);
    // The same fit up to the polish, which starts where the unpolished fit ends.
    assert_eq!(progress[..plain_progress.len()], plain_progress[..]);
    assert_eq!(report.energy_before, plain.fit.energy().unwrap());
    let tail = &progress[plain_progress.len()..];
    let first = plain_progress.last().unwrap().step + 1;
    assert_eq!(tail.iter().map(|p| p.step).collect::<Vec<_>>(), (first..first + 6).collect::<Vec<_>>());
    assert!(tail.iter().all(|p| p.hypothesis.is_none() && p.blur == 0.0));
    let end = polished.fit.energy().unwrap();
    assert!(end <= report.energy_before);
    assert_eq!(end, if report.kept { report.energy_after } else { report.energy_before });
    assert_eq!(FitOptions::default().polish_steps, FitOptions::POLISH_STEPS);
}
