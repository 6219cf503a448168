//! Where a fit to the user's own masks and cameras starts ([`start_from_masks`]): the model's rest
//! pose stood along the cameras' world's up and moved to where the masks place the subject.
//! A calibration's world is its target's: the origin where the target lay (the MakeHuman body
//! 2.9 m from it in 640 × 480 masks: none of 30 fits found it from the rest position), and the up
//! its normal or its edge (z for a target that lay on the floor, −y for a world that is the first
//! camera's frame). The descent moves and turns a body only so far; from this start, a fit to
//! such masks ends as one to masks in the model's own frame (the `fit_pose` example's figures:
//! the README, *Your own masks and cameras*).

use glam::{Quat, Vec4};

use super::{subject_height, triangulate_masks};
use crate::pose::skin::{Pose, SkinnedMesh};
use crate::scene::mesh::bounding_box;
use crate::{Camera, Error, Image, Mesh, Renderer, Result, Vec3};

/// The mean of the cameras' up directions (each camera's image "up", its y axis, in world
/// space), normalised: the world's up as the cameras see it, since cameras around a standing
/// subject are held about level (a capture rig's, or a phone's in portrait or landscape).
/// `None` without cameras, or when their ups cancel out (the mean shorter than 0.1: no common
/// up).
pub fn cameras_up(cameras: &[Camera]) -> Option<Vec3> {
    let sum: Vec3 = cameras.iter().map(|c| c.rotation().row(1)).sum();
    let mean = sum / cameras.len().max(1) as f32;
    (mean.is_finite() && mean.length() >= 0.1).then(|| mean.normalize())
}

/// The world's up for a model to stand along in the cameras' world: [`cameras_up`] snapped to
/// the nearest axis (±x, ±y, ±z) where within 30° of one (calibrated worlds are usually square
/// to the floor; a rig's cameras lean a few degrees), the mean itself otherwise, and +y without a
/// common up.
pub fn world_up(cameras: &[Camera]) -> Vec3 {
    let Some(mean) = cameras_up(cameras) else { return Vec3::Y };
    let axes = [Vec3::Y, Vec3::NEG_Y, Vec3::X, Vec3::NEG_X, Vec3::Z, Vec3::NEG_Z];
    let nearest = axes.into_iter().max_by(|a, b| a.dot(mean).total_cmp(&b.dot(mean))).unwrap_or(Vec3::Y);
    if nearest.dot(mean) >= 30f32.to_radians().cos() {
        nearest
    } else {
        mean
    }
}

/// The rest pose of a model with `joints` joints, upright along +y in its own frame, stood along
/// `up`: its global orientation the shortest turn from +y to `up`, and for `up` = −y the half
/// turn about +x (y and z flipped, as from a world with y up to one with y down such as an
/// OpenCV camera's frame). Errors ([`Error::InvalidSettings`]) for an `up` that is not a finite,
/// non-zero vector.
pub fn upright(joints: usize, up: Vec3) -> Result<Pose> {
    if !(up.is_finite() && up.length() > 1e-6) {
        return Err(Error::InvalidSettings(format!("the up {up} must be a finite, non-zero direction")));
    }
    let up = up.normalize();
    let mut rest = Pose::rest(joints);
    if up.dot(Vec3::Y) < -0.9999 {
        rest.orientation = Vec3::new(std::f32::consts::PI, 0.0, 0.0);
    } else if up != Vec3::Y {
        rest.orientation = Quat::from_rotation_arc(Vec3::Y, up).to_scaled_axis();
    }
    Ok(rest)
}

/// Where [`start_from_masks`] starts a fit, and what it read from the masks and cameras.
#[derive(Clone, Debug, PartialEq)]
pub struct MaskStart {
    /// The starting pose ([`FitOptions::initial`](super::FitOptions::initial)): the rest pose
    /// stood along `up` and moved to `point`.
    pub pose: Pose,
    /// The up the model was stood along: the one given, or [`world_up`].
    pub up: Vec3,
    /// Where the masks place the subject ([`triangulate_masks`]); `None` where that is not
    /// determined (fewer than two views see it): the pose then stays where the model was built.
    pub point: Option<Vec3>,
    /// How tall the masks' subject looks at `point` (the median over the perspective views of its
    /// [`subject_height`] times the depth over the focal length) over the model's rest height:
    /// near 1 where the cameras are in the model's units, about 1,000 for cameras in millimetres
    /// and a model in metres. `None` without a point or a perspective view that sees the subject.
    pub height_ratio: Option<f32>,
}

/// The start of a fit of `model` to `masks` seen by `cameras` (masks at the cameras' sizes,
/// values in [0, 1]): the rest pose stood along `up` (`None`: [`world_up`] of the cameras) and
/// moved so that its bounding box's centre is where the rays through the masks' centres of
/// coverage meet ([`triangulate_masks`]), then once more by the difference between that point
/// and where the model's own silhouettes there (rendered by `renderer`) triangulate to: a
/// silhouette's centre is not the projection of the body's centre, and that bias is about the
/// same for the model as for the subject. The facing is left to the fit
/// ([`FitOptions::facings`](super::FitOptions::facings)).
///
/// Errors: the masks' count or sizes not the cameras' ([`Error::LengthMismatch`],
/// [`Error::SizeMismatch`]), an invalid camera, an invalid `up` ([`upright`]), the renderer's.
pub fn start_from_masks(
    model: &SkinnedMesh,
    cameras: &[Camera],
    masks: &[Image],
    renderer: &mut Renderer,
    up: Option<Vec3>,
) -> Result<MaskStart> {
    let up = up.unwrap_or_else(|| world_up(cameras));
    let rest = upright(model.joint_count(), up)?;
    let Some(point) = triangulate_masks(cameras, masks)? else {
        return Ok(MaskStart { pose: rest, up, point: None, height_ratio: None });
    };
    let (lo, hi) = bounding_box(&model.skin(&rest)?).unwrap_or_default();
    let mut pose = Pose { translation: rest.translation + (point - (lo + hi) * 0.5), ..rest };
    let there = Mesh::with_topology(model.skin(&pose)?, model.mesh.topology().clone())?;
    if let Some(seen) = triangulate_masks(cameras, renderer.render(&there, cameras)?.images())? {
        pose.translation += point - seen;
    }
    // The subject's height in world units as each perspective view sees it at that depth.
    let mut heights: Vec<f32> = cameras
        .iter()
        .zip(masks)
        .filter_map(|(camera, mask)| {
            let p = camera.params();
            let depth = -(Vec4::from(p.row2).dot(point.extend(1.0)));
            (p.perspective == 1 && depth > 0.0 && subject_height(mask) > 0)
                .then(|| subject_height(mask) as f32 * depth / p.scale[1])
        })
        .collect();
    heights.sort_by(f32::total_cmp);
    let model_height = (hi - lo).max_element();
    let height_ratio = heights.get(heights.len() / 2).map(|seen| seen / model_height).filter(|r| r.is_finite());
    Ok(MaskStart { pose, up, point: Some(point), height_ratio })
}
