//! Cameras for a fit: a ring of views around a point, and a ring framing a mesh.

use glam::Vec3;

use crate::{Camera, Mesh, Orbit};

/// Orbits on a circle around `around.target`: `views` azimuths evenly spaced from
/// `around.azimuth` (0°, 90°, 180°, 270° for four views from azimuth 0), all with `around`'s
/// elevation, distance and vertical field of view. [`Orbit::camera`] makes each a camera of any
/// size.
pub fn ring_orbits(around: Orbit, views: u32) -> Vec<Orbit> {
    (0..views)
        .map(|k| Orbit { azimuth: around.azimuth + std::f32::consts::TAU * k as f32 / views as f32, ..around })
        .collect()
}

/// Cameras on a circle around `around.target`: [`ring_orbits`], square `resolution`.
pub fn orbit_cameras(around: Orbit, views: u32, resolution: u32) -> Vec<Camera> {
    ring_orbits(around, views).iter().map(|o| o.camera(resolution, resolution)).collect()
}

/// Cameras framing `mesh`: [`orbit_cameras`] aimed at its bounding-box centre, far enough that
/// its bounding sphere fits the vertical field of view with a 10% margin; a level ring
/// ([`framing_ring`] at elevation 0).
pub fn framing_cameras(mesh: &Mesh, views: u32, resolution: u32) -> Vec<Camera> {
    framing_ring(mesh, views, resolution, 0.0)
}

/// Elevation of the raised ring of views: 15° (`15f32.to_radians()`). From a level ring of four
/// views the 0°/180° and 90°/270° views are mirror images, which cannot tell which leg or arm is
/// in front; raised, the ground-facing parts and the order along the line of sight differ.
pub const RAISED_ELEVATION_DEG: f32 = 15.0;

/// [`framing_cameras`] on a ring raised by `elevation` radians (looking down at the centre from
/// above; strictly between −π/2 and π/2), at the same distance: [`orbit_cameras`] about
/// [`framing_orbit`].
pub fn framing_ring(mesh: &Mesh, views: u32, resolution: u32, elevation: f32) -> Vec<Camera> {
    orbit_cameras(framing_orbit(mesh, elevation), views, resolution)
}

/// The orbit the framing rings use: aimed at `mesh`'s bounding-box centre (the origin for an
/// empty mesh) at azimuth 0 and `elevation` radians, with a 40° vertical field of view, far
/// enough that the mesh's bounding sphere about that centre fits it with a 10% margin. A start
/// for cameras of one's own layout: any azimuth and elevation, and any larger distance, keep the
/// mesh in view.
pub fn framing_orbit(mesh: &Mesh, elevation: f32) -> Orbit {
    let p = mesh.positions();
    let centre = mesh.bounds().map_or(Vec3::ZERO, |(lo, hi)| (lo + hi) * 0.5);
    let radius = p.iter().map(|v| (*v - centre).length()).fold(1e-3f32, f32::max);
    let fov_y = 40f32.to_radians();
    let distance = 1.1 * radius / (0.5 * fov_y).sin();
    Orbit { target: centre, azimuth: 0.0, elevation, distance, fov_y }
}
