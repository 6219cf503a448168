//! [`Orbit`]: a camera placed on a sphere around a point by azimuth, elevation and distance.

use glam::Vec3;

use super::camera::Camera;

/// Where a camera sits on a sphere around `target`, by angles: the named settings behind
/// [`Orbit::camera`] (a perspective camera) and [`Orbit::eye`] (for any other projection).
///
/// ```
/// use diffsil::{Orbit, Vec3};
///
/// // 30° round, 20° above, 3 units away, the default 50° field of view; 128 × 96 pixels.
/// let camera = Orbit {
///     azimuth: 30f32.to_radians(),
///     elevation: 20f32.to_radians(),
///     distance: 3.0,
///     ..Orbit::default()
/// }
/// .camera(128, 96);
/// assert!((camera.eye.length() - 3.0).abs() < 1e-6 && camera.target == Vec3::ZERO);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// The point looked at, at the sphere's centre. Default: the origin.
    pub target: Vec3,
    /// Radians about +y; 0 puts the eye on +z looking along −z, π/2 on +x. Default 0.
    pub azimuth: f32,
    /// Radians above the horizontal plane through `target`; positive looks down from above.
    /// Default 0.
    pub elevation: f32,
    /// Distance from `target` to the eye. Default 2.7 (a mesh of radius 1 then fills about
    /// 87% of the default field of view).
    pub distance: f32,
    /// Vertical field of view of [`Orbit::camera`], radians. Default 50° (`50f32.to_radians()`).
    pub fov_y: f32,
}

impl Default for Orbit {
    fn default() -> Self {
        Orbit { target: Vec3::ZERO, azimuth: 0.0, elevation: 0.0, distance: 2.7, fov_y: 50f32.to_radians() }
    }
}

impl Orbit {
    /// The eye position: `target + distance · (cos el · sin az, sin el, cos el · cos az)`.
    pub fn eye(&self) -> Vec3 {
        let (azimuth, elevation) = (self.azimuth, self.elevation);
        let dir = Vec3::new(elevation.cos() * azimuth.sin(), elevation.sin(), elevation.cos() * azimuth.cos());
        self.target + dir * self.distance
    }

    /// A perspective camera ([`Camera::perspective`]: up = +y, near = 0.01, far = 1000) at
    /// [`Orbit::eye`] looking at `target`, with field of view `fov_y`, rendering
    /// `width × height` pixels.
    pub fn camera(&self, width: u32, height: u32) -> Camera {
        Camera::perspective(self.eye(), self.target, self.fov_y, width, height)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Projection;

    #[test]
    fn orbit_angles_mean_what_they_say() {
        let side = Orbit { azimuth: std::f32::consts::FRAC_PI_2, distance: 2.0, ..Orbit::default() };
        assert!((side.eye() - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-6);
        let above = Orbit { elevation: 0.5, target: Vec3::ONE, ..Orbit::default() };
        assert!(above.eye().y > 1.0 && ((above.eye() - Vec3::ONE).length() - 2.7).abs() < 1e-5);
        let camera = above.camera(40, 30);
        assert_eq!((camera.width, camera.height, camera.target), (40, 30, Vec3::ONE));
        assert_eq!(camera.projection, Projection::Perspective { fov_y: 50f32.to_radians() });
    }
}
