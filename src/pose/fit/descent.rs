//! [`PoseFit`]: one fit's model, views, targets and optimiser state, its energy and its
//! gradient step.

use glam::Vec3;

use super::{inflation, outline};
use crate::loss::GaussianBlur;
use crate::optim::Adam;
use crate::pose::self_intersection::{SelfIntersection, SelfIntersectionChecker};
use crate::pose::skin::{Pose, SkinnedMesh};
use crate::{loss, Camera, Error, Image, Mesh, Renderer, Result};

// A child of this module (it takes steps with a precomputed silhouette pass), in its own file.
#[path = "hypotheses.rs"]
mod hypotheses;
// The inflation and outline nuisances, in their own file.
#[path = "nuisance.rs"]
mod nuisance;
// The checks of the settings and targets, shared with `FitOptions::validate`, in their own file.
#[path = "checks.rs"]
mod checks;
use checks::check_targets;
pub(in crate::pose::fit) use checks::{check_blur, check_intersection_interval, check_rate_and_lambda};
// The pose and shape priors, in their own file.
#[path = "priors.rs"]
mod priors;
pub(in crate::pose::fit) use priors::check_prior_weight;
// E_sl: renders against the blurred targets, in its own file.
#[path = "silhouette.rs"]
mod silhouette;
use silhouette::{silhouette_loss, silhouette_pass};
// The vertex subset the coarsest steps render, and its settings, in its own file.
#[path = "proxy.rs"]
mod proxy;
use proxy::{check_self_intersection, Proxy};
// The optimiser's state, taken out and put back (hypotheses, swap test), in its own file.
#[path = "state.rs"]
mod state;
pub use state::FitState;
// The limb swap test on a final pose, in its own file.
#[path = "swap.rs"]
mod swap;
pub use swap::{head_turns, limb_swaps, LimbSwap, SwapCandidate, SwapReport, SwapScreen, SwapTest};
// The legs crossed over, the candidate of `fit`'s second run, in its own file (it shares the
// swap test's joint-rotation helpers).
#[path = "crossed_legs.rs"]
mod crossed_legs;
pub(in crate::pose::fit) use crossed_legs::changed_pixels;
pub use crossed_legs::crossed_legs;

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
    /// `E_shape = (1/K) Σ_k β_k²`, unweighted (see [`PoseFit::set_shape_prior`]); 0 without
    /// morph targets.
    pub shape_prior: f64,
    /// The energy the step descends: `E_sl + λ·surrogate + μ·E_prior + ν·E_shape` (with the
    /// step's blur).
    pub energy: f64,
}

/// How a [`PoseFit`] starts: the initial pose and the optimiser's settings.
///
/// `FitSettings::default()` is the method's: the rest pose, learning rate 0.02, `λ` = 1e-7.
#[derive(Clone, Debug, PartialEq)]
pub struct FitSettings {
    /// The pose the descent starts from; `None` (the default) for the rest pose.
    /// [`PoseFit::run`] restarts from each of its hypotheses instead.
    pub initial: Option<Pose>,
    /// Adam's learning rate, > 0. Default 0.02 (radians per step, roughly, for joint offsets).
    pub learning_rate: f32,
    /// Self-intersection weight `λ` of `E = E_sl + λ·E_spt`, ≥ 0. Default 1e-7.
    ///
    /// `E_sl` is a mean over pixels: against a sum over the pixels of four 64² views, `λ` weighs
    /// 16,384 times less (1e-7 is 1.6 times the old 0.001 there).
    pub lambda: f32,
    /// The shape coefficients `β` the descent starts from, one per morph target of the model
    /// ([`SkinnedMesh::shape_count`]); empty (the default) for all zero.
    pub initial_shape: Vec<f32>,
}

impl Default for FitSettings {
    fn default() -> Self {
        FitSettings { initial: None, learning_rate: 0.02, lambda: 1e-7, initial_shape: Vec::new() }
    }
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
    /// The vertex subset the steps blurred by at least `proxy_min_blur` render
    /// ([`PoseFit::set_coarse_proxy`]); `None`: the whole mesh.
    proxy: Option<Proxy>,
    proxy_min_blur: f32,
    /// Blur as a fraction of the image height, one filter per view, and the blurred targets.
    blur: f32,
    blurs: Vec<GaussianBlur>,
    blurred_targets: Vec<Image>,
    /// `1 / (total pixel count of all views)`: makes `E_sl` a mean.
    pixel_weight: f64,
    /// Weight `μ` of the pose prior.
    pose_prior: f32,
    /// Multiple of `μ` in force for the current stage of [`PoseFit::run`] (1 outside a run;
    /// [`Stage::prior_scale`](super::Stage::prior_scale)).
    prior_scale: f32,
    /// Weight `ν` of the shape prior.
    shape_prior: f32,
    /// How many of `params` are the pose's (`3J + 6`, `6J + 6` with joint translations, `9J + 6`
    /// with joint scale factors: [`Pose::to_params`]); the shape coefficients follow.
    pose_len: usize,
    /// Whether the initial pose had joint translations (then they are fitted with the joints; a
    /// pose with scale factors alone has zero translations in its parameters, which stay zero).
    fits_joint_translations: bool,
    /// The shape a restart goes back to.
    initial_shape: Vec<f32>,
    /// Which parameters the steps may change ([`PoseFit::set_free`]): joint offsets, global
    /// orientation and translation.
    free: Free,
    /// The inflation `d` ([`PoseFit::set_inflation`]), its Adam and its step size (0: `d` is
    /// not fitted).
    inflation: f32,
    inflation_adam: Adam,
    inflation_rate: f32,
    /// The outline nuisance `a` ([`PoseFit::set_outline`]), its Adam and its step size (0: `a`
    /// is not fitted).
    outline: f32,
    outline_adam: Adam,
    outline_rate: f32,
    /// Steps between self-intersection checks ([`PoseFit::set_intersection_interval`]), the last
    /// check's result and the steps taken since it (`None`: check on the next step).
    intersection_interval: u32,
    intersection: Option<(SelfIntersection, u32)>,
}

/// Which groups of pose parameters a [`PoseFit`] changes; the others keep their values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Free {
    /// The joints' rotation offsets.
    pub joints: bool,
    /// The global orientation and the root translation.
    pub global: bool,
    /// The shape coefficients `β` (when the model has morph targets).
    pub shape: bool,
}

impl Default for Free {
    /// Everything free.
    fn default() -> Self {
        Free { joints: true, global: true, shape: true }
    }
}

impl PoseFit {
    /// The pose prior weight of the fitting method ([`PoseFit::set_pose_prior`]) in its
    /// unblurred stage: about the size of a converged fit's `E_sl` (~1e-4) for offsets of a
    /// fifth of a radian. The blurred stages weigh it [`Schedule::COARSE_PRIOR_SCALE`] times
    /// more ([`Stage::prior_scale`]).
    ///
    /// [`Schedule::COARSE_PRIOR_SCALE`]: super::Schedule::COARSE_PRIOR_SCALE
    /// [`Stage::prior_scale`]: super::Stage::prior_scale
    pub const POSE_PRIOR: f32 = 2e-3;

    /// The shape prior weight of the fitting method ([`PoseFit::set_shape_prior`]).
    pub const SHAPE_PRIOR: f32 = 1e-3;

    /// Starts a fit toward the `targets` (one per camera, each of the camera's size) from
    /// `settings.initial` (the rest pose when `None`), with Adam at `settings.learning_rate`
    /// and self-intersection weight `settings.lambda`. No blur and no pose prior until set
    /// ([`PoseFit::set_blur`], [`PoseFit::set_pose_prior`]; [`PoseFit::run`] sets the blur).
    /// Errors: a target count other than the cameras' ([`Error::ViewCountMismatch`]), a target of
    /// another size than its camera's ([`Error::SizeMismatch`]), a target pixel outside [0, 1] or
    /// a non-finite setting ([`Error::InvalidSettings`]), an invalid camera, initial pose or shape.
    ///
    /// The parameters fitted are the initial pose's: its joint translations, where it has them,
    /// are fitted with the joints' rotations; its joint scale factors ([`Pose::joint_scales`],
    /// e.g. of an animation's frame) are kept as they are, since a silhouette would rather
    /// thin a bone than turn it.
    ///
    /// ```
    /// use diffsil::pose::fit::{framing_cameras, FitSettings, PoseFit};
    /// use diffsil::pose::figure::builtin_figure;
    /// use diffsil::{RenderSettings, Renderer};
    ///
    /// let model = builtin_figure();
    /// let cameras = framing_cameras(&model.mesh, 2, 16);
    /// let mut renderer = Renderer::new(RenderSettings::default())?;
    /// let targets = renderer.render(&model.mesh, &cameras)?.images().to_vec();
    /// let settings = FitSettings { learning_rate: 0.01, ..FitSettings::default() };
    /// let fit = PoseFit::new(model, cameras, targets, renderer, settings)?;
    /// println!("{fit:?}");
    /// # Ok::<(), diffsil::Error>(())
    /// ```
    pub fn new(
        model: SkinnedMesh,
        cameras: Vec<Camera>,
        targets: Vec<Image>,
        renderer: Renderer,
        settings: FitSettings,
    ) -> Result<PoseFit> {
        let FitSettings { initial, learning_rate, lambda, initial_shape } = settings;
        let initial_shape = if initial_shape.is_empty() { vec![0.0; model.shape_count()] } else { initial_shape };
        model.morphs.check_betas(&initial_shape)?;
        let initial = initial.unwrap_or_else(|| Pose::rest(model.joint_count()));
        check_targets(&cameras, &targets)?;
        check_rate_and_lambda(learning_rate, lambda)?;
        initial.validate(model.joint_count())?;
        let checker = SelfIntersectionChecker::new(model.mesh.topology());
        let mesh = model.mesh.clone();
        let pixels: f64 = targets.iter().map(|t| f64::from(t.width()) * f64::from(t.height())).sum();
        let mut params = initial.to_params();
        let pose_len = params.len();
        let fits_joint_translations = initial.has_joint_translations();
        params.extend_from_slice(&initial_shape);
        Ok(PoseFit {
            params,
            pose_len,
            fits_joint_translations,
            initial_shape,
            shape_prior: 0.0,
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
            proxy: None,
            proxy_min_blur: 0.0,
            blur: 0.0,
            pixel_weight: if pixels > 0.0 { 1.0 / pixels } else { 1.0 },
            pose_prior: 0.0,
            prior_scale: 1.0,
            free: Free::default(),
            inflation: 0.0,
            inflation_adam: Adam::new(1.0),
            inflation_rate: 0.0,
            outline: 0.0,
            outline_adam: Adam::new(1.0),
            outline_rate: 0.0,
            intersection_interval: 1,
            intersection: None,
        })
    }

    /// Chooses which parameters the steps change (all by default); a frozen group keeps its
    /// current values exactly (its gradient entries are zeroed before Adam sees them, and its
    /// values restored after the step).
    pub fn set_free(&mut self, free: Free) {
        self.free = free;
    }

    /// Which parameters the steps change.
    pub fn free(&self) -> Free {
        self.free
    }

    /// The model being fitted.
    pub fn model(&self) -> &SkinnedMesh {
        &self.model
    }

    /// The target silhouettes, one per camera.
    pub fn targets(&self) -> &[Image] {
        &self.targets
    }

    /// The current pose.
    pub fn pose(&self) -> Pose {
        Pose::from_params(&self.params[..self.pose_len], self.model.joint_count())
            .expect("parameters keep their length")
    }

    /// The current shape coefficients `β` (empty without morph targets).
    pub fn shape(&self) -> &[f32] {
        &self.params[self.pose_len..]
    }

    /// The model's vertices at the current pose.
    pub fn vertices(&self) -> Result<Vec<Vec3>> {
        self.model.skin_shaped(&self.pose(), self.shape())
    }

    /// Renders the current pose in every view (inflated by [`PoseFit::inflation`] and outlined
    /// by [`PoseFit::outline`], as `E_sl` sees it).
    pub fn render(&mut self) -> Result<Vec<Image>> {
        let vertices = self.vertices()?;
        self.set_rendered_positions(&vertices)?;
        let frame = self.renderer.render(&self.mesh, &self.cameras)?;
        Ok(self.outlined(frame.images()))
    }

    /// `images` (renders of the current pose, not outlined) as `E_sl` sees them: outlined by
    /// [`PoseFit::outline`] when the fit has one.
    pub(in crate::pose::fit) fn outlined(&self, images: &[Image]) -> Vec<Image> {
        match self.outline_setting() {
            Some(a) => images.iter().map(|r| outline::apply(r, a).image).collect(),
            None => images.to_vec(),
        }
    }

    /// The renderer (to ask for its backend name).
    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// Adam's learning rate.
    pub fn learning_rate(&self) -> f32 {
        self.adam.learning_rate
    }

    /// Sets Adam's learning rate (a positive number).
    pub fn set_learning_rate(&mut self, learning_rate: f32) -> Result<()> {
        if !(learning_rate.is_finite() && learning_rate > 0.0) {
            return Err(Error::InvalidSettings(format!("need a positive learning rate, got {learning_rate}")));
        }
        self.adam.learning_rate = learning_rate;
        Ok(())
    }

    /// Checks for self-intersection only every `interval`-th step (≥ 1; 1, the default, checks
    /// every step): the steps in between add the gradient of the last check's surrogate, held
    /// for the vertices they have moved to, and report its penalty and surrogate. The check (a
    /// BVH refit and self-traversal of the whole mesh) is a large share of a step's work on a
    /// body of several thousand triangles, while the surrogate's gradient changes slowly from
    /// one step to the next (the body moves a few millimetres). A restart checks again on the
    /// next step; [`PoseFit::set_state`] restores the check the state was taken with (each
    /// hypothesis keeps its own). Errors on 0.
    pub fn set_intersection_interval(&mut self, interval: u32) -> Result<()> {
        check_intersection_interval(interval)?;
        self.intersection_interval = interval;
        Ok(())
    }

    /// Steps between self-intersection checks ([`PoseFit::set_intersection_interval`]).
    pub fn intersection_interval(&self) -> u32 {
        self.intersection_interval
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
        check_blur("blur", fraction)?;
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
        Ok(self.energy_and_renders()?.0)
    }

    /// [`PoseFit::energy`] and the renders it was computed from (not outlined; see
    /// [`PoseFit::outlined`]), from one render.
    pub(in crate::pose::fit) fn energy_and_renders(&mut self) -> Result<(f64, Vec<Image>)> {
        let vertices = self.vertices()?;
        self.set_rendered_positions(&vertices)?;
        let frame = self.renderer.render(&self.mesh, &self.cameras)?;
        let surrogate = if self.lambda > 0.0 { self.checker.check(&vertices)?.surrogate } else { 0.0 };
        Ok((self.energy_of(frame.images(), surrogate)?, frame.images().to_vec()))
    }

    /// [`PoseFit::energy`] at the current state from its renders (`images`, not outlined) and its
    /// self-intersection surrogate (also used by the hypotheses' batch, `hypotheses.rs`).
    fn energy_of(&self, images: &[Image], surrogate: f64) -> Result<f64> {
        let (silhouette, _) = match self.outline_setting() {
            Some(a) => {
                let outlined: Vec<Image> = images.iter().map(|r| outline::apply(r, a).image).collect();
                loss::squared_error_views(&outlined, &self.targets)?
            }
            None => loss::squared_error_views(images, &self.targets)?,
        };
        let prior = self.prior_energy();
        Ok(silhouette * self.pixel_weight
            + f64::from(self.lambda) * surrogate
            + f64::from(self.pose_prior_weight()) * prior
            + f64::from(self.shape_prior) * self.shape_energy())
    }

    /// One gradient step; returns the energies at the pose before the step.
    pub fn step(&mut self) -> Result<StepReport> {
        self.step_with(None, None)
    }

    /// Whether the next step checks for self-intersection: `λ > 0` and the last check is
    /// `intersection_interval` steps old or missing.
    fn check_due(&self) -> bool {
        self.lambda > 0.0 && !matches!(&self.intersection, Some((_, age)) if *age < self.intersection_interval)
    }

    /// [`PoseFit::step`], with `E_sl`, its vertex gradient at the rendered vertices and
    /// `∂E_sl/∂a` (the outline) already computed when `pass` is given, and the self-intersection
    /// check when `checked` is given and [`PoseFit::check_due`] (the hypotheses' batch,
    /// `hypotheses.rs`, which runs them beside its render).
    fn step_with(
        &mut self,
        pass: Option<(f64, Vec<Vec3>, f64)>,
        checked: Option<SelfIntersection>,
    ) -> Result<StepReport> {
        let pose = self.pose();
        let (vertices, cache) = self.model.skin_shaped_with_cache(&pose, self.shape())?;
        let normals = self.set_rendered_positions(&vertices)?;
        // The self-intersection check is single-threaded and independent of the images: it runs
        // beside the render + backward. It sees the skinned vertices, without inflation.
        // Every `intersection_interval`-th step checks; the steps between reuse that check's
        // surrogate and gradient (see `set_intersection_interval`).
        let lambda = self.lambda;
        let stale = match &mut self.intersection {
            Some((_, age)) if *age < self.intersection_interval => {
                *age += 1;
                true
            }
            _ => false,
        };
        let check = lambda > 0.0 && !stale;
        let outline = self.outline_setting();
        let proxy_mesh = match (&pass, self.active_proxy()) {
            (None, Some(proxy)) => Some(proxy.mesh(self.mesh.positions())?),
            _ => None,
        };
        // A blurred step with a proxy checks the proxy for self-intersection.
        let use_proxy = self.proxy_in_use();
        let proxy = self.proxy.as_mut().filter(|_| use_proxy);
        let checker = &mut self.checker;
        let (renderer, mesh, cameras) = (&mut self.renderer, proxy_mesh.as_ref().unwrap_or(&self.mesh), &self.cameras);
        let (targets, blurs, pixel_weight) = (&self.blurred_targets, &self.blurs, self.pixel_weight);
        let (silhouette_pass, intersection) = rayon::join(
            || match pass {
                Some(pass) => Ok(pass),
                None => silhouette_pass(renderer, mesh, cameras, targets, blurs, pixel_weight, outline),
            },
            || match (check, checked) {
                (false, _) => Ok(None),
                (true, Some(result)) => Ok(Some(result)),
                (true, None) => check_self_intersection(proxy, checker, &vertices).map(Some),
            },
        );
        let (silhouette, d_vertices, d_outline) = silhouette_pass?;
        // A blurred step with a proxy rendered its vertex subset (here, or in the hypotheses'
        // batch): the other vertices' gradient is zero.
        let mut d_vertices = match self.active_proxy() {
            Some(proxy) => proxy.scatter(&d_vertices),
            None => d_vertices,
        };
        // With the normals held constant, ∂v'_i/∂v_i is the identity: the rendered vertices'
        // gradient is the skinned vertices'.
        let d_inflation = match (&normals, self.inflation_rate > 0.0) {
            (Some(normals), true) => Some(inflation::gradient(&d_vertices, normals)),
            _ => None,
        };
        if let Some(result) = intersection? {
            self.intersection = Some((result, 1));
        }
        let (penalty, surrogate) = match &self.intersection {
            Some((result, _)) if lambda > 0.0 => {
                for (g, s) in d_vertices.iter_mut().zip(&result.grad) {
                    *g += lambda * *s;
                }
                (result.penalty, result.surrogate)
            }
            _ => (0.0, 0.0),
        };
        let (d_pose, d_shape) = self.model.backward_with_shape(&cache, &d_vertices)?;
        let mut grads = d_pose.to_params();
        grads.extend_from_slice(&d_shape);
        let prior = self.prior_energy();
        let shape_prior = self.shape_energy();
        self.add_prior_gradient(&mut grads);
        let shapes = self.params.len() - self.pose_len;
        if self.shape_prior > 0.0 && shapes > 0 {
            let scale = 2.0 * self.shape_prior / shapes as f32;
            for (g, &b) in grads[self.pose_len..].iter_mut().zip(&self.params[self.pose_len..]) {
                *g += scale * b;
            }
        }
        let joints = 3 * self.model.joint_count();
        let mut frozen = Vec::new();
        if !self.free.joints {
            // Rotation offsets, and the joint translations when the pose has them.
            frozen.extend([0..joints, joints + 6..self.pose_len]);
        }
        if !self.free.global {
            frozen.push(joints..joints + 6);
        }
        if self.pose_len == Pose::parameter_count_with_scales(self.model.joint_count()) {
            // The initial pose's scale factors, and the zero translations beside them where it
            // had none, are kept (see `PoseFit::new`).
            frozen.push(2 * joints + 6..self.pose_len);
            if !self.fits_joint_translations {
                frozen.push(joints + 6..2 * joints + 6);
            }
        }
        if !self.free.shape {
            frozen.push(self.pose_len..self.params.len());
        }
        let kept: Vec<Vec<f32>> = frozen.iter().map(|r| self.params[r.clone()].to_vec()).collect();
        for r in &frozen {
            grads[r.clone()].fill(0.0);
        }
        self.adam.step(&mut self.params, &grads)?;
        if let Some(g) = d_inflation {
            let mut d = [self.inflation];
            self.inflation_adam.step(&mut d, &[g as f32])?;
            self.inflation = d[0];
        }
        if self.outline_rate > 0.0 {
            let mut a = [self.outline];
            self.outline_adam.step(&mut a, &[d_outline as f32])?;
            self.outline = a[0].clamp(-1.0, 1.0);
        }
        // Adam's moments from before a group was frozen would still move it: put it back.
        for (r, values) in frozen.iter().zip(kept) {
            self.params[r.clone()].copy_from_slice(&values);
        }
        Ok(StepReport {
            silhouette,
            self_intersection: penalty,
            self_intersection_surrogate: surrogate,
            pose_prior: prior,
            shape_prior,
            energy: silhouette
                + f64::from(lambda) * surrogate
                + f64::from(self.pose_prior_weight()) * prior
                + f64::from(self.shape_prior) * shape_prior,
        })
    }
}

impl std::fmt::Debug for PoseFit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let sizes: Vec<(u32, u32)> = self.cameras.iter().map(|c| (c.width, c.height)).collect();
        f.debug_struct("PoseFit")
            .field("joints", &self.model.joint_count())
            .field("vertices", &self.model.vertex_count())
            .field("views", &sizes)
            .field("backend", &self.renderer.backend_name())
            .field("learning_rate", &self.adam.learning_rate)
            .field("lambda", &self.lambda)
            .field("pose_prior", &self.pose_prior)
            .field("prior_scale", &self.prior_scale)
            .field("blur", &self.blur)
            .field("inflation", &self.inflation)
            .field("inflation_rate", &self.inflation_rate)
            .finish_non_exhaustive()
    }
}
