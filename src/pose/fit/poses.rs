//! Poses: random plausible ones (ground truths), the starting poses of a fit, and the error
//! between two posed meshes.

use glam::{Mat3, Quat, Vec3};

use crate::pose::skin::{Pose, SkinnedMesh};
use crate::random::SplitMix64;
use crate::scene::mesh::bounding_box;
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
        joint_scales: Vec::new(),
        orientation: Vec3::new(0.0, rng.range(-max_yaw, max_yaw), 0.0),
        translation: Vec3::ZERO,
    }
}

/// `pose` turned by `angle` radians about its vertical through the centre of the bounding box of
/// `model` skinned at `pose`: about the model's up (+y, the glTF up) as the pose's global
/// orientation holds it (+y itself for an upright pose), the orientation turned and the
/// translation moved so that the centre stays where it was. The starting poses of
/// [`FitOptions::facings`](super::FitOptions::facings) are made this way. `pose` itself (a
/// clone) for an angle of 0.
///
/// Errors: [`crate::Error::InvalidSettings`] for a non-finite `angle`; the skinning's errors
/// (a pose with the wrong number of joints).
pub fn turned_about_vertical(model: &SkinnedMesh, pose: &Pose, angle: f32) -> Result<Pose> {
    if !angle.is_finite() {
        return Err(crate::Error::InvalidSettings(format!(
            "turned_about_vertical: the angle is {angle}; it must be a finite number of radians"
        )));
    }
    if angle == 0.0 {
        return Ok(pose.clone());
    }
    let centre = |pose: &Pose| -> Result<Vec3> { Ok(box_centre(&model.skin(pose)?)) };
    let orientation = Quat::from_scaled_axis(pose.orientation);
    let turn = Quat::from_axis_angle((orientation * Vec3::Y).normalize(), angle) * orientation;
    let mut turned = Pose { orientation: turn.to_scaled_axis(), ..pose.clone() };
    turned.translation += centre(pose)? - centre(&turned)?;
    Ok(turned)
}

/// The centre of the bounding box of `points` (the origin for none).
pub(super) fn box_centre(points: &[Vec3]) -> Vec3 {
    bounding_box(points).map_or(Vec3::ZERO, |(lo, hi)| (lo + hi) * 0.5)
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
/// then the other way round). [`limb_swing_hypotheses`] with no arm swing.
///
/// The legs are the mirrored pair of sibling joints nearest the root: two children of one joint
/// with subtrees of the same size whose rest positions are equally far from their parent (within
/// 10%); for the built-in figure, the hips under the pelvis. A joint that sits at its parent's
/// position with a single child stands for that child (the MakeHuman body's `LHipJoint` and
/// `RHipJoint` under `Hips`: the pair is `LeftUpLeg` and `RightUpLeg`). Which leg the descent brings forward
/// is decided by faint cues when both start straight (see the [module documentation](super)); a
/// stride each way puts a start on each side of that choice. Global orientation and translation
/// stay zero. A skeleton without such a pair gets the rest pose alone.
///
/// Errors: [`crate::Error::InvalidSettings`] for a non-finite `angle` (a stride angle is radians,
/// e.g. 0.35).
pub fn stride_hypotheses(model: &SkinnedMesh, angle: f32) -> Result<Vec<Pose>> {
    limb_swing_hypotheses(model, angle, 0.0)
}

/// Starting poses with the legs and the arms swung forward and back: the rest pose; then, for
/// each way the legs can stride by `leg_angle` ([`stride_hypotheses`]; none when 0 or without
/// legs), the arms swung by `arm_angle` one way and the other (one arm forward, the other back,
/// about the axis through both shoulders; not swung when `arm_angle` is 0 or there are no arms).
/// That is 1, 3 or 5 poses (3 with arms but no legs).
///
/// The arms are the mirrored pair of sibling joints nearest the root after the legs (same rule
/// as the legs'). When such a joint is a collar bone — it has one child, and its bone to that
/// child is less than 60% as long as the child's own bone — its child (the shoulder) swings
/// instead.
///
/// Errors ([`Error::InvalidSettings`](crate::Error::InvalidSettings)) when an angle is not finite.
pub fn limb_swing_hypotheses(model: &SkinnedMesh, leg_angle: f32, arm_angle: f32) -> Result<Vec<Pose>> {
    for (name, angle) in [("leg stride", leg_angle), ("arm swing", arm_angle)] {
        if !angle.is_finite() {
            return Err(crate::Error::InvalidSettings(format!(
                "limb_swing_hypotheses: the {name} angle is {angle}; it must be a finite number of radians, e.g. 0.35"
            )));
        }
    }
    let rest = Pose::rest(model.joint_count());
    let world = model.joint_transforms(&rest)?;
    let pairs = mirrored_pairs(model);
    let legs = pairs.first().copied().filter(|_| leg_angle != 0.0);
    let arms =
        pairs.get(1).copied().filter(|_| arm_angle != 0.0).map(|(a, b)| (shoulder(model, a), shoulder(model, b)));
    let swing = |pose: &mut Pose, (a, b): (usize, usize), angle: f32| -> bool {
        let position = |j: usize| world[j].w_axis.truncate();
        let lateral = (position(a) - position(b)).normalize_or_zero();
        if lateral == Vec3::ZERO {
            return false;
        }
        let local_axis = |j: usize| (offset_frame(model, &world, j).transpose() * lateral).normalize_or_zero();
        pose.joint_rotations[a] += angle * local_axis(a);
        pose.joint_rotations[b] -= angle * local_axis(b);
        true
    };
    let mut hypotheses = vec![rest.clone()];
    let leg_signs: &[f32] = if legs.is_some() { &[1.0, -1.0] } else { &[0.0] };
    let arm_signs: &[f32] = if arms.is_some() { &[-1.0, 1.0] } else { &[0.0] };
    for &leg in leg_signs {
        for &arm in arm_signs {
            let mut pose = rest.clone();
            let mut moved = false;
            if let Some(pair) = legs {
                moved |= swing(&mut pose, pair, leg * leg_angle);
            }
            if let Some(pair) = arms {
                moved |= swing(&mut pose, pair, arm * arm_angle);
            }
            if moved {
                hypotheses.push(pose);
            }
        }
    }
    Ok(hypotheses)
}

/// `j`, or its only child when `j` is a collar bone (see [`limb_swing_hypotheses`]).
pub(in crate::pose::fit) fn shoulder(model: &SkinnedMesh, j: usize) -> usize {
    let parents = &model.skeleton.parents;
    let children: Vec<usize> = (0..parents.len()).filter(|&c| parents[c] == Some(j)).collect();
    let [child] = children[..] else { return j };
    let bone = |k: usize| {
        let mut lengths =
            (0..parents.len()).filter(|&c| parents[c] == Some(k)).map(|c| model.skeleton.rest[c].translation.length());
        lengths.next()
    };
    match (bone(j), bone(child)) {
        (Some(own), Some(next)) if own < 0.6 * next => child,
        _ => j,
    }
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

/// The mirrored pairs of sibling joints (see [`stride_hypotheses`]), nearest the root first
/// (ties in joint order); a joint belongs to at most one pair.
pub(in crate::pose::fit) fn mirrored_pairs(model: &SkinnedMesh) -> Vec<(usize, usize)> {
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
    // A joint at its parent's position with a single child (e.g. the hip joints of a CMU-style
    // skeleton, between the pelvis and the thighs) stands for that child.
    let resolve = |mut j: usize| loop {
        let children: Vec<usize> = (0..n).filter(|&c| parents[c] == Some(j)).collect();
        match children[..] {
            [child] if offset(j) == 0.0 => j = child,
            _ => return j,
        }
    };
    let mut pairs = Vec::new();
    let mut used = vec![false; n];
    for a in 0..n {
        for b in a + 1..n {
            let (Some(pa), Some(pb)) = (parents[a], parents[b]) else { continue };
            let (ra, rb) = (resolve(a), resolve(b));
            let (la, lb) = (offset(ra), offset(rb));
            let mirrored = pa == pb && subtree[a] == subtree[b] && la > 0.0 && (la - lb).abs() <= 0.1 * la.max(lb);
            if mirrored && !used[a] && !used[b] {
                used[a] = true;
                used[b] = true;
                pairs.push((ra, rb));
            }
        }
    }
    pairs.sort_by_key(|&(a, _)| depth[a]);
    pairs
}
