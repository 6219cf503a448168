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
    m: Vec<f32>,
    v: Vec<f32>,
    t: u32,
}

impl Adam {
    /// Adam with the paper's β1 = 0.9, β2 = 0.999 and ε = 1e-8.
    pub fn new(learning_rate: f32) -> Adam {
        Adam { learning_rate, beta1: 0.9, beta2: 0.999, epsilon: 1e-8, m: Vec::new(), v: Vec::new(), t: 0 }
    }

    /// One step: `params -= lr · m̂ / (√v̂ + ε)`. The state resets if the parameter count changes.
    /// Non-finite gradient entries are treated as zero, so a bad gradient never poisons the state.
    /// Errors when the two slices differ in length.
    pub fn step(&mut self, params: &mut [f32], grads: &[f32]) -> crate::Result<()> {
        if params.len() != grads.len() {
            return Err(crate::Error::LengthMismatch {
                what: "Adam gradients",
                expected: params.len(),
                got: grads.len(),
            });
        }
        if self.m.len() != params.len() {
            self.m = vec![0.0; params.len()];
            self.v = vec![0.0; params.len()];
            self.t = 0;
        }
        self.t += 1;
        let c1 = 1.0 - self.beta1.powi(self.t as i32);
        let c2 = 1.0 - self.beta2.powi(self.t as i32);
        for ((p, &g), (m, v)) in params.iter_mut().zip(grads).zip(self.m.iter_mut().zip(self.v.iter_mut())) {
            let g = if g.is_finite() { g } else { 0.0 };
            *m = self.beta1 * *m + (1.0 - self.beta1) * g;
            *v = self.beta2 * *v + (1.0 - self.beta2) * g * g;
            *p -= self.learning_rate * (*m / c1) / ((*v / c2).sqrt() + self.epsilon);
        }
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
    fn first_step_moves_by_the_learning_rate() {
        let mut x = vec![1.0f32];
        Adam::new(0.01).step(&mut x, &[5.0]).unwrap();
        assert!(Adam::new(0.01).step(&mut x, &[1.0, 2.0]).is_err());
        assert!((x[0] - 0.99).abs() < 1e-6);
    }
}
