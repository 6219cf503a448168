//! Pose fitting end to end on the built-in figure: a short fit lowers the error.

use diffsil::figure::{builtin_figure, joint_kinds};
use diffsil::fit::{framing_cameras, per_vertex_error, random_pose, PoseFit};
use diffsil::skin::Pose;
use diffsil::{Error, Image, Mesh, RenderSettings, Renderer};

#[test]
fn a_short_fit_reduces_the_silhouette_error_and_the_vertex_error() {
    let model = builtin_figure();
    let limits: Vec<f32> = joint_kinds(&model.skeleton).iter().map(|k| k.random_pose_limit()).collect();
    let truth = random_pose(&limits, 30f32.to_radians(), 7);
    let truth_vertices = model.skin(&truth).unwrap();
    let cameras = framing_cameras(&model.mesh, 4, 48);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let truth_mesh = Mesh::with_topology(truth_vertices.clone(), model.mesh.topology().clone()).unwrap();
    let targets = renderer.render(&truth_mesh, &cameras).unwrap().images().to_vec();

    let rest = Pose::rest(model.joint_count());
    let mut fit = PoseFit::new(model.clone(), cameras, targets, renderer, &rest, 0.02, 0.001).unwrap();
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
fn fit_rejects_mismatched_targets_and_bad_rates() {
    let model = builtin_figure();
    let cameras = framing_cameras(&model.mesh, 2, 16);
    let rest = Pose::rest(model.joint_count());
    let renderer = || Renderer::new(RenderSettings::default()).unwrap();
    let one = vec![Image::filled(16, 16, 0.0)];
    let err = PoseFit::new(model.clone(), cameras.clone(), one, renderer(), &rest, 0.01, 0.0).err().unwrap();
    assert!(matches!(err, Error::ViewCountMismatch { .. }), "{err}");
    let wrong_size = vec![Image::filled(8, 16, 0.0); 2];
    let err = PoseFit::new(model.clone(), cameras.clone(), wrong_size, renderer(), &rest, 0.01, 0.0).err().unwrap();
    assert!(matches!(err, Error::SizeMismatch { .. }), "{err}");
    let targets = vec![Image::filled(16, 16, 0.0); 2];
    assert!(PoseFit::new(model, cameras, targets, renderer(), &rest, f32::NAN, 0.0).is_err());
}
