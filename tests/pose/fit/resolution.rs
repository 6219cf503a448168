//! The resolution a fit works at (`subject_height`, `downsample_factor`) and its windows
//! (`subject_windows`): hand-made masks, and the framing the README's tables use, which needs
//! no downsampling and no window.

use diffsil::pose::fit::{
    downsample_factor, framing_ring, subject_height, subject_windows, FitFrame, FIT_SUBJECT_HEIGHT,
    RAISED_ELEVATION_DEG,
};
use diffsil::pose::makehuman_body;
use diffsil::pose::skin::Pose;
use diffsil::{Camera, Error, Image, Mesh, PixelRect, RenderSettings, Renderer, Vec3};

/// A `width × height` mask with the rows `rows` set to `value` in column 1.
fn mask(width: u32, height: u32, rows: std::ops::Range<usize>, value: f32) -> Image {
    let mut image = Image::filled(width, height, 0.0);
    for row in rows {
        image.data_mut()[row * width as usize + 1] = value;
    }
    image
}

#[test]
fn the_subject_spans_the_rows_holding_a_pixel_above_one_half() {
    assert_eq!(subject_height(&Image::filled(8, 6, 0.0)), 0);
    assert_eq!(subject_height(&mask(8, 6, 2..3, 1.0)), 1);
    assert_eq!(subject_height(&mask(8, 12, 3..10, 0.6)), 7);
    assert_eq!(subject_height(&mask(8, 12, 3..10, 0.5)), 0, "0.5 is not above one half");
    // A gap inside the subject counts: the rows from the first to the last.
    let mut gap = mask(8, 12, 1..3, 1.0);
    gap.data_mut()[10 * 8 + 5] = 1.0;
    assert_eq!(subject_height(&gap), 10);
    assert_eq!(subject_height(&Image::filled(3, 4, 1.0)), 4);
}

#[test]
fn the_factor_keeps_the_tallest_subject_at_least_the_height_asked_for() {
    // 330 pixels tall: 5 × 66.
    let person = mask(640, 480, 70..400, 1.0);
    assert_eq!(downsample_factor(std::slice::from_ref(&person), 64), 5);
    assert_eq!(downsample_factor(std::slice::from_ref(&person), 66), 5);
    assert_eq!(downsample_factor(std::slice::from_ref(&person), 67), 4);
    // The tallest of several decides; shorter than asked, or no height asked: 1 (never upsampled).
    assert_eq!(downsample_factor(&[mask(640, 480, 0..100, 1.0), person.clone()], 64), 5);
    assert_eq!(downsample_factor(&[mask(64, 64, 5..60, 1.0)], FIT_SUBJECT_HEIGHT), 1);
    assert_eq!(downsample_factor(std::slice::from_ref(&person), 0), 1);
    assert_eq!(downsample_factor(&[], 64), 1);
    assert_eq!(downsample_factor(&[Image::filled(640, 480, 0.0)], 64), 1);
    // Never more than a side of the smallest mask: every downsampled mask keeps a pixel.
    assert_eq!(downsample_factor(&[mask(3, 1000, 0..1000, 1.0)], 1), 3);
    assert_eq!(downsample_factor(&[person, Image::filled(2, 2, 0.0)], 64), 2);
}

/// The README's tables fit the MakeHuman body at 64², seen from the raised ring: there the body
/// is as tall as the method wants, and nothing is downsampled.
#[test]
fn the_tables_framing_needs_no_downsampling() {
    let model = makehuman_body().unwrap();
    let rest =
        Mesh::with_topology(model.skin(&Pose::rest(model.joint_count())).unwrap(), model.mesh.topology().clone())
            .unwrap();
    let cameras = framing_ring(&rest, 4, 64, RAISED_ELEVATION_DEG.to_radians());
    let masks = Renderer::new(RenderSettings::default()).unwrap().render(&rest, &cameras).unwrap().images().to_vec();
    let tallest = masks.iter().map(subject_height).max().unwrap();
    assert!((50..=70).contains(&tallest), "the body is {tallest} pixels tall");
    assert_eq!(downsample_factor(&masks, FIT_SUBJECT_HEIGHT), 1);
    assert_eq!(subject_windows(&masks), None, "framed already");
    // The same rig at 4 times the resolution is brought back to it.
    let large = framing_ring(&rest, 4, 256, RAISED_ELEVATION_DEG.to_radians());
    let masks = Renderer::new(RenderSettings::default()).unwrap().render(&rest, &large).unwrap().images().to_vec();
    let tallest_large = masks.iter().map(subject_height).max().unwrap();
    assert!(tallest_large.abs_diff(4 * tallest) <= 4, "{tallest_large} pixels tall at 256², {tallest} at 64²");
    assert_eq!(downsample_factor(&masks, FIT_SUBJECT_HEIGHT), tallest_large / FIT_SUBJECT_HEIGHT);
    assert!(tallest_large / (tallest_large / FIT_SUBJECT_HEIGHT) >= FIT_SUBJECT_HEIGHT);
}

/// A `width × height` mask covered (1) in the box `x0..x1 × y0..y1`.
fn block(width: u32, height: u32, (x0, x1): (u32, u32), (y0, y1): (u32, u32)) -> Image {
    let mut image = Image::filled(width, height, 0.0);
    for y in y0..y1 {
        for x in x0..x1 {
            image.data_mut()[(y * width + x) as usize] = 1.0;
        }
    }
    image
}

#[test]
fn windows_frame_a_small_subject_in_every_view_alike() {
    // Subjects 40 x 16 (lying down) and 10 x 30 in 200 x 120 masks: one side for both, 1.25 times
    // the largest extent (40), each centred on its own subject.
    let masks = [block(200, 120, (20, 60), (50, 66)), block(200, 120, (150, 160), (2, 32))];
    let windows = subject_windows(&masks).unwrap();
    assert_eq!(
        windows,
        vec![PixelRect { x: 15, y: 33, width: 50, height: 50 }, PixelRect { x: 130, y: 0, width: 50, height: 50 }],
        "the second moved down inside the mask"
    );
    // Each window holds its subject: cropped, the mask keeps every covered pixel.
    for (mask, window) in masks.iter().zip(&windows) {
        let sum = |m: &Image| m.data().iter().sum::<f32>();
        assert_eq!(sum(&mask.cropped(*window).unwrap()), sum(mask));
    }
    // At a subject's edge of the mask the window moves inside it too.
    let corner = subject_windows(&[block(200, 120, (190, 200), (0, 8))]).unwrap();
    assert_eq!(corner, vec![PixelRect { x: 187, y: 0, width: 13, height: 13 }]);
    // A window leaving less than a quarter of a side out: none. 4 · 50 ≤ 3 · 67 but not 3 · 66.
    assert!(subject_windows(&[block(200, 67, (20, 60), (10, 26))]).is_some());
    assert_eq!(subject_windows(&[block(200, 66, (20, 60), (10, 26))]), None);
    // Masks of other sizes: one where the window leaves a quarter out is enough, if it fits in
    // all of them (50 ≤ 50).
    let small_mask = block(50, 66, (10, 20), (10, 20));
    let mixed = subject_windows(&[block(200, 120, (20, 60), (50, 66)), small_mask.clone()]).unwrap();
    assert_eq!(mixed[1], PixelRect { x: 0, y: 0, width: 50, height: 50 }, "one mask small: {mixed:?}");
    let too_small = block(49, 66, (10, 20), (10, 20));
    assert_eq!(subject_windows(&[block(200, 120, (20, 60), (50, 66)), too_small]), None, "the window does not fit");
    assert_eq!(subject_windows(&[block(60, 60, (20, 60), (10, 26)), small_mask]), None, "none leaves a quarter");
    // No subject in a view, or no masks: none.
    assert_eq!(subject_windows(&[masks[0].clone(), Image::filled(200, 120, 0.0)]), None);
    assert_eq!(subject_windows(&[]), None);
    // Only pixels above one half count.
    let mut faint = masks[0].clone();
    faint.data_mut()[119 * 200 + 199] = 0.5;
    assert_eq!(subject_windows(&[faint]).unwrap()[0], windows[0]);
}

/// `FitFrame`: the windows, then the factor, applied to the masks and cameras alike; no windows
/// when not asked for; a mask count or size other than the cameras' is an error.
#[test]
fn a_fit_frame_crops_then_downsamples_masks_and_cameras_alike() {
    // A subject 160 pixels tall in 640 × 480: a 200-pixel window, downsampled 2× for 64.
    let mask = block(640, 480, (300, 340), (100, 260));
    let camera = Camera::perspective(Vec3::new(0.0, 1.0, 5.0), Vec3::new(0.0, 1.0, 0.0), 0.7, 640, 480);
    let frame = FitFrame::new(&[camera], std::slice::from_ref(&mask), 64, true).unwrap();
    let window = PixelRect { x: 220, y: 80, width: 200, height: 200 };
    assert_eq!((frame.windows.clone(), frame.factor), (Some(vec![window]), 2));
    assert_eq!(frame.masks[0], mask.cropped(window).unwrap().downsampled(2).unwrap());
    assert_eq!(frame.cameras[0], camera.cropped(window).unwrap().downsampled(2).unwrap());
    let whole = FitFrame::new(&[camera], std::slice::from_ref(&mask), 64, false).unwrap();
    assert_eq!((whole.windows, whole.factor), (None, 2));
    assert_eq!(whole.masks[0], mask.downsampled(2).unwrap());
    let as_they_are = FitFrame::new(&[camera], std::slice::from_ref(&mask), 0, false).unwrap();
    assert_eq!((as_they_are.cameras, as_they_are.masks), (vec![camera], vec![mask.clone()]));
    let two = FitFrame::new(&[camera, camera], std::slice::from_ref(&mask), 64, true);
    assert!(matches!(two, Err(Error::ViewCountMismatch { views: 2, got: 1, .. })), "{two:?}");
    let other = FitFrame::new(&[camera], &[block(320, 240, (10, 20), (10, 20))], 64, true);
    assert!(matches!(other, Err(Error::SizeMismatch { .. })), "{other:?}");
}
