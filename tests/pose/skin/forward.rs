//! The forward: the rest pose, the hierarchy, the f64 reference, pose parameters, weights.

use super::*;

#[test]
fn rest_pose_reproduces_the_bind_pose() {
    for (seed, parents) in [(1, &CHAIN[..]), (2, &FOREST[..])] {
        let sm = synthetic(parents, 300, true, seed);
        let posed = sm.skin(&Pose::rest(sm.joint_count())).unwrap();
        for (p, q) in posed.iter().zip(sm.mesh.positions()) {
            assert!((*p - *q).length() < 1e-5, "{p} vs {q}");
        }
        // The rest joint transforms are the skeleton's rest world transforms.
        let g = sm.joint_transforms(&Pose::rest(sm.joint_count())).unwrap();
        assert_eq!(g, sm.skeleton.rest_world_transforms().unwrap());
        // A pose away from rest moves the vertices (the test above is not vacuous).
        let mut rng = SplitMix64::new(seed);
        let moved = sm.skin(&random_pose(&mut rng, sm.joint_count(), 0.5)).unwrap();
        assert!(moved.iter().zip(sm.mesh.positions()).any(|(p, q)| (*p - *q).length() > 0.05));
    }
}

#[test]
fn joint_transforms_follow_the_hierarchy() {
    let sm = synthetic(&FOREST, 30, false, 3);
    let mut rng = SplitMix64::new(33);
    let pose = random_pose(&mut rng, sm.joint_count(), 1.0);
    let g = sm.joint_transforms(&pose).unwrap();
    let sk = &sm.skeleton;
    let world = Mat4::from_translation(pose.translation) * Mat4::from_mat3(rodrigues(pose.orientation));
    for j in 0..sk.parents.len() {
        let r = &sk.rest[j];
        let local = Mat4::from_translation(r.translation)
            * Mat4::from_quat(r.rotation)
            * Mat4::from_mat3(rodrigues(pose.joint_rotations[j]))
            * Mat4::from_scale(r.scale);
        let expected = match sk.parents[j] {
            Some(p) => g[p] * local,
            None => world * sk.root_parent[j] * local,
        };
        assert!(g[j].abs_diff_eq(expected, 1e-5), "joint {j}: {} vs {expected}", g[j]);
    }
    // The cache sees the same transforms.
    let (_, cache) = sm.skin_with_cache(&pose).unwrap();
    assert_eq!(cache.joint_transforms(), g);
    assert_eq!(cache.pose(), &pose);
}

#[test]
fn skin_matches_the_reference_and_posed_mesh_shares_topology() {
    let sm = synthetic(&CHAIN, 200, false, 4);
    let mut rng = SplitMix64::new(44);
    let pose = random_pose(&mut rng, sm.joint_count(), 1.0);
    let params: Vec<f64> = pose.to_params().iter().map(|&x| x as f64).collect();
    let reference = reference_vertices(&sm, &params);
    let ours = sm.skin(&pose).unwrap();
    for (a, b) in ours.iter().zip(&reference) {
        assert!((a.as_dvec3() - *b).length() < 1e-5 * (1.0 + b.length()), "{a} vs {b}");
    }
    let mesh = sm.posed_mesh(&pose).unwrap();
    assert_eq!(mesh.positions(), &ours[..]);
    assert!(std::sync::Arc::ptr_eq(mesh.topology(), sm.mesh.topology()));
}

#[test]
fn pose_params_round_trip() {
    let mut rng = SplitMix64::new(5);
    let pose = random_pose(&mut rng, 7, 1.0);
    let params = pose.to_params();
    assert_eq!(params.len(), Pose::parameter_count(7));
    assert_eq!(Pose::parameter_count(7), 27);
    assert_eq!(&params[..3], &pose.joint_rotations[0].to_array());
    assert_eq!(&params[21..24], &pose.orientation.to_array());
    assert_eq!(&params[24..], &pose.translation.to_array());
    assert_eq!(Pose::from_params(&params, 7).unwrap(), pose);
    let rest = Pose::rest(3);
    assert_eq!(rest.to_params(), vec![0.0; 15]);
    assert_eq!(rest.joint_count(), 3);
}

#[test]
fn weights_are_renormalised() {
    let sm = synthetic(&CHAIN, 3, true, 6);
    let mut weights = sm.weights.clone();
    weights[0] = [0.5004, 0.5, 0.0, 0.0];
    weights[1] = [0.9992, 0.0, 0.0, 0.0];
    let joints = vec![[0, 1, 0, 0], [2, 0, 0, 0], sm.joints[2]];
    let fixed = SkinnedMesh::new(sm.mesh.clone(), sm.skeleton.clone(), joints, weights).unwrap();
    for w in &fixed.weights {
        let sum: f64 = w.iter().map(|&x| x as f64).sum();
        assert!((sum - 1.0).abs() < 1e-6, "{w:?}");
    }
    assert!(fixed.weights[0][0] > fixed.weights[0][1]);
    assert_eq!(fixed.weights[1], [1.0, 0.0, 0.0, 0.0]);
}
