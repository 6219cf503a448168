//! Linear-blend skinning: Rodrigues' formula and its derivative, the forward against an independent
//! f64 reference, the rest pose under the glTF convention, the analytic backward against central
//! finite differences of that reference, and clear errors on bad input.

use diffsil::pose::skin::{
    rodrigues, rodrigues_derivative, rodrigues_derivative_f64, rodrigues_f64, JointRest, Pose, Skeleton, SkinnedMesh,
};
use diffsil::{Error, Mesh};
use glam::{DMat3, DMat4, DVec3, Mat3, Mat4, Quat, Vec3};

use crate::common::rng::{Draws, SplitMix64};

// ---------------------------------------------------------------------------------------------
// Helpers

/// The skinning tests' draws, on `common::rng`'s generators.
trait SkinDraws: Draws {
    fn vec3(&mut self, lo: f64, hi: f64) -> Vec3 {
        Vec3::new(self.range_f64(lo, hi) as f32, self.range_f64(lo, hi) as f32, self.range_f64(lo, hi) as f32)
    }
    /// Axis–angle with a random axis and an angle uniform in [0, max_angle].
    fn axis_angle(&mut self, max_angle: f64) -> Vec3 {
        (self.unit_dvec3() * self.range_f64(0.0, max_angle)).as_vec3()
    }
    fn quat(&mut self, max_angle: f64) -> Quat {
        Quat::from_axis_angle(self.unit_dvec3().as_vec3(), self.range_f64(-max_angle, max_angle) as f32)
    }
}

impl SkinDraws for SplitMix64 {}

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
/// (layout of `Pose::to_params`: `3n + 6` values, or `9n + 6` with joint translations `τ` and
/// scale factors `σ`).
fn reference_vertices(sm: &SkinnedMesh, params: &[f64]) -> Vec<DVec3> {
    let sk = &sm.skeleton;
    let n = sk.parents.len();
    assert!(params.len() == 3 * n + 6 || params.len() == 9 * n + 6, "{} parameters", params.len());
    let v3 = |i: usize| DVec3::new(params[i], params[i + 1], params[i + 2]);
    let with_scales = params.len() == 9 * n + 6;
    let world = DMat4::from_translation(v3(3 * n + 3)) * glam_rotation(v3(3 * n));
    let mut global: Vec<DMat4> = Vec::with_capacity(n);
    for j in 0..n {
        let r = &sk.rest[j];
        let (tau, sigma) =
            if with_scales { (v3(3 * n + 6 + 3 * j), v3(6 * n + 6 + 3 * j)) } else { (DVec3::ZERO, DVec3::ONE) };
        let local = DMat4::from_translation(r.translation.as_dvec3() + tau)
            * DMat4::from_quat(r.rotation.as_dquat().normalize())
            * glam_rotation(v3(3 * j))
            * DMat4::from_scale(r.scale.as_dvec3() * sigma);
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
fn random_rest(rng: &mut SplitMix64) -> JointRest {
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
    let mut rng = SplitMix64::new(seed);
    let n = parents.len();
    let rest: Vec<JointRest> = (0..n).map(|_| random_rest(&mut rng)).collect();
    let root_parent: Vec<Mat4> = (0..n)
        .map(|_| Mat4::from_scale_rotation_translation(rng.vec3(0.8, 1.3), rng.quat(1.0), rng.vec3(-0.3, 0.3)))
        .collect();
    let mut skeleton = Skeleton {
        names: (0..n).map(|j| format!("joint{j}")).collect(),
        nodes: Vec::new(),
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
        let raw: Vec<f64> = (0..count).map(|_| rng.range_f64(0.05, 1.0)).collect();
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

fn random_pose(rng: &mut SplitMix64, joint_count: usize, max_angle: f64) -> Pose {
    Pose {
        joint_rotations: (0..joint_count).map(|_| rng.axis_angle(max_angle)).collect(),
        joint_translations: Vec::new(),
        joint_scales: Vec::new(),
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
fn fd_check(sm: &SkinnedMesh, pose: &Pose, rng: &mut SplitMix64, directions: usize) -> FdReport {
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
    assert_eq!(g.len(), params.len(), "the gradient's layout is the pose's");
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
        let d: Vec<f64> = (0..params.len()).map(|_| rng.range_f64(-1.0, 1.0)).collect();
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

fn assert_fd(sm: &SkinnedMesh, pose: &Pose, rng: &mut SplitMix64, label: &str) -> FdReport {
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

mod backward;
mod errors;
mod forward;
mod models;
mod rodrigues;
mod scale;
mod shape;
