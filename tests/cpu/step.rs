//! `Renderer::squared_error_step` (render + squared error + backward in one call) against the same
//! three calls made separately, on the CPU and, where there is an adapter, on the GPU, whose loss
//! stage keeps the images on the device.
//!
//! Here: the CPU; the GPU's are in `tests/gpu`, the shared scene in `common::step`.

use crate::common::step::{cameras, mesh, separately, targets};
use diffsil::{Error, Image, RenderSettings, Renderer, Targets, Vec3};

#[test]
fn cpu_step_equals_render_loss_backward() {
    let (mesh, cameras) = (mesh(), cameras());
    let targets = targets(&mesh, &cameras, Vec3::new(0.04, -0.03, 0.0));
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let step = renderer.squared_error_step(&mesh, &cameras, &targets).unwrap();
    let (loss, view_losses, gradient) = separately(&mut renderer, &mesh, &cameras, &targets);
    assert!(loss > 0.0);
    assert_eq!(step.loss, loss);
    assert_eq!(step.view_losses, view_losses);
    assert_eq!(step.gradient, gradient);
    assert_eq!(step.stats.len(), 2);
}

#[test]
fn step_rejects_mismatched_targets() {
    let (mesh, cameras) = (mesh(), cameras());
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let good = targets(&mesh, &cameras, Vec3::ZERO);
    let one = Targets::new(vec![good.images()[0].clone()]).unwrap();
    assert!(matches!(
        renderer.squared_error_step(&mesh, &cameras, &one),
        Err(Error::ViewCountMismatch { views: 2, got: 1, .. })
    ));
    let swapped = Targets::new(vec![good.images()[1].clone(), good.images()[0].clone()]).unwrap();
    assert!(matches!(renderer.squared_error_step(&mesh, &cameras, &swapped), Err(Error::SizeMismatch { .. })));
    let mut bad = Image::filled(4, 4, 0.0).data().to_vec();
    bad[5] = f32::NAN;
    assert!(matches!(Targets::new(vec![Image::from_vec(4, 4, bad).unwrap()]), Err(Error::InvalidSettings(_))));
    // A perfect fit: zero loss and zero gradient.
    let step = renderer.squared_error_step(&mesh, &cameras, &good).unwrap();
    assert_eq!(step.loss, 0.0);
    assert!(step.gradient.iter().all(|g| *g == Vec3::ZERO));
}

/// The CPU engine fills the buffers of the frames it rendered and that were dropped again, and
/// those of its earlier backward passes (contour bands, segments, crossings, slots): steps
/// of other meshes, image sizes and view counts in one renderer give the bits of fresh
/// renderers, and a frame kept alive across steps keeps its own state.
#[test]
fn reused_buffers_give_the_results_of_fresh_ones() {
    let (blob, cameras) = (mesh(), cameras());
    let sphere = diffsil::shapes::icosphere(3);
    let mut small = cameras[1];
    (small.width, small.height) = (17, 9);
    let scenes: [(&diffsil::Mesh, Vec<diffsil::Camera>); 5] = [
        (&blob, cameras.clone()),
        (&sphere, cameras.clone()),
        (&blob, vec![small]),
        (&sphere, vec![cameras[0], small, cameras[1]]),
        (&blob, cameras.clone()),
    ];
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let kept = renderer.render(&blob, &cameras).unwrap();
    let d_images: Vec<Image> = kept.images().iter().map(|i| Image::filled(i.width(), i.height(), 0.5)).collect();
    let kept_gradient = Renderer::new(RenderSettings::default()).unwrap().backward(&kept, &d_images).unwrap();
    for (k, (mesh, cameras)) in scenes.iter().enumerate() {
        let targets = targets(mesh, cameras, Vec3::new(0.03, 0.02, 0.0));
        let fresh =
            Renderer::new(RenderSettings::default()).unwrap().squared_error_step(mesh, cameras, &targets).unwrap();
        let reused = renderer.squared_error_step(mesh, cameras, &targets).unwrap();
        assert!(fresh.loss > 0.0, "scene {k}");
        assert_eq!((reused.loss, &reused.gradient), (fresh.loss, &fresh.gradient), "scene {k}");
        assert_eq!(renderer.backward(&kept, &d_images).unwrap(), kept_gradient, "scene {k}");
    }
}
