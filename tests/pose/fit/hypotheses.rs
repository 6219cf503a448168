//! `PoseFit::run`'s hypothesis phase renders every hypothesis of a step as one batch, in
//! lock-step; its results (each step's report and pose, the hypotheses' energies, the choice, the
//! final pose, cancellation) are those of running the hypotheses one after the other, bit for
//! bit.

use std::ops::ControlFlow;

use diffsil::pose::figure::random_pose_limits;
use diffsil::pose::fit::{random_pose, stride_hypotheses, PoseFit, Schedule, Stage, StepReport, Stop};
use diffsil::pose::skin::Pose;

use super::fit_from_rest;

/// A short schedule: 4 steps per hypothesis, then one blurred step of the chosen one.
fn schedule() -> Schedule {
    Schedule { hypothesis_steps: 4, stages: vec![Stage::new(Schedule::COARSE_BLUR, 1)], convergence: None }
}

/// The fit of seed 3 at 24², fitting the inflation and the outline too (their own Adam per
/// hypothesis), with a self-intersection check every 3rd step (each hypothesis its own, run
/// beside the batch's render): from the leg strides, and from three wild poses (2.5 times the
/// random poses' limits) whose limbs cross the body, each its own way (seeds 3 and 7), or not
/// (seed 0). With `proxy`, the blurred steps render the coarse proxy (cells of 5% of the
/// figure's height).
fn fit(wild: bool, proxy: bool) -> (PoseFit, Vec<Pose>) {
    let (mut fit, model, _) = fit_from_rest(24, 3);
    if proxy {
        let (vertices, _) = fit.set_coarse_proxy(Some(0.05 * model_height(&model)), 0.0).unwrap();
        assert!(vertices > 0 && vertices < model.vertex_count() / 2, "{vertices}");
    }
    fit.set_inflation_rate(0.01).unwrap();
    fit.set_outline_rate(0.06).unwrap();
    fit.set_intersection_interval(3).unwrap();
    let starts = if wild {
        let limits: Vec<f32> = random_pose_limits(&model.skeleton).iter().map(|l| l * 2.5).collect();
        [3, 7, 0].map(|seed| random_pose(&limits, 0.3, seed)).to_vec()
    } else {
        stride_hypotheses(&model, 0.3).unwrap()
    };
    (fit, starts)
}

/// What [`sequentially`] saw.
struct Sequential {
    /// Each step's report and the pose parameters after it.
    steps: Vec<(StepReport, Vec<f32>)>,
    /// The hypotheses' energies.
    energies: Vec<f64>,
    /// The final energy.
    energy: f64,
}

/// The run as it went before batches: each hypothesis in turn, the best one, its stage.
fn sequentially(fit: &mut PoseFit, schedule: &Schedule, starts: &[Pose]) -> Sequential {
    let mut steps = Vec::new();
    let mut energies = Vec::new();
    let mut states = Vec::new();
    for start in starts {
        fit.restart(start).unwrap();
        fit.set_blur(schedule.stages[0].blur).unwrap();
        for _ in 0..schedule.hypothesis_steps {
            let report = fit.step().unwrap();
            steps.push((report, fit.pose().to_params()));
        }
        energies.push(fit.energy().unwrap());
        states.push(fit.state());
    }
    let chosen = (0..energies.len()).min_by(|&a, &b| energies[a].total_cmp(&energies[b])).unwrap();
    fit.set_state(states.swap_remove(chosen)).unwrap();
    let report = fit.step().unwrap();
    steps.push((report, fit.pose().to_params()));
    fit.set_blur(0.0).unwrap();
    let energy = fit.energy().unwrap();
    Sequential { steps, energies, energy }
}

/// The model's extent along y.
fn model_height(model: &diffsil::pose::skin::SkinnedMesh) -> f32 {
    let ys = model.mesh.positions().iter().map(|p| p.y);
    ys.clone().fold(f32::NEG_INFINITY, f32::max) - ys.fold(f32::INFINITY, f32::min)
}

#[test]
fn batched_hypotheses_equal_hypotheses_in_turn() {
    for wild in [false, true] {
        batched_equals_in_turn(wild, false);
    }
}

/// The same with the coarse proxy: the batch renders each hypothesis's proxy and checks it for
/// self-intersection (the wild starts cross themselves), and the steps scatter its gradients as
/// a step alone does.
#[test]
fn batched_hypotheses_equal_hypotheses_in_turn_with_the_coarse_proxy() {
    for wild in [false, true] {
        let whole = batched_equals_in_turn(wild, false);
        let proxy = batched_equals_in_turn(wild, true);
        assert_ne!(whole, proxy, "the proxy must change the blurred steps for the test to cover it");
    }
}

/// Runs the comparison; returns the parameters after each step.
fn batched_equals_in_turn(wild: bool, proxy: bool) -> Vec<Vec<f32>> {
    let schedule = schedule();
    let (mut reference, starts) = fit(wild, proxy);
    let expected = sequentially(&mut reference, &schedule, &starts);
    assert_eq!(expected.steps.len(), 3 * 4 + 1);
    if wild {
        // Each start crosses itself its own way, or not at all.
        let first: Vec<f64> = (0..3).map(|k| expected.steps[4 * k].0.self_intersection_surrogate).collect();
        assert!(first[0] > 0.0 && first[1] > 0.0 && first[0] != first[1], "{first:?}");
        // (The coarse proxy crosses itself a little where the whole mesh does not.)
        assert!(proxy || first[2] == 0.0, "{first:?}");
    }

    let (mut batched, _) = fit(wild, proxy);
    let mut seen = Vec::new();
    let report = batched
        .run(&schedule, &starts, |fit, p| {
            seen.push((p.report, fit.pose().to_params()));
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(report.stop, Stop::Finished);
    assert_eq!(seen.len(), expected.steps.len());
    for (k, (got, want)) in seen.iter().zip(&expected.steps).enumerate() {
        assert_eq!(got, want, "step {}", k + 1);
    }
    assert_eq!(report.hypothesis_energies, expected.energies);
    assert_eq!(report.energy, expected.energy);
    assert_eq!(batched.pose(), reference.pose());
    assert_eq!(batched.inflation(), reference.inflation());
    assert_eq!(batched.outline(), reference.outline());
    assert!(batched.outline() != 0.0, "the outline must move for the test to cover it");

    // Cancelled in the second step of the second hypothesis: the fit is where it was then.
    let (mut cancelled, _) = fit(wild, proxy);
    let report = cancelled
        .run(&schedule, &starts, |_, p| if p.step == 6 { ControlFlow::Break(()) } else { ControlFlow::Continue(()) })
        .unwrap();
    assert_eq!((report.stop, report.steps, report.chosen), (Stop::Cancelled, 6, 1));
    assert_eq!(report.hypothesis_energies, expected.energies[..1]);
    assert_eq!(cancelled.pose().to_params(), expected.steps[5].1);
    expected.steps.into_iter().map(|(_, params)| params).collect()
}
