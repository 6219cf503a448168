//! [`crossed_legs`]: the legs moved onto each other's places, the starting pose of the second
//! run of [`fit`](super::fit).

use glam::{Mat3, Quat, Vec3};

use super::swap::{joint_rotation, matched_subtrees, world_rotations};
use crate::pose::fit::poses::mirrored_pairs;
use crate::pose::skin::{Pose, SkinnedMesh};
use crate::{Image, Result};

/// `pose` with the legs moved onto each other's places: each leg's bones, from the hip down,
/// turned to point at the other leg's matching joints (the thigh at the other knee, the shin at
/// the other ankle, …), and each leg's last joint given the other's world rotation. The bones
/// keep their lengths and the hips stay, so each joint lands within a hip's width of the other
/// leg's (the joints of the mean shape, `β` = 0, whatever shape the fit holds). Only the legs'
/// joint rotations change. `None` when the skeleton has no pair of legs
/// with the same joint tree (the legs of
/// [`limb_swing_hypotheses`](crate::pose::fit::limb_swing_hypotheses)); errors when `pose` does
/// not fit the skeleton.
///
/// What it is for ([`FitOptions::crossed_legs_within`](crate::pose::fit::FitOptions::crossed_legs_within)):
/// when the legs cross (at the knees or the shins) or stand close together, the descent now and
/// then ends with them in each other's places, the left knee and foot where the right ones
/// belong and the other way round. The fits of the built-in figure that ended that way had 7 to
/// 8 times the true pose's energy, so the silhouettes tell them apart, but neither the descent
/// nor the swap test gets there: exchanging the legs' rotations
/// ([`LimbSwap::ExchangeLegs`](crate::pose::fit::LimbSwap::ExchangeLegs)) mirrors them, which
/// does not move a crossed leg across, and legs cannot pass through each other.
pub fn crossed_legs(model: &SkinnedMesh, pose: &Pose) -> Result<Option<Pose>> {
    pose.validate(model.joint_count())?;
    let Some(&(left, right)) = mirrored_pairs(model).first() else { return Ok(None) };
    let parents = &model.skeleton.parents;
    let Some(matched) = matched_subtrees(parents, left, right) else { return Ok(None) };
    let n = parents.len();
    let mut partner = vec![None; n];
    for &(a, b) in &matched {
        partner[a] = Some(b);
        partner[b] = Some(a);
    }
    // Each joint's world rotation relative to rest, `T_k = Q_k Q⁰_kᵀ`, as in the swap test.
    let (rest_rot, moved, posed) = world_rotations(model, pose)?;
    let at: Vec<Vec3> = posed.iter().map(|g| g.w_axis.truncate()).collect();
    // Parents before children: a skeleton lists every joint after its parent.
    let mut order: Vec<usize> = matched.iter().flat_map(|&(a, b)| [a, b]).collect();
    order.sort_unstable();
    let (mut t, mut new_at) = (moved.clone(), at.clone());
    for &k in &order {
        let children: Vec<usize> = (0..n).filter(|&c| parents[c] == Some(k)).collect();
        let Some(&child) = children.iter().find(|&&c| partner[c].is_some()) else {
            // The leg's last joint (a foot or a toe): the other's orientation.
            t[k] = moved[partner[k].expect("a leg joint")];
            continue;
        };
        let bone = at[child] - at[k];
        let want = at[partner[child].expect("a leg joint")] - new_at[k];
        let turn = match (bone.try_normalize(), want.try_normalize()) {
            (Some(from), Some(to)) => Mat3::from_quat(Quat::from_rotation_arc(from, to)),
            _ => Mat3::IDENTITY,
        };
        t[k] = turn * moved[k];
        for c in children {
            new_at[c] = new_at[k] + turn * (at[c] - at[k]);
        }
    }
    let mut out = pose.clone();
    for &k in &order {
        out.joint_rotations[k] = joint_rotation(parents, &rest_rot, &t, k);
    }
    Ok(Some(out))
}

/// How much worse a candidate's renders match the targets than the fitted pose's, where the two
/// renders differ (see [`changed_pixels`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::pose::fit) struct ChangedPixels {
    /// The candidate's squared error over the pixels whose value differs between the two
    /// renders, divided by the fitted pose's over the same pixels; `f64::INFINITY` when the
    /// fitted pose matches the targets exactly there (nothing to gain) or nothing differs.
    pub ratio: f64,
    /// The candidate's squared error minus the fitted pose's over those pixels, per pixel;
    /// `f64::INFINITY` when nothing differs.
    pub excess: f64,
}

/// How much worse `candidate`'s renders match the `targets` than `fitted`'s, where the two
/// differ. Pixels where the renders agree add the same to both energies whatever the targets
/// hold there (noise in the masks, parts of the body the candidate does not move), so the ratio,
/// unlike the ratio of the whole energies, does not drift towards 1 when the masks are noisy
/// there. Noise among the changed pixels still adds to both sides, which pulls the ratio towards
/// 1 but leaves the excess per pixel as it was on average. The three lists hold one image per
/// view, of the same sizes.
pub(in crate::pose::fit) fn changed_pixels(candidate: &[Image], fitted: &[Image], targets: &[Image]) -> ChangedPixels {
    let (mut ours, mut theirs, mut count) = (0.0f64, 0.0f64, 0usize);
    for ((c, f), t) in candidate.iter().zip(fitted).zip(targets) {
        for ((&c, &f), &t) in c.data().iter().zip(f.data()).zip(t.data()) {
            if c != f {
                let (c, f, t) = (f64::from(c), f64::from(f), f64::from(t));
                ours += (c - t) * (c - t);
                theirs += (f - t) * (f - t);
                count += 1;
            }
        }
    }
    ChangedPixels {
        ratio: if theirs > 0.0 { ours / theirs } else { f64::INFINITY },
        excess: if count > 0 { (ours - theirs) / count as f64 } else { f64::INFINITY },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: &[f32]) -> Image {
        Image::from_vec(values.len() as u32, 1, values.to_vec()).unwrap()
    }

    #[test]
    fn the_ratio_and_the_excess_count_only_the_pixels_where_the_renders_differ() {
        let targets = [image(&[1.0, 0.0, 1.0, 0.0])];
        let fitted = [image(&[0.5, 0.0, 1.0, 0.0])];
        let candidate = [image(&[1.0, 0.0, 0.0, 0.0])];
        // Pixels 0 and 2 differ: the candidate's error there 0 + 1, the fit's 0.25 + 0; the
        // excess (1 − 0.25) / 2.
        let expected = ChangedPixels { ratio: 4.0, excess: 0.375 };
        assert_eq!(changed_pixels(&candidate, &fitted, &targets), expected);
        // Noise where the renders agree (pixels 1 and 3) changes nothing.
        let noisy = [image(&[1.0, 1.0, 1.0, 0.7])];
        assert_eq!(changed_pixels(&candidate, &fitted, &noisy), expected);
        // Several views add up (and the excess stays a mean per pixel).
        let two = |i: &[Image; 1]| [i[0].clone(), i[0].clone()];
        assert_eq!(changed_pixels(&two(&candidate), &two(&fitted), &two(&targets)), expected);
        // Nothing differs: both infinite; the fit exact where they do: an infinite ratio and the
        // candidate's own error per pixel.
        let infinite = ChangedPixels { ratio: f64::INFINITY, excess: f64::INFINITY };
        assert_eq!(changed_pixels(&fitted, &fitted, &targets), infinite);
        assert_eq!(changed_pixels(&candidate, &targets, &targets), ChangedPixels { ratio: f64::INFINITY, excess: 1.0 });
    }
}
