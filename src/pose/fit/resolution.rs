//! The resolution a fit works at. The method's settings were chosen, and its figures measured, on
//! targets where the body is 50–70 pixels tall (the README's tables: 64 × 64 images, the
//! MakeHuman body about 54 pixels tall). Masks at a camera's own resolution (a person 300 or
//! 1,000 pixels tall) make every step cost more, and some settings count in pixels (the outline
//! nuisance's one pixel, the misfit check's 2 × 2 blocks), so the fit is not better for it:
//! [`downsample_factor`] picks a factor that brings the body back to that scale, and
//! [`Image::downsampled`] and [`Camera::downsampled`](crate::Camera::downsampled) apply it to
//! the masks and their cameras alike. A subject small in a large frame matters too: the blur is a
//! fraction of the image height and `E_sl` a mean over the pixels, both set where the body fills
//! most of the image, so [`subject_windows`] gives windows that frame it that way, for
//! [`Image::cropped`] and [`Camera::cropped`](crate::Camera::cropped).

use crate::{Camera, Error, Image, PixelRect, Result};

/// The subject height in pixels [`downsample_factor`] aims for by default: 64.
pub const FIT_SUBJECT_HEIGHT: u32 = 64;

/// The height in pixels of the subject in `mask`: the rows from the first to the last holding a
/// pixel above 0.5, 0 when none does.
pub fn subject_height(mask: &Image) -> u32 {
    subject_box(mask).map_or(0, |(_, y0, _, y1)| y1 - y0 + 1)
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

/// The window side [`subject_windows`] gives, over the subject's largest extent: 1.25 (the
/// subject fills 80% of it, as the MakeHuman body fills about 84% of the 64 × 64 views the method
/// was tuned on).
pub const SUBJECT_WINDOW_SCALE: f64 = 1.25;

/// The box `(x0, y0, x1, y1)` (inclusive) of `mask`'s pixels above 0.5; `None` when none is.
fn subject_box(mask: &Image) -> Option<(u32, u32, u32, u32)> {
    let width = mask.width().max(1) as usize;
    let mut found: Option<(u32, u32, u32, u32)> = None;
    for (k, _) in mask.data().iter().enumerate().filter(|(_, v)| **v > 0.5) {
        let (x, y) = ((k % width) as u32, (k / width) as u32);
        found = Some(found.map_or((x, y, x, y), |(x0, y0, x1, y1)| (x0.min(x), y0.min(y), x1.max(x), y1.max(y))));
    }
    found
}

/// Square windows of one size, one per mask, each framing its view's subject (the pixels above
/// 0.5) as the method was tuned: the side [`SUBJECT_WINDOW_SCALE`] times the subject's largest
/// extent over the views (width or height), centred on the subject's box and moved inside the
/// image where it would reach beyond. `None`, to fit the masks as they are, where the window
/// would not fit inside every mask, where it would leave out less than a quarter of the width or
/// of the height of every mask (the subject already fills its frames, as in a framing rig), or
/// where a mask shows no subject.
///
/// Why: the masks of the `fit_pose` example's own targets at 64 × 64, placed in larger empty
/// images with their cameras' principal points moved to match, fit worse and slower the more
/// empty image there is around the subject (the MakeHuman body, seed 2, at 64²: 3.64 mm in
/// 1.7 s; in 128²: 4.36 mm; in 192²: 23.5 mm in 10 s; in 640 × 480: 9.85 mm in 46 s), since the
/// blur is a fraction of the image height and `E_sl` a mean over all pixels.
///
/// ```
/// use diffsil::pose::fit::subject_windows;
/// use diffsil::{Image, PixelRect};
///
/// // A subject 40 pixels tall and 10 wide in a 640 × 480 mask: a 50 × 50 window about it.
/// let mut mask = Image::filled(640, 480, 0.0);
/// for row in 100..140 {
///     for column in 300..310 {
///         mask.data_mut()[row * 640 + column] = 1.0;
///     }
/// }
/// let windows = subject_windows(&[mask.clone()]).unwrap();
/// assert_eq!(windows, vec![PixelRect { x: 280, y: 95, width: 50, height: 50 }]);
/// // Framed already (a 40-pixel subject in 48 × 48, where a 50-pixel window does not fit):
/// // nothing to crop.
/// assert_eq!(subject_windows(&[mask.cropped(PixelRect { x: 281, y: 96, width: 48, height: 48 }).unwrap()]), None);
/// ```
pub fn subject_windows(masks: &[Image]) -> Option<Vec<PixelRect>> {
    let boxes: Vec<(u32, u32, u32, u32)> = masks.iter().map(subject_box).collect::<Option<_>>()?;
    let extent = boxes.iter().map(|&(x0, y0, x1, y1)| (x1 - x0 + 1).max(y1 - y0 + 1)).max()?;
    let side = (extent as f64 * SUBJECT_WINDOW_SCALE).ceil() as u64;
    let fits = masks.iter().all(|m| side <= m.width().min(m.height()) as u64);
    let leaves_a_quarter = masks.iter().any(|m| 4 * side <= 3 * m.width().min(m.height()) as u64);
    if !(fits && leaves_a_quarter) {
        return None;
    }
    let side = side as u32;
    let place = |lo: u32, hi: u32, size: u32| {
        // Centred on the box (rounded down), then moved inside `0..size`.
        let start = (lo as i64 + hi as i64 + 1 - side as i64).div_euclid(2);
        start.clamp(0, (size - side) as i64) as u32
    };
    Some(
        masks
            .iter()
            .zip(&boxes)
            .map(|(m, &(x0, y0, x1, y1))| PixelRect {
                x: place(x0, x1, m.width()),
                y: place(y0, y1, m.height()),
                width: side,
                height: side,
            })
            .collect(),
    )
}

/// Where a fit of masks at a camera's resolution works: the masks and their cameras cropped to
/// [`subject_windows`] (where those are given and `crop` is set), then downsampled together by
/// [`downsample_factor`] for the subject `height` (0: not downsampled). Pass [`FitFrame::cameras`]
/// and [`FitFrame::masks`] to [`fit`](super::fit); the fitted pose is in world space and renders
/// with the original cameras at the masks' own resolution.
///
/// ```
/// use diffsil::pose::fit::{FitFrame, FIT_SUBJECT_HEIGHT};
/// use diffsil::{Camera, Image, PixelRect, Vec3};
///
/// // A subject 300 pixels tall in a 1920 × 1080 mask: a 375-pixel window, then 4× smaller.
/// let mut mask = Image::filled(1920, 1080, 0.0);
/// for row in 500..800 {
///     mask.data_mut()[row * 1920 + 1000] = 1.0;
/// }
/// let camera = Camera::perspective(Vec3::new(0.0, 1.0, 5.0), Vec3::new(0.0, 1.0, 0.0), 0.6, 1920, 1080);
/// let frame = FitFrame::new(&[camera], &[mask], FIT_SUBJECT_HEIGHT, true).unwrap();
/// assert_eq!(frame.windows, Some(vec![PixelRect { x: 813, y: 462, width: 375, height: 375 }]));
/// assert_eq!((frame.factor, frame.masks[0].width(), frame.cameras[0].height), (4, 93, 93));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct FitFrame {
    /// The windows the masks were cropped to, one per mask; `None` where they were not.
    pub windows: Option<Vec<PixelRect>>,
    /// The factor they were then downsampled by (1: not at all).
    pub factor: u32,
    /// The cameras, cropped and downsampled.
    pub cameras: Vec<Camera>,
    /// The masks, cropped and downsampled.
    pub masks: Vec<Image>,
}

impl FitFrame {
    /// The frame of `masks` seen by `cameras` (one mask per camera, of its size).
    ///
    /// Errors: [`Error::ViewCountMismatch`] for a mask count other than the cameras',
    /// [`Error::SizeMismatch`] for a mask of another size than its camera, and those of
    /// [`Camera::cropped`] and [`Camera::downsampled`] (an orthographic camera that cannot
    /// be).
    pub fn new(cameras: &[Camera], masks: &[Image], height: u32, crop: bool) -> Result<FitFrame> {
        if masks.len() != cameras.len() {
            return Err(Error::ViewCountMismatch { what: "masks", views: cameras.len(), got: masks.len() });
        }
        for (camera, mask) in cameras.iter().zip(masks) {
            mask.expect_size("mask", camera.width, camera.height)?;
        }
        let windows = if crop { subject_windows(masks) } else { None };
        // The crops where there are windows; the masks themselves (not copied) where not.
        let cropped = match &windows {
            Some(windows) => Some((
                cameras.iter().zip(windows).map(|(c, w)| c.cropped(*w)).collect::<Result<Vec<_>>>()?,
                masks.iter().zip(windows).map(|(m, w)| m.cropped(*w)).collect::<Result<Vec<_>>>()?,
            )),
            None => None,
        };
        let (cameras, masks) = cropped.as_ref().map_or((cameras, masks), |(c, m)| (c.as_slice(), m.as_slice()));
        let factor = downsample_factor(masks, height);
        let cameras = cameras.iter().map(|c| c.downsampled(factor)).collect::<Result<_>>()?;
        let masks = masks.iter().map(|m| m.downsampled(factor)).collect::<Result<_>>()?;
        Ok(FitFrame { windows, factor, cameras, masks })
    }
}
