//! Adam (Kingma & Ba), the optimiser of the paper (β1 = 0.9, β2 = 0.999).

/// Adam over a flat parameter vector.
#[derive(Clone, Debug)]
pub struct Adam {
    /// Learning rate.
    pub learning_rate: f32,
    /// Decay of the first-moment estimate.
    pub beta1: f32,
    /// Decay of the second-moment estimate.
    pub beta2: f32,
    /// Added to the denominator for stability.
    pub epsilon: f32,
    // The moments in f64: a gradient of 1e38 squares to 1e76, beyond f32.
    m: Vec<f64>,
    v: Vec<f64>,
    t: u32,
}

impl Adam {
    /// Adam with the paper's β1 = 0.9, β2 = 0.999 and ε = 1e-8.
    pub fn new(learning_rate: f32) -> Adam {
        Adam { learning_rate, beta1: 0.9, beta2: 0.999, epsilon: 1e-8, m: Vec::new(), v: Vec::new(), t: 0 }
    }

    /// Checks the hyperparameters: a learning rate and ε that are finite and positive, and decays
    /// in [0, 1). [`Adam::step`] calls it first, so `Adam::new(f32::NAN)` fails on its first step
    /// instead of turning the parameters into NaN.
    pub fn validate(&self) -> crate::Result<()> {
        let invalid = |name: &str, value: f32, need: &str| {
            Err(crate::Error::InvalidSettings(format!("Adam {name} is {value}: it must be {need}")))
        };
        if !(self.learning_rate.is_finite() && self.learning_rate > 0.0) {
            return invalid("learning_rate", self.learning_rate, "a finite number > 0, e.g. 0.01");
        }
        if !(self.epsilon.is_finite() && self.epsilon > 0.0) {
            return invalid("epsilon", self.epsilon, "a finite number > 0, e.g. 1e-8");
        }
        for (name, beta) in [("beta1", self.beta1), ("beta2", self.beta2)] {
            if !(0.0..1.0).contains(&beta) {
                return invalid(name, beta, "in [0, 1), e.g. 0.9 or 0.999");
            }
        }
        Ok(())
    }

    /// One step: `params -= lr · (m̂ / (√v̂ + ε))`, the ratio first (it is at most about
    /// `1/(1 − β1)` in size, so a huge learning rate cannot overflow it), with the moments kept in
    /// f64. The state resets if the parameter count changes. Non-finite gradient entries are
    /// treated as zero, so a bad gradient never poisons the state.
    ///
    /// Errors: [`crate::Error::LengthMismatch`] when the two slices differ in length;
    /// [`crate::Error::InvalidSettings`] for invalid hyperparameters ([`Adam::validate`]) or when a
    /// parameter would leave the f32 range (lower the learning rate); the parameters and the
    /// state are then left unchanged.
    pub fn step(&mut self, params: &mut [f32], grads: &[f32]) -> crate::Result<()> {
        if params.len() != grads.len() {
            return Err(crate::Error::LengthMismatch {
                what: "Adam gradients",
                expected: params.len(),
                got: grads.len(),
            });
        }
        self.validate()?;
        let (mut m, mut v, t) = if self.m.len() == params.len() {
            (self.m.clone(), self.v.clone(), self.t.saturating_add(1))
        } else {
            (vec![0.0; params.len()], vec![0.0; params.len()], 1)
        };
        let (beta1, beta2) = (f64::from(self.beta1), f64::from(self.beta2));
        let c1 = 1.0 - beta1.powi(t.min(i32::MAX as u32) as i32);
        let c2 = 1.0 - beta2.powi(t.min(i32::MAX as u32) as i32);
        let (lr, epsilon) = (f64::from(self.learning_rate), f64::from(self.epsilon));
        let mut updated = params.to_vec();
        for (i, ((p, &g), (m, v))) in updated.iter_mut().zip(grads).zip(m.iter_mut().zip(v.iter_mut())).enumerate() {
            let g = if g.is_finite() { f64::from(g) } else { 0.0 };
            *m = beta1 * *m + (1.0 - beta1) * g;
            *v = beta2 * *v + (1.0 - beta2) * g * g;
            let ratio = (*m / c1) / ((*v / c2).sqrt() + epsilon);
            let next = (f64::from(*p) - lr * ratio) as f32;
            if !next.is_finite() {
                return Err(crate::Error::InvalidSettings(format!(
                    "Adam step: parameter {i} would move from {p} to {next} (learning rate {lr}): lower the \
                     learning rate"
                )));
            }
            *p = next;
        }
        params.copy_from_slice(&updated);
        (self.m, self.v, self.t) = (m, v, t);
        Ok(())
    }

    /// Number of steps taken.
    pub fn steps(&self) -> u32 {
        self.t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimises_a_quadratic() {
        let mut x = vec![3.0f32, -2.0];
        let mut adam = Adam::new(0.1);
        for _ in 0..500 {
            let g: Vec<f32> = x.iter().map(|v| 2.0 * v).collect();
            adam.step(&mut x, &g).unwrap();
        }
        assert!(x.iter().all(|v| v.abs() < 1e-2), "{x:?}");
    }

    #[test]
    fn huge_learning_rates_and_gradients_stay_finite() {
        let mut x = vec![1.0f32, -1.0];
        let mut adam = Adam::new(1e30);
        for _ in 0..5 {
            adam.step(&mut x, &[1e38, -3e38]).unwrap();
        }
        assert!(x.iter().all(|v| v.is_finite()), "{x:?}");
        // lr · m̂ (1e30 · 1e38) is beyond f32; the ratio first is not.
        assert!(x[0] < -1e30 && x[1] > 1e30, "{x:?}");
    }

    #[test]
    fn invalid_hyperparameters_are_rejected_without_touching_the_parameters() {
        for lr in [f32::NAN, f32::INFINITY, 0.0, -1.0] {
            let mut x = vec![1.0f32];
            let e = Adam::new(lr).step(&mut x, &[1.0]).unwrap_err().to_string();
            assert!(e.contains("learning_rate") && e.contains("> 0"), "{e}");
            assert_eq!(x, [1.0]);
        }
        let mut adam = Adam::new(0.1);
        adam.beta1 = 1.0;
        assert!(adam.step(&mut [1.0], &[1.0]).unwrap_err().to_string().contains("beta1"));
        let mut adam = Adam::new(3e38);
        let mut x = vec![3e38f32];
        let e = adam.step(&mut x, &[-1.0]).unwrap_err().to_string();
        assert!(e.contains("parameter 0") && e.contains("lower the learning rate"), "{e}");
        assert_eq!(x, [3e38]);
    }

    #[test]
    fn first_step_moves_by_the_learning_rate() {
        let mut x = vec![1.0f32];
        Adam::new(0.01).step(&mut x, &[5.0]).unwrap();
        assert!(Adam::new(0.01).step(&mut x, &[1.0, 2.0]).is_err());
        assert!((x[0] - 0.99).abs() < 1e-6);
    }
}
