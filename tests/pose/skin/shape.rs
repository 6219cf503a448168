//! Shaped skinning (morph targets, joints following the shape) with joint translations and scale
//! factors: the forward against an independent f64 reference, `∂L/∂β`, `∂L/∂τ` and `∂L/∂σ`
//! against central finite differences, the shaped rest pose, and errors.

use diffsil::pose::skin::MorphTargets;

use super::*;

/// `sm` with `count` random morph targets, and random joint offsets when `offsets`.
fn with_morphs(sm: SkinnedMesh, count: usize, offsets: bool, rng: &mut SplitMix64) -> SkinnedMesh {
    let (v, j) = (sm.vertex_count(), sm.joint_count());
    let morphs = MorphTargets {
        names: (0..count).map(|k| format!("shape{k}")).collect(),
        deltas: (0..count).map(|_| (0..v).map(|_| rng.vec3(-0.2, 0.2)).collect()).collect(),
        joint_offsets: offsets.then(|| (0..count).map(|_| (0..j).map(|_| rng.vec3(-0.1, 0.1)).collect()).collect()),
    };
    sm.with_morph_targets(morphs).unwrap()
}

/// Shaped skinning evaluated independently of the crate, in f64, by another route: the shaped
/// rest world transforms are `T(Δp_j)·G⁰_j`, each shaped local rest transform is
/// `G'⁰_parent⁻¹ · G'⁰_j`, and the pose enters as `T(τ_j) · local'_j · S⁻¹ · R(θ_j) · S(s ⊙ σ_j)`.
/// `params` has the layout of `Pose::to_params` with joint translations (`6n + 6`), or with
/// joint translations and scale factors `σ` (`9n + 6`).
fn reference_shaped(sm: &SkinnedMesh, params: &[f64], betas: &[f64]) -> Vec<DVec3> {
    let sk = &sm.skeleton;
    let n = sk.parents.len();
    assert!(params.len() == 6 * n + 6 || params.len() == 9 * n + 6, "{} parameters", params.len());
    let v3 = |i: usize| DVec3::new(params[i], params[i + 1], params[i + 2]);
    let offset = |j: usize| -> DVec3 {
        match &sm.morphs.joint_offsets {
            Some(o) => (0..betas.len()).map(|k| o[k][j].as_dvec3() * betas[k]).sum(),
            None => DVec3::ZERO,
        }
    };
    let rest_local = |j: usize| {
        let r = &sk.rest[j];
        DMat4::from_translation(r.translation.as_dvec3())
            * DMat4::from_quat(r.rotation.as_dquat().normalize())
            * DMat4::from_scale(r.scale.as_dvec3())
    };
    let mut rest_global: Vec<DMat4> = Vec::with_capacity(n);
    for j in 0..n {
        let g = match sk.parents[j] {
            Some(p) => rest_global[p] * rest_local(j),
            None => sk.root_parent[j].as_dmat4() * rest_local(j),
        };
        rest_global.push(g);
    }
    let shaped_rest: Vec<DMat4> = (0..n).map(|j| DMat4::from_translation(offset(j)) * rest_global[j]).collect();
    let world = DMat4::from_translation(v3(3 * n + 3)) * glam_rotation(v3(3 * n));
    let mut global: Vec<DMat4> = Vec::with_capacity(n);
    for j in 0..n {
        let parent_rest = match sk.parents[j] {
            Some(p) => shaped_rest[p],
            None => sk.root_parent[j].as_dmat4(),
        };
        let scale = DMat4::from_scale(sk.rest[j].scale.as_dvec3());
        let sigma = if params.len() == 9 * n + 6 { v3(6 * n + 6 + 3 * j) } else { DVec3::ONE };
        let local = DMat4::from_translation(v3(3 * n + 6 + 3 * j))
            * (parent_rest.inverse() * shaped_rest[j])
            * scale.inverse()
            * glam_rotation(v3(3 * j))
            * DMat4::from_scale(sk.rest[j].scale.as_dvec3() * sigma);
        let g = match sk.parents[j] {
            Some(p) => global[p] * local,
            None => world * sk.root_parent[j].as_dmat4() * local,
        };
        global.push(g);
    }
    let skinning: Vec<DMat4> =
        (0..n).map(|j| global[j] * sk.inverse_bind[j].as_dmat4() * DMat4::from_translation(-offset(j))).collect();
    (0..sm.vertex_count())
        .map(|i| {
            let p = sm.mesh.positions()[i].as_dvec3()
                + (0..betas.len()).map(|k| sm.morphs.deltas[k][i].as_dvec3() * betas[k]).sum::<DVec3>();
            let (js, ws) = (sm.joints[i], sm.weights[i]);
            (0..4).map(|k| skinning[js[k] as usize].transform_point3(p) * ws[k] as f64).sum::<DVec3>()
        })
        .collect()
}

fn random_translated_pose(rng: &mut SplitMix64, joint_count: usize) -> Pose {
    let mut pose = random_pose(rng, joint_count, 1.0);
    pose.joint_translations = (0..joint_count).map(|_| rng.vec3(-0.2, 0.2)).collect();
    pose
}

/// Checks the forward against [`reference_shaped`] and `∂L/∂(pose, τ, β)` of `L = Σ c_i·v_i`
/// against central finite differences of it; returns the worst relative errors.
fn check_shaped(sm: &SkinnedMesh, pose: &Pose, betas: &[f32], rng: &mut SplitMix64, label: &str) {
    let n = sm.joint_count();
    let c: Vec<Vec3> = (0..sm.vertex_count()).map(|_| rng.vec3(-1.0, 1.0)).collect();
    let (vertices, cache) = sm.skin_shaped_with_cache(pose, betas).unwrap();
    let params: Vec<f64> = pose.clone().with_joint_translations().to_params().iter().map(|&x| x as f64).collect();
    let b64: Vec<f64> = betas.iter().map(|&b| b as f64).collect();
    let reference = reference_shaped(sm, &params, &b64);
    let forward = vertices
        .iter()
        .zip(&reference)
        .map(|(v, r)| (v.as_dvec3() - *r).length() / (1.0 + r.length()))
        .fold(0.0, f64::max);
    assert!(forward <= 1e-5, "{label}: forward differs from the reference by {forward}");

    let (grad, d_betas) = sm.backward_with_shape(&cache, &c).unwrap();
    assert_eq!(grad.joint_translations.len(), n, "{label}: a pose with translations gets their gradient");
    assert_eq!(d_betas.len(), sm.shape_count());
    let mut g: Vec<f64> = grad.to_params().iter().map(|&x| x as f64).collect();
    g.extend(d_betas.iter().map(|&x| x as f64));
    let mut x = params.clone();
    x.extend(&b64);
    let split = params.len();
    let loss_at = |x: &[f64]| linear_loss(&reference_shaped(sm, &x[..split], &x[split..]), &c);
    let h = 1e-5;
    let fd: Vec<f64> = (0..x.len())
        .map(|k| {
            let (mut plus, mut minus) = (x.clone(), x.clone());
            plus[k] += h;
            minus[k] -= h;
            (loss_at(&plus) - loss_at(&minus)) / (2.0 * h)
        })
        .collect();
    let norm = fd.iter().map(|v| v * v).sum::<f64>().sqrt();
    let group = |range: std::ops::Range<usize>| {
        let diff = range.clone().map(|k| (g[k] - fd[k]).powi(2)).sum::<f64>().sqrt();
        let scale = range.map(|k| fd[k] * fd[k]).sum::<f64>().sqrt().max(1e-3 * norm);
        diff / scale
    };
    let (rotations, translations, shape) = (group(0..3 * n + 6), group(3 * n + 6..6 * n + 6), group(split..x.len()));
    let scales = if split > 6 * n + 6 { group(6 * n + 6..split) } else { 0.0 };
    println!(
        "{label}: forward {forward:.1e}, pose {rotations:.1e}, τ {translations:.1e}, σ {scales:.1e}, β {shape:.1e}"
    );
    assert!(rotations <= 1e-3, "{label}: pose gradient vs finite differences: {rotations}");
    assert!(translations <= 1e-3, "{label}: joint translation gradient vs finite differences: {translations}");
    assert!(scales <= 1e-3, "{label}: joint scale gradient vs finite differences: {scales}");
    assert!(shape <= 1e-3, "{label}: ∂L/∂β vs finite differences: {shape}");
}

#[test]
fn shaped_backward_matches_finite_differences_with_joint_offsets() {
    let mut rng = SplitMix64::new(300);
    for (parents, glb_ibm, label) in [(&CHAIN[..], false, "chain"), (&FOREST[..], true, "forest")] {
        let sm = with_morphs(synthetic(parents, 90, glb_ibm, 30), 3, true, &mut rng);
        for trial in 0..2 {
            let pose = random_translated_pose(&mut rng, sm.joint_count());
            let betas: Vec<f32> = (0..3).map(|_| rng.range_f64(-1.0, 1.0) as f32).collect();
            check_shaped(&sm, &pose, &betas, &mut rng, &format!("{label}, offsets, trial {trial}"));
        }
        // At β = 0 the gradient with respect to β still has every term.
        let pose = random_translated_pose(&mut rng, sm.joint_count());
        check_shaped(&sm, &pose, &[0.0; 3], &mut rng, &format!("{label}, offsets, β = 0"));
    }
}

#[test]
fn shaped_backward_matches_finite_differences_with_joint_scales() {
    // β, joint offsets and joint scale factors together: the shape's joint shifts are in the
    // parent's frame, so a scaled parent scales them with its bone.
    let mut rng = SplitMix64::new(307);
    let sm = with_morphs(synthetic(&FOREST, 90, false, 36), 3, true, &mut rng);
    for trial in 0..2 {
        let mut pose = random_translated_pose(&mut rng, sm.joint_count());
        pose.joint_scales = (0..sm.joint_count()).map(|_| rng.vec3(0.6, 1.5)).collect();
        let betas: Vec<f32> = (0..3).map(|_| rng.range_f64(-1.0, 1.0) as f32).collect();
        check_shaped(&sm, &pose, &betas, &mut rng, &format!("forest, offsets and scales, trial {trial}"));
    }
}

#[test]
fn shaped_backward_matches_finite_differences_without_joint_offsets() {
    let mut rng = SplitMix64::new(301);
    let sm = with_morphs(synthetic(&FOREST, 90, false, 31), 4, false, &mut rng);
    let pose = random_translated_pose(&mut rng, sm.joint_count());
    let betas: Vec<f32> = (0..4).map(|_| rng.range_f64(-1.0, 1.0) as f32).collect();
    check_shaped(&sm, &pose, &betas, &mut rng, "forest, no offsets");
    // Without offsets the joints stay put whatever β.
    let rest = Pose::rest(sm.joint_count());
    assert_eq!(sm.joint_transforms_shaped(&rest, &betas).unwrap(), sm.joint_transforms(&rest).unwrap());
}

#[test]
fn shaped_backward_on_many_vertices_is_deterministic() {
    let mut rng = SplitMix64::new(302);
    let sm = with_morphs(synthetic(&FOREST, 20_000, false, 32), 2, true, &mut rng);
    let pose = random_translated_pose(&mut rng, sm.joint_count());
    let c: Vec<Vec3> = (0..sm.vertex_count()).map(|_| rng.vec3(-1.0, 1.0)).collect();
    let (_, cache) = sm.skin_shaped_with_cache(&pose, &[0.3, -0.7]).unwrap();
    let first = sm.backward_with_shape(&cache, &c).unwrap();
    for _ in 0..3 {
        assert_eq!(sm.backward_with_shape(&cache, &c).unwrap(), first);
    }
}

#[test]
fn zero_shape_is_the_unshaped_skin_bit_for_bit() {
    let mut rng = SplitMix64::new(303);
    let sm = with_morphs(synthetic(&FOREST, 60, false, 33), 3, true, &mut rng);
    let pose = random_pose(&mut rng, sm.joint_count(), 1.0);
    let plain = sm.skin(&pose).unwrap();
    assert_eq!(sm.skin_shaped(&pose, &[]).unwrap(), plain);
    assert_eq!(sm.skin_shaped(&pose, &[0.0; 3]).unwrap(), plain);
    // Zero joint translations are no translations.
    assert_eq!(sm.skin(&pose.clone().with_joint_translations()).unwrap(), plain);
    // A pose without translations gets a gradient without them, with the old layout.
    let (_, cache) = sm.skin_with_cache(&pose).unwrap();
    let grad = sm.backward(&cache, &vec![Vec3::ONE; sm.vertex_count()]).unwrap();
    assert!(grad.joint_translations.is_empty());
    assert_eq!(grad.to_params().len(), Pose::parameter_count(sm.joint_count()));
}

#[test]
fn shaped_rest_pose_is_the_shaped_bind_mesh_with_moved_joints() {
    let mut rng = SplitMix64::new(304);
    let sm = with_morphs(synthetic(&FOREST, 60, true, 34), 2, true, &mut rng);
    let betas = [0.8f32, -0.5];
    let rest = Pose::rest(sm.joint_count());
    let posed = sm.skin_shaped(&rest, &betas).unwrap();
    for (i, p) in posed.iter().enumerate() {
        let expected = sm.mesh.positions()[i] + betas[0] * sm.morphs.deltas[0][i] + betas[1] * sm.morphs.deltas[1][i];
        assert!((*p - expected).length() < 1e-4, "vertex {i}: {p} vs {expected}");
    }
    let offsets = sm.morphs.joint_offsets.as_ref().unwrap();
    let plain = sm.joint_transforms(&rest).unwrap();
    let shaped = sm.joint_transforms_shaped(&rest, &betas).unwrap();
    for j in 0..sm.joint_count() {
        let moved = shaped[j].w_axis.truncate() - plain[j].w_axis.truncate();
        let expected = betas[0] * offsets[0][j] + betas[1] * offsets[1][j];
        assert!((moved - expected).length() < 1e-5, "joint {j} moved by {moved}, expected {expected}");
        // Rotations and scales are unchanged.
        assert!(Mat3::from_mat4(shaped[j]).abs_diff_eq(Mat3::from_mat4(plain[j]), 1e-5), "joint {j}");
    }
}

#[test]
fn pose_parameters_with_joint_translations_round_trip() {
    let mut rng = SplitMix64::new(305);
    let pose = random_translated_pose(&mut rng, 5);
    let params = pose.to_params();
    assert_eq!(params.len(), Pose::parameter_count_with_translations(5));
    assert_eq!(Pose::from_params(&params, 5).unwrap(), pose);
    // The first 3J + 6 values keep their meaning.
    let without = Pose { joint_translations: Vec::new(), ..pose.clone() };
    assert_eq!(&params[..Pose::parameter_count(5)], &without.to_params()[..]);
    assert!(matches!(Pose::from_params(&params[..params.len() - 1], 5), Err(Error::LengthMismatch { .. })));
}

#[test]
fn bad_shapes_and_translations_are_clear_errors() {
    let mut rng = SplitMix64::new(306);
    let sm = with_morphs(synthetic(&CHAIN, 30, false, 35), 2, true, &mut rng);
    let rest = Pose::rest(sm.joint_count());
    let err = sm.skin_shaped(&rest, &[1.0]).unwrap_err();
    assert!(matches!(err, Error::LengthMismatch { expected: 2, got: 1, .. }), "{err}");
    let err = sm.skin_shaped(&rest, &[0.0, f32::NAN]).unwrap_err();
    assert!(err.to_string().contains("β_1"), "{err}");
    let mut pose = rest.clone();
    pose.joint_translations = vec![Vec3::ZERO; 2];
    assert!(matches!(sm.skin(&pose), Err(Error::LengthMismatch { .. })));
    pose.joint_translations = vec![Vec3::ZERO; sm.joint_count()];
    pose.joint_translations[1].y = f32::INFINITY;
    assert!(sm.skin(&pose).unwrap_err().to_string().contains("joint 1"));
    // Morph tables that do not fit the mesh or the skeleton.
    let mut bad = sm.morphs.clone();
    bad.deltas[1].pop();
    assert!(matches!(sm.clone().with_morph_targets(bad), Err(Error::LengthMismatch { .. })));
    let mut bad = sm.morphs.clone();
    bad.joint_offsets.as_mut().unwrap()[0].push(Vec3::ZERO);
    assert!(matches!(sm.clone().with_morph_targets(bad), Err(Error::LengthMismatch { .. })));
    let mut broken = sm.clone();
    broken.morphs.deltas[0][3].x = f32::NAN;
    assert!(broken.skin_shaped(&rest, &[0.5, 0.5]).unwrap_err().to_string().contains("vertex 3"));
    // Infinities too, in any coordinate and target, found by the forward and the backward alike.
    let mut broken = sm.clone();
    broken.morphs.deltas[1][17].z = f32::NEG_INFINITY;
    let err = broken.skin_shaped(&rest, &[0.5, 0.5]).unwrap_err().to_string();
    assert!(err.contains("morph target 1") && err.contains("vertex 17"), "{err}");
    let (vertices, cache) = sm.skin_shaped_with_cache(&rest, &[0.5, 0.5]).unwrap();
    let err = broken.backward_with_shape(&cache, &vertices).unwrap_err().to_string();
    assert!(err.contains("vertex 17"), "{err}");
}
