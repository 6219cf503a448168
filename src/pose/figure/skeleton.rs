//! The figure's skeleton: SMPL's joint names and hierarchy, the rest positions of the joints, and
//! the classification of joints by what part of the body they move.

use glam::Vec3;

use super::JOINT_COUNT;
use crate::pose::skin::{Skeleton, SkinnedMesh};

/// Joint names of the built-in figure, in SMPL's order.
pub const JOINT_NAMES: [&str; 24] = [
    "pelvis",
    "left_hip",
    "right_hip",
    "spine1",
    "left_knee",
    "right_knee",
    "spine2",
    "left_ankle",
    "right_ankle",
    "spine3",
    "left_foot",
    "right_foot",
    "neck",
    "left_collar",
    "right_collar",
    "head",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hand",
    "right_hand",
];

/// Parent of each joint of the built-in figure (SMPL's kinematic tree); parents come first.
pub const JOINT_PARENTS: [Option<usize>; 24] = [
    None,
    Some(0),
    Some(0),
    Some(0),
    Some(1),
    Some(2),
    Some(3),
    Some(4),
    Some(5),
    Some(6),
    Some(7),
    Some(8),
    Some(9),
    Some(9),
    Some(9),
    Some(12),
    Some(13),
    Some(14),
    Some(16),
    Some(17),
    Some(18),
    Some(19),
    Some(20),
    Some(21),
];

/// What part of the body a joint moves; decides how far a random plausible pose may rotate it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum JointKind {
    /// The root (pelvis): its rotation duplicates the global orientation.
    Root,
    /// Spine / torso joints.
    Spine,
    /// Collar bones (clavicles).
    Collar,
    /// The neck.
    Neck,
    /// The head.
    Head,
    /// Arms, legs, hands and feet.
    Limb,
    /// Fingers, thumbs and toes: too small to see in a silhouette at the resolutions fitted.
    Digit,
}

impl JointKind {
    /// Classifies a non-root joint by its name (case-insensitive): names containing `spine`,
    /// `torso`, `chest` or `abdomen` are [`Spine`](JointKind::Spine), `collar` or `clavicle`
    /// [`Collar`](JointKind::Collar), `neck` [`Neck`](JointKind::Neck), `head`
    /// [`Head`](JointKind::Head), `pelvis` or exactly `hips`/`root`
    /// [`Root`](JointKind::Root), `finger`, `thumb`, `toe`, `index` or `pinky`
    /// [`Digit`](JointKind::Digit) (checked first); `back` is spine too (MakeHuman's
    /// `LowerBack`); anything else is a [`Limb`](JointKind::Limb).
    pub fn of_name(name: &str) -> JointKind {
        let n = name.to_ascii_lowercase();
        let has = |words: &[&str]| words.iter().any(|w| n.contains(w));
        if has(&["finger", "thumb", "toe", "index", "pinky"]) {
            JointKind::Digit
        } else if has(&["spine", "torso", "chest", "abdomen", "back"]) {
            JointKind::Spine
        } else if has(&["collar", "clavicle"]) {
            JointKind::Collar
        } else if has(&["neck"]) {
            JointKind::Neck
        } else if has(&["head"]) {
            JointKind::Head
        } else if has(&["pelvis"]) || n == "hips" || n == "root" {
            JointKind::Root
        } else {
            JointKind::Limb
        }
    }

    /// Largest rotation offset (radians) of a random plausible pose: 0.5 for limbs, 0.25 for
    /// spine, collars, neck and head, 0 for the root (use the global orientation instead) and
    /// for fingers and toes (no flailing digits).
    pub fn random_pose_limit(self) -> f32 {
        match self {
            JointKind::Root | JointKind::Digit => 0.0,
            JointKind::Spine | JointKind::Collar | JointKind::Neck | JointKind::Head => 0.25,
            JointKind::Limb => 0.5,
        }
    }
}

/// The kind of every joint of a skeleton: roots (no parent) are [`JointKind::Root`], others are
/// classified by name with [`JointKind::of_name`].
pub fn joint_kinds(skeleton: &Skeleton) -> Vec<JointKind> {
    skeleton
        .parents
        .iter()
        .enumerate()
        .map(|(j, parent)| match parent {
            None => JointKind::Root,
            Some(_) => JointKind::of_name(skeleton.names.get(j).map_or("", String::as_str)),
        })
        .collect()
}

/// Every joint's [`JointKind::random_pose_limit`], in joint order: the `limits` of
/// [`crate::pose::fit::random_pose`] for this skeleton.
pub fn random_pose_limits(skeleton: &Skeleton) -> Vec<f32> {
    joint_kinds(skeleton).iter().map(|k| k.random_pose_limit()).collect()
}

/// Indices of the joints of kind [`JointKind::Limb`] (arms, legs, hands, feet).
pub fn limb_joints(figure: &SkinnedMesh) -> Vec<usize> {
    joint_kinds(&figure.skeleton).iter().enumerate().filter(|(_, k)| **k == JointKind::Limb).map(|(j, _)| j).collect()
}

/// Rest world positions of the joints before the figure is lifted onto the floor.
pub(super) fn joint_positions() -> [Vec3; JOINT_COUNT] {
    let mut p = [Vec3::ZERO; JOINT_COUNT];
    let mut pair = |left: usize, v: Vec3| {
        p[left] = v;
        p[left + 1] = v * Vec3::new(-1.0, 1.0, 1.0);
    };
    // Left arm direction: 45° below horizontal, outwards.
    let arm = Vec3::new(1.0, -1.0, 0.0).normalize();
    let shoulder = Vec3::new(0.185, 1.425, -0.015);
    let elbow = shoulder + 0.265 * arm;
    let wrist = elbow + 0.245 * arm;
    pair(1, Vec3::new(0.09, 0.87, 0.0));
    pair(4, Vec3::new(0.10, 0.49, 0.005));
    pair(7, Vec3::new(0.11, 0.085, -0.03));
    pair(10, Vec3::new(0.115, 0.03, 0.09));
    pair(13, Vec3::new(0.075, 1.40, -0.005));
    pair(16, shoulder);
    pair(18, elbow);
    pair(20, wrist);
    pair(22, wrist + 0.085 * arm);
    p[0] = Vec3::new(0.0, 0.94, 0.0);
    p[3] = Vec3::new(0.0, 1.05, -0.01);
    p[6] = Vec3::new(0.0, 1.18, -0.005);
    p[9] = Vec3::new(0.0, 1.25, 0.0);
    p[12] = Vec3::new(0.0, 1.47, -0.015);
    p[15] = Vec3::new(0.0, 1.56, 0.01);
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joint_kinds_by_name() {
        assert_eq!(JointKind::of_name("Spine2"), JointKind::Spine);
        assert_eq!(JointKind::of_name("torso_joint_1"), JointKind::Spine);
        assert_eq!(JointKind::of_name("neck_joint_2"), JointKind::Neck);
        assert_eq!(JointKind::of_name("left_collar"), JointKind::Collar);
        assert_eq!(JointKind::of_name("left_hip"), JointKind::Limb);
        assert_eq!(JointKind::of_name("arm_joint_L_1"), JointKind::Limb);
        assert_eq!(JointKind::of_name("Head"), JointKind::Head);
        assert_eq!(JointKind::of_name("LeftHandFinger1"), JointKind::Digit);
        assert_eq!(JointKind::of_name("RThumb"), JointKind::Digit);
        assert_eq!(JointKind::of_name("LeftToeBase"), JointKind::Digit);
        assert_eq!(JointKind::of_name("LowerBack"), JointKind::Spine);
    }
}
