//! Where the body stands: a starting position from the masks themselves. A fit starts from the
//! model's rest pose where the model was built (the MakeHuman body at the origin); calibrated
//! cameras put the world's origin wherever the calibration target lay, and a body far from the
//! model's rest position is out of the descent's reach (the MakeHuman body 2.9 m off in 640 ×
//! 480 masks of four cameras: none of 30 fits found it; 1.3 m off, one of three missed it).
//! [`triangulate_masks`] finds the point nearest to the rays through each mask's centre of
//! coverage; moving the starting pose's root translation there puts the body where the cameras
//! see it (the `fit_pose` example: 2.7 / 4.5 / 28.0 mm median / p90 / worst on those 30).

use glam::{DMat3, DVec3};

use crate::{Camera, Error, Image, Result, Vec3};

/// The ray through screen point `(u, v)` of `camera`: its origin and unit direction, world space.
fn pixel_ray(camera: &Camera, u: f64, v: f64) -> (DVec3, DVec3) {
    let p = camera.params();
    let rows = [p.row0, p.row1, p.row2].map(|r| DVec3::new(r[0] as f64, r[1] as f64, r[2] as f64));
    let t = DVec3::new(p.row0[3] as f64, p.row1[3] as f64, p.row2[3] as f64);
    // World from camera space: Rᵀ. The rows of R are the camera's axes in world space.
    let to_world = |c: DVec3| rows[0] * c.x + rows[1] * c.y + rows[2] * c.z;
    let (x, y) = ((u - p.centre[0] as f64) / p.scale[0] as f64, -(v - p.centre[1] as f64) / p.scale[1] as f64);
    if p.perspective == 1 {
        (to_world(-t), to_world(DVec3::new(x, y, -1.0)).normalize())
    } else {
        (to_world(DVec3::new(x, y, 0.0) - t), to_world(DVec3::NEG_Z))
    }
}

/// The centre of coverage of `mask` in screen coordinates (pixel `(i, j)` at `(j + 0.5, i + 0.5)`,
/// each weighted by its value clamped to [0, 1]), `None` when it covers nothing.
fn coverage_centre(mask: &Image) -> Option<(f64, f64)> {
    let (mut sum, mut su, mut sv) = (0.0f64, 0.0f64, 0.0f64);
    let width = mask.width().max(1) as usize;
    for (k, &value) in mask.data().iter().enumerate() {
        let w = if value.is_nan() { 0.0 } else { value.clamp(0.0, 1.0) as f64 };
        sum += w;
        su += w * ((k % width) as f64 + 0.5);
        sv += w * ((k / width) as f64 + 0.5);
    }
    (sum > 0.0).then(|| (su / sum, sv / sum))
}

/// The point nearest, in the least-squares sense, to the rays from each camera through its
/// mask's centre of coverage (each pixel weighted by its value): where the subject of the masks
/// stands, for a fit's starting position (the root translation of
/// [`FitOptions::initial`](super::FitOptions::initial) that moves the model's centre there).
/// A silhouette's centre is not the projection of the body's centre, so the point is a start,
/// off by a fraction of the body's size.
///
/// `None` when fewer than two masks cover anything or their rays are (nearly) parallel, so that
/// the point is not determined. Errors: a mask count other than the cameras'
/// ([`Error::LengthMismatch`]), a mask of another size than its camera's image
/// ([`Error::SizeMismatch`]), an invalid camera.
pub fn triangulate_masks(cameras: &[Camera], masks: &[Image]) -> Result<Option<Vec3>> {
    if cameras.len() != masks.len() {
        return Err(Error::LengthMismatch {
            what: "masks (one per camera)",
            expected: cameras.len(),
            got: masks.len(),
        });
    }
    let (mut a, mut b, mut rays) = (DMat3::ZERO, DVec3::ZERO, 0);
    for (camera, mask) in cameras.iter().zip(masks) {
        camera.validate()?;
        mask.expect_size("mask", camera.width, camera.height)?;
        let Some((u, v)) = coverage_centre(mask) else { continue };
        let (origin, d) = pixel_ray(camera, u, v);
        // (I − d dᵀ) projects onto the plane across the ray: the squared distance of x to the
        // ray is |(I − d dᵀ)(x − origin)|².
        let across = DMat3::IDENTITY - DMat3::from_cols(d * d.x, d * d.y, d * d.z);
        a += across;
        b += across * origin;
        rays += 1;
    }
    // Two rays at an angle θ give a determinant of 2·sin²θ: below about 1° apart (and alike for
    // more rays) the point is not determined.
    if rays < 2 || a.determinant().abs() < 1e-4 * (rays as f64).powi(3) {
        return Ok(None);
    }
    let x = a.inverse() * b;
    Ok(x.is_finite().then(|| x.as_vec3()))
}
