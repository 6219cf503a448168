//! Pose fitting to multi-view silhouettes (paper §4): `E = E_sl + λ·E_spt`, minimised over the
//! pose with Adam.
//!
//! One [`PoseFit::step`] skins the model at the current pose, renders every view, takes the
//! squared silhouette error against the targets (`E_sl`, paper Eq. 18, summed over views), adds
//! `λ` times the self-intersection surrogate (`E_spt`, see [`crate::self_intersection`]), and
//! back-propagates through the renderer, the cameras and the skinning to the pose parameters.

use glam::Vec3;

use crate::optim::Adam;
use crate::self_intersection::SelfIntersectionChecker;
use crate::skin::{Pose, SkinnedMesh};
use crate::{loss, Camera, Error, Image, Mesh, Renderer, Result};

/// A small deterministic random source (SplitMix64), so fits and poses reproduce from a seed.
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator seeded with `seed`.
    pub fn new(seed: u64) -> SplitMix64 {
        SplitMix64(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// A uniform number in `[0, 1)`.
    pub fn uniform(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A uniform number in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.uniform()
    }

    /// A uniformly distributed unit vector.
    pub fn unit_vector(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

/// A random plausible pose: each joint rotated about a random axis by an angle uniform in
/// `[0, limit_j]` (`limits`, e.g. from [`crate::figure::JointKind::random_pose_limit`]), and a
/// global orientation within ±`max_yaw` radians about the vertical (+y) axis. No translation.
pub fn random_pose(limits: &[f32], max_yaw: f32, seed: u64) -> Pose {
    let mut rng = SplitMix64::new(seed);
    let joint_rotations = limits.iter().map(|&limit| rng.unit_vector() * rng.range(0.0, limit)).collect();
    Pose { joint_rotations, orientation: Vec3::new(0.0, rng.range(-max_yaw, max_yaw), 0.0), translation: Vec3::ZERO }
}

/// Cameras on a horizontal circle around `target`: `views` azimuths evenly spaced from 0° (0°, 90°,
/// 180°, 270° for four views), `elevation` radians, at `distance`, vertical field of view `fov_y`,
/// square `resolution`.
pub fn orbit_cameras(
    views: u32,
    target: Vec3,
    elevation: f32,
    distance: f32,
    fov_y: f32,
    resolution: u32,
) -> Vec<Camera> {
    (0..views)
        .map(|k| {
            let azimuth = std::f32::consts::TAU * k as f32 / views as f32;
            Camera::orbit(target, azimuth, elevation, distance, fov_y, resolution, resolution)
        })
        .collect()
}

/// Cameras framing `mesh`: [`orbit_cameras`] aimed at its bounding-box centre, far enough that
/// its bounding sphere fits the vertical field of view with a 10% margin.
pub fn framing_cameras(mesh: &Mesh, views: u32, resolution: u32) -> Vec<Camera> {
    let p = mesh.positions();
    let (lo, hi) =
        p.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let centre = if p.is_empty() { Vec3::ZERO } else { (lo + hi) * 0.5 };
    let radius = p.iter().map(|v| (*v - centre).length()).fold(1e-3f32, f32::max);
    let fov_y = 40f32.to_radians();
    let distance = 1.1 * radius / (0.5 * fov_y).sin();
    orbit_cameras(views, centre, 0.0, distance, fov_y, resolution)
}

/// Mean distance between corresponding vertices (paper Eq. 21), in the mesh's units.
pub fn per_vertex_error(a: &[Vec3], b: &[Vec3]) -> f64 {
    if a.is_empty() || a.len() != b.len() {
        return if a.len() == b.len() { 0.0 } else { f64::INFINITY };
    }
    a.iter().zip(b).map(|(p, q)| (*p - *q).length() as f64).sum::<f64>() / a.len() as f64
}

/// The numbers of one fitting step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepReport {
    /// `E_sl`: squared silhouette error summed over views.
    pub silhouette: f64,
    /// `E_spt`: the fraction of vertices inside a self-intersection.
    pub self_intersection: f64,
    /// The self-intersection surrogate whose gradient is used (`Σ depth² / N`).
    pub self_intersection_surrogate: f64,
}

/// A pose fit in progress: the model, the views and their target silhouettes, the optimiser state.
pub struct PoseFit {
    model: SkinnedMesh,
    cameras: Vec<Camera>,
    targets: Vec<Image>,
    renderer: Renderer,
    checker: SelfIntersectionChecker,
    adam: Adam,
    lambda: f32,
    params: Vec<f32>,
    mesh: Mesh,
}

impl PoseFit {
    /// Starts a fit at `initial` toward the `targets` (one per camera, each of the camera's
    /// size), with Adam at `learning_rate` and self-intersection weight `lambda`.
    pub fn new(
        model: SkinnedMesh,
        cameras: Vec<Camera>,
        targets: Vec<Image>,
        renderer: Renderer,
        initial: &Pose,
        learning_rate: f32,
        lambda: f32,
    ) -> Result<PoseFit> {
        if targets.len() != cameras.len() {
            return Err(Error::ViewCountMismatch {
                what: "target silhouettes",
                views: cameras.len(),
                got: targets.len(),
            });
        }
        for (camera, target) in cameras.iter().zip(&targets) {
            camera.validate()?;
            target.expect_size("target silhouette", camera.width, camera.height)?;
        }
        if !(learning_rate.is_finite() && learning_rate > 0.0 && lambda.is_finite() && lambda >= 0.0) {
            return Err(Error::InvalidSettings(format!(
                "need a positive learning rate and a non-negative λ, got {learning_rate} and {lambda}"
            )));
        }
        initial.validate(model.joint_count())?;
        let checker = SelfIntersectionChecker::new(model.mesh.topology());
        let mesh = model.mesh.clone();
        Ok(PoseFit {
            params: initial.to_params(),
            model,
            cameras,
            targets,
            renderer,
            checker,
            adam: Adam::new(learning_rate),
            lambda,
            mesh,
        })
    }

    /// The current pose.
    pub fn pose(&self) -> Pose {
        Pose::from_params(&self.params, self.model.joint_count()).expect("parameters keep their length")
    }

    /// The model's vertices at the current pose.
    pub fn vertices(&self) -> Result<Vec<Vec3>> {
        self.model.skin(&self.pose())
    }

    /// Renders the current pose in every view.
    pub fn render(&mut self) -> Result<Vec<Image>> {
        let vertices = self.vertices()?;
        self.mesh.set_positions(&vertices)?;
        Ok(self.renderer.render(&self.mesh, &self.cameras)?.images().to_vec())
    }

    /// The renderer (to ask for its backend name).
    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// One gradient step; returns the energies at the pose before the step.
    pub fn step(&mut self) -> Result<StepReport> {
        let pose = self.pose();
        let (vertices, cache) = self.model.skin_with_cache(&pose)?;
        self.mesh.set_positions(&vertices)?;
        let frame = self.renderer.render(&self.mesh, &self.cameras)?;
        let (silhouette, d_images) = loss::squared_error_views(frame.images(), &self.targets)?;
        let mut d_vertices = self.renderer.backward(&frame, &d_images)?;
        let (penalty, surrogate) = if self.lambda > 0.0 {
            let result = self.checker.check(&vertices)?;
            for (g, s) in d_vertices.iter_mut().zip(&result.grad) {
                *g += self.lambda * *s;
            }
            (result.penalty, result.surrogate)
        } else {
            (0.0, 0.0)
        };
        let d_pose = self.model.backward(&cache, &d_vertices)?;
        self.adam.step(&mut self.params, &d_pose.to_params())?;
        Ok(StepReport { silhouette, self_intersection: penalty, self_intersection_surrogate: surrogate })
    }
}
