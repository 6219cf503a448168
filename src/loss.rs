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
    finite_output("squared error", value, &grad)?;
    Ok(LossOutput { value, grad: Image::from_vec(image.width(), image.height(), grad)? })
}

/// [`Error::InvalidSettings`] when a loss overflowed (its value in f64, or `∂L/∂I` in f32), naming
/// the pixel: values whose difference is near `f32::MAX` (e.g. targets of ±3e38).
fn finite_output(what: &str, value: f64, grad: &[f32]) -> Result<()> {
    if let Some(p) = first_non_finite(grad) {
        return Err(Error::InvalidSettings(format!(
            "{what}: ∂L/∂I at pixel {p} is {} (beyond f32): the image and target values are too large; keep \
             targets and the inside/outside values within ±1e18",
            grad[p]
        )));
    }
    if !value.is_finite() {
        return Err(Error::InvalidSettings(format!(
            "{what}: the loss is {value}: the image and target values are too large; keep them within ±1e18"
        )));
    }
    Ok(())
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
    finite_output("soft IoU", value, &grad)?;
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

/// A normalised Gaussian filter, truncated at three standard deviations, with zero padding
/// outside the image (a silhouette's background is 0, so padding adds nothing that is not there).
///
/// Separable: a horizontal pass then a vertical one. As a linear map on images it is symmetric
/// (the kernel is even and the padding is zero), so it is its own adjoint: the gradient of a loss
/// of the blurred image is the blurred gradient. Standard deviation 0 is the identity.
#[derive(Clone, Debug, PartialEq)]
pub struct GaussianBlur {
    sigma: f32,
    /// `2r + 1` weights summing to 1, centre at index `r`.
    kernel: Vec<f32>,
}

impl GaussianBlur {
    /// The identity filter (σ = 0).
    pub fn identity() -> GaussianBlur {
        GaussianBlur { sigma: 0.0, kernel: vec![1.0] }
    }

    /// A Gaussian of standard deviation `sigma` pixels (0 is the identity). Errors on a negative
    /// or non-finite σ, or one above 1024 pixels.
    pub fn new(sigma: f32) -> Result<GaussianBlur> {
        if !(sigma.is_finite() && (0.0..=1024.0).contains(&sigma)) {
            return Err(Error::InvalidSettings(format!(
                "blur standard deviation {sigma}: use a finite number of pixels in [0, 1024]"
            )));
        }
        if sigma == 0.0 {
            return Ok(GaussianBlur::identity());
        }
        let r = (3.0 * sigma).ceil() as i32;
        let weights: Vec<f64> =
            (-r..=r).map(|k| (-(f64::from(k * k)) / (2.0 * f64::from(sigma) * f64::from(sigma))).exp()).collect();
        let sum: f64 = weights.iter().sum();
        Ok(GaussianBlur { sigma, kernel: weights.iter().map(|w| (w / sum) as f32).collect() })
    }

    /// The standard deviation in pixels.
    pub fn sigma(&self) -> f32 {
        self.sigma
    }

    /// The blurred image (same size).
    pub fn apply(&self, image: &Image) -> Image {
        if self.kernel.len() == 1 {
            return image.clone();
        }
        let (w, h) = (image.width() as usize, image.height() as usize);
        let r = (self.kernel.len() / 2) as isize;
        let src = image.data();
        // Horizontal pass: out[x] += g_k · row[x + k − r] wherever x + k − r is inside the row.
        let mut tmp = vec![0.0f32; w * h];
        for (row, out) in src.chunks_exact(w.max(1)).zip(tmp.chunks_exact_mut(w.max(1))) {
            for (k, &g) in self.kernel.iter().enumerate() {
                let off = k as isize - r;
                let lo = (-off).clamp(0, w as isize) as usize;
                let hi = (w as isize - off).clamp(0, w as isize) as usize;
                if lo < hi {
                    let shifted = &row[(lo as isize + off) as usize..(hi as isize + off) as usize];
                    for (o, v) in out[lo..hi].iter_mut().zip(shifted) {
                        *o += g * v;
                    }
                }
            }
        }
        // Vertical pass, one whole row at a time.
        let mut out = vec![0.0f32; w * h];
        for y in 0..h {
            let dst = &mut out[y * w..(y + 1) * w];
            for (k, &g) in self.kernel.iter().enumerate() {
                let yy = y as isize + k as isize - r;
                if (0..h as isize).contains(&yy) {
                    let yy = yy as usize;
                    for (o, v) in dst.iter_mut().zip(&tmp[yy * w..(yy + 1) * w]) {
                        *o += g * v;
                    }
                }
            }
        }
        Image::from_vec(image.width(), image.height(), out).expect("same size as the input")
    }
}

/// Squared error between blurred images: `L = Σ (G∗I − G∗T)²`, `∂L/∂I = 2 G∗(G∗I − G∗T)`, with
/// `G` the filter `blur` and `blurred_target = blur.apply(T)` (pass it blurred, so that a fit
/// blurs its fixed target once). With [`GaussianBlur::identity`] this is [`squared_error`].
///
/// Comparing blurred silhouettes widens the basin of attraction: a limb that does not overlap
/// its target at all feels the target's blurred tail, where the plain squared error is flat.
pub fn blurred_squared_error(image: &Image, blurred_target: &Image, blur: &GaussianBlur) -> Result<LossOutput> {
    check(image, blurred_target)?;
    let blurred = blur.apply(image);
    let LossOutput { value, grad } = squared_error(&blurred, blurred_target)?;
    Ok(LossOutput { value, grad: blur.apply(&grad) })
}

/// The index of the first value that is not finite, if any. Whether there is one is answered
/// first by a loop without an early exit, which the compiler vectorises (a `position` that
/// stops at the first non-finite value runs one value at a time: about 1% of a pose-fit step).
fn first_non_finite(data: &[f32]) -> Option<usize> {
    let all_finite = data.chunks(256).all(|chunk| chunk.iter().fold(true, |ok, v| ok & v.is_finite()));
    if all_finite {
        None
    } else {
        data.iter().position(|v| !v.is_finite())
    }
}

/// Same size, and every value finite in both images.
fn check(image: &Image, target: &Image) -> Result<()> {
    target.expect_size("target", image.width(), image.height())?;
    for (what, img) in [("rendered image", image), ("target", target)] {
        if let Some(k) = first_non_finite(img.data()) {
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
