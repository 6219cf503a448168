//! Joint scale factors (`Pose::joint_scales`, what glTF animations' scale channels sample to): the
//! forward against the f64 reference, `∂L/∂σ` with the rest of the pose against central finite
//! differences, the parameter and JSON layouts, and errors.

use super::*;

/// A random pose with joint translations and scale factors in [0.6, 1.5].
fn random_scaled_pose(rng: &mut SplitMix64, joint_count: usize) -> Pose {
    let mut pose = random_pose(rng, joint_count, 1.0);
    pose.joint_translations = (0..joint_count).map(|_| rng.vec3(-0.2, 0.2)).collect();
    pose.joint_scales = (0..joint_count).map(|_| rng.vec3(0.6, 1.5)).collect();
    pose
}

#[test]
fn scale_gradients_match_finite_differences() {
    // Rest scales are non-uniform (random_rest), so σ multiplies them component by component.
    for (parents, seed) in [(&CHAIN[..], 40), (&FOREST[..], 41)] {
        let sm = synthetic(parents, 150, false, seed);
        let mut rng = SplitMix64::new(400 + seed);
        for trial in 0..3 {
            let pose = random_scaled_pose(&mut rng, sm.joint_count());
            assert_fd(&sm, &pose, &mut rng, &format!("{} joints, scaled pose {trial}", parents.len()));
        }
    }
}

#[test]
fn scale_gradients_are_those_of_each_component() {
    // ∂L/∂σ alone, one component at a time, against a central difference of the reference.
    let sm = synthetic(&FOREST, 90, true, 42);
    let mut rng = SplitMix64::new(442);
    let pose = random_scaled_pose(&mut rng, sm.joint_count());
    let c: Vec<Vec3> = (0..sm.vertex_count()).map(|_| rng.vec3(-1.0, 1.0)).collect();
    let (_, cache) = sm.skin_with_cache(&pose).unwrap();
    let grad = sm.backward(&cache, &c).unwrap();
    assert_eq!(grad.joint_scales.len(), sm.joint_count());
    let params: Vec<f64> = pose.to_params().iter().map(|&x| x as f64).collect();
    let n = sm.joint_count();
    let h = 1e-6;
    for j in 0..n {
        for axis in 0..3 {
            let k = 6 * n + 6 + 3 * j + axis;
            let (mut plus, mut minus) = (params.clone(), params.clone());
            plus[k] += h;
            minus[k] -= h;
            let fd = (linear_loss(&reference_vertices(&sm, &plus), &c)
                - linear_loss(&reference_vertices(&sm, &minus), &c))
                / (2.0 * h);
            let analytic = grad.joint_scales[j][axis] as f64;
            assert!((analytic - fd).abs() <= 1e-4 * (1.0 + fd.abs()), "joint {j} axis {axis}: {analytic} vs {fd}");
        }
    }
}

#[test]
fn unit_scale_factors_are_no_scales_bit_for_bit() {
    let sm = synthetic(&FOREST, 60, false, 43);
    let mut rng = SplitMix64::new(443);
    let pose = random_pose(&mut rng, sm.joint_count(), 1.0);
    let plain = sm.skin(&pose).unwrap();
    assert_eq!(sm.skin(&pose.clone().with_joint_scales()).unwrap(), plain);
    // A pose without scales gets a gradient without them; one with gets one with.
    let (_, cache) = sm.skin_with_cache(&pose).unwrap();
    assert!(sm.backward(&cache, &vec![Vec3::ONE; sm.vertex_count()]).unwrap().joint_scales.is_empty());
    let (_, cache) = sm.skin_with_cache(&pose.clone().with_joint_scales()).unwrap();
    let grad = sm.backward(&cache, &vec![Vec3::ONE; sm.vertex_count()]).unwrap();
    assert_eq!(grad.to_params().len(), Pose::parameter_count_with_scales(sm.joint_count()));
}

#[test]
fn pose_parameters_with_joint_scales_round_trip() {
    let mut rng = SplitMix64::new(444);
    let pose = random_scaled_pose(&mut rng, 5);
    let params = pose.to_params();
    assert_eq!(params.len(), Pose::parameter_count_with_scales(5));
    assert_eq!(Pose::from_params(&params, 5).unwrap(), pose);
    // The first 3J + 6 values, and the translations after them, keep their meaning.
    let without = Pose { joint_scales: Vec::new(), ..pose.clone() };
    assert_eq!(&params[..Pose::parameter_count_with_translations(5)], &without.to_params()[..]);
    // Scales without translations flatten with zero translations, and read back with them.
    let scales_only = Pose { joint_translations: Vec::new(), ..pose.clone() };
    let flat = scales_only.to_params();
    assert_eq!(flat.len(), Pose::parameter_count_with_scales(5));
    assert!(flat[21..36].iter().all(|&t| t == 0.0));
    let back = Pose::from_params(&flat, 5).unwrap();
    assert_eq!(back.joint_translations, vec![Vec3::ZERO; 5]);
    assert_eq!(back.joint_scales, pose.joint_scales);
    // JSON keeps them (and leaves them out when there are none).
    let (read, betas) = Pose::from_json(&pose.to_json(&[0.5])).unwrap();
    assert_eq!((read, betas), (pose.clone(), vec![0.5]));
    assert!(!Pose::rest(5).to_json(&[]).contains("joint_scales"));
    assert!(matches!(Pose::from_params(&params[..params.len() - 3], 5), Err(Error::LengthMismatch { .. })));
}

#[test]
fn bad_joint_scales_are_clear_errors() {
    let sm = synthetic(&CHAIN, 30, false, 45);
    let mut pose = Pose::rest(sm.joint_count());
    pose.joint_scales = vec![Vec3::ONE; 2];
    assert!(matches!(sm.skin(&pose), Err(Error::LengthMismatch { .. })));
    pose.joint_scales = vec![Vec3::ONE; sm.joint_count()];
    pose.joint_scales[2].z = f32::NAN;
    let err = sm.skin(&pose).unwrap_err();
    assert!(err.to_string().contains("scale factor of joint 2"), "{err}");
    pose.joint_scales[2].z = 1e30;
    assert!(sm.skin(&pose).unwrap_err().to_string().contains("beyond"));
    let text = concat!(
        r#"{"format":"diffsil-pose-1","joint_rotations":[[0,0,0]],"joint_scales":[[1,1]],"#,
        r#""orientation":[0,0,0],"translation":[0,0,0]}"#
    );
    assert!(Pose::from_json(text).unwrap_err().to_string().contains("joint_scales"));
}
