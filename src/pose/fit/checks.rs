//! The checks [`PoseFit`](crate::pose::fit::PoseFit) makes of its settings and targets, shared with
//! [`FitOptions::validate`](crate::pose::fit::FitOptions::validate).

use crate::{Camera, Error, Image, Result};

/// Errors unless there is one target per camera ([`Error::ViewCountMismatch`]), each of its
/// camera's size ([`Error::SizeMismatch`]), every camera valid, and every pixel finite and in
/// [0, 1] ([`Error::InvalidSettings`], naming the view and the pixel).
pub(super) fn check_targets(cameras: &[Camera], targets: &[Image]) -> Result<()> {
    if targets.len() != cameras.len() {
        return Err(Error::ViewCountMismatch { what: "target silhouettes", views: cameras.len(), got: targets.len() });
    }
    for (camera, target) in cameras.iter().zip(targets) {
        camera.validate()?;
        target.expect_size("target silhouette", camera.width, camera.height)?;
    }
    crate::render::check_finite_targets(targets)?;
    for (view, target) in targets.iter().enumerate() {
        if let Some((p, v)) = target.data().iter().enumerate().find(|(_, v)| !(0.0..=1.0).contains(*v)) {
            return Err(Error::InvalidSettings(format!(
                "target {view} has the value {v} at pixel {p}: a silhouette's pixels are the covered \
                 fraction, in [0, 1] (divide a 0–255 mask by 255)"
            )));
        }
    }
    Ok(())
}

/// Errors ([`Error::InvalidSettings`]) unless `learning_rate` is finite and > 0 and `lambda` is
/// finite and ≥ 0 ([`PoseFit::new`](crate::pose::fit::PoseFit::new), [`FitOptions::validate`](crate::pose::fit::FitOptions::validate)).
pub(in crate::pose::fit) fn check_rate_and_lambda(learning_rate: f32, lambda: f32) -> Result<()> {
    if learning_rate.is_finite() && learning_rate > 0.0 && lambda.is_finite() && lambda >= 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidSettings(format!(
            "need a positive learning rate and a non-negative λ, got {learning_rate} and {lambda}"
        )))
    }
}

/// Errors ([`Error::InvalidSettings`]) on an interval of 0 steps
/// ([`PoseFit::set_intersection_interval`](crate::pose::fit::PoseFit::set_intersection_interval), [`FitOptions::validate`](crate::pose::fit::FitOptions::validate)).
pub(in crate::pose::fit) fn check_intersection_interval(interval: u32) -> Result<()> {
    if interval == 0 {
        return Err(Error::InvalidSettings("the self-intersection interval must be at least 1 step".into()));
    }
    Ok(())
}

/// Errors ([`Error::InvalidSettings`]) unless the blur `fraction` (of the image height; `what`
/// names it in the message) is finite and in [0, 1] ([`PoseFit::set_blur`](crate::pose::fit::PoseFit::set_blur),
/// [`FitOptions::validate`](crate::pose::fit::FitOptions::validate)).
pub(in crate::pose::fit) fn check_blur(what: &str, fraction: f32) -> Result<()> {
    if fraction.is_finite() && (0.0..=1.0).contains(&fraction) {
        Ok(())
    } else {
        Err(Error::InvalidSettings(format!("{what} {fraction}: use a fraction of the image height in [0, 1]")))
    }
}
