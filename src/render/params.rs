//! Gradients to parameters: from the per-vertex gradients the renderer returns to a camera's
//! extrinsics and intrinsics ([`camera_gradient`]) and to a rigid transform of a mesh
//! ([`RigidTransform::backward`]).
//!
//! Both chain in Rust from what either engine returns — `∂L/∂(screen vertex)` per view
//! ([`Renderer::backward_screen`](crate::Renderer::backward_screen),
//! [`Step::screen_gradients`](crate::Step::screen_gradients)) or `∂L/∂(world vertex)`
//! ([`Renderer::backward`](crate::Renderer::backward), [`Step::gradient`](crate::Step::gradient))
//! — so they are the same on the CPU and GPU backends. Sums run in `f64`, in vertex order.
//!
//! **Rotations** are differentiated in the tangent space: the gradient `g_ω` with respect to a
//! rotation `R` is the derivative of `L` at `δ = 0` of the perturbed rotation `exp([δ]×)·R` (a
//! left perturbation, `δ` an axis–angle vector in radians). A gradient step is then
//! `R ← exp([−η·g_ω]×)·R`: [`RigidTransform::retract`], [`Extrinsics::retract`](crate::Extrinsics::retract).

use glam::{DVec3, Mat3, Quat, Vec2, Vec3};

use crate::scene::camera::Camera;
use crate::{Error, Result};

/// A similarity transform of a mesh: `p ↦ scale · R(rotation) · p + translation`, with `rotation`
/// an axis–angle vector (radians; direction = axis, length = angle) about the mesh's own origin.
/// Centre a mesh at its origin for the rotation to turn it in place.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidTransform {
    /// Axis–angle rotation, radians.
    pub rotation: Vec3,
    /// Translation, world units.
    pub translation: Vec3,
    /// Uniform scale (> 0).
    pub scale: f32,
}

impl Default for RigidTransform {
    fn default() -> Self {
        RigidTransform::IDENTITY
    }
}

/// `∂L/∂(rigid transform)` ([`RigidTransform::backward`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RigidGradient {
    /// Tangent-space rotation gradient (left perturbation `exp([δ]×)·R`, world axes).
    pub rotation: Vec3,
    /// `∂L/∂translation`.
    pub translation: Vec3,
    /// `∂L/∂scale`.
    pub scale: f32,
}

impl RigidTransform {
    /// No rotation, no translation, scale 1.
    pub const IDENTITY: RigidTransform = RigidTransform { rotation: Vec3::ZERO, translation: Vec3::ZERO, scale: 1.0 };

    /// The rotation matrix `R(rotation)`.
    pub fn matrix(&self) -> Mat3 {
        Mat3::from_quat(Quat::from_scaled_axis(self.rotation))
    }

    /// Checks that every part is finite and the scale positive.
    pub fn validate(&self) -> Result<()> {
        if !(self.rotation.is_finite() && self.translation.is_finite() && self.scale.is_finite() && self.scale > 0.0) {
            return Err(Error::InvalidSettings(format!(
                "rigid transform needs finite rotation and translation and a finite scale > 0, got {self:?}"
            )));
        }
        Ok(())
    }

    /// The transformed points `scale · R · p + translation`.
    pub fn apply(&self, positions: &[Vec3]) -> Vec<Vec3> {
        let m = self.matrix() * self.scale;
        positions.iter().map(|&p| m * p + self.translation).collect()
    }

    /// `∂L/∂(this transform)` from `gradient = ∂L/∂(transformed point)` at the points
    /// `positions` (untransformed, as given to [`RigidTransform::apply`]):
    /// translation `Σ g`, scale `Σ g·(R·p)`, rotation `Σ (s·R·p) × g`.
    ///
    /// Errors: lengths that differ ([`Error::LengthMismatch`]).
    pub fn backward(&self, positions: &[Vec3], gradient: &[Vec3]) -> Result<RigidGradient> {
        if positions.len() != gradient.len() {
            return Err(Error::LengthMismatch {
                what: "vertex gradients",
                expected: positions.len(),
                got: gradient.len(),
            });
        }
        let r = self.matrix().as_dmat3();
        let s = self.scale as f64;
        let (mut rotation, mut translation, mut scale) = (DVec3::ZERO, DVec3::ZERO, 0.0);
        for (&p, &g) in positions.iter().zip(gradient) {
            let (rp, g) = (r * p.as_dvec3(), g.as_dvec3());
            translation += g;
            scale += g.dot(rp);
            rotation += (s * rp).cross(g);
        }
        Ok(RigidGradient { rotation: rotation.as_vec3(), translation: translation.as_vec3(), scale: scale as f32 })
    }

    /// The transform after a step in the tangent space, the parametrisation of
    /// [`RigidTransform::backward`]: `R ← exp([step.rotation]×)·R` (a turn about the mesh's own
    /// origin, in world axes), `translation += step.translation`, `scale += step.scale`.
    pub fn retract(&self, step: &RigidGradient) -> RigidTransform {
        let q = Quat::from_scaled_axis(step.rotation);
        let rotation = (q * Quat::from_scaled_axis(self.rotation)).normalize().to_scaled_axis();
        RigidTransform { rotation, translation: self.translation + step.translation, scale: self.scale + step.scale }
    }
}

/// `∂L/∂(camera parameters)` ([`camera_gradient`]).
///
/// Extrinsics in OpenCV's camera axes ([`Camera::opencv_extrinsics`]): `rotation` is the
/// tangent-space gradient of `R` (left perturbation `exp([δ]×)·R`, camera axes), `translation`
/// is `∂L/∂t`. Intrinsics in diffsil pixel coordinates ([`Camera::intrinsics`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraGradient {
    /// Tangent-space gradient of the world → camera rotation.
    pub rotation: Vec3,
    /// `∂L/∂t` (world → camera translation, OpenCV axes).
    pub translation: Vec3,
    /// `∂L/∂fx` (orthographic: pixels per world unit in x).
    pub fx: f32,
    /// `∂L/∂fy`.
    pub fy: f32,
    /// `∂L/∂cx`.
    pub cx: f32,
    /// `∂L/∂cy`.
    pub cy: f32,
}

impl CameraGradient {
    /// The intrinsics part `[∂L/∂fx, ∂L/∂fy, ∂L/∂cx, ∂L/∂cy]`.
    pub fn intrinsics(&self) -> [f32; 4] {
        [self.fx, self.fy, self.cx, self.cy]
    }
}

/// `∂L/∂(camera)` from `screen_gradient = ∂L/∂(screen vertex)` of one view rendered by `camera`
/// from the world points `positions` (vertices the camera does not see contribute nothing).
///
/// With `c = R·p + t` (OpenCV axes) and, for a perspective or pinhole camera,
/// `u = cx + fx·c.x/c.z`, `v = cy + fy·c.y/c.z` (orthographic: `u = cx + fx·c.x`,
/// `v = cy + fy·c.y`): `∂L/∂c` per vertex, then `∂L/∂t = Σ ∂L/∂c` and the rotation gradient
/// `Σ (R·p) × ∂L/∂c`. A [`Projection::Perspective`](crate::Projection::Perspective) camera is
/// differentiated as its pinhole equivalent; a look-at camera's pose as its
/// [`Camera::opencv_extrinsics`].
///
/// Errors: an invalid camera, lengths that differ ([`Error::LengthMismatch`]).
pub fn camera_gradient(camera: &Camera, positions: &[Vec3], screen_gradient: &[Vec2]) -> Result<CameraGradient> {
    camera.validate()?;
    if screen_gradient.is_empty() && !positions.is_empty() {
        return Err(Error::LengthMismatch {
            what: "screen vertex gradients (empty: the view had triangles clipped at the near or far plane, which \
                   have no per-vertex screen gradient; move the near plane or the camera)",
            expected: positions.len(),
            got: 0,
        });
    }
    if positions.len() != screen_gradient.len() {
        return Err(Error::LengthMismatch {
            what: "screen vertex gradients",
            expected: positions.len(),
            got: screen_gradient.len(),
        });
    }
    let view = camera.params();
    let pose = camera.opencv_extrinsics();
    let (r, t) = (pose.rotation.as_dmat3(), pose.translation.as_dvec3());
    let [fx, fy, _, _] = camera.intrinsics().map(f64::from);
    let perspective = view.perspective == 1;
    let (mut rotation, mut translation) = (DVec3::ZERO, DVec3::ZERO);
    let mut intrinsics = [0f64; 4];
    for (&p, &g) in positions.iter().zip(screen_gradient) {
        if g == Vec2::ZERO || !view.project(p).1 {
            continue;
        }
        let (gu, gv) = (g.x as f64, g.y as f64);
        let rp = r * p.as_dvec3();
        let c = rp + t;
        let dc = if perspective {
            let (x, y) = (c.x / c.z, c.y / c.z);
            intrinsics[0] += gu * x;
            intrinsics[1] += gv * y;
            DVec3::new(gu * fx / c.z, gv * fy / c.z, -(gu * fx * x + gv * fy * y) / c.z)
        } else {
            intrinsics[0] += gu * c.x;
            intrinsics[1] += gv * c.y;
            DVec3::new(gu * fx, gv * fy, 0.0)
        };
        intrinsics[2] += gu;
        intrinsics[3] += gv;
        translation += dc;
        rotation += rp.cross(dc);
    }
    let [fx, fy, cx, cy] = intrinsics.map(|v| v as f32);
    Ok(CameraGradient { rotation: rotation.as_vec3(), translation: translation.as_vec3(), fx, fy, cx, cy })
}
