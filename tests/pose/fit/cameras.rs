//! The framing cameras (`framing_orbit`, `framing_ring`): the ring is the orbit's, and the orbit
//! keeps the mesh in view from any direction and any larger distance.

use diffsil::pose::figure::builtin_figure;
use diffsil::pose::fit::{framing_orbit, framing_ring, orbit_cameras};
use diffsil::random::SplitMix64;
use diffsil::{Mesh, Orbit, Vec3};

#[test]
fn the_framing_ring_is_the_framing_orbit_turned_about_the_mesh() {
    let mesh = builtin_figure().mesh;
    let elevation = 0.3;
    let orbit = framing_orbit(&mesh, elevation);
    assert_eq!(framing_ring(&mesh, 5, 48, elevation), orbit_cameras(orbit, 5, 48));
    // Aimed at the bounding box's centre, from outside the bounding sphere.
    let (lo, hi) = mesh
        .positions()
        .iter()
        .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    assert!((orbit.target - (lo + hi) * 0.5).length() < 1e-6, "{orbit:?}");
    assert!(orbit.distance > (hi - lo).length() * 0.5, "{orbit:?}");
    assert_eq!((orbit.azimuth, orbit.elevation), (0.0, elevation));
}

#[test]
fn the_framing_orbit_keeps_every_vertex_in_view_from_any_direction_and_farther() {
    let mesh = builtin_figure().mesh;
    let base = framing_orbit(&mesh, 0.0);
    let mut rng = SplitMix64::new(7);
    for _ in 0..50 {
        let orbit = Orbit {
            azimuth: rng.range(-3.2, 3.2),
            elevation: rng.range(-1.4, 1.4),
            distance: base.distance * rng.range(1.0, 3.0),
            ..base
        };
        let (width, height) = (40, 40);
        let view = orbit.camera(width, height).params();
        for &p in mesh.positions() {
            let (screen, valid) = view.project(p);
            assert!(valid, "{orbit:?}: {p}");
            let inside = |x: f32, side: u32| x > 0.04 * side as f32 && x < 0.96 * side as f32;
            assert!(inside(screen.x, width) && inside(screen.y, height), "{orbit:?}: {p} at {screen}");
        }
    }
}

#[test]
fn an_empty_mesh_is_framed_about_the_origin() {
    let orbit = framing_orbit(&Mesh::new(Vec::new(), Vec::new()).unwrap(), 0.2);
    assert_eq!(orbit.target, Vec3::ZERO);
    assert!(orbit.distance.is_finite() && orbit.distance > 0.0, "{orbit:?}");
}
