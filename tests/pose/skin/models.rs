//! The backward against finite differences on the built-in figure and, ignored by default, the
//! rigged models in `$DIFFSIL_ASSETS`.

use super::*;

fn asset(name: &str) -> std::path::PathBuf {
    let dir = std::env::var_os("DIFFSIL_ASSETS").expect("set DIFFSIL_ASSETS to the folder holding the test assets");
    std::path::Path::new(&dir).join(name)
}

fn load_skinned(name: &str) -> SkinnedMesh {
    match diffsil::io::gltf::load_gltf(asset(name)).unwrap() {
        diffsil::io::gltf::Model::Skinned(skinned) => skinned,
        diffsil::io::gltf::Model::Static(_) => panic!("{name} loaded without its skin"),
    }
}

/// Finite-difference checks of the backward on a real model at its rest pose and random poses.
fn check_model(sm: &SkinnedMesh, label: &str, seed: u64) {
    let mut rng = SplitMix64::new(seed);
    assert_fd(sm, &Pose::rest(sm.joint_count()), &mut rng, &format!("{label}, rest pose"));
    for trial in 0..3 {
        let pose = random_pose(&mut rng, sm.joint_count(), 1.0);
        assert_fd(sm, &pose, &mut rng, &format!("{label}, pose {trial}"));
    }
}

#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn backward_matches_finite_differences_on_rigged_simple() {
    check_model(&load_skinned("RiggedSimple.glb"), "RiggedSimple", 500);
}

#[test]
#[ignore = "needs DIFFSIL_ASSETS"]
fn backward_matches_finite_differences_on_rigged_figure() {
    check_model(&load_skinned("RiggedFigure.glb"), "RiggedFigure", 501);
}

#[test]
fn backward_matches_finite_differences_on_the_builtin_figure() {
    let figure = diffsil::pose::figure::builtin_figure();
    // The figure's inverse bind matrices follow the glTF convention: the rest pose is the mesh.
    let rest = figure.skin(&Pose::rest(figure.joint_count())).unwrap();
    let worst = rest.iter().zip(figure.mesh.positions()).map(|(a, b)| (*a - *b).length()).fold(0.0, f32::max);
    assert!(worst < 1e-5, "the rest pose moves the built-in figure by {worst}");
    check_model(&figure, "built-in figure", 502);
}
