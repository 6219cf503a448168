//! Image losses against a target silhouette, each returning its value and `∂L/∂I`.
//!
//! The gradient image has the size of the rendered image and feeds the renderer's backward pass.
//! Sums are accumulated in `f64`. Every function rejects a target of another size
//! ([`Error::SizeMismatch`]) and non-finite pixel values ([`Error::InvalidSettings`]), so no NaN
//! comes out.

use crate::{Error, Image, Result};

/// A loss value and its gradient with respect to the rendered image.
#[derive(Clone, Debug, PartialEq)]
pub struct LossOutput {
    /// The loss `L`.
    pub value: f64,
    /// `∂L/∂I`, one value per pixel of the rendered image.
    pub grad: Image,
}

/// Sum of squared differences (paper Eq. 18): `L = Σ (I − T)²`, `∂L/∂I = 2 (I − T)`.
pub fn squared_error(image: &Image, target: &Image) -> Result<LossOutput> {
    check(image, target)?;
    let mut value = 0.0f64;
    let grad: Vec<f32> = image
        .data()
        .iter()
        .zip(target.data())
        .map(|(&i, &t)| {
            let d = f64::from(i) - f64::from(t);
            value += d * d;
            (2.0 * d) as f32
        })
        .collect();
    Ok(LossOutput { value, grad: Image::from_vec(image.width(), image.height(), grad)? })
}

/// Soft intersection over union: `L = 1 − Σ I·T / Σ (I + T − I·T)`, for values in [0, 1].
///
/// With `A = Σ I·T` and `U = Σ (I + T − I·T)`, `∂L/∂I = −(T·U − A·(1 − T)) / U²`. When `U` is
/// zero (both images empty) the images match: the loss is 0 and the gradient zero.
pub fn soft_iou(image: &Image, target: &Image) -> Result<LossOutput> {
    check(image, target)?;
    let (mut inter, mut union) = (0.0f64, 0.0f64);
    for (&i, &t) in image.data().iter().zip(target.data()) {
        let (i, t) = (f64::from(i), f64::from(t));
        inter += i * t;
        union += i + t - i * t;
    }
    if union == 0.0 || !union.is_finite() {
        return Ok(LossOutput { value: 0.0, grad: Image::filled(image.width(), image.height(), 0.0) });
    }
    let value = 1.0 - inter / union;
    let u2 = union * union;
    let grad: Vec<f32> = target
        .data()
        .iter()
        .map(|&t| {
            let t = f64::from(t);
            (-(t * union - inter * (1.0 - t)) / u2) as f32
        })
        .collect();
    Ok(LossOutput { value, grad: Image::from_vec(image.width(), image.height(), grad)? })
}

/// [`squared_error`] summed over views: returns the total and one `∂L/∂I` per view.
///
/// Errors with [`Error::ViewCountMismatch`] unless there is one target per image.
pub fn squared_error_views(images: &[Image], targets: &[Image]) -> Result<(f64, Vec<Image>)> {
    per_view(images, targets, 1.0, squared_error)
}

/// [`soft_iou`] averaged over views: returns the mean and one `∂L/∂I` per view (each view's
/// gradient divided by the number of views). No views give 0.
///
/// Errors with [`Error::ViewCountMismatch`] unless there is one target per image.
pub fn soft_iou_views(images: &[Image], targets: &[Image]) -> Result<(f64, Vec<Image>)> {
    let scale = if images.is_empty() { 1.0 } else { 1.0 / images.len() as f64 };
    per_view(images, targets, scale, soft_iou)
}

/// Applies `loss` to each (image, target) pair, scaling values and gradients by `scale`.
fn per_view(
    images: &[Image],
    targets: &[Image],
    scale: f64,
    loss: fn(&Image, &Image) -> Result<LossOutput>,
) -> Result<(f64, Vec<Image>)> {
    if targets.len() != images.len() {
        return Err(Error::ViewCountMismatch { what: "targets", views: images.len(), got: targets.len() });
    }
    let mut total = 0.0;
    let mut grads = Vec::with_capacity(images.len());
    for (image, target) in images.iter().zip(targets) {
        let LossOutput { value, mut grad } = loss(image, target)?;
        total += value * scale;
        if scale != 1.0 {
            for g in grad.data_mut() {
                *g = (f64::from(*g) * scale) as f32;
            }
        }
        grads.push(grad);
    }
    Ok((total, grads))
}

/// Same size, and every value finite in both images.
fn check(image: &Image, target: &Image) -> Result<()> {
    target.expect_size("target", image.width(), image.height())?;
    for (what, img) in [("rendered image", image), ("target", target)] {
        if let Some(k) = img.data().iter().position(|v| !v.is_finite()) {
            let w = img.width().max(1) as usize;
            return Err(Error::InvalidSettings(format!(
                "{what} pixel (row {}, column {}) is {}: loss inputs must be finite",
                k / w,
                k % w,
                img.data()[k]
            )));
        }
    }
    Ok(())
}
