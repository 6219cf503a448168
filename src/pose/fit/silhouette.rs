//! `E_sl`, the silhouette term of a [`PoseFit`](super::PoseFit)'s energy: renders against the
//! (blurred) targets, each render first grown or shrunk by the outline nuisance when it is fitted,
//! and the gradients back to the vertices and to the outline. A child of `descent.rs`, in its own
//! file.

use glam::Vec3;
use rayon::prelude::*;

use super::super::outline;
use crate::loss::GaussianBlur;
use crate::{loss, Camera, Image, Mesh, Renderer, Result};

/// Renders `mesh`, `E_sl` against the (blurred) `targets` as a mean over pixels (`pixel_weight`
/// per pixel), with the renders outlined by `outline` when it is `Some` (see
/// [`PoseFit::outline`]), its gradient with respect to the mesh's vertices and `∂E_sl/∂a`
/// (0 without an outline).
pub(super) fn silhouette_pass(
    renderer: &mut Renderer,
    mesh: &Mesh,
    cameras: &[Camera],
    targets: &[Image],
    blurs: &[GaussianBlur],
    pixel_weight: f64,
    outline: Option<f32>,
) -> Result<(f64, Vec<Vec3>, f64)> {
    let frame = renderer.render(mesh, cameras)?;
    let (silhouette, d_images, d_outline) = silhouette_loss(frame.images(), targets, blurs, pixel_weight, outline)?;
    Ok((silhouette, renderer.backward(&frame, &d_images)?, d_outline))
}

/// `E_sl` of rendered `images` (each grown or shrunk by the outline nuisance `a` when given)
/// against the (blurred) `targets` as a mean over pixels (`pixel_weight` per pixel), its
/// gradient per image, and `∂E_sl/∂a`.
pub(super) fn silhouette_loss(
    images: &[Image],
    targets: &[Image],
    blurs: &[GaussianBlur],
    pixel_weight: f64,
    outline: Option<f32>,
) -> Result<(f64, Vec<Image>, f64)> {
    // Each view on its own (side by side), then the sums in view order: the bits of one loop.
    let views: Vec<(f64, Image, f64)> = images
        .par_iter()
        .zip(targets)
        .zip(blurs)
        .map(|((image, target), blur)| {
            let outlined = outline.map(|a| outline::apply(image, a));
            let compared = outlined.as_ref().map_or(image, |o| &o.image);
            let loss::LossOutput { value, mut grad } = loss::blurred_squared_error(compared, target, blur)?;
            for g in grad.data_mut() {
                *g = (f64::from(*g) * pixel_weight) as f32;
            }
            let mut d_a = 0.0;
            if let (Some(a), Some(outlined)) = (outline, &outlined) {
                let (d_image, d) = outline::backward(image, outlined, a, &grad);
                grad = d_image;
                d_a = d;
            }
            Ok((value, grad, d_a))
        })
        .collect::<Result<_>>()?;
    let mut silhouette = 0.0;
    let mut d_outline = 0.0;
    let mut d_images = Vec::with_capacity(views.len());
    for (value, grad, d_a) in views {
        silhouette += value * pixel_weight;
        d_outline += d_a;
        d_images.push(grad);
    }
    Ok((silhouette, d_images, d_outline))
}
