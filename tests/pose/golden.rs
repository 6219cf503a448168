//! Golden hashes: the bits of images, gradients, losses and fitted poses on the test scenes,
//! recorded before the redesign (#10) and compared after it. Any change to the arithmetic of a
//! stage changes a hash. `DIFFSIL_GOLDEN_PRINT=1` prints the table instead of comparing.
//!
//! Here: the pose fit (the renderer's are in `tests/cpu` and `tests/gpu`); the shared machinery is `common::golden`.

use crate::common::golden::Hash;
use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{framing_cameras, random_pose, FitSettings, PoseFit};
use diffsil::pose::skin::Pose;
use diffsil::{Mesh, RenderSettings, Renderer};

/// A few steps of the pose fit on the built-in figure at 32², CPU.
fn pose_fit_hash() -> u64 {
    let model = builtin_figure();
    let limits = random_pose_limits(&model.skeleton);
    let truth = random_pose(&limits, 30f32.to_radians(), 5);
    let cameras = framing_cameras(&model.mesh, 4, 32);
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let truth_mesh = Mesh::with_topology(model.skin(&truth).unwrap(), model.mesh.topology().clone()).unwrap();
    let targets = renderer.render(&truth_mesh, &cameras).unwrap().images().to_vec();
    let settings = FitSettings {
        initial: Some(Pose::rest(model.joint_count())),
        learning_rate: 0.02,
        lambda: 1e-7,
        ..FitSettings::default()
    };
    let mut fit = PoseFit::new(model, cameras, targets, renderer, settings).unwrap();
    let mut h = Hash::new();
    for _ in 0..5 {
        let report = fit.step().unwrap();
        h.f64(report.silhouette);
    }
    h.floats(fit.pose().to_params());
    h.0
}

const POSE_FIT: u64 = 0x97ac115f3f6b93bf;

#[test]
fn pose_fit_matches_its_golden_hash() {
    let h = pose_fit_hash();
    if std::env::var("DIFFSIL_GOLDEN_PRINT").is_ok() {
        println!("const POSE_FIT: u64 = 0x{h:016x};");
        return;
    }
    assert_eq!(h, POSE_FIT, "pose fit changed bits");
}
