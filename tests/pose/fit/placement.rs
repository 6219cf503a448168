//! Where the masks put the body (`triangulate_masks`): a sphere seen by orthographic cameras
//! (its silhouette's centre is its centre's projection), the built-in figure far from the origin
//! seen by perspective and OpenCV cameras, and the cases with no answer or bad input.

use diffsil::pose::figure::builtin_figure;
use diffsil::pose::fit::{framing_ring, triangulate_masks};
use diffsil::{shapes, Camera, Error, Image, Mesh, RenderSettings, Renderer, Vec3};

fn masks(mesh: &Mesh, cameras: &[Camera]) -> Vec<Image> {
    Renderer::new(RenderSettings::default()).unwrap().render(mesh, cameras).unwrap().images().to_vec()
}

fn moved(mesh: &Mesh, offset: Vec3) -> Mesh {
    Mesh::with_topology(mesh.positions().iter().map(|p| *p + offset).collect(), mesh.topology().clone()).unwrap()
}

#[test]
fn a_sphere_seen_by_orthographic_cameras_is_placed_at_its_centre() {
    let centre = Vec3::new(0.4, -0.3, 0.25);
    let sphere = moved(&shapes::icosphere(4), centre);
    // Three views from different sides, none aimed at the sphere's centre.
    let cameras: Vec<Camera> = [Vec3::new(0.0, 0.5, 4.0), Vec3::new(4.0, 1.0, -1.0), Vec3::new(-2.0, 3.0, 2.0)]
        .into_iter()
        .map(|eye| Camera::orthographic(eye, Vec3::ZERO, 3.0, 96, 80))
        .collect();
    let point = triangulate_masks(&cameras, &masks(&sphere, &cameras)).unwrap().unwrap();
    assert!((point - centre).length() < 0.01, "{point} against {centre}");
}

#[test]
fn the_figure_far_from_the_origin_is_placed_where_it_stands() {
    let figure = builtin_figure().mesh;
    let (lo, hi) = figure.bounds().expect("a mesh with vertices");
    let height = (hi - lo).max_element();
    for offset in [Vec3::ZERO, Vec3::new(2.0, 0.3, -1.5) * height, Vec3::new(-6.0, 0.0, 4.0) * height] {
        let there = moved(&figure, offset);
        let mut cameras = framing_ring(&there, 4, 64, 0.3);
        // And a calibrated camera beside them: from +x, looking along −x at the figure.
        let eye = (lo + hi) * 0.5 + offset + Vec3::new(3.0 * height, 0.0, 0.0);
        // Rows: camera x (right) = −z, y (down) = −y, z (forward) = −x; t = −R·eye.
        let r = [[0.0, 0.0, -1.0], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]];
        let t = [eye.z, eye.y, eye.x];
        let k = [[40.0, 0.0, 29.0], [0.0, 42.0, 33.0], [0.0, 0.0, 1.0]];
        cameras.push(Camera::from_opencv(k, r, t, 64, 64).unwrap());
        let images = masks(&there, &cameras);
        assert!(images.iter().all(|m| m.data().iter().any(|v| *v > 0.5)), "every view sees the figure");
        let point = triangulate_masks(&cameras, &images).unwrap().unwrap();
        let centre = (lo + hi) * 0.5 + offset;
        // A silhouette's centre is not the body's: within a tenth of the height.
        assert!((point - centre).length() < 0.1 * height, "{point} against {centre} (height {height})");
    }
}

#[test]
fn no_point_without_two_views_at_an_angle() {
    let sphere = shapes::icosphere(2);
    let camera = Camera::perspective(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 0.8, 32, 32);
    let seen = masks(&sphere, &[camera]);
    assert_eq!(triangulate_masks(&[camera], &seen).unwrap(), None, "one view");
    assert_eq!(triangulate_masks(&[camera, camera], &[seen[0].clone(), seen[0].clone()]).unwrap(), None, "parallel");
    let empty = Image::filled(32, 32, 0.0);
    let side = Camera::perspective(Vec3::new(4.0, 0.0, 0.0), Vec3::ZERO, 0.8, 32, 32);
    assert_eq!(triangulate_masks(&[camera, side], &[seen[0].clone(), empty.clone()]).unwrap(), None, "one covers");
    assert_eq!(triangulate_masks(&[], &[]).unwrap(), None);
    // NaN and negative values count as nothing, values above 1 as 1.
    let mut odd = Image::filled(32, 32, f32::NAN);
    odd.data_mut()[0] = -5.0;
    assert_eq!(triangulate_masks(&[camera, side], &[odd, empty]).unwrap(), None);
}

#[test]
fn bad_input_is_an_error() {
    let camera = Camera::perspective(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 0.8, 32, 32);
    let mask = Image::filled(32, 32, 1.0);
    assert!(matches!(
        triangulate_masks(&[camera, camera], std::slice::from_ref(&mask)),
        Err(Error::LengthMismatch { .. })
    ));
    assert!(matches!(triangulate_masks(&[camera], &[Image::filled(32, 30, 1.0)]), Err(Error::SizeMismatch { .. })));
    let bad = Camera { near: -1.0, ..camera };
    assert!(matches!(triangulate_masks(&[bad], &[mask]), Err(Error::InvalidCamera(_))));
}
