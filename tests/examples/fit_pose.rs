//! `fit_pose`'s imperfect masks: a dilation grows a silhouette by one pixel, an erosion shrinks
//! it by one, a flip changes the asked-for fraction of pixels and nothing else.

#[path = "../../examples/fit_pose/masks.rs"]
#[allow(dead_code)]
mod masks;

use diffsil::Image;
use masks::{apply, MaskNoise};

/// A 12×12 image with a 4×4 square of ones at rows and columns 4..8.
fn square() -> Image {
    let mut image = Image::filled(12, 12, 0.0);
    for i in 4..8 {
        for j in 4..8 {
            image.data_mut()[i * 12 + j] = 1.0;
        }
    }
    image
}

fn count(image: &Image) -> usize {
    image.data().iter().filter(|v| **v == 1.0).count()
}

#[test]
fn dilate_and_erode_move_the_outline_by_one_pixel() {
    let image = square();
    let fat = apply(MaskNoise::Dilate, &image, 0.0, 1);
    assert_eq!(count(&fat), 36, "a 6×6 square");
    assert_eq!((fat.get(3, 3), fat.get(8, 8), fat.get(2, 2)), (1.0, 1.0, 0.0));
    let thin = apply(MaskNoise::Erode, &image, 0.0, 1);
    assert_eq!(count(&thin), 4, "a 2×2 square");
    assert_eq!((thin.get(5, 5), thin.get(4, 4)), (1.0, 0.0));
    assert_eq!(apply(MaskNoise::None, &image, 0.5, 1), image);
}

#[test]
fn flip_changes_about_the_fraction_asked_for() {
    let image = Image::filled(100, 100, 0.0);
    let flipped = apply(MaskNoise::Flip, &image, 0.02, 7);
    let changed = count(&flipped);
    assert!((150..=250).contains(&changed), "{changed} of 10,000 pixels flipped");
    assert_eq!(flipped, apply(MaskNoise::Flip, &image, 0.02, 7), "same seed, same pixels");
    assert_ne!(flipped, apply(MaskNoise::Flip, &image, 0.02, 8));
}
