//! PNG images: rendered images out, silhouette targets in.

use std::fs::File;
use std::io::{BufWriter, Cursor, Write};
use std::path::Path;

use image::{DynamicImage, ImageEncoder};

use super::{format_error, read_regular_file, MAX_FILE_BYTES};
use crate::scene::camera::MAX_RESOLUTION;
use crate::{Error, Image, Result};

/// Saves an image as an 8-bit grayscale PNG: each value is clamped to [0, 1], scaled by 255 and
/// rounded (NaN is written as 0).
///
/// Errors: [`Error::Io`] if the file cannot be written; [`Error::Format`] for an image with a
/// zero side, which PNG cannot store.
pub fn save_png(image: &Image, path: impl AsRef<Path>) -> Result<()> {
    let path = path.as_ref();
    if image.width() == 0 || image.height() == 0 {
        return Err(format_error(
            path,
            format!("cannot save a {}x{} image as PNG: both sides must be at least 1", image.width(), image.height()),
        ));
    }
    let bytes: Vec<u8> = image.data().iter().map(|&v| (unit(v) * 255.0).round() as u8).collect();
    let io_error = |source| Error::Io { path: path.to_path_buf(), source };
    let file = File::create(path).map_err(io_error)?;
    let mut writer = BufWriter::new(file);
    image::codecs::png::PngEncoder::new(&mut writer)
        .write_image(&bytes, image.width(), image.height(), image::ExtendedColorType::L8)
        .map_err(|e| image_error(path, e))?;
    writer.flush().map_err(io_error)
}

/// Most memory [`load_png_target`] lets the PNG decoder allocate: 1 GiB (a 16384² RGBA 8-bit
/// image). A file declaring more is refused before its pixels are decoded.
pub const MAX_PNG_DECODE_BYTES: u64 = 1 << 30;

/// How [`load_png_target`] turns a PNG's pixels into target values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TargetMode {
    /// The pixel's value in [0, 1] (see [`load_png_target`]), kept as soft coverage.
    Coverage,
    /// A hard silhouette: 1.0 where the pixel's value is strictly greater than the threshold,
    /// else 0.0. The threshold must not be NaN.
    Threshold(f32),
}

/// Loads a PNG silhouette as a target image (row 0 at the top).
///
/// Accepts 8- and 16-bit grayscale, grayscale + alpha, RGB, RGBA and palette PNGs. A pixel's
/// value is, with every channel normalised to [0, 1]:
/// - grayscale: the gray value;
/// - RGB: the Rec. 709 luma `0.2126 R + 0.7152 G + 0.0722 B` (no gamma decoding: a silhouette
///   PNG is white on black, so this is only a tie-break for coloured masks);
/// - with alpha, the above times alpha, so transparent pixels are background. (A mask stored
///   only in the alpha channel of a black image therefore loads as all zero: convert it first.)
///
/// [`TargetMode`] then keeps that value or thresholds it to 0/1.
///
/// Untrusted files: the file must be a regular file of at most
/// [`MAX_FILE_BYTES`](crate::io::MAX_FILE_BYTES); the decoder refuses images with a side above
/// [`MAX_RESOLUTION`](crate::scene::camera::MAX_RESOLUTION) (no view can render larger) and
/// decoded pixel data above [`MAX_PNG_DECODE_BYTES`], before decoding (a small compressed file
/// can declare a huge image).
///
/// Errors: [`Error::Io`] if the file cannot be read; [`Error::Format`] if it is not a PNG the
/// decoder accepts, is truncated, or is above the limits; [`Error::InvalidSettings`] for a NaN
/// threshold.
pub fn load_png_target(path: impl AsRef<Path>, mode: TargetMode) -> Result<Image> {
    let path = path.as_ref();
    if let TargetMode::Threshold(t) = mode {
        if t.is_nan() {
            return Err(Error::InvalidSettings("the target threshold is NaN: use a number such as 0.5".into()));
        }
    }
    let bytes = read_regular_file(path, MAX_FILE_BYTES, "a PNG file", "downscale the image")?;
    let mut reader = image::ImageReader::with_format(Cursor::new(bytes), image::ImageFormat::Png);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_RESOLUTION);
    limits.max_image_height = Some(MAX_RESOLUTION);
    limits.max_alloc = Some(MAX_PNG_DECODE_BYTES);
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| image_error(path, e))?;
    let (width, height) = (decoded.width(), decoded.height());
    let values = match &decoded {
        DynamicImage::ImageLuma8(b) => pixel_values(b.as_raw(), 1, u8::MAX.into()),
        DynamicImage::ImageLumaA8(b) => pixel_values(b.as_raw(), 2, u8::MAX.into()),
        DynamicImage::ImageRgb8(b) => pixel_values(b.as_raw(), 3, u8::MAX.into()),
        DynamicImage::ImageRgba8(b) => pixel_values(b.as_raw(), 4, u8::MAX.into()),
        DynamicImage::ImageLuma16(b) => pixel_values(b.as_raw(), 1, u16::MAX.into()),
        DynamicImage::ImageLumaA16(b) => pixel_values(b.as_raw(), 2, u16::MAX.into()),
        DynamicImage::ImageRgb16(b) => pixel_values(b.as_raw(), 3, u16::MAX.into()),
        DynamicImage::ImageRgba16(b) => pixel_values(b.as_raw(), 4, u16::MAX.into()),
        DynamicImage::ImageRgb32F(b) => pixel_values(b.as_raw(), 3, 1.0),
        DynamicImage::ImageRgba32F(b) => pixel_values(b.as_raw(), 4, 1.0),
        other => pixel_values(other.to_rgba32f().as_raw(), 4, 1.0),
    };
    let image = Image::from_vec(width, height, values)?;
    Ok(match mode {
        TargetMode::Threshold(t) => image.thresholded(t),
        TargetMode::Coverage => image,
    })
}

/// Per-pixel values in [0, 1] from interleaved samples with `channels` channels (1: gray,
/// 2: gray + alpha, 3: RGB, 4: RGBA) whose full scale is `max`.
fn pixel_values<T: Copy + Into<f32>>(samples: &[T], channels: usize, max: f32) -> Vec<f32> {
    let norm = |s: T| unit(s.into() / max);
    samples
        .chunks_exact(channels)
        .map(|p| {
            let colour = |p: &[T]| match p.len() {
                1 => norm(p[0]),
                _ => 0.2126 * norm(p[0]) + 0.7152 * norm(p[1]) + 0.0722 * norm(p[2]),
            };
            match channels {
                1 => norm(p[0]),
                2 => norm(p[0]) * norm(p[1]),
                3 => colour(p),
                _ => colour(&p[..3]) * norm(p[3]),
            }
        })
        .map(unit)
        .collect()
}

/// Clamps to [0, 1], mapping NaN to 0.
fn unit(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

/// The decoder's error as ours: a file that ends early is a truncated PNG, a limit names the
/// limit.
fn image_error(path: &Path, e: image::ImageError) -> Error {
    use image::error::{ImageError, LimitErrorKind};
    match e {
        ImageError::IoError(source) if source.kind() == std::io::ErrorKind::UnexpectedEof => format_error(
            path,
            "truncated PNG: the file ends before the image data is complete; re-export or re-download it".into(),
        ),
        ImageError::IoError(source) => Error::Io { path: path.to_path_buf(), source },
        ImageError::Limits(limit) => {
            let which = match limit.kind() {
                LimitErrorKind::DimensionError => {
                    format!("a side above the largest supported resolution, {MAX_RESOLUTION} pixels")
                }
                LimitErrorKind::InsufficientMemory => {
                    format!("more than the decoding limit of {MAX_PNG_DECODE_BYTES} bytes of pixel data")
                }
                _ => format!("an unsupported size ({limit})"),
            };
            format_error(path, format!("PNG image refused before decoding: it declares {which}; downscale it first"))
        }
        other => {
            let text = other.to_string();
            if text.contains("end of file") || text.contains("EOF") || text.contains("truncated") {
                return format_error(path, format!("truncated PNG ({text}): re-export or re-download it"));
            }
            format_error(path, format!("not a usable PNG image: {text}"))
        }
    }
}
