//! The self-intersection interval of a pose fit: every k-th step checks, the steps between
//! reuse that check's surrogate and gradient, a restart checks again, a restored state keeps its
//! check, and 0 is an error.

use diffsil::pose::figure::builtin_figure;
use diffsil::pose::fit::{framing_cameras, random_pose, FitSettings, PoseFit};
use diffsil::pose::self_intersection::self_intersection;
use diffsil::pose::skin::{Pose, SkinnedMesh};
use diffsil::{Error, RenderSettings, Renderer};

/// The first random pose with wide joint limits (1.5 rad) whose skinned body intersects itself.
fn intersecting_pose(model: &SkinnedMesh) -> Pose {
    let limits = vec![1.5; model.joint_count()];
    (0..100)
        .map(|seed| random_pose(&limits, 0.0, seed))
        .find(|pose| {
            let vertices = model.skin(pose).unwrap();
            self_intersection(&vertices, model.mesh.triangles()).unwrap().surrogate > 0.0
        })
        .expect("a self-intersecting pose among 100 wide random ones")
}

/// A fit toward the rest pose's silhouettes (2 views at 24²) from `start`, with a large `λ`.
fn fit_from(model: &SkinnedMesh, start: &Pose, interval: u32) -> PoseFit {
    let cameras = framing_cameras(&model.mesh, 2, 24);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let targets = renderer.render(&model.mesh, &cameras).unwrap().images().to_vec();
    let settings = FitSettings { initial: Some(start.clone()), lambda: 1e-3, ..FitSettings::default() };
    let mut fit = PoseFit::new(model.clone(), cameras, targets, renderer, settings).unwrap();
    assert_eq!(fit.intersection_interval(), 1);
    fit.set_intersection_interval(interval).unwrap();
    fit
}

/// The surrogate of a fresh check at the fit's current vertices.
fn fresh_surrogate(model: &SkinnedMesh, fit: &PoseFit) -> f64 {
    self_intersection(&fit.vertices().unwrap(), model.mesh.triangles()).unwrap().surrogate
}

/// Equal to 1e-9 relative.
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

#[test]
fn every_kth_step_checks_and_the_steps_between_reuse_the_check() {
    let model = builtin_figure();
    let start = intersecting_pose(&model);
    let mut every = fit_from(&model, &start, 1);
    let mut third = fit_from(&model, &start, 3);
    // The first step checks in both, so it is the same step.
    let (a, b) = (every.step().unwrap(), third.step().unwrap());
    assert_eq!(a, b);
    assert!(a.self_intersection_surrogate > 0.0);
    assert_eq!(every.pose(), third.pose());
    // Steps 2 and 3 reuse step 1's check; checking every step sees the moved body.
    for _ in 0..2 {
        let fresh = fresh_surrogate(&model, &third);
        assert!(!close(fresh, a.self_intersection_surrogate), "the body should have moved");
        assert_eq!(third.step().unwrap().self_intersection_surrogate, a.self_intersection_surrogate);
        let fresh = fresh_surrogate(&model, &every);
        assert!(close(every.step().unwrap().self_intersection_surrogate, fresh));
    }
    // Step 4 checks again.
    let fresh = fresh_surrogate(&model, &third);
    assert!(close(third.step().unwrap().self_intersection_surrogate, fresh));
    // A restart checks on its next step.
    third.step().unwrap();
    third.restart(&start).unwrap();
    let again = third.step().unwrap();
    assert_eq!(again.silhouette, a.silhouette);
    assert!(close(again.self_intersection_surrogate, a.self_intersection_surrogate));
    // A state carries its check: restored after other steps, the next step reuses the check the
    // state was taken with (lock-stepped hypotheses each keep their own), not a fresh one.
    let (mut fit, mut other) = (fit_from(&model, &start, 3), fit_from(&model, &start, 3));
    let first = fit.step().unwrap();
    other.step().unwrap();
    let kept = fit.state();
    for _ in 0..3 {
        fit.step().unwrap();
    }
    fit.set_state(kept).unwrap();
    let fresh = fresh_surrogate(&model, &fit);
    assert!(!close(fresh, first.self_intersection_surrogate), "the body should have moved");
    let (resumed, straight) = (fit.step().unwrap(), other.step().unwrap());
    assert_eq!(resumed.self_intersection_surrogate, first.self_intersection_surrogate);
    assert_eq!(resumed, straight);
    assert!(matches!(third.set_intersection_interval(0), Err(Error::InvalidSettings(_))));
    assert_eq!(third.intersection_interval(), 3);
}
