//! Skeletal animation clips (glTF animations): keyframed joint rotations, translations and
//! scales, sampled at a time into a [`Pose`] relative to the skeleton's rest.

use glam::{DQuat, DVec3, Mat4};

use super::{JointRest, Pose, Skeleton};
use crate::{Error, Result};

/// How a channel's values vary between two keys (the glTF `interpolation` modes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// The value of the last key at or before the time, held until the next key.
    Step,
    /// Linear for translations and scales, spherical-linear (shortest path) for rotations.
    Linear,
    /// Cubic Hermite spline with per-key in- and out-tangents (scaled by the key interval);
    /// rotations are normalised after the spline.
    CubicSpline,
}

/// What a channel animates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Property {
    /// The joint node's rotation (quaternion keys, `[x, y, z, w]`).
    Rotation,
    /// The joint node's translation (`[x, y, z]` keys).
    Translation,
    /// The joint node's scale (`[x, y, z]` keys).
    Scale,
}

/// One animated property of one joint.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// The skeleton joint it moves.
    pub joint: usize,
    /// Rotation, translation or scale.
    pub property: Property,
    /// Interpolation between keys.
    pub interpolation: Interpolation,
    /// Key times in seconds, strictly increasing.
    pub times: Vec<f32>,
    /// Key values, 4 components (rotation) or 3 (translation, scale: the 4th ignored) each. For
    /// [`Interpolation::CubicSpline`] three entries per key: in-tangent, value, out-tangent.
    pub values: Vec<[f32; 4]>,
}

/// The parts of a joint's local transform an animation does not replace, as the file has them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnimatedNode {
    /// The joint node's own translation / rotation / scale (the values an animation replaces).
    pub node_rest: JointRest,
    /// Transform of the non-joint nodes between the joint and its parent joint (identity when
    /// none), which the skeleton folds into the joint's rest transform.
    pub above: Mat4,
}

/// A skeletal animation clip.
///
/// [`Animation::sample`] turns the animated local transform of each joint into pose offsets
/// relative to the skeleton's rest (see the [module docs](super) for the model): with
/// `local = above · T(t) · R(q) · S(s)` the animated node transform (unanimated properties at the
/// node's own values), written as `T(t') · R(q') · S(s')`, the pose has
///
/// - rotation offset `θ_j = axis–angle(q_restⱼ⁻¹ · q')`, so that `R(q_rest)·R(θ_j) = R(q')`;
/// - translation offset `τ_j = t' − t_restⱼ` (only when the clip has translation channels);
/// - scale factor `σ_j = s' ⊘ s_restⱼ`, component by component, so that `S(s_restⱼ ⊙ σ_j) =
///   S(s')` (only when the clip has scale channels; a rest scale component of 0 gives the factor
///   1 where `s'` is 0 there too, and an error otherwise).
///
/// Writing `above · T(t)·R(q)·S(s)` as `T(t')·R(q')·S(s')` is exact where the non-joint
/// transforms `above` are the identity (as in most rigs) or scale uniformly; a non-uniform scale
/// in `above` over a rotated joint makes a sheared transform, of which glam's decomposition keeps
/// the nearest `T·R·S`.
///
/// The global orientation and translation of the pose stay zero; a translated root joint moves
/// through its `τ`.
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    /// The clip's name (glTF `animation.name`; `animation_k` when it has none).
    pub name: String,
    /// The channels that move joints.
    pub channels: Vec<Channel>,
    /// Per skeleton joint, what the animation does not replace.
    pub nodes: Vec<AnimatedNode>,
    /// Duration in seconds: the last key time over all channels.
    pub duration: f32,
    /// Channels skipped because they target a node that is not a joint of the skin, or morph
    /// weights.
    pub ignored_other_channels: usize,
}

impl Channel {
    /// Number of keys.
    fn keys(&self) -> usize {
        self.times.len()
    }

    /// The key value `k` (the middle entry for cubic splines).
    fn value(&self, k: usize) -> [f64; 4] {
        let i = if self.interpolation == Interpolation::CubicSpline { 3 * k + 1 } else { k };
        self.values[i].map(f64::from)
    }

    /// Checks the key tables.
    fn validate(&self, joint_count: usize) -> Result<()> {
        let per_key = if self.interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        let bad =
            |why: String| Err(Error::InvalidSettings(format!("animation channel on joint {}: {why}", self.joint)));
        if self.joint >= joint_count {
            return bad(format!("the skeleton has only {joint_count} joints"));
        }
        if self.times.is_empty() {
            return bad("no keys".into());
        }
        if self.values.len() != per_key * self.times.len() {
            return bad(format!("{} keys but {} values (expected {per_key} per key)", self.keys(), self.values.len()));
        }
        if self.times.iter().any(|t| !t.is_finite()) || self.times.windows(2).any(|w| w[1] <= w[0]) {
            return bad("key times must be finite and strictly increasing".into());
        }
        if self.values.iter().flatten().any(|v| !v.is_finite()) {
            return bad("a key value is not finite".into());
        }
        Ok(())
    }

    /// The channel's value at `time` (clamped to the first and last keys), 4 components.
    fn sample(&self, time: f64) -> [f64; 4] {
        let times = &self.times;
        let n = times.len();
        if n == 1 || time <= times[0] as f64 {
            return self.value(0);
        }
        if time >= times[n - 1] as f64 {
            return self.value(n - 1);
        }
        let k = times.partition_point(|&t| t as f64 <= time) - 1;
        let (t0, t1) = (times[k] as f64, times[k + 1] as f64);
        let dt = t1 - t0;
        let s = (time - t0) / dt;
        let (a, b) = (self.value(k), self.value(k + 1));
        match (self.interpolation, self.property) {
            (Interpolation::Step, _) => a,
            (Interpolation::Linear, Property::Translation | Property::Scale) => {
                std::array::from_fn(|c| a[c] + s * (b[c] - a[c]))
            }
            (Interpolation::Linear, Property::Rotation) => {
                let q = |v: [f64; 4]| DQuat::from_array(v).normalize();
                q(a).slerp(q(b), s).to_array()
            }
            (Interpolation::CubicSpline, property) => {
                let out_tangent = self.values[3 * k + 2].map(f64::from);
                let in_tangent = self.values[3 * (k + 1)].map(f64::from);
                let (s2, s3) = (s * s, s * s * s);
                let h = [2.0 * s3 - 3.0 * s2 + 1.0, dt * (s3 - 2.0 * s2 + s), -2.0 * s3 + 3.0 * s2, dt * (s3 - s2)];
                let v: [f64; 4] =
                    std::array::from_fn(|c| h[0] * a[c] + h[1] * out_tangent[c] + h[2] * b[c] + h[3] * in_tangent[c]);
                match property {
                    Property::Rotation => DQuat::from_array(v).normalize().to_array(),
                    Property::Translation | Property::Scale => v,
                }
            }
        }
    }
}

/// The axis–angle vector of a unit quaternion (angle in [0, π]).
fn axis_angle(q: DQuat) -> DVec3 {
    let q = if q.w < 0.0 { -q } else { q };
    let sin_half = q.xyz().length();
    if sin_half < 1e-12 {
        return q.xyz() * 2.0;
    }
    let angle = 2.0 * sin_half.atan2(q.w);
    q.xyz() * (angle / sin_half)
}

impl Animation {
    /// Checks the clip against a skeleton: one [`AnimatedNode`] per joint, valid channels.
    pub fn validate(&self, skeleton: &Skeleton) -> Result<()> {
        let n = skeleton.joint_count();
        if self.nodes.len() != n {
            return Err(Error::LengthMismatch {
                what: "animation nodes (one per skeleton joint)",
                expected: n,
                got: self.nodes.len(),
            });
        }
        self.channels.iter().try_for_each(|c| c.validate(n))
    }

    /// Whether any channel moves a joint's translation (then sampled poses carry
    /// [`Pose::joint_translations`]).
    pub fn has_translations(&self) -> bool {
        self.channels.iter().any(|c| c.property == Property::Translation)
    }

    /// Whether any channel scales a joint (then sampled poses carry [`Pose::joint_scales`]).
    pub fn has_scales(&self) -> bool {
        self.channels.iter().any(|c| c.property == Property::Scale)
    }

    /// The pose at `time` seconds (clamped to the clip), relative to the rest of `skeleton` (the
    /// skeleton the clip was loaded with); see the type's docs for the definition.
    pub fn sample(&self, skeleton: &Skeleton, time: f32) -> Result<Pose> {
        self.validate(skeleton)?;
        skeleton.validate()?;
        if !time.is_finite() {
            return Err(Error::InvalidSettings(format!("animation `{}`: the time {time} is not finite", self.name)));
        }
        let n = skeleton.joint_count();
        let mut translation: Vec<Option<DVec3>> = vec![None; n];
        let mut rotation: Vec<Option<DQuat>> = vec![None; n];
        let mut scale: Vec<Option<DVec3>> = vec![None; n];
        for channel in &self.channels {
            let v = channel.sample(time as f64);
            match channel.property {
                Property::Rotation => rotation[channel.joint] = Some(DQuat::from_array(v).normalize()),
                Property::Translation => translation[channel.joint] = Some(DVec3::new(v[0], v[1], v[2])),
                Property::Scale => scale[channel.joint] = Some(DVec3::new(v[0], v[1], v[2])),
            }
        }
        let mut pose = Pose::rest(n);
        if self.has_translations() {
            pose = pose.with_joint_translations();
        }
        if self.has_scales() {
            pose = pose.with_joint_scales();
        }
        for j in 0..n {
            if rotation[j].is_none() && translation[j].is_none() && scale[j].is_none() {
                continue;
            }
            let node = &self.nodes[j];
            let t = translation[j].unwrap_or(node.node_rest.translation.as_dvec3());
            let q = rotation[j].unwrap_or(node.node_rest.rotation.as_dquat().normalize());
            let s = scale[j].unwrap_or(node.node_rest.scale.as_dvec3());
            let (t, q, s) = if node.above == Mat4::IDENTITY {
                (t, q, s)
            } else {
                let local = node.above.as_dmat4() * glam::DMat4::from_scale_rotation_translation(s, q, t);
                let (s, q, t) = local.to_scale_rotation_translation();
                (t, q.normalize(), s)
            };
            let rest = &skeleton.rest[j];
            let offset = rest.rotation.as_dquat().normalize().inverse() * q;
            pose.joint_rotations[j] = axis_angle(offset).as_vec3();
            if pose.has_joint_translations() {
                pose.joint_translations[j] = (t - rest.translation.as_dvec3()).as_vec3();
            }
            if pose.has_joint_scales() {
                pose.joint_scales[j] = self.scale_factor(j, s, rest.scale.as_dvec3())?;
            }
        }
        // A degenerate spline key could normalise to NaN: never return it.
        pose.validate(n)?;
        Ok(pose)
    }

    /// The factor `σ = s ⊘ rest` of joint `j` (1 where both components are 0; an error where only
    /// the rest's is).
    fn scale_factor(&self, j: usize, s: DVec3, rest: DVec3) -> Result<glam::Vec3> {
        let factor = |s: f64, r: f64| -> Result<f64> {
            if r != 0.0 {
                Ok(s / r)
            } else if s == 0.0 {
                Ok(1.0)
            } else {
                Err(Error::InvalidSettings(format!(
                    "animation `{}`: joint {j} has a rest scale component of 0, which its animated scale {s} \
                     cannot be expressed as a factor of",
                    self.name
                )))
            }
        };
        Ok(glam::Vec3::new(factor(s.x, rest.x)? as f32, factor(s.y, rest.y)? as f32, factor(s.z, rest.z)? as f32))
    }

    /// `count` poses evenly spaced over the clip, from time 0 to [`Animation::duration`].
    pub fn sample_frames(&self, skeleton: &Skeleton, count: usize) -> Result<Vec<Pose>> {
        (0..count)
            .map(|k| {
                let time = if count > 1 { self.duration * k as f32 / (count - 1) as f32 } else { 0.0 };
                self.sample(skeleton, time)
            })
            .collect()
    }
}
