//! The nuisances of a [`PoseFit`]: the inflation `d` (the rendered vertices moved along their
//! normals) and the outline `a` (each render grown or shrunk by up to one pixel), their settings
//! and gradients, and the rendered vertices they act on. A child of `descent.rs`, in its own
//! file.

use glam::Vec3;

use super::super::inflation;
use super::{silhouette_pass, PoseFit};
use crate::optim::Adam;
use crate::{Error, Result};

impl PoseFit {
    /// The inflation `d` (world units): `E_sl` compares the silhouettes of the skinned vertices
    /// moved along their normals, `v_i + d·n_i` (`n_i` the unit area-weighted vertex normals of
    /// the posed mesh, [`vertex_normals`](crate::pose::fit::vertex_normals)). [`PoseFit::pose`] and
    /// [`PoseFit::vertices`] never include it; the self-intersection term and the priors do not see it.
    pub fn inflation(&self) -> f32 {
        self.inflation
    }

    /// Sets the inflation `d` (world units; see [`PoseFit::inflation`]). Errors on a non-finite
    /// value.
    pub fn set_inflation(&mut self, d: f32) -> Result<()> {
        if !d.is_finite() {
            return Err(Error::InvalidSettings(format!("inflation {d}: need a finite number")));
        }
        self.inflation = d;
        Ok(())
    }

    /// How far a step may move the inflation `d`: its own Adam's learning rate, in world units
    /// (Adam steps are about this size). 0 (the default) does not fit `d`, which then stays
    /// where it is (0 unless set): the fit is then exactly the one without inflation. With a
    /// positive rate each step also descends `∂E/∂d = Σ_i ∂E_sl/∂v_i · n_i`, the normals held
    /// constant within the step, so that a mask uniformly too fat or too thin is explained by
    /// `d` rather than by twisting the pose. Errors on a negative or non-finite rate.
    pub fn set_inflation_rate(&mut self, rate: f32) -> Result<()> {
        set_rate("inflation", rate, &mut self.inflation_rate, &mut self.inflation_adam)
    }

    /// The inflation step size (0: `d` is not fitted).
    pub fn inflation_rate(&self) -> f32 {
        self.inflation_rate
    }

    /// `∂E_sl/∂d` at the current pose, shape and inflation, with the current blur (what a step
    /// descends).
    pub fn inflation_gradient(&mut self) -> Result<f64> {
        let vertices = self.vertices()?;
        let normals = self.normals(&vertices);
        self.mesh.set_positions(&inflation::inflate(&vertices, &normals, self.inflation))?;
        let (_, d_vertices, _) = self.silhouette_pass()?;
        Ok(inflation::gradient(&d_vertices, &normals))
    }

    /// The unit vertex normals of the mesh at `vertices`.
    pub(super) fn normals(&self, vertices: &[Vec3]) -> Vec<Vec3> {
        inflation::vertex_normals(vertices, self.mesh.triangles())
    }

    /// Puts `vertices` inflated by `d` into the rendered mesh; returns the normals when they
    /// were needed (`d` ≠ 0 or fitted).
    pub(super) fn set_rendered_positions(&mut self, vertices: &[Vec3]) -> Result<Option<Vec<Vec3>>> {
        if self.inflation == 0.0 && self.inflation_rate == 0.0 {
            self.mesh.set_positions(vertices)?;
            return Ok(None);
        }
        let normals = self.normals(vertices);
        self.mesh.set_positions(&inflation::inflate(vertices, &normals, self.inflation))?;
        Ok(Some(normals))
    }

    /// Renders the rendered mesh, `E_sl` against the blurred targets (a mean over pixels) and its
    /// gradient with respect to the rendered vertices.
    pub(super) fn silhouette_pass(&mut self) -> Result<(f64, Vec<Vec3>, f64)> {
        let outline = self.outline_setting();
        silhouette_pass(
            &mut self.renderer,
            &self.mesh,
            &self.cameras,
            &self.blurred_targets,
            &self.blurs,
            self.pixel_weight,
            outline,
        )
    }

    /// The outline nuisance `a` when it is applied (`a` ≠ 0 or fitted).
    pub(in crate::pose::fit) fn outline_setting(&self) -> Option<f32> {
        (self.outline != 0.0 || self.outline_rate > 0.0).then_some(self.outline)
    }

    /// The outline nuisance `a` in [−1, 1]: `E_sl` compares each rendered silhouette grown
    /// (`a > 0`) or shrunk (`a < 0`) by `|a|` of a one-pixel grey-scale dilation or erosion
    /// (the 3×3 maximum or minimum of the coverage blended in by `|a|`) with its target, so
    /// that masks up to one pixel too fat or too thin, thin limbs erased included, are
    /// explained by `a` rather than by the pose. [`PoseFit::pose`] and [`PoseFit::vertices`]
    /// never include it ([`PoseFit::render`] does). 0 unless set or fitted.
    pub fn outline(&self) -> f32 {
        self.outline
    }

    /// Sets the outline nuisance `a` ([`PoseFit::outline`]). Errors outside [−1, 1].
    pub fn set_outline(&mut self, a: f32) -> Result<()> {
        if !(a.is_finite() && (-1.0..=1.0).contains(&a)) {
            return Err(Error::InvalidSettings(format!("outline {a}: need a number in [-1, 1]")));
        }
        self.outline = a;
        Ok(())
    }

    /// The step size of the outline `a` (its own Adam's learning rate; 0, the default, does not
    /// fit it). Each step then also descends `∂E_sl/∂a`, and `a` is kept in [−1, 1]. Errors on a
    /// negative or non-finite rate.
    pub fn set_outline_rate(&mut self, rate: f32) -> Result<()> {
        set_rate("outline", rate, &mut self.outline_rate, &mut self.outline_adam)
    }

    /// The outline step size (0: `a` is not fitted).
    pub fn outline_rate(&self) -> f32 {
        self.outline_rate
    }

    /// `∂E_sl/∂a` at the current pose, shape, inflation and outline, with the current blur
    /// (what a step descends; one-sided at `a = 0`, the growing side's).
    pub fn outline_gradient(&mut self) -> Result<f64> {
        let vertices = self.vertices()?;
        self.set_rendered_positions(&vertices)?;
        let outline = Some(self.outline);
        let (_, _, d_outline) = silhouette_pass(
            &mut self.renderer,
            &self.mesh,
            &self.cameras,
            &self.blurred_targets,
            &self.blurs,
            self.pixel_weight,
            outline,
        )?;
        Ok(d_outline)
    }
}

/// Sets a nuisance's step size (`what` names it in the error): stores `rate` and, when it is
/// positive, makes it the nuisance's own Adam learning rate (0 leaves the nuisance unfitted).
/// Errors on a negative or non-finite rate.
fn set_rate(what: &str, rate: f32, slot: &mut f32, adam: &mut Adam) -> Result<()> {
    if !(rate.is_finite() && rate >= 0.0) {
        return Err(Error::InvalidSettings(format!("need a non-negative {what} rate, got {rate}")));
    }
    *slot = rate;
    if rate > 0.0 {
        adam.learning_rate = rate;
    }
    Ok(())
}
