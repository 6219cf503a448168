//! Coincident silhouette edges (several mesh edges on one screen segment, same side) move the area
//! once: the derivative along a translation of the whole mesh against finite differences of the
//! exact-area oracle, the face-on cube by hand, and a mesh concatenated with a copy of
//! itself (the copy carries nothing, the original exactly what it carries alone).

use diffsil::{Image, RenderSettings, Renderer, Vec3};

use crate::common::fd::{self, FdOptions};

/// The derivative along a rigid translation matches central differences of the oracle to 1e-3 on
/// every coincident-edge scene (it was 2× where two edges coincide).
#[test]
fn coincident_edges_move_the_area_once() {
    for (scene, reference) in fd::coincident_scenes() {
        let check = fd::check_translation(&scene, &reference, FdOptions { h: 1.0 / 1024.0, ..FdOptions::default() });
        println!("{check}");
        check.assert_within(1e-3);
        assert!(!check.directions.is_empty(), "{}: no axis moves the silhouette", scene.name);
    }
}

/// `∂L/∂(translate x)` of the cube with `∂L/∂I = 1` on pixel column 48: the right outline
/// (front and back edges, coincident) spans 32 rows at 32 pixels per world unit, so 32 · 32 = 1024.
#[test]
fn face_on_cube_by_hand() {
    let scene = fd::cube_orthographic();
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let frame = renderer.render(&scene.mesh, &scene.cameras).unwrap();
    let d: Vec<f32> = (0..64 * 64).map(|i| if i % 64 == 48 { 1.0 } else { 0.0 }).collect();
    let grads = renderer.backward(&frame, &[Image::from_vec(64, 64, d).unwrap()]).unwrap();
    let total: Vec3 = grads.iter().sum();
    assert!((total.x - 1024.0).abs() <= 1e-3, "dL/dx = {} (1024 by hand)", total.x);
    assert_eq!((total.y, total.z), (0.0, 0.0));
}

/// A mesh concatenated with an exact copy of itself: the original's faces rank first, so the copy's
/// vertices get exactly zero and the original's exactly the gradient of the mesh alone.
#[test]
fn a_copy_of_the_mesh_carries_nothing() {
    for single in [fd::cube_orthographic(), fd::cube_perspective(), crate::common::scenes::two_spheres_3d()] {
        let double = fd::doubled(&single, "doubled");
        let n = single.mesh.positions().len();
        let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
        let camera = &single.cameras[0];
        let d = Image::from_vec(
            camera.width,
            camera.height,
            fd::Rng::new(5).weights((camera.width * camera.height) as usize),
        )
        .unwrap();
        let f1 = renderer.render(&single.mesh, &single.cameras).unwrap();
        let g1 = renderer.backward(&f1, std::slice::from_ref(&d)).unwrap();
        let f2 = renderer.render(&double.mesh, &double.cameras).unwrap();
        assert_eq!(f1.images(), f2.images(), "{}: the copy changes the image", single.name);
        let g2 = renderer.backward(&f2, &[d]).unwrap();
        assert_eq!(&g2[..n], &g1[..], "{}: the original's gradient changed", single.name);
        assert!(g2[n..].iter().all(|g| *g == Vec3::ZERO), "{}: the copy got a gradient", single.name);
        assert!(g1.iter().any(|g| *g != Vec3::ZERO), "{}: no gradient at all", single.name);
    }
}
