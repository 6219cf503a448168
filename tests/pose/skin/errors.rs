//! Clear errors on bad poses, bindings, skeletons and backward inputs.

use super::*;

fn invalid_settings(result: Result<impl std::fmt::Debug, Error>, needle: &str) {
    match result {
        Err(Error::InvalidSettings(msg)) => assert!(msg.contains(needle), "message {msg:?} lacks {needle:?}"),
        other => panic!("expected InvalidSettings containing {needle:?}, got {other:?}"),
    }
}

fn length_mismatch(result: Result<impl std::fmt::Debug, Error>, expected_len: usize, got_len: usize) {
    match result {
        Err(Error::LengthMismatch { expected, got, .. }) => assert_eq!((expected, got), (expected_len, got_len)),
        other => panic!("expected LengthMismatch {expected_len} vs {got_len}, got {other:?}"),
    }
}

#[test]
fn bad_poses_are_errors() {
    let sm = synthetic(&CHAIN, 30, true, 20);
    let n = sm.joint_count();
    length_mismatch(sm.skin(&Pose::rest(n + 1)), n, n + 1);
    length_mismatch(sm.skin_with_cache(&Pose::rest(n - 1)), n, n - 1);
    length_mismatch(sm.joint_transforms(&Pose::rest(0)), n, 0);
    length_mismatch(Pose::from_params(&vec![0.0; 3 * n + 5], n), 3 * n + 6, 3 * n + 5);

    let mut pose = Pose::rest(n);
    pose.joint_rotations[2].y = f32::NAN;
    invalid_settings(sm.skin(&pose), "joint 2");
    let mut pose = Pose::rest(n);
    pose.orientation.x = f32::INFINITY;
    invalid_settings(sm.skin(&pose), "orientation");
    let mut pose = Pose::rest(n);
    pose.translation.z = f32::NEG_INFINITY;
    invalid_settings(sm.joint_transforms(&pose), "translation");
    let mut params = vec![0.0; 3 * n + 6];
    params[4] = f32::NAN;
    invalid_settings(Pose::from_params(&params, n), "parameter 4");
}

#[test]
fn bad_bindings_are_errors() {
    let sm = synthetic(&CHAIN, 30, true, 21);
    let (mesh, skeleton) = (sm.mesh.clone(), sm.skeleton.clone());
    let n = sm.joint_count();

    let mut joints = sm.joints.clone();
    joints[5] = [0, n as u16, 0, 0];
    invalid_settings(
        SkinnedMesh::new(mesh.clone(), skeleton.clone(), joints.clone(), sm.weights.clone()),
        "vertex 5 influence 1 uses joint 4",
    );
    // Also caught when the public fields are edited after construction.
    let mut edited = sm.clone();
    edited.joints = joints;
    invalid_settings(edited.skin(&Pose::rest(n)), "vertex 5");

    let mut weights = sm.weights.clone();
    weights[3] = [0.5, 0.2, 0.0, 0.0];
    invalid_settings(SkinnedMesh::new(mesh.clone(), skeleton.clone(), sm.joints.clone(), weights), "sum to");
    let mut weights = sm.weights.clone();
    weights[3] = [1.5, -0.5, 0.0, 0.0];
    invalid_settings(SkinnedMesh::new(mesh.clone(), skeleton.clone(), sm.joints.clone(), weights), "non-negative");
    let mut weights = sm.weights.clone();
    weights[3] = [f32::NAN, 1.0, 0.0, 0.0];
    invalid_settings(SkinnedMesh::new(mesh.clone(), skeleton.clone(), sm.joints.clone(), weights), "finite");

    length_mismatch(
        SkinnedMesh::new(mesh.clone(), skeleton.clone(), sm.joints[1..].to_vec(), sm.weights.clone()),
        30,
        29,
    );
    let mut weights = sm.weights.clone();
    weights.push([1.0, 0.0, 0.0, 0.0]);
    length_mismatch(SkinnedMesh::new(mesh.clone(), skeleton.clone(), sm.joints.clone(), weights), 30, 31);
}

#[test]
fn bad_skeletons_are_errors() {
    let sm = synthetic(&CHAIN, 30, true, 22);
    let n = sm.joint_count();
    let make = |skeleton: Skeleton| SkinnedMesh::new(sm.mesh.clone(), skeleton, sm.joints.clone(), sm.weights.clone());

    let mut sk = sm.skeleton.clone();
    sk.inverse_bind.pop();
    length_mismatch(make(sk), n, n - 1);
    let mut sk = sm.skeleton.clone();
    sk.names.push("extra".into());
    length_mismatch(sk.validate(), n, n + 1);
    let mut sk = sm.skeleton.clone();
    sk.rest.pop();
    length_mismatch(make(sk), n, n - 1);
    let mut sk = sm.skeleton.clone();
    sk.root_parent.clear();
    length_mismatch(sk.rest_world_transforms(), n, 0);

    let mut sk = sm.skeleton.clone();
    sk.parents[1] = Some(3);
    invalid_settings(make(sk), "joint 1 has parent 3");
    let mut sk = sm.skeleton.clone();
    sk.parents[2] = Some(2);
    invalid_settings(sk.validate(), "joint 2 has parent 2");
    let mut sk = sm.skeleton.clone();
    sk.rest[1].scale.x = f32::NAN;
    invalid_settings(make(sk), "joint 1");
    let mut sk = sm.skeleton.clone();
    sk.rest[1].rotation = Quat::from_xyzw(0.0, 0.0, 0.0, 2.0);
    invalid_settings(make(sk), "unit quaternion");
    let mut sk = sm.skeleton.clone();
    sk.inverse_bind[3].x_axis.y = f32::INFINITY;
    invalid_settings(make(sk), "inverse bind");
    let mut sk = sm.skeleton.clone();
    sk.root_parent[0].w_axis.x = f32::NAN;
    invalid_settings(make(sk), "root-parent");
    // Root-parent matrices of non-root joints are ignored.
    let mut sk = sm.skeleton.clone();
    sk.root_parent[1].w_axis.x = f32::NAN;
    assert!(sk.validate().is_ok());

    let empty = Skeleton {
        names: vec![],
        nodes: vec![],
        parents: vec![],
        rest: vec![],
        root_parent: vec![],
        inverse_bind: vec![],
    };
    invalid_settings(empty.validate(), "no joints");
    let mut degenerate = sm.skeleton.clone();
    degenerate.rest[0].scale = Vec3::new(1.0, 0.0, 1.0);
    invalid_settings(degenerate.set_inverse_bind_to_rest(), "singular");
}

#[test]
fn bad_backward_inputs_are_errors() {
    let sm = synthetic(&CHAIN, 30, true, 23);
    let other = synthetic(&FOREST, 30, true, 24);
    let n = sm.joint_count();
    let (_, cache) = sm.skin_with_cache(&Pose::rest(n)).unwrap();
    length_mismatch(sm.backward(&cache, &[Vec3::ONE; 29]), 30, 29);
    let mut d = vec![Vec3::ONE; 30];
    d[7].x = f32::NAN;
    invalid_settings(sm.backward(&cache, &d), "vertex 7");
    let (_, other_cache) = other.skin_with_cache(&Pose::rest(other.joint_count())).unwrap();
    invalid_settings(sm.backward(&other_cache, &[Vec3::ONE; 30]), "cache");
    assert!(sm.backward(&cache, &[Vec3::ONE; 30]).is_ok());
}
