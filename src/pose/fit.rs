//! Pose fitting to multi-view silhouettes (paper §4): `E = E_sl + λ·E_spt`, minimised over the
//! pose with Adam.
//!
//! One [`PoseFit::step`] skins the model at the current pose, renders every view, takes the
//! squared silhouette error against the targets (`E_sl`, paper Eq. 18), adds `λ` times the
//! self-intersection surrogate (`E_spt`, see [`crate::pose::self_intersection`]), and back-propagates
//! through the renderer, the cameras and the skinning to the pose parameters.
//!
//! # The fitting method ([`PoseFit::run`])
//!
//! Plain descent from the rest pose stalls in local minima on a large share of random poses
//! (16 of seeds 1–30 end more than 20 mm off for the built-in figure at 64², F = 4, 300 steps;
//! the errors are bimodal: 2.5–7 mm, or 22–71 mm). The stalled fits are not ambiguities the silhouettes cannot decide:
//! their silhouette error stays 6–50 times that of the converged ones. Their per-joint errors
//! show whole limbs in the wrong place (a wrist or an ankle 30–45 cm off), of two kinds:
//!
//! - **No overlap, no gradient.** A limb whose silhouette does not overlap its target in a view
//!   feels nothing there: the squared error is flat until the two touch. An arm that should reach
//!   forward, fitted alongside (and hidden behind) the torso in the side views, stays there.
//! - **Which leg is in front.** The four views are pairwise mirror images (0°/180°, 90°/270°),
//!   and in a side view the nearer leg hides the other, so only the nearer leg's contour gets a
//!   gradient. From the symmetric rest pose, the descent decides which leg goes forward (or
//!   crosses in front) on faint cues (perspective, foot shape), and often decides wrong: the
//!   fitted legs then hold each other's depths, and they cannot pass through each other to swap.
//!
//! Once those are avoided, what is left of the error is mostly twist: a limb's rotation about
//! its own axis, which silhouettes barely see and which a joint and its child can trade between
//! them (10–30° on the thighs and arms of otherwise converged fits).
//!
//! The method answers all three, with the same settings for every resolution and supersampling:
//!
//! 1. **Coarse to fine.** `E_sl` compares the rendered and target silhouettes blurred by the
//!    same Gaussian ([`loss::blurred_squared_error`]), whose standard deviation is a fraction of
//!    the image height (so every resolution sees the same blurred picture), shrinking in stages
//!    to no blur ([`Schedule`]). Blurred silhouettes attract from farther away.
//! 2. **Multiple hypotheses.** The fit starts from several initial poses ([`stride_hypotheses`]:
//!    the rest pose, and the legs in a small stride one way and the other), runs each for the
//!    same few steps of the coarsest stage, and keeps the one with the lowest energy `E`
//!    (unblurred), which then runs the remaining stages. This is the classic way to treat a
//!    discrete ambiguity that descent cannot cross: start on each side of it and let the
//!    objective choose.
//! 3. **A pose prior.** `E` gains `μ·E_prior`, `E_prior` the mean squared joint offset
//!    ([`PoseFit::set_pose_prior`], μ = [`PoseFit::POSE_PRIOR`]): a zero-mean Gaussian prior,
//!    as the random poses are drawn around the rest pose. It holds the directions the silhouettes
//!    do not see (twist) near rest instead of letting Adam's noise move them.
//! 4. **Mean, not sum.** `E_sl` is the mean over all pixels of all views, so its scale, and so
//!    the meaning of `λ` and `μ`, does not depend on the resolution or the number of views
//!    (Adam's steps do not depend on the scale of the loss, but the balance of the terms does).
//!
//! Costs: a blurred step costs about a third more than a sharp one (see
//! [`PoseFit::set_blur`]), so the default 300 steps (130 blurred) take about 1.06 times as long
//! as 300 plain steps. With them, seeds 1–30 at 64², F = 4 end at a median of 4.6 mm, one of
//! them more than 20 mm off (a leg-order ambiguity no start resolved).

use glam::{Mat3, Vec3};

use crate::loss::GaussianBlur;
use crate::optim::Adam;
use crate::pose::self_intersection::SelfIntersectionChecker;
use crate::pose::skin::{Pose, SkinnedMesh};
use crate::random::SplitMix64;
use crate::{loss, Camera, Error, Image, Mesh, Renderer, Result};

/// A random plausible pose: each joint rotated about a random axis by an angle uniform in
/// `[0, limit_j]` (`limits`, e.g. from [`crate::pose::figure::JointKind::random_pose_limit`]), and a
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
    /// `E_sl`: squared silhouette error, the mean over all pixels of all views, between the
    /// silhouettes blurred by the current blur ([`PoseFit::set_blur`]; none by default).
    pub silhouette: f64,
    /// `E_spt`: the fraction of vertices inside a self-intersection.
    pub self_intersection: f64,
    /// The self-intersection surrogate whose gradient is used (`Σ depth² / N`, world units²).
    pub self_intersection_surrogate: f64,
    /// `E_prior = (1/J) Σ_j |θ_j|²` (rad²), unweighted (see [`PoseFit::set_pose_prior`]).
    pub pose_prior: f64,
}

/// The optimiser's state: the pose parameters and Adam's moments. [`PoseFit::state`] and
/// [`PoseFit::set_state`] move it in and out, so that one fit can follow several hypotheses.
#[derive(Clone, Debug)]
pub struct FitState {
    params: Vec<f32>,
    adam: Adam,
}

/// One stage of a [`Schedule`]: this many steps with the silhouettes blurred by a Gaussian of
/// standard deviation `blur` × the image height.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stage {
    /// Standard deviation of the blur, as a fraction of the image height (0: no blur).
    pub blur: f32,
    /// Adam steps.
    pub steps: u32,
}

/// A coarse-to-fine, multi-hypothesis schedule for [`PoseFit::run`]: every hypothesis runs
/// `hypothesis_steps` steps with the blur of the first stage, the one with the lowest energy is
/// kept, and it runs every stage in turn.
#[derive(Clone, Debug, PartialEq)]
pub struct Schedule {
    /// Steps each hypothesis gets before one is chosen.
    pub hypothesis_steps: u32,
    /// The stages the chosen hypothesis runs, coarse to fine.
    pub stages: Vec<Stage>,
}

impl Schedule {
    /// Blur of the coarsest stage: 6% of the image height (3.8 pixels at 64², 1.9 at 32²).
    pub const COARSE_BLUR: f32 = 0.06;

    /// The default schedule: `total_steps` Adam steps in all, shared by `hypotheses` starting
    /// poses. Each hypothesis gets a tenth of the steps at blur [`Schedule::COARSE_BLUR`]
    /// (fewer if there are more than five, so that half the steps are left); the chosen one
    /// continues with a twentieth of the steps at the same blur, a twelfth at half that blur,
    /// and the rest unblurred. For 300 steps and 3 hypotheses: 3 × 30, then 15, 25 and 170.
    /// Every resolution and supersampling gets the same schedule.
    pub fn coarse_to_fine(total_steps: u32, hypotheses: usize) -> Schedule {
        let hypotheses = hypotheses.max(1) as u32;
        let hypothesis_steps = (total_steps / 10).min(total_steps / (2 * hypotheses));
        let coarse = total_steps / 20;
        let middle = total_steps / 12;
        let fine = total_steps.saturating_sub(hypotheses * hypothesis_steps + coarse + middle);
        Schedule {
            hypothesis_steps,
            stages: vec![
                Stage { blur: Self::COARSE_BLUR, steps: coarse },
                Stage { blur: Self::COARSE_BLUR / 2.0, steps: middle },
                Stage { blur: 0.0, steps: fine },
            ],
        }
    }

    /// Steps [`PoseFit::run`] takes with this schedule and `hypotheses` starting poses.
    pub fn total_steps(&self, hypotheses: usize) -> u32 {
        hypotheses.max(1) as u32 * self.hypothesis_steps + self.stages.iter().map(|s| s.steps).sum::<u32>()
    }
}

/// Where [`PoseFit::run`] is, passed to its callback after every step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Steps taken so far, all hypotheses included (1 after the first).
    pub step: u32,
    /// The hypothesis being run, while they are tried; `None` once one has been chosen.
    pub hypothesis: Option<usize>,
    /// The blur of this step (fraction of the image height).
    pub blur: f32,
    /// The step's energies.
    pub report: StepReport,
}

/// What [`PoseFit::run`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct RunReport {
    /// Adam steps taken, all hypotheses included.
    pub steps: u32,
    /// Energy `E` (unblurred, [`PoseFit::energy`]) of each hypothesis after its steps.
    pub hypothesis_energies: Vec<f64>,
    /// The hypothesis that was kept.
    pub chosen: usize,
    /// Energy at the final pose (unblurred).
    pub energy: f64,
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
    /// Blur as a fraction of the image height, one filter per view, and the blurred targets.
    blur: f32,
    blurs: Vec<GaussianBlur>,
    blurred_targets: Vec<Image>,
    /// `1 / (total pixel count of all views)`: makes `E_sl` a mean.
    pixel_weight: f64,
    /// Weight `μ` of the pose prior.
    pose_prior: f32,
}

impl PoseFit {
    /// The pose prior weight of the fitting method ([`PoseFit::set_pose_prior`]): about the
    /// size of a converged fit's `E_sl` (~1e-4) for offsets of a third of a radian.
    pub const POSE_PRIOR: f32 = 1e-3;

    /// Starts a fit at `initial` toward the `targets` (one per camera, each of the camera's
    /// size), with Adam at `learning_rate` and self-intersection weight `lambda`. `E_sl` is a
    /// mean over pixels: against a sum over the pixels of four 64² views, `λ` weighed 16,384
    /// times less (the example's 1e-7 is 1.6 times the old 0.001 there). No blur and no pose
    /// prior until set.
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
        let pixels: f64 = targets.iter().map(|t| f64::from(t.width()) * f64::from(t.height())).sum();
        Ok(PoseFit {
            params: initial.to_params(),
            model,
            cameras,
            blurs: vec![GaussianBlur::identity(); targets.len()],
            blurred_targets: targets.clone(),
            targets,
            renderer,
            checker,
            adam: Adam::new(learning_rate),
            lambda,
            mesh,
            blur: 0.0,
            pixel_weight: if pixels > 0.0 { 1.0 / pixels } else { 1.0 },
            pose_prior: 0.0,
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

    /// The optimiser's state (pose parameters and Adam's moments).
    pub fn state(&self) -> FitState {
        FitState { params: self.params.clone(), adam: self.adam.clone() }
    }

    /// Restores a state taken by [`PoseFit::state`] from this fit.
    pub fn set_state(&mut self, state: FitState) -> Result<()> {
        if state.params.len() != self.params.len() {
            return Err(Error::LengthMismatch {
                what: "fit state parameters",
                expected: self.params.len(),
                got: state.params.len(),
            });
        }
        self.params = state.params;
        self.adam = state.adam;
        Ok(())
    }

    /// Moves to `pose` and forgets Adam's moments (a fresh start from there).
    pub fn restart(&mut self, pose: &Pose) -> Result<()> {
        pose.validate(self.model.joint_count())?;
        self.params = pose.to_params();
        self.adam = Adam::new(self.adam.learning_rate);
        Ok(())
    }

    /// Sets Adam's learning rate (a positive number).
    pub fn set_learning_rate(&mut self, learning_rate: f32) -> Result<()> {
        if !(learning_rate.is_finite() && learning_rate > 0.0) {
            return Err(Error::InvalidSettings(format!("need a positive learning rate, got {learning_rate}")));
        }
        self.adam.learning_rate = learning_rate;
        Ok(())
    }

    /// Weight `μ` of the pose prior: the energy gains `μ·E_prior` with
    /// `E_prior = (1/J) Σ_j |θ_j|²`, the mean squared rotation offset (radians²) of the `J`
    /// joints; global orientation and translation are free. 0 (none) unless set; the method's
    /// value is [`PoseFit::POSE_PRIOR`]. Errors on a negative or non-finite weight.
    ///
    /// This is a zero-mean Gaussian prior on the offsets (the energy is then a negative log
    /// posterior): silhouettes barely see a limb's twist about its own axis, which a joint and its
    /// child can also trade between them, so without a prior those directions drift wherever
    /// the noise of the descent takes them. The prior keeps them near the rest pose unless the
    /// silhouettes say otherwise, and hands a rotation of the whole body from the root joint to the
    /// global orientation, which it does not penalise.
    pub fn set_pose_prior(&mut self, weight: f32) -> Result<()> {
        if !(weight.is_finite() && weight >= 0.0) {
            return Err(Error::InvalidSettings(format!("need a non-negative pose prior weight, got {weight}")));
        }
        self.pose_prior = weight;
        Ok(())
    }

    /// `E_prior` at the current pose.
    fn prior_energy(&self) -> f64 {
        let joints = self.model.joint_count();
        let offsets = &self.params[..3 * joints];
        offsets.iter().map(|&t| f64::from(t) * f64::from(t)).sum::<f64>() / joints.max(1) as f64
    }

    /// Adds `μ·∂E_prior/∂θ = 2μ θ / J` to the joint offsets' entries of `grads`.
    fn add_prior_gradient(&self, grads: &mut [f32]) {
        if self.pose_prior > 0.0 {
            let joints = self.model.joint_count();
            let scale = 2.0 * self.pose_prior / joints as f32;
            for (g, &t) in grads.iter_mut().zip(&self.params[..3 * joints]) {
                *g += scale * t;
            }
        }
    }

    /// The current blur, as a fraction of the image height.
    pub fn blur(&self) -> f32 {
        self.blur
    }

    /// Blurs the silhouettes that `E_sl` compares by a Gaussian of standard deviation
    /// `fraction` × each view's image height (0: no blur). Errors on a negative or non-finite
    /// fraction, or one above 1.
    ///
    /// A blurred step costs more than a sharp one (about a third more for the built-in figure at
    /// 64²): the gradient image is no longer zero where the silhouettes agree, so the renderer's
    /// backward visits every visible contour segment rather than only those in disagreeing
    /// pixels.
    pub fn set_blur(&mut self, fraction: f32) -> Result<()> {
        if !(fraction.is_finite() && (0.0..=1.0).contains(&fraction)) {
            return Err(Error::InvalidSettings(format!(
                "blur {fraction}: use a fraction of the image height in [0, 1]"
            )));
        }
        if fraction == self.blur {
            return Ok(());
        }
        self.blurs =
            self.targets.iter().map(|t| GaussianBlur::new(fraction * t.height() as f32)).collect::<Result<Vec<_>>>()?;
        self.blurred_targets = self.targets.iter().zip(&self.blurs).map(|(t, b)| b.apply(t)).collect();
        self.blur = fraction;
        Ok(())
    }

    /// The energy `E = E_sl + λ·E_spt + μ·E_prior` at the current pose, unblurred whatever the
    /// current blur, with the self-intersection surrogate as `E_spt` (what the descent
    /// minimises).
    pub fn energy(&mut self) -> Result<f64> {
        let vertices = self.vertices()?;
        self.mesh.set_positions(&vertices)?;
        let frame = self.renderer.render(&self.mesh, &self.cameras)?;
        let (silhouette, _) = loss::squared_error_views(frame.images(), &self.targets)?;
        let surrogate = if self.lambda > 0.0 { self.checker.check(&vertices)?.surrogate } else { 0.0 };
        let prior = self.prior_energy();
        Ok(silhouette * self.pixel_weight + f64::from(self.lambda) * surrogate + f64::from(self.pose_prior) * prior)
    }

    /// One gradient step; returns the energies at the pose before the step.
    pub fn step(&mut self) -> Result<StepReport> {
        let pose = self.pose();
        let (vertices, cache) = self.model.skin_with_cache(&pose)?;
        self.mesh.set_positions(&vertices)?;
        // The self-intersection check is single-threaded and independent of the images: it runs
        // beside the render + backward.
        let (checker, lambda) = (&mut self.checker, self.lambda);
        let (silhouette_pass, intersection) = rayon::join(
            || -> Result<(f64, Vec<Vec3>)> {
                let frame = self.renderer.render(&self.mesh, &self.cameras)?;
                let mut silhouette = 0.0;
                let mut d_images = Vec::with_capacity(self.targets.len());
                for ((image, target), blur) in frame.images().iter().zip(&self.blurred_targets).zip(&self.blurs) {
                    let loss::LossOutput { value, mut grad } = loss::blurred_squared_error(image, target, blur)?;
                    silhouette += value * self.pixel_weight;
                    for g in grad.data_mut() {
                        *g = (f64::from(*g) * self.pixel_weight) as f32;
                    }
                    d_images.push(grad);
                }
                Ok((silhouette, self.renderer.backward(&frame, &d_images)?))
            },
            || if lambda > 0.0 { checker.check(&vertices).map(Some) } else { Ok(None) },
        );
        let (silhouette, mut d_vertices) = silhouette_pass?;
        let (penalty, surrogate) = match intersection? {
            Some(result) => {
                for (g, s) in d_vertices.iter_mut().zip(&result.grad) {
                    *g += lambda * *s;
                }
                (result.penalty, result.surrogate)
            }
            None => (0.0, 0.0),
        };
        let d_pose = self.model.backward(&cache, &d_vertices)?;
        let mut grads = d_pose.to_params();
        let prior = self.prior_energy();
        self.add_prior_gradient(&mut grads);
        self.adam.step(&mut self.params, &grads)?;
        Ok(StepReport {
            silhouette,
            self_intersection: penalty,
            self_intersection_surrogate: surrogate,
            pose_prior: prior,
        })
    }

    /// Runs a whole fit: each of `hypotheses` (starting poses; the current pose when empty) for
    /// `schedule.hypothesis_steps` steps at the first stage's blur, each from a fresh Adam, then
    /// the one with the lowest energy ([`PoseFit::energy`]) through every stage of `schedule`,
    /// keeping its Adam state. Calls `on_step` after every step. Ends unblurred, at the chosen
    /// hypothesis's final pose. Errors (and stops) on the first step that errors.
    pub fn run(
        &mut self,
        schedule: &Schedule,
        hypotheses: &[Pose],
        mut on_step: impl FnMut(&PoseFit, &Progress),
    ) -> Result<RunReport> {
        let first_blur = schedule.stages.first().map_or(0.0, |s| s.blur);
        let mut step = 0;
        let mut states = Vec::new();
        let mut energies = Vec::new();
        let current = self.pose();
        let starts = if hypotheses.is_empty() { std::slice::from_ref(&current) } else { hypotheses };
        for (k, start) in starts.iter().enumerate() {
            self.restart(start)?;
            self.set_blur(first_blur)?;
            for _ in 0..schedule.hypothesis_steps {
                let report = self.step()?;
                step += 1;
                on_step(self, &Progress { step, hypothesis: Some(k), blur: self.blur, report });
            }
            energies.push(self.energy()?);
            states.push(self.state());
        }
        let chosen = energies
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map(|(k, _)| k)
            .expect("at least one hypothesis");
        self.set_state(states.swap_remove(chosen))?;
        for stage in &schedule.stages {
            self.set_blur(stage.blur)?;
            for _ in 0..stage.steps {
                let report = self.step()?;
                step += 1;
                on_step(self, &Progress { step, hypothesis: None, blur: self.blur, report });
            }
        }
        self.set_blur(0.0)?;
        let energy = self.energy()?;
        Ok(RunReport { steps: step, hypothesis_energies: energies, chosen, energy })
    }
}

/// Starting poses for [`PoseFit::run`]: the rest pose, and, when the skeleton has a pair of legs,
/// the rest pose with the legs in a stride of `angle` radians each way (one leg swung forward
/// and the other back by `angle` about the axis through both hips, then the other way round).
///
/// The legs are the mirrored pair of sibling joints nearest the root: two children of one joint
/// with subtrees of the same size whose rest positions are equally far from their parent (within
/// 10%); for the built-in figure, the hips under the pelvis. Which leg the descent brings forward
/// is decided by faint cues when both start straight (see the [module documentation](self)); a
/// stride each way puts a start on each side of that choice. Global orientation and translation
/// stay zero. A skeleton without such a pair gets the rest pose alone.
pub fn stride_hypotheses(model: &SkinnedMesh, angle: f32) -> Result<Vec<Pose>> {
    let rest = Pose::rest(model.joint_count());
    let Some((a, b)) = leg_pair(model) else {
        return Ok(vec![rest]);
    };
    let world = model.joint_transforms(&rest)?;
    let position = |j: usize| world[j].w_axis.truncate();
    let lateral = (position(a) - position(b)).normalize_or_zero();
    if lateral == Vec3::ZERO {
        return Ok(vec![rest]);
    }
    let local_axis = |j: usize| (offset_frame(model, &world, j).transpose() * lateral).normalize_or_zero();
    let mut hypotheses = vec![rest.clone()];
    for sign in [1.0, -1.0] {
        let mut pose = rest.clone();
        pose.joint_rotations[a] = sign * angle * local_axis(a);
        pose.joint_rotations[b] = -sign * angle * local_axis(b);
        hypotheses.push(pose);
    }
    Ok(hypotheses)
}

/// The rest-pose world rotation of the frame joint `j`'s offset acts in:
/// `rotation(G_parent) · R(q_j)` (offsets act after the rest rotation), from the rest world
/// transforms `world`; the parent's scale is divided out of its columns.
fn offset_frame(model: &SkinnedMesh, world: &[glam::Mat4], j: usize) -> Mat3 {
    let parent = match model.skeleton.parents[j] {
        Some(p) => Mat3::from_mat4(world[p]),
        None => Mat3::from_mat4(model.skeleton.root_parent[j]),
    };
    let unscaled = Mat3::from_cols(
        parent.x_axis.normalize_or_zero(),
        parent.y_axis.normalize_or_zero(),
        parent.z_axis.normalize_or_zero(),
    );
    unscaled * Mat3::from_quat(model.skeleton.rest[j].rotation.normalize())
}

/// The mirrored pair of sibling joints nearest the root (see [`stride_hypotheses`]).
fn leg_pair(model: &SkinnedMesh) -> Option<(usize, usize)> {
    let parents = &model.skeleton.parents;
    let n = parents.len();
    let mut subtree = vec![1usize; n];
    let mut depth = vec![0usize; n];
    for j in 0..n {
        if let Some(p) = parents[j] {
            depth[j] = depth[p] + 1;
        }
    }
    for j in (0..n).rev() {
        if let Some(p) = parents[j] {
            subtree[p] += subtree[j];
        }
    }
    let offset = |j: usize| model.skeleton.rest[j].translation.length();
    let mut best: Option<(usize, usize)> = None;
    for a in 0..n {
        for b in a + 1..n {
            let (Some(pa), Some(pb)) = (parents[a], parents[b]) else { continue };
            let (la, lb) = (offset(a), offset(b));
            let mirrored = pa == pb && subtree[a] == subtree[b] && la > 0.0 && (la - lb).abs() <= 0.1 * la.max(lb);
            if mirrored && best.is_none_or(|(c, _)| depth[a] < depth[c]) {
                best = Some((a, b));
            }
        }
    }
    best
}
