//! A single-channel f32 image, row-major, row 0 at the top.

use crate::{Error, Result};

/// A single-channel image of `f32` values, row-major with row 0 at the top: pixel (i, j) (row i,
/// column j) is `data[i * width + j]` and covers the square `[j, j+1] × [i, i+1]` of screen space.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    width: u32,
    height: u32,
    data: Vec<f32>,
}

impl Image {
    /// An image filled with `value`.
    pub fn filled(width: u32, height: u32, value: f32) -> Image {
        Image { width, height, data: vec![value; width as usize * height as usize] }
    }

    /// An image from row-major data; `data.len()` must be `width * height`.
    pub fn from_vec(width: u32, height: u32, data: Vec<f32>) -> Result<Image> {
        let expected = width as usize * height as usize;
        if data.len() != expected {
            return Err(Error::LengthMismatch { what: "image data", expected, got: data.len() });
        }
        Ok(Image { width, height, data })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixel values, row-major.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// The pixel values, row-major, mutable.
    pub fn data_mut(&mut self) -> &mut [f32] {
        &mut self.data
    }

    /// Consumes the image, returning its row-major values.
    pub fn into_vec(self) -> Vec<f32> {
        self.data
    }

    /// Value of pixel (row, column).
    ///
    /// # Panics
    ///
    /// When the pixel is outside the image (`row >= height` or `column >= width`), naming both; use
    /// [`Image::checked_get`] for indices that may be out of range.
    pub fn get(&self, row: u32, column: u32) -> f32 {
        match self.checked_get(row, column) {
            Some(v) => v,
            None => panic!(
                "Image::get: pixel (row {row}, column {column}) is outside the {}x{} image",
                self.width, self.height
            ),
        }
    }

    /// Value of pixel (row, column), or `None` when it is outside the image.
    pub fn checked_get(&self, row: u32, column: u32) -> Option<f32> {
        if row >= self.height || column >= self.width {
            return None;
        }
        self.data.get(row as usize * self.width as usize + column as usize).copied()
    }

    /// Errors with [`Error::SizeMismatch`] unless this image is `width × height`.
    pub fn expect_size(&self, what: &'static str, width: u32, height: u32) -> Result<()> {
        if self.width != width || self.height != height {
            return Err(Error::SizeMismatch {
                what,
                expected_width: width,
                expected_height: height,
                width: self.width,
                height: self.height,
            });
        }
        Ok(())
    }
}
