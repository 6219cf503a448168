//! The one-call method `fit::fit`: it beats its start on a small case, stops early when the
//! energy stops falling, can be cancelled, and leaves the parts it does not fit unchanged.

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};

use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{
    fit, framing_cameras, limb_swing_hypotheses, per_vertex_error, random_pose, Convergence, FitOptions, Stop,
};
use diffsil::pose::skin::{Pose, SkinnedMesh};
use diffsil::{Camera, Image, RenderSettings, Renderer, Vec3};

/// The built-in figure, 4 cameras at `resolution`² and the silhouettes of `truth`.
pub(super) fn views_of(truth: &Pose, resolution: u32) -> (SkinnedMesh, Vec<Camera>, Vec<Image>) {
    let model = builtin_figure();
    let cameras = framing_cameras(&model.mesh, 4, resolution);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let targets = renderer.render(&model.posed_mesh(truth).unwrap(), &cameras).unwrap().images().to_vec();
    (model, cameras, targets)
}

/// A renderer with the default settings (also used by `crossed_legs.rs` and
/// `head_turns.rs`).
pub(super) fn renderer() -> Renderer {
    Renderer::new(RenderSettings::default()).unwrap()
}

/// A progress callback that never cancels (also used by `crossed_legs.rs` and `head_turns.rs`).
pub(super) fn go_on(_: &diffsil::pose::fit::PoseFit, _: &diffsil::pose::fit::Progress) -> ControlFlow<()> {
    ControlFlow::Continue(())
}

#[test]
fn the_library_call_beats_its_start() {
    let model = builtin_figure();
    let truth = random_pose(&random_pose_limits(&model.skeleton), 30f32.to_radians(), 3);
    let (model, cameras, targets) = views_of(&truth, 24);
    let truth_vertices = model.skin(&truth).unwrap();
    let start_error = per_vertex_error(&model.skin(&Pose::rest(model.joint_count())).unwrap(), &truth_vertices);
    let options = FitOptions { steps: 80, ..FitOptions::default() };
    let mut steps = 0;
    let fitted = fit(model.clone(), cameras, targets, renderer(), &options, |_, p| {
        steps = p.step;
        ControlFlow::Continue(())
    })
    .unwrap();
    // The runs from the crossed legs, the restart and the polish, when there are any, number
    // their steps on.
    let more = fitted.first.crossed_legs.as_ref().map_or(0, |c| c.steps())
        + fitted.restart.as_ref().map_or(0, |r| r.steps())
        + fitted.polish.as_ref().map_or(0, |p| p.steps);
    assert_eq!(fitted.first.report.steps + more, steps, "one progress call per step");
    assert!(fitted.first.report.steps <= 80);
    assert_eq!(fitted.first.report.hypothesis_energies.len(), 3, "rest and a stride each way");
    let error = per_vertex_error(&fitted.fit.vertices().unwrap(), &truth_vertices);
    assert!(error < 0.5 * start_error, "per-vertex error {start_error} → {error} m");
}

#[test]
fn the_fit_stops_early_once_the_energy_stops_falling() {
    // Started at the truth, the energy is zero and cannot fall: the last stage ends after two
    // windows. (The coarse proxy off: its silhouettes are not quite the truth's, so its steps
    // would move the pose off the truth before the last stage.)
    let rest = Pose::rest(builtin_figure().joint_count());
    let (model, cameras, targets) = views_of(&rest, 16);
    let convergence = Convergence { window: 6, tolerance: 0.01 };
    let options = FitOptions { steps: 100, convergence: Some(convergence), coarse_proxy: 0.0, ..FitOptions::default() };
    let (schedule, hypotheses) = options.plan(&model).unwrap();
    let before_last: u32 = hypotheses.len() as u32 * schedule.hypothesis_steps
        + schedule.stages[..schedule.stages.len() - 1].iter().map(|s| s.steps).sum::<u32>();
    let fitted = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &options, go_on).unwrap();
    assert_eq!(fitted.first.report.stop, Stop::Converged);
    assert_eq!(fitted.first.report.steps, before_last + 12);
    // Without the rule every step runs.
    let options = FitOptions { convergence: None, ..options };
    let fitted = fit(model, cameras, targets, renderer(), &options, go_on).unwrap();
    assert_eq!((fitted.first.report.stop, fitted.first.report.steps), (Stop::Finished, 100));
}

/// `steps: 0` takes no step: not in the run, nor in anything that follows one (the swap test,
/// the crossed legs, the runner-up facing, the restarts, the polish); the fit ends at the
/// starting pose of lowest energy.
#[test]
fn no_steps_take_no_step_and_end_at_the_lowest_starting_pose() {
    let model = builtin_figure();
    let truth = random_pose(&random_pose_limits(&model.skeleton), 30f32.to_radians(), 5);
    let (model, cameras, targets) = views_of(&truth, 16);
    let options = FitOptions { steps: 0, facings: FitOptions::ANY_FACING.to_vec(), ..FitOptions::default() };
    let (_, starts) = options.plan(&model).unwrap();
    let mut calls = 0;
    let fitted = fit(model, cameras, targets, renderer(), &options, |_, _| {
        calls += 1;
        ControlFlow::Continue(())
    })
    .unwrap();
    assert_eq!((calls, fitted.steps()), (0, 0));
    let energies = &fitted.first.report.hypothesis_energies;
    assert_eq!(energies.len(), starts.len());
    let lowest = (0..energies.len()).min_by(|a, b| energies[*a].total_cmp(&energies[*b])).unwrap();
    assert_eq!(fitted.first.report.chosen, lowest);
    assert_eq!(fitted.fit.pose(), starts[lowest]);
    assert!(fitted.first.swap.is_none() && fitted.first.crossed_legs.is_none());
    assert!(fitted.facing_run.is_none() && fitted.restart.is_none() && fitted.polish.is_none());
}

#[test]
fn the_convergence_rule_compares_window_means() {
    let rule = Convergence { window: 2, tolerance: 0.1 };
    assert!(!rule.met(&[1.0, 1.0, 1.0]), "needs two windows");
    assert!(rule.met(&[1.0, 1.0, 1.0, 1.0]));
    assert!(!rule.met(&[1.0, 1.0, 0.8, 0.8]), "20% lower: still falling");
    assert!(rule.met(&[1.0, 1.0, 0.95, 0.95]), "5% lower: converged");
    assert!(rule.met(&[0.1, 1.0, 1.0, 1.0, 1.0]), "only the last two windows count");
}

#[test]
fn a_cancelled_fit_ends_at_once_where_it_is() {
    let model = builtin_figure();
    let truth = random_pose(&random_pose_limits(&model.skeleton), 30f32.to_radians(), 4);
    let (model, cameras, targets) = views_of(&truth, 16);
    let cancel = AtomicBool::new(false);
    let options = FitOptions { steps: 200, ..FitOptions::default() };
    let fitted = fit(model, cameras, targets, renderer(), &options, |fit, p| {
        if p.step == 7 {
            // What a user interface would do from another thread.
            cancel.store(true, Ordering::Relaxed);
        }
        assert!(fit.pose().validate(fit.pose().joint_count()).is_ok());
        if cancel.load(Ordering::Relaxed) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    assert_eq!((fitted.first.report.stop, fitted.first.report.steps), (Stop::Cancelled, 7));
    assert_eq!(fitted.fit.blur(), 0.0);
    assert!(fitted.first.report.energy.is_finite());
}

#[test]
fn switched_off_parts_keep_their_values() {
    let model = builtin_figure();
    let mut truth = random_pose(&random_pose_limits(&model.skeleton), 30f32.to_radians(), 6);
    truth.translation = Vec3::new(0.05, 0.0, -0.03);
    let (model, cameras, targets) = views_of(&truth, 16);
    let mut initial = Pose::rest(model.joint_count());
    initial.joint_rotations[4] = Vec3::new(0.2, 0.0, 0.0);
    initial.orientation = Vec3::new(0.0, 0.1, 0.0);
    initial.translation = Vec3::new(0.0, 0.02, 0.0);
    let base = FitOptions { steps: 30, convergence: None, initial: Some(initial.clone()), ..FitOptions::default() };

    let global_only = FitOptions { fit_pose: false, ..base.clone() };
    let fitted = fit(model.clone(), cameras.clone(), targets.clone(), renderer(), &global_only, go_on).unwrap();
    let pose = fitted.fit.pose();
    assert_eq!(pose.joint_rotations, initial.joint_rotations, "joint offsets frozen");
    assert_ne!(pose.orientation, initial.orientation);
    assert_ne!(pose.translation, initial.translation);
    assert_eq!(fitted.first.report.hypothesis_energies.len(), 1, "no limb hypotheses without the pose");

    let joints_only = FitOptions { fit_global: false, ..base };
    let fitted = fit(model, cameras, targets, renderer(), &joints_only, go_on).unwrap();
    let pose = fitted.fit.pose();
    assert_eq!((pose.orientation, pose.translation), (initial.orientation, initial.translation), "global frozen");
    assert_ne!(pose.joint_rotations, initial.joint_rotations);
}

#[test]
fn limb_swings_move_the_shoulders_not_the_collars() {
    let model = builtin_figure();
    let hypotheses = limb_swing_hypotheses(&model, 0.3, 0.4).unwrap();
    assert_eq!(hypotheses.len(), 5, "rest, then 2 strides × 2 arm swings");
    let (left_hip, left_collar, left_shoulder, right_shoulder) = (1, 13, 16, 17);
    for h in &hypotheses[1..] {
        assert!((h.joint_rotations[left_hip].length() - 0.3).abs() < 1e-6);
        assert!((h.joint_rotations[left_shoulder].length() - 0.4).abs() < 1e-6, "{h:?}");
        assert!((h.joint_rotations[left_shoulder] + h.joint_rotations[right_shoulder]).length() < 1e-5);
        assert_eq!(h.joint_rotations[left_collar], Vec3::ZERO);
    }
    // Every combination of the two signs appears once.
    let signs: Vec<(bool, bool)> = hypotheses[1..]
        .iter()
        .map(|h| (h.joint_rotations[left_hip].x > 0.0, h.joint_rotations[left_shoulder].x > 0.0))
        .collect();
    for pair in [(true, true), (true, false), (false, true), (false, false)] {
        assert_eq!(signs.iter().filter(|s| **s == pair).count(), 1, "{signs:?}");
    }
    assert_eq!(limb_swing_hypotheses(&model, 0.3, 0.0).unwrap().len(), 3);
    assert_eq!(limb_swing_hypotheses(&model, 0.0, 0.0).unwrap().len(), 1);
}

#[test]
fn a_hip_joint_at_the_pelvis_stands_for_its_thigh() {
    // The MakeHuman body's legs hang from `LHipJoint` / `RHipJoint`, which sit at `Hips` (zero
    // offset): the stride swings the thighs, `LeftUpLeg` and `RightUpLeg`, and nothing else.
    let body = diffsil::pose::makehuman_body().unwrap();
    let names = &body.skeleton.names;
    let index = |name: &str| names.iter().position(|n| n == name).unwrap();
    let (left_thigh, right_thigh) = (index("LeftUpLeg"), index("RightUpLeg"));
    let (left_foot, right_foot) = (index("LeftFoot"), index("RightFoot"));
    let hypotheses = limb_swing_hypotheses(&body, 0.3, 0.0).unwrap();
    assert_eq!(hypotheses.len(), 3);
    let rest = body.joint_transforms(&hypotheses[0]).unwrap();
    for h in &hypotheses[1..] {
        for (j, r) in h.joint_rotations.iter().enumerate() {
            let expected = if j == left_thigh || j == right_thigh { 0.3 } else { 0.0 };
            assert!((r.length() - expected).abs() < 1e-6, "{}: {r}", names[j]);
        }
        // One foot forward (+z, the way the body faces), the other back, by about as much.
        let g = body.joint_transforms(h).unwrap();
        let moved = |j: usize| g[j].w_axis.truncate() - rest[j].w_axis.truncate();
        let (l, r) = (moved(left_foot), moved(right_foot));
        assert!(l.z.abs() > 0.1 && l.z * r.z < 0.0, "feet moved by {l} and {r}");
        assert!((l.z + r.z).abs() < 0.1 * l.z.abs(), "feet moved by {l} and {r}");
    }
}

#[test]
fn options_out_of_range_are_errors_without_a_model() {
    use diffsil::pose::fit::{RestartFamily, SwapScreen};
    use diffsil::Error;
    assert!(FitOptions::default().validate().is_ok());
    let d = FitOptions::default;
    let cases = [
        ("learning rate", FitOptions { learning_rate: 0.0, ..d() }),
        ("lambda", FitOptions { lambda: f32::NAN, ..d() }),
        ("intersection interval", FitOptions { intersection_interval: 0, ..d() }),
        ("shape prior", FitOptions { shape_prior: -1.0, ..d() }),
        ("pose prior", FitOptions { pose_prior: -1.0, ..d() }),
        ("coarse proxy", FitOptions { coarse_proxy: f32::NAN, ..d() }),
        ("coarse blur", FitOptions { coarse_blur: 1.5, ..d() }),
        ("coarse prior scale", FitOptions { coarse_prior_scale: f32::INFINITY, ..d() }),
        ("outline settle", FitOptions { outline_settle: -0.1, ..d() }),
        ("leg stride", FitOptions { leg_stride: f32::NAN, ..d() }),
        ("arm swing", FitOptions { arm_swing: f32::NEG_INFINITY, ..d() }),
        ("inflation rate", FitOptions { fit_inflation: true, inflation_rate: 0.0, ..d() }),
        ("outline rate", FitOptions { outline_rate: f32::NAN, ..d() }),
        ("crossed legs bound", FitOptions { crossed_legs_within: -1.0, ..d() }),
        ("looser bound", FitOptions { crossed_legs_loose_within: f64::NAN, ..d() }),
        ("excess bound", FitOptions { crossed_legs_excess: f64::INFINITY, ..d() }),
        ("fourth run bound", FitOptions { fourth_run_below: 1.5, ..d() }),
        ("swap screen", FitOptions { swap_screen: SwapScreen { within: f64::NAN, ..SwapScreen::default() }, ..d() }),
        ("head turn bound", FitOptions { head_turn_below: -0.5, ..d() }),
        ("restart arm swing", FitOptions { restart_arm_swing: -0.4, ..d() }),
        ("thinned bound", FitOptions { thinned_below: f32::NAN, ..d() }),
        ("thinned family", FitOptions { thinned_restarts: vec![RestartFamily::swing(0.3, f32::NAN)], ..d() }),
    ];
    let figure = builtin_figure();
    for (what, options) in cases {
        assert!(matches!(options.validate(), Err(Error::InvalidSettings(_))), "{what}");
        assert!(matches!(options.plan(&figure), Err(Error::InvalidSettings(_))), "{what}: plan");
    }
    // A setting only read where its part is fitted is not checked where it is not.
    assert!(FitOptions { fit_inflation: false, inflation_rate: 0.0, ..d() }.validate().is_ok());
    assert!(FitOptions { fit_outline: false, outline_rate: f32::NAN, ..d() }.validate().is_ok());
}
