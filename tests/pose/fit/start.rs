//! The start of a fit to the user's masks (`start_from_masks`): the world's up read from the
//! cameras (`cameras_up`, `world_up`), the rest pose stood along it (`upright`), and moved to where
//! the masks place the subject, in worlds whose up is not the model's.

use std::f32::consts::PI;

use diffsil::pose::figure::{builtin_figure, random_pose_limits};
use diffsil::pose::fit::{cameras_up, framing_ring, random_pose, start_from_masks, upright, world_up};
use diffsil::{Camera, Error, Extrinsics, Image, Mesh, RenderSettings, Renderer, Vec3};
use glam::{Mat3, Quat};

use super::facing::centre;

#[test]
fn the_cameras_up_is_the_worlds() {
    let figure = builtin_figure();
    // A raised ring of look-at cameras, +y up: their ups lean in, and cancel about the ring.
    let ring = framing_ring(&figure.mesh, 4, 32, 20f32.to_radians());
    let up = cameras_up(&ring).unwrap();
    assert!((up - Vec3::Y).length() < 1e-5, "{up}");
    assert_eq!(world_up(&ring), Vec3::Y);
    // The same cameras in a world whose up is +z, then 20° and 40° from +y.
    let z_up = Mat3::from_cols(Vec3::X, Vec3::Z, Vec3::NEG_Y);
    let turned: Vec<Camera> = ring.iter().map(|c| c.in_world(z_up, Vec3::ZERO)).collect();
    let up = cameras_up(&turned).unwrap();
    assert!((up - Vec3::Z).length() < 1e-5, "{up}");
    assert_eq!(world_up(&turned), Vec3::Z);
    for (degrees, snapped) in [(20f32, true), (40.0, false)] {
        let q = Mat3::from_rotation_x(degrees.to_radians());
        let tilted: Vec<Camera> = ring.iter().map(|c| c.in_world(q, Vec3::ZERO)).collect();
        let expected = if snapped { Vec3::Y } else { q * Vec3::Y };
        assert!((world_up(&tilted) - expected).length() < 1e-5, "{degrees}°: {}", world_up(&tilted));
    }
    // No cameras, or two whose ups cancel (one upside down): no common up, and +y.
    assert_eq!(cameras_up(&[]), None);
    let upright_camera = Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.8, 16, 16);
    let e = upright_camera.opencv_extrinsics();
    let flip = Mat3::from_diagonal(Vec3::new(-1.0, -1.0, 1.0));
    let upside_down =
        upright_camera.with_extrinsics(Extrinsics { rotation: flip * e.rotation, translation: flip * e.translation });
    assert_eq!(cameras_up(&[upright_camera, upside_down]), None);
    assert_eq!(world_up(&[upright_camera, upside_down]), Vec3::Y);
}

#[test]
fn the_rest_pose_stands_along_the_up() {
    let model = builtin_figure();
    for up in [Vec3::Y, Vec3::Z, Vec3::NEG_Z, Vec3::X, Vec3::NEG_Y, Vec3::new(0.0, 0.766, 0.643)] {
        let pose = upright(model.joint_count(), up).unwrap();
        let stood = Quat::from_scaled_axis(pose.orientation) * Vec3::Y;
        assert!((stood - up.normalize()).length() < 1e-5, "{up}: stood along {stood}");
    }
    assert_eq!(upright(model.joint_count(), Vec3::NEG_Y).unwrap().orientation, Vec3::new(PI, 0.0, 0.0));
    assert_eq!(upright(model.joint_count(), Vec3::Y).unwrap(), diffsil::pose::skin::Pose::rest(model.joint_count()));
    for bad in [Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 0.0)] {
        assert!(matches!(upright(model.joint_count(), bad), Err(Error::InvalidSettings(_))), "{bad}");
    }
}

#[test]
fn the_start_stands_where_the_masks_place_the_subject_in_any_world() {
    let model = builtin_figure();
    let truth = model.skin(&random_pose(&random_pose_limits(&model.skeleton), 20f32.to_radians(), 4)).unwrap();
    let ys = model.mesh.positions().iter().map(|p| p.y);
    let height = ys.clone().fold(f32::MIN, f32::max) - ys.fold(f32::MAX, f32::min);
    let ring = framing_ring(&model.mesh, 4, 48, 15f32.to_radians());
    let mut renderer = Renderer::new(RenderSettings::default()).unwrap();
    let truth_mesh = Mesh::with_topology(truth.clone(), model.mesh.topology().clone()).unwrap();
    let masks = renderer.render(&truth_mesh, &ring).unwrap().images().to_vec();
    let offset = Vec3::new(2.0, 0.3, -1.5);
    for q in [
        Mat3::IDENTITY,
        Mat3::from_cols(Vec3::X, Vec3::Z, Vec3::NEG_Y),
        Mat3::from_diagonal(Vec3::new(1.0, -1.0, -1.0)),
    ] {
        let cameras: Vec<Camera> = ring.iter().map(|c| c.in_world(q, offset)).collect();
        let start = start_from_masks(&model, &cameras, &masks, &mut renderer, None).unwrap();
        assert!((start.up - q * Vec3::Y).length() < 1e-5, "up {}", start.up);
        let there: Vec<Vec3> = truth.iter().map(|p| q * *p + offset).collect();
        let placed = centre(&model.skin(&start.pose).unwrap());
        assert!(
            (placed - centre(&there)).length() < 0.1 * height,
            "placed at {placed}, the subject at {}",
            centre(&there)
        );
        let ratio = start.height_ratio.unwrap();
        assert!((0.7..1.3).contains(&ratio), "height ratio {ratio}");
        // Given, the up is kept.
        let given = start_from_masks(&model, &cameras, &masks, &mut renderer, Some(Vec3::X)).unwrap();
        assert_eq!(given.up, Vec3::X);
    }
    // Masks that see nothing: no point, the upright rest pose where the model was built.
    let empty: Vec<Image> = masks.iter().map(|m| Image::filled(m.width(), m.height(), 0.0)).collect();
    let start = start_from_masks(&model, &ring, &empty, &mut renderer, None).unwrap();
    assert_eq!((start.point, start.height_ratio), (None, None));
    assert_eq!(start.pose, upright(model.joint_count(), Vec3::Y).unwrap());
    let e = start_from_masks(&model, &ring, &masks[..2], &mut renderer, None).unwrap_err();
    assert!(matches!(e, Error::LengthMismatch { .. }), "{e}");
    let e = start_from_masks(&model, &ring, &masks, &mut renderer, Some(Vec3::ZERO)).unwrap_err();
    assert!(matches!(e, Error::InvalidSettings(_)), "{e}");
}
