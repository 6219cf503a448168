//! Batches on the CPU engine: `render_batch`, `backward_batch` and `squared_error_step_batch`
//! equal one call per instance, bit for bit (each instance runs through the same per-call code),
//! and bad batches are clear errors.
//!
//! Here: the CPU; the GPU's (and GPU against CPU) are in `tests/gpu/batch.rs`, the scene in
//! `common::batch`.

use crate::common::batch::{image_gradients, instances, scene, targets};
use diffsil::{shapes, Error, Image, Instance, Mesh, RenderSettings, Renderer, Targets};

#[test]
fn cpu_batch_equals_separate_calls() {
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    for count in [1, 3, 8] {
        let (meshes, cameras) = scene(count, 7 + count as u64);
        let batch = instances(&meshes, &cameras);
        let frame = renderer.render_batch(&batch).unwrap();
        assert_eq!(frame.instance_count(), count);
        assert_eq!(frame.view_count(), cameras.iter().map(Vec::len).sum::<usize>());
        let d_images = image_gradients(&cameras, count as u64);
        let grads = renderer.backward_batch(&frame, &d_images).unwrap();
        let batch_stats = renderer.last_backward_stats().to_vec();
        let mut separate_stats = Vec::new();
        for (i, (mesh, cams)) in meshes.iter().zip(&cameras).enumerate() {
            let single = renderer.render(mesh, cams).unwrap();
            assert_eq!(frame.images(i), single.images(), "B = {count}, instance {i}: images differ");
            assert_eq!(frame.stats(i), single.stats(), "B = {count}, instance {i}: stats differ");
            let grad = renderer.backward(&single, &d_images[i]).unwrap();
            assert_eq!(grads[i], grad, "B = {count}, instance {i}: gradient bits differ");
            assert!(grad.iter().any(|g| *g != diffsil::Vec3::ZERO), "B = {count}, instance {i}: zero gradient");
            separate_stats.extend_from_slice(renderer.last_backward_stats());
        }
        assert_eq!(batch_stats, separate_stats, "B = {count}: backward stats");
        assert!(frame.images(count).is_empty() && frame.stats(count).is_empty());

        let targets = targets(&meshes, &cameras);
        let refs: Vec<&Targets> = targets.iter().collect();
        let steps = renderer.squared_error_step_batch(&batch, &refs).unwrap();
        assert_eq!(steps.len(), count);
        for (i, ((mesh, cams), t)) in meshes.iter().zip(&cameras).zip(&targets).enumerate() {
            let single = renderer.squared_error_step(mesh, cams, t).unwrap();
            assert!(single.loss > 0.0);
            assert_eq!(steps[i], single, "B = {count}, instance {i}: step differs");
        }
    }
}

/// One set of targets may serve several instances (the hypotheses of a fit share theirs).
#[test]
fn cpu_batch_shares_targets_between_instances() {
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let (meshes, _) = scene(3, 11);
    let (_, cameras) = scene(1, 12);
    let cameras = vec![cameras[0].clone(); 3];
    let targets = targets(&meshes[..1], &cameras[..1]);
    let steps = renderer.squared_error_step_batch(&instances(&meshes, &cameras), &[&targets[0]; 3]).unwrap();
    for (i, mesh) in meshes.iter().enumerate() {
        assert_eq!(steps[i], renderer.squared_error_step(mesh, &cameras[i], &targets[0]).unwrap(), "instance {i}");
    }
}

#[test]
fn bad_batches_are_clear_errors() {
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let (meshes, cameras) = scene(3, 5);
    let batch = instances(&meshes, &cameras);
    let targets = targets(&meshes, &cameras);
    let refs: Vec<&Targets> = targets.iter().collect();

    assert!(matches!(renderer.render_batch(&[]), Err(Error::EmptyBatch)));
    assert!(matches!(renderer.squared_error_step_batch(&[], &[]), Err(Error::EmptyBatch)));

    // The same contents in another `Arc` is another topology.
    let copy = Mesh::new(meshes[1].positions().to_vec(), meshes[1].triangles().to_vec()).unwrap();
    let mut other = batch.clone();
    other[1] = Instance { mesh: &copy, cameras: &cameras[1] };
    assert!(matches!(renderer.render_batch(&other), Err(Error::TopologyMismatch { instance: 1 })));
    let sphere = shapes::icosphere(1);
    other[1] = Instance { mesh: &sphere, cameras: &cameras[1] };
    let message = renderer.render_batch(&other).unwrap_err().to_string();
    assert!(message.contains("instance 1") && message.contains("with_topology"), "{message}");

    // An invalid camera of one instance.
    let mut bad_camera = cameras[2].clone();
    bad_camera[0].width = 0;
    other[1] = batch[1];
    other[2] = Instance { mesh: &meshes[2], cameras: &bad_camera };
    assert!(renderer.render_batch(&other).is_err());

    // Targets: one set per instance, one image per camera, each of its camera's size.
    assert!(matches!(
        renderer.squared_error_step_batch(&batch, &refs[..2]),
        Err(Error::LengthMismatch { expected: 3, got: 2, .. })
    ));
    let swapped = [refs[0], refs[2], refs[1]];
    assert!(matches!(
        renderer.squared_error_step_batch(&batch, &swapped),
        Err(Error::ViewCountMismatch { views: 2, got: 3, .. })
    ));
    let mut resized: Vec<Image> = targets[2].images().to_vec();
    resized[1] = Image::filled(resized[1].width() + 1, resized[1].height(), 0.0);
    let resized = Targets::new(resized).unwrap();
    assert!(matches!(
        renderer.squared_error_step_batch(&batch, &[refs[0], refs[1], &resized]),
        Err(Error::SizeMismatch { .. })
    ));

    // Image gradients: one list per instance, one image per view, each of its view's size.
    let frame = renderer.render_batch(&batch).unwrap();
    let mut d_images = image_gradients(&cameras, 1);
    assert!(matches!(
        renderer.backward_batch(&frame, &d_images[..2]),
        Err(Error::LengthMismatch { expected: 3, got: 2, .. })
    ));
    d_images[1].pop();
    assert!(matches!(
        renderer.backward_batch(&frame, &d_images),
        Err(Error::ViewCountMismatch { views: 2, got: 1, .. })
    ));
    let mut d_images = image_gradients(&cameras, 1);
    d_images[2][0] = Image::filled(3, 3, 0.0);
    assert!(matches!(renderer.backward_batch(&frame, &d_images), Err(Error::SizeMismatch { .. })));
    let mut d_images = image_gradients(&cameras, 1);
    d_images[0][0].data_mut()[4] = f32::NAN;
    assert!(matches!(renderer.backward_batch(&frame, &d_images), Err(Error::InvalidSettings(_))));
}

/// A batch in which one view crosses its near plane runs instance by instance through the
/// clipping path (`render`, `backward`, `squared_error_step`): the same results as separate
/// calls, and the clipped view really is clipped.
#[test]
fn cpu_batch_with_a_clipped_view_equals_separate_calls() {
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let (meshes, mut cameras) = scene(3, 21);
    // Instance 1's first camera: the near plane through the blob's centre.
    let camera = &mut cameras[1][0];
    camera.near = (camera.target - camera.eye).length();
    let batch = instances(&meshes, &cameras);
    let frame = renderer.render_batch(&batch).unwrap();
    assert!(frame.stats(1)[0].clipped_triangles > 0, "the scene must clip");
    let d_images = image_gradients(&cameras, 4);
    let grads = renderer.backward_batch(&frame, &d_images).unwrap();
    let batch_stats = renderer.last_backward_stats().to_vec();
    let targets = targets(&meshes, &cameras);
    let refs: Vec<&Targets> = targets.iter().collect();
    let steps = renderer.squared_error_step_batch(&batch, &refs).unwrap();
    let mut separate_stats = Vec::new();
    for (i, (mesh, cams)) in meshes.iter().zip(&cameras).enumerate() {
        let single = renderer.render(mesh, cams).unwrap();
        assert_eq!(frame.images(i), single.images(), "instance {i}: images differ");
        assert_eq!(frame.stats(i), single.stats(), "instance {i}: stats differ");
        assert_eq!(grads[i], renderer.backward(&single, &d_images[i]).unwrap(), "instance {i}: gradient differs");
        separate_stats.extend_from_slice(renderer.last_backward_stats());
        assert_eq!(steps[i], renderer.squared_error_step(mesh, cams, &targets[i]).unwrap(), "instance {i}: step");
    }
    assert_eq!(batch_stats, separate_stats);
}
