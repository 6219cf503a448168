//! Cameras: 3D world points → 2D pixel coordinates, and the Jacobian of that map.
//!
//! Pixel coordinates are continuous: pixel (row i, column j) covers `[j, j+1] × [i, i+1]`, x to the
//! right, y **down**, so the image spans `[0, width] × [0, height]` and pixel centres sit at
//! `(j + 0.5, i + 0.5)`. [`Projection::Perspective`] has square pixels (the horizontal field of
//! view follows from the vertical one and `width/height`) and the principal point at the image
//! centre; [`Projection::Pinhole`] takes focal lengths `fx, fy` and a principal point `cx, cy` in
//! pixels, in these coordinates.
//!
//! **Pose.** A camera is posed either by look-at (`eye`, `target`, `up`) or, when
//! [`Camera::extrinsics`] is set, by an exact world → camera rotation and translation in OpenCV's
//! camera axes (x right, y down, z forward): [`Camera::from_opencv`] builds such a camera from a
//! calibration (`K`, `R`, `t`). OpenCV puts pixel centres at integer coordinates, diffsil at
//! `+0.5`, so `from_opencv` adds 0.5 to `cx` and `cy`.

use glam::{Mat3, Vec2, Vec3};

use crate::mirror::ViewParams;
use crate::{Error, Result};

/// Largest supported image side, in pixels.
pub const MAX_RESOLUTION: u32 = 16384;

/// Largest magnitude [`Camera::validate`] accepts for a coordinate of the eye or the target: 1e18
/// (squared distances stay far inside f32).
pub const MAX_CAMERA_COORDINATE: f64 = 1e18;

/// Shortest `up` vector [`Camera::validate`] accepts: 1e-12.
const MIN_UP_LENGTH: f64 = 1e-12;
/// Longest `up` vector [`Camera::validate`] accepts: 1e12 (its cross product with the unit
/// viewing direction is normalised in f32).
const MAX_UP_LENGTH: f64 = 1e12;

/// How camera-space points map to the image plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Pinhole perspective with a vertical field of view in radians.
    Perspective {
        /// Vertical field of view, radians, in (0, π).
        fov_y: f32,
    },
    /// Parallel projection; `height` world units span the image height.
    Orthographic {
        /// World units spanned by the image height.
        height: f32,
    },
    /// Pinhole perspective with focal lengths and principal point in pixels: a camera-space point
    /// `(X, Y, Z)` in OpenCV axes (z forward, y down) lands at `(cx + fx·X/Z, cy + fy·Y/Z)`.
    /// `cx, cy` are in diffsil's pixel coordinates (the image centre is `(width/2, height/2)`).
    Pinhole {
        /// Horizontal focal length, pixels (> 0).
        fx: f32,
        /// Vertical focal length, pixels (> 0; differs from `fx` for non-square pixels).
        fy: f32,
        /// Principal point x, pixels.
        cx: f32,
        /// Principal point y, pixels (y down).
        cy: f32,
    },
}

/// An exact world → camera pose in OpenCV's camera axes (x right, y down, z forward):
/// a world point `p` has camera coordinates `c = rotation · p + translation`, and the camera
/// centre is `−rotationᵀ · translation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extrinsics {
    /// World → camera rotation `R` (orthonormal, determinant +1).
    pub rotation: Mat3,
    /// World → camera translation `t`.
    pub translation: Vec3,
}

/// Largest deviation of `RᵀR` from the identity (per entry) that [`Extrinsics`] accept.
pub const ROTATION_TOLERANCE: f32 = 1e-4;

/// `diag(1, −1, −1)`: OpenCV camera axes ↔ diffsil camera axes (x right, y up, z backward).
const FLIP: Mat3 = Mat3::from_cols(Vec3::X, Vec3::NEG_Y, Vec3::NEG_Z);

impl Extrinsics {
    /// Checks that both parts are finite and the rotation is orthonormal with determinant +1
    /// (within [`ROTATION_TOLERANCE`]).
    pub fn validate(&self) -> Result<()> {
        if !(self.rotation.is_finite() && self.translation.is_finite()) {
            return Err(Error::InvalidCamera("extrinsics: R and t must be finite".into()));
        }
        let deviation = (self.rotation.transpose() * self.rotation - Mat3::IDENTITY)
            .to_cols_array()
            .iter()
            .fold(0f32, |m, v| m.max(v.abs()));
        if deviation > ROTATION_TOLERANCE {
            return Err(Error::InvalidCamera(format!(
                "extrinsics: R is not orthonormal (RᵀR deviates from I by {deviation:e})"
            )));
        }
        if self.rotation.determinant() < 0.0 {
            return Err(Error::InvalidCamera("extrinsics: R is a reflection (determinant −1), not a rotation".into()));
        }
        let far = self.translation.abs().max_element() as f64;
        if far > MAX_CAMERA_COORDINATE {
            return Err(Error::InvalidCamera(format!(
                "extrinsics: t has a coordinate of {far:e}, beyond ±{MAX_CAMERA_COORDINATE:e}: the projection would \
                 overflow; move the scene and the camera closer to the origin"
            )));
        }
        Ok(())
    }

    /// The camera centre in world space, `−Rᵀ·t`.
    pub fn centre(&self) -> Vec3 {
        -(self.rotation.transpose() * self.translation)
    }

    /// The pose after a step in the tangent space (the parametrisation of
    /// [`CameraGradient`](crate::CameraGradient)): `R ← exp([δ]×)·R`,
    /// `t ← t + dt`, with `δ` an axis–angle vector (radians) in camera axes.
    pub fn retract(&self, rotation: Vec3, translation: Vec3) -> Extrinsics {
        Extrinsics {
            rotation: Mat3::from_quat(glam::Quat::from_scaled_axis(rotation)) * self.rotation,
            translation: self.translation + translation,
        }
    }
}

/// A camera looking from `eye` at `target` (or posed by exact [`Extrinsics`]), rendering a
/// `width × height` image.
///
/// Build one with [`Camera::perspective`], [`Camera::orthographic`], [`Camera::pinhole`]
/// (focal lengths and principal point), [`Camera::from_opencv`] (a calibration), or, for a camera
/// on a sphere around a point given by angles, [`Orbit::camera`](crate::Orbit::camera).
///
/// Only what lies between the `near` and `far` planes (depth along the viewing direction) is
/// drawn: [`Renderer::render`](crate::Renderer::render) clips a triangle crossing either plane to
/// the part between them (counted in [`RenderStats::clipped_triangles`](crate::RenderStats)), and
/// the backward differentiates the clipped geometry; a triangle wholly behind `near` or beyond
/// `far` is dropped ([`RenderStats::culled_triangles`](crate::RenderStats)). For a perspective
/// camera the clipped vertices lie at depth `near` and project far off-centre when `near` is tiny
/// (beyond [`COORD_LIMIT`](crate::COORD_LIMIT) they cull their triangle): raise `near` for
/// close-ups. Nothing there produces NaN.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Position of the eye, world space.
    pub eye: Vec3,
    /// Point the camera looks at.
    pub target: Vec3,
    /// Approximate up direction (must not be parallel to `target - eye`).
    pub up: Vec3,
    /// Perspective or orthographic.
    pub projection: Projection,
    /// Near clipping depth (> 0 for perspective; orthographic cameras may use 0, the eye's plane).
    pub near: f32,
    /// Far clipping depth (> near).
    pub far: f32,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// When set, the camera's pose: it overrides `eye`, `target` and `up`, which then describe
    /// the same camera as look-at for information only ([`Camera::with_extrinsics`] keeps them
    /// in step). `None` for look-at cameras.
    pub extrinsics: Option<Extrinsics>,
}

impl Camera {
    /// A perspective camera with up = +y, near = 0.01, far = 1000.
    pub fn perspective(eye: Vec3, target: Vec3, fov_y: f32, width: u32, height: u32) -> Camera {
        Camera {
            eye,
            target,
            up: Vec3::Y,
            projection: Projection::Perspective { fov_y },
            near: 0.01,
            far: 1000.0,
            width,
            height,
            extrinsics: None,
        }
    }

    /// An orthographic camera with up = +y whose image height spans `view_height` world units;
    /// near = 0 (points behind the eye are clipped), far = 1000.
    pub fn orthographic(eye: Vec3, target: Vec3, view_height: f32, width: u32, height: u32) -> Camera {
        Camera {
            eye,
            target,
            up: Vec3::Y,
            projection: Projection::Orthographic { height: view_height },
            near: 0.0,
            far: 1000.0,
            width,
            height,
            extrinsics: None,
        }
    }

    /// A pinhole camera with up = +y, near = 0.01, far = 1000, looking from `eye` at `target`,
    /// with focal lengths `focal = (fx, fy)` and principal point `principal = (cx, cy)` in pixels
    /// (diffsil's coordinates: the image centre is `(width/2, height/2)`; see
    /// [`Projection::Pinhole`]).
    pub fn pinhole(eye: Vec3, target: Vec3, focal: Vec2, principal: Vec2, width: u32, height: u32) -> Camera {
        Camera {
            projection: Projection::Pinhole { fx: focal.x, fy: focal.y, cx: principal.x, cy: principal.y },
            ..Camera::perspective(eye, target, 1.0, width, height)
        }
    }

    /// A camera from an OpenCV calibration: intrinsics `k = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`
    /// (rows, OpenCV's pixel convention: pixel centres at integer coordinates) and the
    /// world → camera pose `r` (rows), `t` in OpenCV's camera axes (x right, y down, z forward),
    /// rendering `width × height` pixels; near = 0.01, far = 1000 (in the units of `t`).
    ///
    /// A world point `p` with `c = R·p + t` lands at diffsil pixel coordinates
    /// `(fx·c.x/c.z + cx + 0.5, fy·c.y/c.z + cy + 0.5)`: the `+0.5` moves OpenCV's pixel
    /// centres onto diffsil's. Errors ([`Error::InvalidCamera`]): a non-finite entry, a skewed or
    /// non-pinhole `k` (non-zero skew, last row other than `(0, 0, 1)`), `fx` or `fy` ≤ 0, an `r`
    /// that is not a rotation (see [`Extrinsics::validate`]), and a bad resolution.
    pub fn from_opencv(k: [[f32; 3]; 3], r: [[f32; 3]; 3], t: [f32; 3], width: u32, height: u32) -> Result<Camera> {
        if k.iter().flatten().any(|v| !v.is_finite()) {
            return Err(Error::InvalidCamera(format!("K must be finite, got {k:?}")));
        }
        if k[0][1] != 0.0 || k[1][0] != 0.0 || k[2] != [0.0, 0.0, 1.0] {
            return Err(Error::InvalidCamera(format!(
                "K must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (no skew), got {k:?}"
            )));
        }
        let extrinsics = Extrinsics { rotation: Mat3::from_cols_array_2d(&r).transpose(), translation: Vec3::from(t) };
        extrinsics.validate()?;
        let camera = Camera::pinhole(
            Vec3::ZERO,
            Vec3::NEG_Z,
            Vec2::new(k[0][0], k[1][1]),
            Vec2::new(k[0][2] + 0.5, k[1][2] + 0.5),
            width,
            height,
        )
        .with_extrinsics(extrinsics);
        camera.validate()?;
        Ok(camera)
    }

    /// The camera of this one's image downsampled by `factor` ([`Image::downsampled`](crate::Image::downsampled)):
    /// `width / factor × height / factor` pixels (the partial blocks on the right and at the
    /// bottom left out), the same pose, near and far, and a projection that lands every point at
    /// its old pixel coordinates divided by `factor` (up to rounding): a [`Projection::Pinhole`]'s
    /// `fx, fy, cx, cy` divided by `factor`; a [`Projection::Perspective`] kept as it is when
    /// `factor` divides both sides, otherwise the equivalent pinhole (its principal point is no
    /// longer the centre of the smaller image); a [`Projection::Orthographic`] kept when `factor`
    /// divides both sides.
    ///
    /// ```
    /// use diffsil::{Camera, Vec3};
    ///
    /// let k = [[700.0, 0.0, 317.0], [0.0, 700.0, 245.0], [0.0, 0.0, 1.0]];
    /// let r = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    /// let camera = Camera::from_opencv(k, r, [0.0, 0.0, 3.0], 640, 480).unwrap();
    /// let small = camera.downsampled(5).unwrap();
    /// assert_eq!((small.width, small.height), (128, 96));
    /// let p = Vec3::new(0.2, -0.1, 0.4);
    /// let (a, b) = (camera.params().project(p).0, small.params().project(p).0);
    /// assert!((a / 5.0 - b).length() < 1e-4);
    /// ```
    ///
    /// Errors: [`Error::InvalidSettings`] for a `factor` of 0 or larger than a side, or an
    /// orthographic camera whose sides `factor` does not divide (its image centre would move,
    /// which that projection cannot express).
    pub fn downsampled(&self, factor: u32) -> Result<Camera> {
        crate::scene::image::check_downsampling("camera", factor, self.width, self.height)?;
        let divides = self.width.is_multiple_of(factor) && self.height.is_multiple_of(factor);
        let k = factor as f32;
        let projection = match self.projection {
            Projection::Perspective { .. } | Projection::Orthographic { .. } if divides => self.projection,
            // A pinhole's own intrinsics, or a perspective camera's equivalent pinhole.
            Projection::Pinhole { .. } | Projection::Perspective { .. } => {
                let [fx, fy, cx, cy] = self.intrinsics();
                Projection::Pinhole { fx: fx / k, fy: fy / k, cx: cx / k, cy: cy / k }
            }
            Projection::Orthographic { .. } => {
                return Err(Error::InvalidSettings(format!(
                    "an orthographic {}x{} camera cannot be downsampled by {factor}: the factor must divide \
                     the width and the height",
                    self.width, self.height
                )))
            }
        };
        Ok(Camera { projection, width: self.width / factor, height: self.height / factor, ..*self })
    }

    /// The part `rect` of this camera's image as a camera of its own, `rect.width × rect.height`
    /// pixels: it projects every point where this one does, less `(rect.x, rect.y)`, so it goes
    /// with [`Image::cropped`](crate::Image::cropped) targets. A perspective camera becomes the
    /// equivalent pinhole with its principal point moved (by whole pixels: exact in f32 below
    /// 2²⁴), except for a centred band of full height, which keeps the projection as it is; pose,
    /// near and far are kept.
    ///
    /// ```
    /// use diffsil::{Camera, PixelRect, Vec3};
    ///
    /// let camera = Camera::perspective(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, 0.8, 640, 480);
    /// let crop = camera.cropped(PixelRect { x: 250, y: 180, width: 100, height: 120 }).unwrap();
    /// assert_eq!((crop.width, crop.height), (100, 120));
    /// let p = Vec3::new(0.1, 0.2, -0.3);
    /// let (a, b) = (camera.params().project(p).0, crop.params().project(p).0);
    /// assert!((a - diffsil::Vec2::new(250.0, 180.0) - b).length() < 1e-3);
    /// ```
    ///
    /// Errors: [`Error::InvalidSettings`] for an empty `rect`, one reaching beyond the image, or
    /// an orthographic camera cropped other than to a centred band of full height (that
    /// projection keeps its image centre at the middle and its scale in the image height).
    pub fn cropped(&self, rect: crate::PixelRect) -> Result<Camera> {
        rect.check_inside("camera", self.width, self.height)?;
        // A band of full height about the middle: the same projection, narrower.
        let band =
            2 * rect.x as u64 + rect.width as u64 == self.width as u64 && rect.y == 0 && rect.height == self.height;
        let projection = match self.projection {
            Projection::Orthographic { .. } | Projection::Perspective { .. } if band => self.projection,
            Projection::Orthographic { .. } => {
                return Err(Error::InvalidSettings(format!(
                    "an orthographic {}x{} camera cannot be cropped to {}x{} pixels at ({}, {}): only to a band of \
                     full height centred on the image",
                    self.width, self.height, rect.width, rect.height, rect.x, rect.y
                )))
            }
            Projection::Pinhole { .. } | Projection::Perspective { .. } => {
                let [fx, fy, cx, cy] = self.intrinsics();
                Projection::Pinhole { fx, fy, cx: cx - rect.x as f32, cy: cy - rect.y as f32 }
            }
        };
        Ok(Camera { projection, width: rect.width, height: rect.height, ..*self })
    }

    /// This camera posed by `extrinsics` (OpenCV axes), with `eye`, `target` and `up` set to the
    /// equivalent look-at (eye at the camera centre, target one unit along the optical axis, up
    /// = −y of the camera).
    pub fn with_extrinsics(self, extrinsics: Extrinsics) -> Camera {
        let rt = extrinsics.rotation.transpose();
        let eye = extrinsics.centre();
        Camera { eye, target: eye + rt * Vec3::Z, up: -(rt * Vec3::Y), extrinsics: Some(extrinsics), ..self }
    }

    /// This camera in the world `X' = rotation · X + offset` (the scene turned by `rotation`, a
    /// rotation matrix, then moved by `offset`, as a calibration's world may be): it sees at `X'`
    /// what this camera sees at `X`, with the same intrinsics and size. Posed by extrinsics
    /// `R' = R · rotationᵀ`, `t' = t − R' · offset` ([`Camera::with_extrinsics`]).
    ///
    /// ```
    /// use diffsil::{Camera, Mat3, Vec3};
    ///
    /// let camera = Camera::perspective(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, 0.8, 64, 48);
    /// // The world whose up is +z, moved 2 units along x.
    /// let (z_up, offset) = (Mat3::from_cols(Vec3::X, Vec3::Z, Vec3::NEG_Y), Vec3::new(2.0, 0.0, 0.0));
    /// let moved = camera.in_world(z_up, offset);
    /// let p = Vec3::new(0.1, 0.4, -0.2);
    /// let (a, b) = (camera.params().project(p).0, moved.params().project(z_up * p + offset).0);
    /// assert!((a - b).length() < 1e-4);
    /// ```
    pub fn in_world(self, rotation: Mat3, offset: Vec3) -> Camera {
        let e = self.opencv_extrinsics();
        let rotation = e.rotation * rotation.transpose();
        self.with_extrinsics(Extrinsics { rotation, translation: e.translation - rotation * offset })
    }

    /// The world → camera pose in OpenCV axes, for any camera: [`Camera::extrinsics`] when set,
    /// otherwise the look-at pose's.
    pub fn opencv_extrinsics(&self) -> Extrinsics {
        match self.extrinsics {
            Some(e) => e,
            None => {
                let r = self.rotation();
                Extrinsics { rotation: FLIP * r, translation: FLIP * -(r * self.eye) }
            }
        }
    }

    /// The pinhole intrinsics `(fx, fy, cx, cy)` in diffsil pixel coordinates: those of
    /// [`Projection::Pinhole`], or the equivalent of [`Projection::Perspective`] (`fx = fy`,
    /// principal point at the image centre); for [`Projection::Orthographic`] the pixels per world
    /// unit and the image centre.
    pub fn intrinsics(&self) -> [f32; 4] {
        let p = self.params();
        [p.scale[0], p.scale[1], p.centre[0], p.centre[1]]
    }

    /// Checks that the camera can form an image; every render calls this. Besides a supported
    /// resolution, finite values, `near < far` and a valid projection, it needs the eye and target
    /// within ±[`MAX_CAMERA_COORDINATE`] and an `up` of length 1e-12 to 1e12 that is not parallel
    /// to the viewing direction; each error names the value and what to do.
    pub fn validate(&self) -> Result<()> {
        if self.width == 0 || self.height == 0 || self.width > MAX_RESOLUTION || self.height > MAX_RESOLUTION {
            return Err(Error::InvalidResolution { width: self.width, height: self.height, max: MAX_RESOLUTION });
        }
        if let Some(extrinsics) = &self.extrinsics {
            extrinsics.validate()?;
        } else {
            self.validate_look_at()?;
        }
        if !(self.near.is_finite() && self.far.is_finite() && self.far > self.near) {
            return Err(Error::InvalidCamera(format!(
                "need finite near < far, got near {} far {}",
                self.near, self.far
            )));
        }
        match self.projection {
            Projection::Perspective { fov_y } => {
                if !(fov_y > 0.0 && fov_y < std::f32::consts::PI) {
                    return Err(Error::InvalidCamera(format!(
                        "perspective fov_y must be in (0, π) radians, got {fov_y}"
                    )));
                }
            }
            Projection::Pinhole { fx, fy, cx, cy } => {
                if !(fx > 0.0 && fy > 0.0 && fx.is_finite() && fy.is_finite() && cx.is_finite() && cy.is_finite()) {
                    return Err(Error::InvalidCamera(format!(
                        "pinhole needs finite fx, fy > 0 and finite cx, cy, got fx {fx} fy {fy} cx {cx} cy {cy}"
                    )));
                }
            }
            Projection::Orthographic { height } => {
                if !(height > 0.0 && height.is_finite()) {
                    return Err(Error::InvalidCamera(format!("orthographic view height must be > 0, got {height}")));
                }
            }
        }
        if !matches!(self.projection, Projection::Orthographic { .. }) && self.near <= 0.0 {
            return Err(Error::InvalidCamera(format!("a perspective camera needs near > 0, got {}", self.near)));
        }
        Ok(())
    }

    fn validate_look_at(&self) -> Result<()> {
        if !(self.eye.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return Err(Error::InvalidCamera("eye, target and up must be finite".into()));
        }
        // In f64: `target - eye` and its square overflow f32 for an eye farther than ~1.8e19.
        let (eye, target, up) = (self.eye.as_dvec3(), self.target.as_dvec3(), self.up.as_dvec3());
        let far = eye.abs().max_element().max(target.abs().max_element());
        if far > MAX_CAMERA_COORDINATE {
            return Err(Error::InvalidCamera(format!(
                "the eye or target has a coordinate of {far:e}, beyond ±{MAX_CAMERA_COORDINATE:e}: the projection \
                 would overflow; move the scene and the camera closer to the origin"
            )));
        }
        let forward = target - eye;
        if forward.length_squared() < 1e-20 {
            return Err(Error::InvalidCamera("eye and target coincide: the viewing direction is undefined".into()));
        }
        // The parallel check on the normalised `up` (in f64, so its length cannot overflow); the
        // projection normalises `up × back` in f32, so `up` must have a moderate length.
        let up_length = up.length();
        if !(MIN_UP_LENGTH..=MAX_UP_LENGTH).contains(&up_length) {
            return Err(Error::InvalidCamera(format!(
                "`up` has length {:e}, outside [{MIN_UP_LENGTH:e}, {MAX_UP_LENGTH:e}]: pass a direction of \
                 moderate length such as (0, 1, 0)",
                up_length as f32
            )));
        }
        let up = up / up_length;
        if forward.normalize().cross(up).length_squared() < 1e-12 {
            return Err(Error::InvalidCamera(
                "`up` is parallel to the viewing direction: choose another up vector".into(),
            ));
        }
        Ok(())
    }

    /// World → camera rotation in diffsil's camera axes; rows are the camera's right, up and
    /// backward axes (for [`Camera::extrinsics`]: `diag(1, −1, −1)·R`).
    pub fn rotation(&self) -> Mat3 {
        if let Some(e) = &self.extrinsics {
            return FLIP * e.rotation;
        }
        let back = (self.eye - self.target).normalize();
        let right = self.up.cross(back).normalize();
        let up = back.cross(right);
        Mat3::from_cols(right, up, back).transpose()
    }

    /// The per-view constants the `project` stage uses (CPU and WGSL alike).
    pub fn params(&self) -> ViewParams {
        let r = self.rotation();
        let t = match &self.extrinsics {
            Some(e) => FLIP * e.translation,
            None => -(r * self.eye),
        };
        let image_centre = [0.5 * self.width as f32, 0.5 * self.height as f32];
        let (scale, centre, perspective) = match self.projection {
            Projection::Perspective { fov_y } => {
                let s = 0.5 * self.height as f32 / (0.5 * fov_y).tan();
                ([s, s], image_centre, 1)
            }
            Projection::Pinhole { fx, fy, cx, cy } => ([fx, fy], [cx, cy], 1),
            Projection::Orthographic { height } => {
                let s = self.height as f32 / height;
                ([s, s], image_centre, 0)
            }
        };
        ViewParams {
            row0: r.row(0).extend(t.x).to_array(),
            row1: r.row(1).extend(t.y).to_array(),
            row2: r.row(2).extend(t.z).to_array(),
            centre,
            scale,
            perspective,
            near: self.near,
            far: self.far,
            width: self.width,
            height: self.height,
            pad0: 0,
            pad1: 0,
            pad2: 0,
        }
    }
}

impl ViewParams {
    /// Camera-space point of `p`, in exactly the `f32` arithmetic of [`ViewParams::project`].
    #[inline]
    pub(crate) fn camera_space(&self, p: Vec3) -> Vec3 {
        let h = p.extend(1.0);
        Vec3::new(
            glam::Vec4::from(self.row0).dot(h),
            glam::Vec4::from(self.row1).dot(h),
            glam::Vec4::from(self.row2).dot(h),
        )
    }

    /// Projects `p`: pixel coordinates, and whether the point is inside the near/far range and the
    /// coordinate limit.
    #[inline]
    pub fn project(&self, p: Vec3) -> (Vec2, bool) {
        let c = self.camera_space(p);
        let depth = -c.z;
        let in_range = depth > self.near && depth < self.far;
        let (x, y) = if self.perspective == 1 {
            if !in_range {
                return (Vec2::ZERO, false);
            }
            (c.x / depth, c.y / depth)
        } else {
            (c.x, c.y)
        };
        let screen = Vec2::new(self.centre[0] + self.scale[0] * x, self.centre[1] - self.scale[1] * y);
        let valid =
            in_range && screen.x.abs() < crate::mirror::COORD_LIMIT && screen.y.abs() < crate::mirror::COORD_LIMIT;
        (if valid { screen } else { Vec2::ZERO }, valid)
    }

    /// Jacobian of [`ViewParams::project`] at `p`: rows `∂x/∂p` and `∂y/∂p`. Zero for clipped points.
    #[inline]
    pub fn jacobian(&self, p: Vec3) -> [Vec3; 2] {
        let c = self.camera_space(p);
        let r0 = Vec3::from_slice(&self.row0[..3]);
        let r1 = Vec3::from_slice(&self.row1[..3]);
        let r2 = Vec3::from_slice(&self.row2[..3]);
        if self.perspective == 1 {
            let depth = -c.z;
            if !(depth > self.near && depth < self.far) {
                return [Vec3::ZERO; 2];
            }
            let (kx, ky) = (self.scale[0] / depth, self.scale[1] / depth);
            // d = −r2·p − t.z, so ∂(c.x/d)/∂p = r0/d + c.x·r2/d².
            [kx * (r0 + (c.x / depth) * r2), -ky * (r1 + (c.y / depth) * r2)]
        } else {
            [self.scale[0] * r0, -self.scale[1] * r1]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_of_view_projects_to_image_centre() {
        let cam = Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.8, 64, 32);
        let (p, valid) = cam.params().project(Vec3::ZERO);
        assert!(valid);
        assert!((p - Vec2::new(32.0, 16.0)).length() < 1e-5);
        // +y world is up on screen, i.e. smaller pixel y.
        let (q, _) = cam.params().project(Vec3::new(0.0, 0.1, 0.0));
        assert!(q.y < p.y);
        let (r, _) = cam.params().project(Vec3::new(0.1, 0.0, 0.0));
        assert!(r.x > p.x);
    }

    #[test]
    fn behind_camera_is_invalid_and_zero() {
        let cam = Camera::perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.8, 64, 64);
        let (p, valid) = cam.params().project(Vec3::new(0.0, 0.0, 4.0));
        assert!(!valid);
        assert_eq!(p, Vec2::ZERO);
        assert_eq!(cam.params().jacobian(Vec3::new(0.0, 0.0, 4.0)), [Vec3::ZERO; 2]);
    }
}
