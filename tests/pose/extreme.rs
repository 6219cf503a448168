//! Extreme values in pose fitting (issue 13): a huge learning rate or a NaN stride angle is an
//! error or a finite result, never a panic or a NaN pose.

use diffsil::pose::figure::builtin_figure;
use diffsil::pose::fit::{framing_cameras, stride_hypotheses, FitSettings, PoseFit};
use diffsil::pose::skin::Pose;
use diffsil::{Mesh, RenderSettings, Renderer};

#[test]
fn a_learning_rate_of_1e30_gives_errors_or_finite_poses_never_a_panic() {
    let model = builtin_figure();
    let cameras = framing_cameras(&model.mesh, 2, 24);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let mut pose = Pose::rest(model.joint_count());
    pose.joint_rotations[1].x = 0.3;
    let truth = Mesh::with_topology(model.skin(&pose).unwrap(), model.mesh.topology().clone()).unwrap();
    let targets = renderer.render(&truth, &cameras).unwrap().images().to_vec();
    let settings = FitSettings { learning_rate: 1e30, ..FitSettings::default() };
    let mut fit = PoseFit::new(model, cameras, targets, renderer, settings).unwrap();
    let mut errors = 0;
    for step in 0..6 {
        match fit.step() {
            Ok(report) => assert!(report.silhouette.is_finite(), "step {step}: {report:?}"),
            Err(e) => {
                // The pose left the range the skeleton can be posed in: the error says so.
                let message = e.to_string();
                assert!(
                    message.contains("1e18") || message.contains("lower the learning rate"),
                    "step {step}: {message}"
                );
                errors += 1;
            }
        }
        let params = fit.pose().to_params();
        assert!(params.iter().all(|p| p.is_finite()), "step {step}: a non-finite pose parameter");
    }
    println!("learning rate 1e30: {errors} of 6 steps were errors");
}

#[test]
fn a_nan_or_infinite_stride_angle_is_an_error() {
    let model = builtin_figure();
    for angle in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let message = stride_hypotheses(&model, angle).unwrap_err().to_string();
        assert!(message.contains("stride angle") && message.contains("finite number of radians"), "{message}");
    }
    let poses = stride_hypotheses(&model, 0.35).unwrap();
    assert!(poses.iter().all(|p| p.to_params().iter().all(|v| v.is_finite())));
}
