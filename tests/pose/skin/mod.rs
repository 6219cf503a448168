//! Linear-blend skinning: Rodrigues' formula and its derivative, the forward against an independent
//! f64 reference, the rest pose under the glTF convention, the analytic backward against central
//! finite differences of that reference, and clear errors on bad input.

use diffsil::pose::skin::{
    rodrigues, rodrigues_derivative, rodrigues_derivative_f64, rodrigues_f64, JointRest, Pose, Skeleton, SkinnedMesh,
};
use diffsil::{Error, Mesh};
use glam::{DMat3, DMat4, DVec3, Mat3, Mat4, Quat, Vec3};

// ---------------------------------------------------------------------------------------------
// Helpers

/// SplitMix64: a tiny deterministic generator (no dev-dependency needed).
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    fn direction(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
    fn vec3(&mut self, lo: f64, hi: f64) -> Vec3 {
        Vec3::new(self.range(lo, hi) as f32, self.range(lo, hi) as f32, self.range(lo, hi) as f32)
    }
    /// Axis–angle with a random axis and an angle uniform in [0, max_angle].
    fn axis_angle(&mut self, max_angle: f64) -> Vec3 {
        (self.direction() * self.range(0.0, max_angle)).as_vec3()
    }
    fn quat(&mut self, max_angle: f64) -> Quat {
        Quat::from_axis_angle(self.direction().as_vec3(), self.range(-max_angle, max_angle) as f32)
    }
}

fn max_abs3(a: &DMat3, b: &DMat3) -> f64 {
    (0..3).map(|c| (a.col(c) - b.col(c)).abs().max_element()).fold(0.0, f64::max)
}

fn skew(v: DVec3) -> DMat3 {
    DMat3::from_cols(DVec3::new(0.0, v.z, -v.y), DVec3::new(-v.z, 0.0, v.x), DVec3::new(v.y, -v.x, 0.0))
}

/// Rotation of an axis–angle vector through glam (independent of the crate's Rodrigues).
fn glam_rotation(v: DVec3) -> DMat4 {
    let t = v.length();
    if t == 0.0 {
        DMat4::IDENTITY
    } else {
        DMat4::from_axis_angle(v / t, t)
    }
}

/// The skinning model evaluated independently of the crate, in f64, at flat pose parameters
/// (layout of `Pose::to_params`).
fn reference_vertices(sm: &SkinnedMesh, params: &[f64]) -> Vec<DVec3> {
    let sk = &sm.skeleton;
    let n = sk.parents.len();
    assert_eq!(params.len(), 3 * n + 6);
    let v3 = |i: usize| DVec3::new(params[i], params[i + 1], params[i + 2]);
    let world = DMat4::from_translation(v3(3 * n + 3)) * glam_rotation(v3(3 * n));
    let mut global: Vec<DMat4> = Vec::with_capacity(n);
    for j in 0..n {
        let r = &sk.rest[j];
        let local = DMat4::from_translation(r.translation.as_dvec3())
            * DMat4::from_quat(r.rotation.as_dquat().normalize())
            * glam_rotation(v3(3 * j))
            * DMat4::from_scale(r.scale.as_dvec3());
        let g = match sk.parents[j] {
            Some(p) => global[p] * local,
            None => world * sk.root_parent[j].as_dmat4() * local,
        };
        global.push(g);
    }
    let skinning: Vec<DMat4> = global.iter().zip(&sk.inverse_bind).map(|(g, ibm)| *g * ibm.as_dmat4()).collect();
    sm.mesh
        .positions()
        .iter()
        .zip(&sm.joints)
        .zip(&sm.weights)
        .map(|((p, js), ws)| {
            (0..4).map(|k| skinning[js[k] as usize].transform_point3(p.as_dvec3()) * ws[k] as f64).sum::<DVec3>()
        })
        .collect()
}

fn linear_loss(vertices: &[DVec3], c: &[Vec3]) -> f64 {
    vertices.iter().zip(c).map(|(v, c)| v.dot(c.as_dvec3())).sum()
}

/// Rest transforms with translation, rotation and non-uniform scale.
fn random_rest(rng: &mut Rng) -> JointRest {
    JointRest {
        translation: rng.vec3(-0.4, 0.4) + Vec3::new(0.0, 0.5, 0.0),
        rotation: rng.quat(1.2),
        scale: rng.vec3(0.7, 1.4),
    }
}

/// A synthetic skinned mesh: the given hierarchy with random rest transforms, non-identity
/// root-parent matrices (garbage for non-roots, which must be ignored), inverse bind matrices that
/// are the glTF ones times a random affine (`glb_ibm` false) or exactly the glTF ones, and random
/// vertices with 1–4 random influences each.
fn synthetic(parents: &[Option<usize>], vertex_count: usize, glb_ibm: bool, seed: u64) -> SkinnedMesh {
    let mut rng = Rng(seed);
    let n = parents.len();
    let rest: Vec<JointRest> = (0..n).map(|_| random_rest(&mut rng)).collect();
    let root_parent: Vec<Mat4> = (0..n)
        .map(|_| Mat4::from_scale_rotation_translation(rng.vec3(0.8, 1.3), rng.quat(1.0), rng.vec3(-0.3, 0.3)))
        .collect();
    let mut skeleton = Skeleton {
        names: (0..n).map(|j| format!("joint{j}")).collect(),
        parents: parents.to_vec(),
        rest,
        root_parent,
        inverse_bind: vec![Mat4::IDENTITY; n],
    };
    skeleton.set_inverse_bind_to_rest().unwrap();
    if !glb_ibm {
        for ibm in &mut skeleton.inverse_bind {
            *ibm *= Mat4::from_scale_rotation_translation(rng.vec3(0.9, 1.1), rng.quat(0.3), rng.vec3(-0.2, 0.2));
        }
    }
    let positions: Vec<Vec3> = (0..vertex_count).map(|_| rng.vec3(-1.0, 1.0) + Vec3::new(0.0, 1.0, 0.0)).collect();
    let triangles: Vec<[u32; 3]> = (0..vertex_count as u32 / 3).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
    let mut joints = Vec::with_capacity(vertex_count);
    let mut weights = Vec::with_capacity(vertex_count);
    for _ in 0..vertex_count {
        let count = 1 + rng.below(4.min(n));
        let mut js = [0u16; 4];
        let mut ws = [0f32; 4];
        let mut chosen: Vec<usize> = Vec::new();
        while chosen.len() < count {
            let j = rng.below(n);
            if !chosen.contains(&j) {
                chosen.push(j);
            }
        }
        let raw: Vec<f64> = (0..count).map(|_| rng.range(0.05, 1.0)).collect();
        let sum: f64 = raw.iter().sum();
        for k in 0..count {
            js[k] = chosen[k] as u16;
            ws[k] = (raw[k] / sum) as f32;
        }
        joints.push(js);
        weights.push(ws);
    }
    SkinnedMesh::new(Mesh::new(positions, triangles).unwrap(), skeleton, joints, weights).unwrap()
}

fn random_pose(rng: &mut Rng, joint_count: usize, max_angle: f64) -> Pose {
    Pose {
        joint_rotations: (0..joint_count).map(|_| rng.axis_angle(max_angle)).collect(),
        orientation: rng.axis_angle(max_angle),
        translation: rng.vec3(-1.0, 1.0),
    }
}

/// Errors of the analytic gradient against central differences of the f64 reference.
#[derive(Debug)]
struct FdReport {
    /// ‖g − g_fd‖ / ‖g_fd‖ over the whole gradient.
    whole: f64,
    /// Worst |g·d − fd_d| / max(|fd_d|, 1e-2·‖g_fd‖) over random unit directions d.
    directional: f64,
    /// Worst |crate forward − reference| / (1 + |reference|) over the vertices.
    forward: f64,
}

/// Checks the backward of `L = Σ c_i·v_i` at `pose` against central finite differences.
fn fd_check(sm: &SkinnedMesh, pose: &Pose, rng: &mut Rng, directions: usize) -> FdReport {
    let c: Vec<Vec3> = (0..sm.mesh.positions().len()).map(|_| rng.vec3(-1.0, 1.0)).collect();
    let (vertices, cache) = sm.skin_with_cache(pose).unwrap();
    let params: Vec<f64> = pose.to_params().iter().map(|&x| x as f64).collect();
    let reference = reference_vertices(sm, &params);
    let forward = vertices
        .iter()
        .zip(&reference)
        .map(|(v, r)| (v.as_dvec3() - *r).length() / (1.0 + r.length()))
        .fold(0.0, f64::max);

    let grad = sm.backward(&cache, &c).unwrap();
    assert_eq!(grad.joint_rotations.len(), sm.joint_count());
    let g: Vec<f64> = grad.to_params().iter().map(|&x| x as f64).collect();
    assert_eq!(g.len(), Pose::parameter_count(sm.joint_count()));
    assert!(g.iter().all(|x| x.is_finite()), "{g:?}");

    let h = 1e-5;
    let loss_at = |p: &[f64]| linear_loss(&reference_vertices(sm, p), &c);
    let fd: Vec<f64> = (0..params.len())
        .map(|k| {
            let mut plus = params.clone();
            let mut minus = params.clone();
            plus[k] += h;
            minus[k] -= h;
            (loss_at(&plus) - loss_at(&minus)) / (2.0 * h)
        })
        .collect();
    let norm_fd = fd.iter().map(|x| x * x).sum::<f64>().sqrt();
    let diff = g.iter().zip(&fd).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
    let whole = diff / norm_fd;

    let mut directional: f64 = 0.0;
    for _ in 0..directions {
        let d: Vec<f64> = (0..params.len()).map(|_| rng.range(-1.0, 1.0)).collect();
        let dn = d.iter().map(|x| x * x).sum::<f64>().sqrt();
        let d: Vec<f64> = d.iter().map(|x| x / dn).collect();
        let plus: Vec<f64> = params.iter().zip(&d).map(|(p, d)| p + h * d).collect();
        let minus: Vec<f64> = params.iter().zip(&d).map(|(p, d)| p - h * d).collect();
        let fd_d = (loss_at(&plus) - loss_at(&minus)) / (2.0 * h);
        let an_d: f64 = g.iter().zip(&d).map(|(a, b)| a * b).sum();
        directional = directional.max((an_d - fd_d).abs() / fd_d.abs().max(1e-2 * norm_fd));
    }
    FdReport { whole, directional, forward }
}

fn assert_fd(sm: &SkinnedMesh, pose: &Pose, rng: &mut Rng, label: &str) -> FdReport {
    let report = fd_check(sm, pose, rng, 8);
    println!("{label}: {report:?}");
    assert!(report.forward <= 1e-5, "{label}: forward differs from the f64 reference: {report:?}");
    assert!(report.whole <= 1e-3, "{label}: gradient vs finite differences: {report:?}");
    assert!(report.directional <= 1e-3, "{label}: directional derivatives vs finite differences: {report:?}");
    report
}

const CHAIN: [Option<usize>; 4] = [None, Some(0), Some(1), Some(2)];
/// Two roots, a branch (joints 2 and 3 share parent 1).
const FOREST: [Option<usize>; 5] = [None, Some(0), Some(1), Some(1), None];

// ---------------------------------------------------------------------------------------------
// Rodrigues

fn rodrigues_samples() -> Vec<DVec3> {
    let mut rng = Rng(7);
    let mut samples = vec![DVec3::ZERO];
    for angle in [
        1e-20,
        1e-12,
        1e-8,
        1e-5,
        1e-3,
        0.02,
        0.0499999,
        0.05,
        0.0500001,
        0.3,
        1.0,
        3.0,
        std::f64::consts::PI,
        6.0,
        10.0,
    ] {
        samples.push(rng.direction() * angle);
    }
    for _ in 0..100 {
        samples.push(rng.direction() * rng.range(0.0, 7.0));
    }
    samples
}

#[test]
fn rodrigues_is_orthonormal() {
    for v in rodrigues_samples() {
        let r = rodrigues(v.as_vec3());
        assert!(r.is_finite(), "{v}");
        let rtr = (r.transpose() * r).as_dmat3();
        assert!(max_abs3(&rtr, &DMat3::IDENTITY) < 1e-6, "RᵀR at {v}: {rtr}");
        assert!((r.determinant() - 1.0).abs() < 1e-6, "det at {v}");
        let r64 = rodrigues_f64(v);
        assert!(max_abs3(&(r64.transpose() * r64), &DMat3::IDENTITY) < 1e-14, "f64 RᵀR at {v}");
        assert!((r64.determinant() - 1.0).abs() < 1e-14, "f64 det at {v}");
    }
    assert_eq!(rodrigues(Vec3::ZERO), Mat3::IDENTITY);
    assert_eq!(rodrigues_f64(DVec3::ZERO), DMat3::IDENTITY);
}

#[test]
fn rodrigues_matches_glam() {
    for v in rodrigues_samples() {
        let t = v.length();
        if t == 0.0 {
            continue;
        }
        let ours = rodrigues(v.as_vec3()).as_dmat3();
        let glam32 = Mat3::from_axis_angle((v / t).as_vec3(), t as f32).as_dmat3();
        assert!(max_abs3(&ours, &glam32) < 2e-6, "f32 at {v}: {ours} vs {glam32}");
        let glam64 = DMat3::from_axis_angle(v / t, t);
        assert!(max_abs3(&rodrigues_f64(v), &glam64) < 1e-13, "f64 at {v}");
    }
    // And the direction: a quarter turn about z takes x to y.
    let r = rodrigues(Vec3::new(0.0, 0.0, std::f32::consts::FRAC_PI_2));
    assert!((r * Vec3::X - Vec3::Y).length() < 1e-6);
}

#[test]
fn rodrigues_derivative_matches_finite_differences() {
    let h = 1e-6;
    for v in rodrigues_samples() {
        let analytic = rodrigues_derivative_f64(v);
        for (k, axis) in [DVec3::X, DVec3::Y, DVec3::Z].into_iter().enumerate() {
            let fd = (rodrigues_f64(v + axis * h) - rodrigues_f64(v - axis * h)) * (0.5 / h);
            let err = max_abs3(&analytic[k], &fd);
            assert!(err < 1e-8, "∂R/∂θ_{k} at {v} (|θ| = {}): error {err}\n{}\nvs\n{fd}", v.length(), analytic[k]);
        }
        let d32 = rodrigues_derivative(v.as_vec3());
        for k in 0..3 {
            assert!(d32[k].is_finite());
            assert!(max_abs3(&d32[k].as_dmat3(), &analytic[k]) < 1e-6);
        }
    }
}

#[test]
fn rodrigues_derivative_at_zero_is_the_generators() {
    let generators = [DVec3::X, DVec3::Y, DVec3::Z].map(skew);
    assert_eq!(rodrigues_derivative_f64(DVec3::ZERO), generators);
    assert_eq!(rodrigues_derivative(Vec3::ZERO), generators.map(|m| m.as_mat3()));
    // Continuous across the switch from the series to the closed form.
    let dir = DVec3::new(0.3, -0.5, 0.8).normalize();
    let below = rodrigues_derivative_f64(dir * (0.05 - 1e-12));
    let above = rodrigues_derivative_f64(dir * (0.05 + 1e-12));
    for k in 0..3 {
        assert!(max_abs3(&below[k], &above[k]) < 1e-11, "jump at the series threshold");
    }
}

// ---------------------------------------------------------------------------------------------
// Forward

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
        let mut rng = Rng(seed);
        let moved = sm.skin(&random_pose(&mut rng, sm.joint_count(), 0.5)).unwrap();
        assert!(moved.iter().zip(sm.mesh.positions()).any(|(p, q)| (*p - *q).length() > 0.05));
    }
}

#[test]
fn joint_transforms_follow_the_hierarchy() {
    let sm = synthetic(&FOREST, 30, false, 3);
    let mut rng = Rng(33);
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
    let mut rng = Rng(44);
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
    let mut rng = Rng(5);
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

// ---------------------------------------------------------------------------------------------
// Backward against finite differences

#[test]
fn backward_matches_finite_differences_on_a_chain() {
    let sm = synthetic(&CHAIN, 120, false, 10);
    let mut rng = Rng(100);
    for trial in 0..4 {
        let pose = random_pose(&mut rng, sm.joint_count(), 1.0);
        assert_fd(&sm, &pose, &mut rng, &format!("chain, pose {trial}"));
    }
}

#[test]
fn backward_matches_finite_differences_on_a_forest() {
    let sm = synthetic(&FOREST, 150, false, 11);
    let mut rng = Rng(101);
    for trial in 0..4 {
        let pose = random_pose(&mut rng, sm.joint_count(), 1.0);
        assert_fd(&sm, &pose, &mut rng, &format!("forest, pose {trial}"));
    }
}

#[test]
fn backward_matches_finite_differences_at_rest_and_tiny_angles() {
    let sm = synthetic(&FOREST, 100, true, 12);
    let mut rng = Rng(102);
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
    let mut rng = Rng(103);
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

// ---------------------------------------------------------------------------------------------
// Errors

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

    let empty = Skeleton { names: vec![], parents: vec![], rest: vec![], root_parent: vec![], inverse_bind: vec![] };
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

// ---------------------------------------------------------------------------------------------
// Speed

// ---------------------------------------------------------------------------------------------
// Real models

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
    let mut rng = Rng(seed);
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
