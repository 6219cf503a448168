//! The hypothesis phase of [`PoseFit::run`]: every starting pose takes the same steps, in
//! lock-step, and each step renders and differentiates all of them as one batch
//! ([`crate::Renderer::render_batch`], [`crate::Renderer::backward_batch`]): on the GPU one
//! submission for the forward of every view of every hypothesis (and one for the backward)
//! instead of one per hypothesis; on the CPU the hypotheses run side by side.
//!
//! Each hypothesis keeps its own optimiser state (its Adam moments, nuisances and last
//! self-intersection check) and goes through the same
//! arithmetic as [`PoseFit::step`] (the batch returns the bits of separate calls; the
//! self-intersection check sorts its pairs, so it does not depend on which pose it saw before),
//! so the phase's results are those of running the hypotheses one after the other, bit for bit.
//! The self-intersection checks that a step has due (one thread, one hypothesis after the other)
//! run beside the batch's render and backward, as a single step runs its own check beside its
//! render; run inside each hypothesis's step, after the batch, they left the other core idle.
//! Their final energies are rendered as one batch too, with the self-intersection checks beside
//! the render.

use glam::Vec3;

use super::{check_self_intersection, silhouette_loss, FitState, PoseFit, StepReport};
use crate::pose::self_intersection::SelfIntersection;
use crate::pose::skin::Pose;
use crate::{Image, Instance, Mesh, Result};

/// One hypothesis after the phase.
pub(in crate::pose::fit) struct Hypothesis {
    /// Each step's report and the state after it.
    pub steps: Vec<(StepReport, FitState)>,
    /// The state at the end of the phase.
    pub state: FitState,
    /// The energy there ([`PoseFit::energy`], unblurred).
    pub energy: f64,
}

impl PoseFit {
    /// Restarts from each of `starts`, sets the blur to `blur` and takes `steps` steps from each,
    /// in lock-step, one batch per step; returns each hypothesis's steps, final state and energy.
    /// The fit is left at the last hypothesis's final state.
    pub(in crate::pose::fit) fn run_hypotheses(
        &mut self,
        starts: &[Pose],
        blur: f32,
        steps: u32,
    ) -> Result<Vec<Hypothesis>> {
        let mut states = Vec::with_capacity(starts.len());
        for start in starts {
            self.restart(start)?;
            states.push(self.state());
        }
        self.run_states(states, blur, steps)
    }

    /// [`PoseFit::run_hypotheses`] from given states (their Adam moments and nuisances kept)
    /// instead of fresh starts: the limb swap test (`swap.rs`) refines its candidates with it.
    pub(in crate::pose::fit) fn run_states(
        &mut self,
        mut states: Vec<FitState>,
        blur: f32,
        steps: u32,
    ) -> Result<Vec<Hypothesis>> {
        self.set_blur(blur)?;
        let mut traces: Vec<Vec<(StepReport, FitState)>> = states.iter().map(|_| Vec::new()).collect();
        for _ in 0..steps {
            // Every hypothesis's rendered vertices and outline, as its step computes them, and
            // its skinned vertices where its step checks for self-intersection.
            let mut meshes = Vec::with_capacity(states.len());
            let mut outlines = Vec::with_capacity(states.len());
            let mut checks = Vec::with_capacity(states.len());
            for state in &states {
                self.set_state(state.clone())?;
                let (vertices, _) = self.model.skin_shaped_with_cache(&self.pose(), self.shape())?;
                self.set_rendered_positions(&vertices)?;
                meshes.push(self.rendered_mesh()?);
                outlines.push(self.outline_setting());
                checks.push(self.check_due().then_some(vertices));
            }
            let (passes, checked) = self.silhouette_passes(&meshes, &outlines, &checks)?;
            for (((state, trace), pass), checked) in states.iter_mut().zip(&mut traces).zip(passes).zip(checked) {
                self.set_state(state.clone())?;
                let report = self.step_with(Some(pass), checked)?;
                *state = self.state();
                trace.push((report, state.clone()));
            }
        }
        let energies = self.energies(&states)?;
        Ok(states
            .into_iter()
            .zip(traces)
            .zip(energies)
            .map(|((state, steps), energy)| Hypothesis { steps, state, energy })
            .collect())
    }

    /// [`PoseFit::energy`] at each of `states`, their renders in one batch and their
    /// self-intersection checks beside it (the same bits as one call per state). The fit is
    /// left at the last state.
    pub(in crate::pose::fit) fn energies(&mut self, states: &[FitState]) -> Result<Vec<f64>> {
        if states.is_empty() {
            return Ok(Vec::new());
        }
        let mut meshes = Vec::with_capacity(states.len());
        let mut vertices = Vec::with_capacity(states.len());
        for state in states {
            self.set_state(state.clone())?;
            let v = self.vertices()?;
            self.set_rendered_positions(&v)?;
            meshes.push(self.mesh.clone());
            vertices.push(v);
        }
        let lambda = self.lambda;
        let (renderer, checker, cameras) = (&mut self.renderer, &mut self.checker, &self.cameras);
        let (frame, surrogates) = rayon::join(
            || {
                let instances: Vec<Instance<'_>> = meshes.iter().map(|mesh| Instance { mesh, cameras }).collect();
                renderer.render_batch(&instances)
            },
            || {
                let check = |v: &Vec<Vec3>| if lambda > 0.0 { checker.check(v).map(|r| r.surrogate) } else { Ok(0.0) };
                vertices.iter().map(check).collect::<Result<Vec<f64>>>()
            },
        );
        let (frame, surrogates) = (frame?, surrogates?);
        let mut energies = Vec::with_capacity(states.len());
        for (k, (state, surrogate)) in states.iter().zip(surrogates).enumerate() {
            self.set_state(state.clone())?;
            energies.push(self.energy_of(frame.images(k), surrogate)?);
        }
        Ok(energies)
    }

    /// `E_sl`, its gradient at the rendered vertices and `∂E_sl/∂a` for each of `meshes` (the
    /// rendered mesh of each hypothesis, compared with its outline nuisance), one batch; beside
    /// it, on one thread, the self-intersection check of each skinned mesh in `checks` (`None`:
    /// no check due), in order (the same bits as in each step).
    #[allow(clippy::type_complexity)]
    fn silhouette_passes(
        &mut self,
        meshes: &[Mesh],
        outlines: &[Option<f32>],
        checks: &[Option<Vec<Vec3>>],
    ) -> Result<(Vec<(f64, Vec<Vec3>, f64)>, Vec<Option<SelfIntersection>>)> {
        let use_proxy = self.proxy_in_use();
        let mut proxy = self.proxy.as_mut().filter(|_| use_proxy);
        let (renderer, checker, cameras) = (&mut self.renderer, &mut self.checker, &self.cameras);
        let (targets, blurs, pixel_weight) = (&self.blurred_targets, &self.blurs, self.pixel_weight);
        let mut check = move |v: &Vec<Vec3>| check_self_intersection(proxy.as_deref_mut(), checker, v);
        let (passes, checked) = rayon::join(
            || -> Result<Vec<(f64, Vec<Vec3>, f64)>> {
                let instances: Vec<Instance<'_>> = meshes.iter().map(|mesh| Instance { mesh, cameras }).collect();
                let frame = renderer.render_batch(&instances)?;
                let mut losses = Vec::with_capacity(meshes.len());
                let mut d_images: Vec<Vec<Image>> = Vec::with_capacity(meshes.len());
                for (k, outline) in outlines.iter().enumerate() {
                    let (loss, d, d_outline) =
                        silhouette_loss(frame.images(k), targets, blurs, pixel_weight, *outline)?;
                    losses.push((loss, d_outline));
                    d_images.push(d);
                }
                let grads = renderer.backward_batch(&frame, &d_images)?;
                Ok(losses.into_iter().zip(grads).map(|((loss, d_outline), grad)| (loss, grad, d_outline)).collect())
            },
            || checks.iter().map(|v| v.as_ref().map(&mut check).transpose()).collect::<Result<Vec<_>>>(),
        );
        Ok((passes?, checked?))
    }
}
