//! The resolution a fit works at. The method's settings were chosen, and its figures measured, on
//! targets where the body is 50–70 pixels tall (the README's tables: 64 × 64 images, the
//! MakeHuman body about 54 pixels tall). Masks at a camera's own resolution (a person 300 or
//! 1,000 pixels tall) make every step cost more, and some settings count in pixels (the outline
//! nuisance's one pixel, the misfit check's 2 × 2 blocks), so the fit is not better for it:
//! [`downsample_factor`] picks a factor that brings the body back to that scale, and
//! [`Image::downsampled`] and [`Camera::downsampled`](crate::Camera::downsampled) apply it to
//! the masks and their cameras alike.

use crate::Image;

/// The subject height in pixels [`downsample_factor`] aims for by default: 64.
pub const FIT_SUBJECT_HEIGHT: u32 = 64;

/// The height in pixels of the subject in `mask`: the rows from the first to the last holding a
/// pixel above 0.5, 0 when none does.
pub fn subject_height(mask: &Image) -> u32 {
    let occupied = |row: &[f32]| row.iter().any(|v| *v > 0.5);
    let rows: Vec<&[f32]> = mask.data().chunks(mask.width().max(1) as usize).collect();
    match (rows.iter().position(|r| occupied(r)), rows.iter().rposition(|r| occupied(r))) {
        (Some(first), Some(last)) => (last - first + 1) as u32,
        _ => 0,
    }
}

/// The largest whole factor by which `masks` (and their cameras) can be downsampled keeping the
/// tallest subject among them ([`subject_height`]) at least `height` pixels tall, and every mask
/// at least one pixel wide and high; 1 when no subject is taller than `height` (nothing is
/// upsampled), when `height` is 0, or when there are no masks.
///
/// Measured with the `fit_pose` example (`--seeds 1-30 --views irregular --resolution 480`: the
/// MakeHuman body in random poses seen by four cameras placed at random, 480² masks; median /
/// p90 / worst per-vertex error, wall seconds per fit with two fits at a time): at the masks' own
/// resolution (`--fit-height 0`) 4.0 / 6.8 / 12.3 mm in 26.6 s, the misfit restart running in
/// every fit (a 480² fit always leaves some 2 × 2 blocks); downsampled 5–6× to 80² or 96² by
/// [`FIT_SUBJECT_HEIGHT`] 2.6 / 3.7 / 4.8 mm in 1.8 s, 15 times faster; with a height of 96, 2.3
/// / 3.8 / 6.3 mm in 2.1 s (with the outline nuisance; with the surface offset,
/// [`FitOptions::for_downsampled`](super::FitOptions::for_downsampled), 2.5 / 3.6 / 4.2 and 2.4
/// / 4.0 / 5.4 mm).
///
/// ```
/// use diffsil::pose::fit::{downsample_factor, FIT_SUBJECT_HEIGHT};
/// use diffsil::Image;
///
/// // A person 330 pixels tall in a 640 × 480 mask: downsampled 5×, 66 pixels tall.
/// let mut mask = Image::filled(640, 480, 0.0);
/// for row in 70..400 {
///     mask.data_mut()[row * 640 + 300] = 1.0;
/// }
/// assert_eq!(downsample_factor(&[mask], FIT_SUBJECT_HEIGHT), 5);
/// ```
pub fn downsample_factor(masks: &[Image], height: u32) -> u32 {
    let tallest = masks.iter().map(subject_height).max().unwrap_or(0);
    let smallest_side = masks.iter().map(|m| m.width().min(m.height())).min().unwrap_or(1);
    if height == 0 {
        return 1;
    }
    (tallest / height).clamp(1, smallest_side.max(1))
}
