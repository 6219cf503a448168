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

    /// The image hardened at `threshold`: 1 where a pixel's value is above it, else 0 (what
    /// [`TargetMode::Threshold`](crate::io::TargetMode::Threshold) does to a loaded mask).
    ///
    /// ```
    /// use diffsil::Image;
    ///
    /// let soft = Image::from_vec(3, 1, vec![0.2, 0.5, 0.8])?;
    /// assert_eq!(soft.thresholded(0.5).data(), &[0.0, 0.0, 1.0]);
    /// # Ok::<(), diffsil::Error>(())
    /// ```
    pub fn thresholded(mut self, threshold: f32) -> Image {
        for v in &mut self.data {
            *v = if *v > threshold { 1.0 } else { 0.0 };
        }
        self
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

    /// This image at `1/factor` of its resolution: each new pixel the mean of a `factor × factor`
    /// block, the `width % factor` columns on the right and `height % factor` rows at the bottom
    /// (the partial blocks) left out. Pixel `(i, j)` then covers `[j, j+1] × [i, i+1]` of the old
    /// image's screen space divided by `factor`, the same area as its block: a coverage image
    /// downsampled is the coverage at the lower resolution (up to rounding), so targets at a
    /// camera's resolution go with [`Camera::downsampled`](crate::Camera::downsampled) cameras.
    /// The sums are taken in f64.
    ///
    /// ```
    /// use diffsil::Image;
    ///
    /// let image = Image::from_vec(5, 2, vec![1.0, 0.0, 0.5, 0.5, 9.0, 0.0, 1.0, 0.5, 0.5, 9.0]).unwrap();
    /// let half = image.downsampled(2).unwrap(); // the fifth column is a partial block: left out
    /// assert_eq!((half.width(), half.height(), half.data()), (2, 1, &[0.5, 0.5][..]));
    /// ```
    ///
    /// Errors: [`Error::InvalidSettings`] for a `factor` of 0, or one larger than the width or
    /// the height (nothing would be left).
    pub fn downsampled(&self, factor: u32) -> Result<Image> {
        check_downsampling("image", factor, self.width, self.height)?;
        let (width, height) = (self.width / factor, self.height / factor);
        let (k, stride) = (factor as usize, self.width as usize);
        let scale = 1.0 / (k * k) as f64;
        let mut data = Vec::with_capacity(width as usize * height as usize);
        for i in 0..height as usize {
            for j in 0..width as usize {
                let block = (0..k).flat_map(|r| &self.data[(i * k + r) * stride + j * k..][..k]);
                data.push((block.map(|&v| v as f64).sum::<f64>() * scale) as f32);
            }
        }
        Ok(Image { width, height, data })
    }

    /// The pixels of `rect` as an image of their own: pixel `(i, j)` of the result is pixel
    /// `(rect.y + i, rect.x + j)` of this one. Targets cropped so go with
    /// [`Camera::cropped`](crate::Camera::cropped) cameras.
    ///
    /// ```
    /// use diffsil::{Image, PixelRect};
    ///
    /// let image = Image::from_vec(3, 2, vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]).unwrap();
    /// let right = image.cropped(PixelRect { x: 1, y: 0, width: 2, height: 2 }).unwrap();
    /// assert_eq!((right.width(), right.height(), right.data()), (2, 2, &[1.0, 2.0, 4.0, 5.0][..]));
    /// ```
    ///
    /// Errors: [`Error::InvalidSettings`] for an empty `rect` or one reaching beyond the image.
    pub fn cropped(&self, rect: PixelRect) -> Result<Image> {
        rect.check_inside("image", self.width, self.height)?;
        let stride = self.width as usize;
        let data = (rect.y..rect.y + rect.height)
            .flat_map(|i| &self.data[i as usize * stride + rect.x as usize..][..rect.width as usize])
            .copied()
            .collect();
        Ok(Image { width: rect.width, height: rect.height, data })
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

/// Errors with [`Error::InvalidSettings`] unless `factor` is at least 1 and at most `width` and
/// `height`: the check of [`Image::downsampled`] and [`Camera::downsampled`](crate::Camera::downsampled)
/// (`what` names the one downsampled).
pub(crate) fn check_downsampling(what: &str, factor: u32, width: u32, height: u32) -> Result<()> {
    if factor == 0 || factor > width || factor > height {
        return Err(Error::InvalidSettings(format!(
            "downsampling factor {factor} for a {width}x{height} {what}: it must be at least 1 and at most the \
             width and the height"
        )));
    }
    Ok(())
}

/// A rectangle of whole pixels of an image: the columns `x..x + width` and the rows
/// `y..y + height` ([`Image::cropped`], [`Camera::cropped`](crate::Camera::cropped)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PixelRect {
    /// The first column.
    pub x: u32,
    /// The first row.
    pub y: u32,
    /// Columns, at least 1.
    pub width: u32,
    /// Rows, at least 1.
    pub height: u32,
}

impl PixelRect {
    /// Errors with [`Error::InvalidSettings`] unless this rectangle is non-empty and lies inside a
    /// `width × height` image (`what` names the image or camera).
    pub(crate) fn check_inside(&self, what: &str, width: u32, height: u32) -> Result<()> {
        let inside = |start: u32, size: u32, side: u32| size >= 1 && start.checked_add(size).is_some_and(|e| e <= side);
        if !(inside(self.x, self.width, width) && inside(self.y, self.height, height)) {
            return Err(Error::InvalidSettings(format!(
                "crop of {}x{} pixels at ({}, {}) for a {width}x{height} {what}: it must hold at least one pixel \
                 and lie inside",
                self.width, self.height, self.x, self.y
            )));
        }
        Ok(())
    }
}
