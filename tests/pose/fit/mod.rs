//! Pose fitting end to end on the built-in figure: a short fit lowers the error, the
//! coarse-to-fine multi-start method runs as scheduled, and bad settings are errors.

mod call;
mod cameras;
mod crossed_legs;
mod facing;
mod head_turns;
mod hypotheses;
mod inflation;
mod interval;
mod outline;
mod placement;
mod polish;
mod prior_scale;
mod proxy;
mod resolution;
mod restart;
mod start;
mod swap;
mod warmup;

use std::ops::ControlFlow;

use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{
    framing_cameras, per_vertex_error, random_pose, stride_hypotheses, FitOptions, FitSettings, PoseFit, Schedule,
    Stage, Stop,
};
use diffsil::pose::skin::{JointRest, Pose, Skeleton, SkinnedMesh};
use diffsil::{Camera, Error, Image, Mesh, RenderSettings, Renderer, Vec3};

/// The built-in figure, cameras around it and the silhouettes of a random pose (seed `seed`).
fn scene(resolution: u32, seed: u64) -> (SkinnedMesh, Vec<Camera>, Vec<Image>, Vec<Vec3>) {
    let model = builtin_figure();
    let limits = random_pose_limits(&model.skeleton);
    let truth = random_pose(&limits, 30f32.to_radians(), seed);
    let truth_vertices = model.skin(&truth).unwrap();
    let cameras = framing_cameras(&model.mesh, 4, resolution);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let truth_mesh = Mesh::with_topology(truth_vertices.clone(), model.mesh.topology().clone()).unwrap();
    let targets = renderer.render(&truth_mesh, &cameras).unwrap().images().to_vec();
    (model, cameras, targets, truth_vertices)
}

/// A fit of [`scene`] from the rest pose (learning rate 0.02, λ = 1e-7, CPU), the model, and the
/// true vertices.
fn fit_from_rest(resolution: u32, seed: u64) -> (PoseFit, SkinnedMesh, Vec<Vec3>) {
    let (model, cameras, targets, truth_vertices) = scene(resolution, seed);
    let renderer = Renderer::new(RenderSettings::default()).unwrap();
    let fit = PoseFit::new(model.clone(), cameras, targets, renderer, FitSettings::default()).unwrap();
    (fit, model, truth_vertices)
}

/// One setting of each stage the built-in figure's plan under `options` has (`FitOptions::plan`).
fn planned<T>(options: &FitOptions, setting: impl Fn(&Stage) -> T) -> Vec<T> {
    options.plan(&builtin_figure()).unwrap().0.stages.iter().map(setting).collect()
}

/// Asserts that [`PoseFit::run`] of a plain stage followed by `bad` is an
/// [`Error::InvalidSettings`] before any step (`what` names the case in a failure).
fn assert_stage_rejected_before_any_step(fit: &mut PoseFit, bad: Stage, what: &str) {
    let schedule = Schedule { hypothesis_steps: 0, stages: vec![Stage::new(0.0, 1), bad], convergence: None };
    let mut steps = 0;
    let result = fit.run(&schedule, &[], |_, _| {
        steps += 1;
        ControlFlow::Continue(())
    });
    assert!(matches!(result, Err(Error::InvalidSettings(_))), "{what}: {result:?}");
    assert_eq!(steps, 0, "{what}");
}

#[test]
fn a_short_fit_reduces_the_silhouette_error_and_the_vertex_error() {
    let (mut fit, _, truth_vertices) = fit_from_rest(48, 7);
    let error_before = per_vertex_error(&fit.vertices().unwrap(), &truth_vertices);
    let first = fit.step().unwrap();
    let mut last = first;
    for _ in 0..60 {
        last = fit.step().unwrap();
    }
    let error_after = per_vertex_error(&fit.vertices().unwrap(), &truth_vertices);
    assert!(last.silhouette < 0.5 * first.silhouette, "E_sl {} → {}", first.silhouette, last.silhouette);
    assert!(error_after < 0.7 * error_before, "per-vertex error {error_before} → {error_after} m");
}

#[test]
fn the_method_runs_its_schedule_and_lowers_the_error() {
    let (mut fit, model, truth_vertices) = fit_from_rest(32, 3);
    let error_before = per_vertex_error(&fit.vertices().unwrap(), &truth_vertices);
    let energy_before = fit.energy().unwrap();
    let hypotheses = stride_hypotheses(&model, 0.3).unwrap();
    let schedule = Schedule::coarse_to_fine(60, hypotheses.len());
    let mut seen = Vec::new();
    let report = fit
        .run(&schedule, &hypotheses, |_, p| {
            seen.push((p.step, p.hypothesis, p.blur));
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(report.stop, Stop::Finished);
    assert_eq!(report.steps, 60);
    assert_eq!(seen.len(), 60);
    assert_eq!(seen.first(), Some(&(1, Some(0), Schedule::COARSE_BLUR)));
    assert_eq!(seen.last(), Some(&(60, None, 0.0)));
    let h = schedule.hypothesis_steps as usize;
    assert!(seen[..3 * h].iter().enumerate().all(|(i, s)| s.1 == Some(i / h)), "{seen:?}");
    assert_eq!(report.hypothesis_energies.len(), 3);
    let best = report.hypothesis_energies.iter().copied().fold(f64::INFINITY, f64::min);
    assert_eq!(report.hypothesis_energies[report.chosen], best);
    assert_eq!(fit.blur(), 0.0);
    let error_after = per_vertex_error(&fit.vertices().unwrap(), &truth_vertices);
    assert!(report.energy < 0.3 * energy_before, "E {energy_before} → {}", report.energy);
    assert!(error_after < 0.5 * error_before, "per-vertex error {error_before} → {error_after} m");
}

/// The built-in figure, its random pose of seed 5, and that pose's silhouettes in 2 views at 24²,
/// with the renderer that drew them.
fn truth_in_two_views() -> (SkinnedMesh, Pose, Vec<Camera>, Vec<Image>, Renderer) {
    let model = builtin_figure();
    let limits = random_pose_limits(&model.skeleton);
    let truth = random_pose(&limits, 30f32.to_radians(), 5);
    let cameras = framing_cameras(&model.mesh, 2, 24);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let targets = renderer.render(&model.posed_mesh(&truth).unwrap(), &cameras).unwrap().images().to_vec();
    (model, truth, cameras, targets, renderer)
}

/// Settings starting at `initial`, without the self-intersection term.
fn settings(initial: &Pose, learning_rate: f32) -> FitSettings {
    FitSettings { initial: Some(initial.clone()), learning_rate, lambda: 0.0, ..FitSettings::default() }
}

#[test]
fn energy_is_zero_at_the_truth_and_blur_is_validated() {
    let (model, truth, cameras, targets, renderer) = truth_in_two_views();
    let mut fit = PoseFit::new(model, cameras, targets, renderer, settings(&truth, 0.02)).unwrap();
    assert_eq!(fit.energy().unwrap(), 0.0);
    fit.set_blur(0.05).unwrap();
    assert_eq!(fit.blur(), 0.05);
    // Blurred or not, the truth is a zero of E_sl.
    assert_eq!(fit.step().unwrap().silhouette, 0.0);
    for bad in [-0.1, 1.5, f32::NAN] {
        assert!(matches!(fit.set_blur(bad), Err(Error::InvalidSettings(_))), "blur {bad}");
    }
    assert!(fit.set_learning_rate(0.0).is_err());
    assert!(fit.restart(&Pose::rest(3)).is_err());
}

#[test]
fn an_initial_poses_scale_factors_are_kept_and_its_rotations_fitted() {
    // The truth with a joint scaled (as an animation's frame may be): silhouettes of that, and a
    // fit started from the truth's scales with the rotations at rest.
    let (model, mut truth, cameras, _, mut renderer) = truth_in_two_views();
    truth = truth.with_joint_scales();
    truth.joint_scales[3] = Vec3::new(1.2, 0.8, 1.0);
    let targets = renderer.render(&model.posed_mesh(&truth).unwrap(), &cameras).unwrap().images().to_vec();
    let initial = Pose { joint_rotations: vec![Vec3::ZERO; model.joint_count()], ..truth.clone() };
    let mut fit = PoseFit::new(model.clone(), cameras, targets, renderer, settings(&initial, 0.02)).unwrap();
    let before = fit.energy().unwrap();
    for _ in 0..5 {
        fit.step().unwrap();
    }
    let pose = fit.pose();
    assert_eq!(pose.joint_scales, truth.joint_scales, "the scale factors stay the initial pose's");
    assert_eq!(pose.joint_translations, vec![Vec3::ZERO; model.joint_count()], "no translations were asked for");
    assert_ne!(pose.joint_rotations, initial.joint_rotations);
    assert!(fit.energy().unwrap() < before);
    assert!(fit.restart(&initial).is_ok(), "a restart keeps the layout");
}

#[test]
fn the_pose_prior_adds_to_the_energy_and_pulls_offsets_to_rest() {
    let (model, truth, cameras, targets, renderer) = truth_in_two_views();
    let mut fit = PoseFit::new(model.clone(), cameras, targets, renderer, settings(&truth, 0.01)).unwrap();
    assert!(matches!(fit.set_pose_prior(-1.0), Err(Error::InvalidSettings(_))));
    assert!(fit.set_pose_prior(f32::NAN).is_err());
    fit.set_pose_prior(0.5).unwrap();
    // E_prior is the mean over joints of |θ_j|².
    let expected: f64 =
        truth.joint_rotations.iter().map(|r| r.length_squared() as f64).sum::<f64>() / model.joint_count() as f64;
    assert!(
        (fit.energy().unwrap() - 0.5 * expected).abs() < 1e-6 * expected,
        "{} vs {expected}",
        fit.energy().unwrap()
    );
    // At the truth the silhouettes agree, so the first step follows the prior alone: Adam moves
    // every non-zero offset by the learning rate toward zero (up to its ε), and the rest stays.
    let report = fit.step().unwrap();
    assert_eq!(report.silhouette, 0.0);
    assert!((report.pose_prior - expected).abs() < 1e-6 * expected);
    for (after, before) in fit.pose().joint_rotations.iter().zip(&truth.joint_rotations) {
        for k in 0..3 {
            let (a, b) = (after[k], before[k]);
            let expected = if b == 0.0 { 0.0 } else { b - 0.01 * b.signum() };
            assert!((a - expected).abs() < 1e-4, "{b} → {a}");
        }
    }
    assert_eq!(fit.pose().orientation, truth.orientation);
}

#[test]
fn default_schedule_splits_the_steps() {
    let s = Schedule::coarse_to_fine(300, 3);
    assert_eq!(s.hypothesis_steps, 30);
    let steps: Vec<u32> = s.stages.iter().map(|st| st.steps).collect();
    assert_eq!(steps, [15, 25, 170]);
    let blurs: Vec<f32> = s.stages.iter().map(|st| st.blur).collect();
    assert_eq!(blurs, [Schedule::COARSE_BLUR, Schedule::COARSE_BLUR / 2.0, 0.0]);
    assert_eq!(s.total_steps(3), 300);
    assert_eq!(Schedule::coarse_to_fine(300, 1).total_steps(1), 300);
    // Many starts still leave half the steps to the chosen one; tiny budgets do not underflow.
    let many = Schedule::coarse_to_fine(100, 20);
    assert!(20 * many.hypothesis_steps <= 50);
    assert!(Schedule::coarse_to_fine(3, 3).total_steps(3) <= 3);
    let plain = Schedule { hypothesis_steps: 0, stages: vec![Stage::new(0.0, 5)], convergence: None };
    assert_eq!(plain.total_steps(1), 5);
}

#[test]
fn stride_hypotheses_swing_the_legs_both_ways() {
    let model = builtin_figure();
    let hypotheses = stride_hypotheses(&model, 0.3).unwrap();
    assert_eq!(hypotheses.len(), 3);
    assert_eq!(hypotheses[0], Pose::rest(model.joint_count()));
    let (left_hip, right_hip, left_ankle, right_ankle) = (1, 2, 7, 8);
    for (h, sign) in [(&hypotheses[1], 1.0f32), (&hypotheses[2], -1.0)] {
        // The figure's joint frames are the world's: the axis through both hips is x.
        assert!((h.joint_rotations[left_hip] - Vec3::new(0.3 * sign, 0.0, 0.0)).length() < 1e-6, "{h:?}");
        assert!((h.joint_rotations[right_hip] + Vec3::new(0.3 * sign, 0.0, 0.0)).length() < 1e-6, "{h:?}");
        let others = h.joint_rotations.iter().enumerate().filter(|(j, _)| *j != left_hip && *j != right_hip);
        assert!(others.into_iter().all(|(_, r)| *r == Vec3::ZERO));
        assert_eq!((h.orientation, h.translation), (Vec3::ZERO, Vec3::ZERO));
        // One foot goes forward (+z, the way the figure faces), the other back.
        let g = model.joint_transforms(h).unwrap();
        let (zl, zr) = (g[left_ankle].w_axis.z, g[right_ankle].w_axis.z);
        assert!(zl * zr < 0.0 && (zl + zr).abs() < 0.1, "ankles at z = {zl}, {zr}");
        assert!(-sign * zl > 0.1, "stride {sign}: left ankle at z = {zl}");
    }
    // A single chain has no legs: the rest pose alone.
    assert_eq!(stride_hypotheses(&chain(), 0.3).unwrap(), vec![Pose::rest(2)]);
}

/// A tetrahedron on a two-joint chain.
fn chain() -> SkinnedMesh {
    let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    let mesh = Mesh::new(positions, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]).unwrap();
    let rest = vec![JointRest::IDENTITY, JointRest { translation: Vec3::Y, ..JointRest::IDENTITY }];
    let mut skeleton = Skeleton {
        names: vec!["a".into(), "b".into()],
        nodes: Vec::new(),
        parents: vec![None, Some(0)],
        rest,
        root_parent: vec![glam::Mat4::IDENTITY; 2],
        inverse_bind: Vec::new(),
    };
    skeleton.set_inverse_bind_to_rest().unwrap();
    SkinnedMesh::new(mesh, skeleton, vec![[0, 1, 0, 0]; 4], vec![[0.5, 0.5, 0.0, 0.0]; 4]).unwrap()
}

#[test]
fn fit_rejects_mismatched_targets_and_bad_rates() {
    let model = builtin_figure();
    let cameras = framing_cameras(&model.mesh, 2, 16);
    let rest = Pose::rest(model.joint_count());
    let renderer = || Renderer::new(RenderSettings::default()).unwrap();
    let one = vec![Image::filled(16, 16, 0.0)];
    let err = PoseFit::new(model.clone(), cameras.clone(), one, renderer(), settings(&rest, 0.01)).err().unwrap();
    assert!(matches!(err, Error::ViewCountMismatch { .. }), "{err}");
    let wrong_size = vec![Image::filled(8, 16, 0.0); 2];
    let err =
        PoseFit::new(model.clone(), cameras.clone(), wrong_size, renderer(), settings(&rest, 0.01)).err().unwrap();
    assert!(matches!(err, Error::SizeMismatch { .. }), "{err}");
    let targets = vec![Image::filled(16, 16, 0.0); 2];
    assert!(
        PoseFit::new(model.clone(), cameras.clone(), targets.clone(), renderer(), settings(&rest, f32::NAN)).is_err()
    );
    // A target with a non-finite pixel is refused where the fit is made, naming the view and the pixel.
    for bad in [f32::NAN, f32::INFINITY] {
        let mut targets = targets.clone();
        targets[1].data_mut()[37] = bad;
        let err = PoseFit::new(model.clone(), cameras.clone(), targets, renderer(), settings(&rest, 0.01)).err();
        let err = err.expect("a non-finite target pixel is an error");
        assert!(err.to_string().contains("target 1") && err.to_string().contains("pixel 37"), "{err}");
    }
    // So is a value outside [0, 1] (a 0–255 mask not divided by 255); 0 and 1 themselves are not.
    for (bad, says) in [(255.0, "the value 255 at pixel 5"), (-0.5, "the value -0.5 at pixel 5")] {
        let mut targets = targets.clone();
        targets[0].data_mut()[5] = bad;
        let err = PoseFit::new(model.clone(), cameras.clone(), targets, renderer(), settings(&rest, 0.01)).err();
        let err = err.expect("a target pixel outside [0, 1] is an error").to_string();
        assert!(err.contains("target 0") && err.contains(says) && err.contains("divide"), "{err}");
    }
    let mut edges = targets;
    edges[0].data_mut()[..2].copy_from_slice(&[0.0, 1.0]);
    assert!(PoseFit::new(model, cameras, edges, renderer(), settings(&rest, 0.01)).is_ok());
}
