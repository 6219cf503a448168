//! Poses: random plausible ones (ground truths), the starting poses of a fit, and the error
//! between two posed meshes.

use glam::{Mat3, Vec3};

use crate::pose::skin::{Pose, SkinnedMesh};
use crate::random::SplitMix64;
use crate::Result;

/// A random plausible pose: each joint rotated about a random axis by an angle uniform in
/// `[0, limit_j]` (`limits`, e.g. from [`crate::pose::figure::JointKind::random_pose_limit`]), and a
/// global orientation within ±`max_yaw` radians about the vertical (+y) axis. No translation.
pub fn random_pose(limits: &[f32], max_yaw: f32, seed: u64) -> Pose {
    let mut rng = SplitMix64::new(seed);
    let joint_rotations = limits.iter().map(|&limit| rng.unit_vector() * rng.range(0.0, limit)).collect();
    Pose {
        joint_rotations,
        joint_translations: Vec::new(),
        orientation: Vec3::new(0.0, rng.range(-max_yaw, max_yaw), 0.0),
        translation: Vec3::ZERO,
    }
}

/// Mean distance between corresponding vertices (paper Eq. 21), in the mesh's units.
pub fn per_vertex_error(a: &[Vec3], b: &[Vec3]) -> f64 {
    if a.is_empty() || a.len() != b.len() {
        return if a.len() == b.len() { 0.0 } else { f64::INFINITY };
    }
    a.iter().zip(b).map(|(p, q)| (*p - *q).length() as f64).sum::<f64>() / a.len() as f64
}

/// Starting poses for [`PoseFit::run`](super::PoseFit::run): the rest pose, and, when the
/// skeleton has a pair of legs, the rest pose with the legs in a stride of `angle` radians each
/// way (one leg swung forward and the other back by `angle` about the axis through both hips,
/// then the other way round).
///
/// The legs are the mirrored pair of sibling joints nearest the root: two children of one joint
/// with subtrees of the same size whose rest positions are equally far from their parent (within
/// 10%); for the built-in figure, the hips under the pelvis. Which leg the descent brings forward
/// is decided by faint cues when both start straight (see the [module documentation](super)); a
/// stride each way puts a start on each side of that choice. Global orientation and translation
/// stay zero. A skeleton without such a pair gets the rest pose alone.
///
/// Errors: [`crate::Error::InvalidSettings`] for a non-finite `angle` (a stride angle is radians,
/// e.g. 0.35).
pub fn stride_hypotheses(model: &SkinnedMesh, angle: f32) -> Result<Vec<Pose>> {
    if !angle.is_finite() {
        return Err(crate::Error::InvalidSettings(format!(
            "stride_hypotheses: the stride angle is {angle}; it must be a finite number of radians, e.g. 0.35"
        )));
    }
    let rest = Pose::rest(model.joint_count());
    let Some((a, b)) = leg_pair(model) else {
        return Ok(vec![rest]);
    };
    let world = model.joint_transforms(&rest)?;
    let position = |j: usize| world[j].w_axis.truncate();
    let lateral = (position(a) - position(b)).normalize_or_zero();
    if lateral == Vec3::ZERO {
        return Ok(vec![rest]);
    }
    let local_axis = |j: usize| (offset_frame(model, &world, j).transpose() * lateral).normalize_or_zero();
    let mut hypotheses = vec![rest.clone()];
    for sign in [1.0, -1.0] {
        let mut pose = rest.clone();
        pose.joint_rotations[a] = sign * angle * local_axis(a);
        pose.joint_rotations[b] = -sign * angle * local_axis(b);
        hypotheses.push(pose);
    }
    Ok(hypotheses)
}

/// The rest-pose world rotation of the frame joint `j`'s offset acts in:
/// `rotation(G_parent) · R(q_j)` (offsets act after the rest rotation), from the rest world
/// transforms `world`; the parent's scale is divided out of its columns.
fn offset_frame(model: &SkinnedMesh, world: &[glam::Mat4], j: usize) -> Mat3 {
    let parent = match model.skeleton.parents[j] {
        Some(p) => Mat3::from_mat4(world[p]),
        None => Mat3::from_mat4(model.skeleton.root_parent[j]),
    };
    let unscaled = Mat3::from_cols(
        parent.x_axis.normalize_or_zero(),
        parent.y_axis.normalize_or_zero(),
        parent.z_axis.normalize_or_zero(),
    );
    unscaled * Mat3::from_quat(model.skeleton.rest[j].rotation.normalize())
}

/// The mirrored pair of sibling joints nearest the root (see [`stride_hypotheses`]).
fn leg_pair(model: &SkinnedMesh) -> Option<(usize, usize)> {
    let parents = &model.skeleton.parents;
    let n = parents.len();
    let mut subtree = vec![1usize; n];
    let mut depth = vec![0usize; n];
    for j in 0..n {
        if let Some(p) = parents[j] {
            depth[j] = depth[p] + 1;
        }
    }
    for j in (0..n).rev() {
        if let Some(p) = parents[j] {
            subtree[p] += subtree[j];
        }
    }
    let offset = |j: usize| model.skeleton.rest[j].translation.length();
    let mut best: Option<(usize, usize)> = None;
    for a in 0..n {
        for b in a + 1..n {
            let (Some(pa), Some(pb)) = (parents[a], parents[b]) else { continue };
            let (la, lb) = (offset(a), offset(b));
            let mirrored = pa == pb && subtree[a] == subtree[b] && la > 0.0 && (la - lb).abs() <= 0.1 * la.max(lb);
            if mirrored && best.is_none_or(|(c, _)| depth[a] < depth[c]) {
                best = Some((a, b));
            }
        }
    }
    best
}
