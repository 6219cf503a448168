//! The analytic backward against central finite differences of the f64 reference.

use super::*;

#[test]
fn backward_matches_finite_differences_on_a_chain() {
    let sm = synthetic(&CHAIN, 120, false, 10);
    let mut rng = SplitMix64::new(100);
    for trial in 0..4 {
        let pose = random_pose(&mut rng, sm.joint_count(), 1.0);
        assert_fd(&sm, &pose, &mut rng, &format!("chain, pose {trial}"));
    }
}

#[test]
fn backward_matches_finite_differences_on_a_forest() {
    let sm = synthetic(&FOREST, 150, false, 11);
    let mut rng = SplitMix64::new(101);
    for trial in 0..4 {
        let pose = random_pose(&mut rng, sm.joint_count(), 1.0);
        assert_fd(&sm, &pose, &mut rng, &format!("forest, pose {trial}"));
    }
}

#[test]
fn backward_matches_finite_differences_at_rest_and_tiny_angles() {
    let sm = synthetic(&FOREST, 100, true, 12);
    let mut rng = SplitMix64::new(102);
    assert_fd(&sm, &Pose::rest(sm.joint_count()), &mut rng, "forest, rest pose");
    // Some joints exactly at zero, some at tiny angles (the series branch), some large.
    let mut pose = random_pose(&mut rng, sm.joint_count(), 1.0);
    pose.joint_rotations[0] = Vec3::ZERO;
    pose.joint_rotations[2] = Vec3::new(1e-4, -2e-4, 3e-5);
    pose.orientation = Vec3::new(0.0, 0.01, 0.0);
    assert_fd(&sm, &pose, &mut rng, "forest, zero and tiny angles");
}

#[test]
fn backward_on_many_vertices_is_deterministic_and_correct() {
    // More vertices than one block of the backward's sums and than the parallel threshold.
    let sm = synthetic(&FOREST, 40_000, false, 13);
    let mut rng = SplitMix64::new(103);
    let pose = random_pose(&mut rng, sm.joint_count(), 1.0);
    let report = assert_fd(&sm, &pose, &mut rng, "forest, 40k vertices");
    assert!(report.whole.is_finite());
    let c: Vec<Vec3> = (0..40_000).map(|_| rng.vec3(-1.0, 1.0)).collect();
    let (_, cache) = sm.skin_with_cache(&pose).unwrap();
    let first = sm.backward(&cache, &c).unwrap();
    for _ in 0..3 {
        assert_eq!(sm.backward(&cache, &c).unwrap(), first);
    }
}
