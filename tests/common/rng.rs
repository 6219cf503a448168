//! The tests' random numbers, in one place. Two streams, because tolerances and chosen cases were
//! tuned on them: [`SplitMix64`] (the crate's own `diffsil::random::SplitMix64`, seeded with its
//! raw state) and [`Rng`] (xorshift64*, the finite-difference checks' generator). [`Draws`] gives
//! both the same f64 draws.

use glam::DVec3;

pub use diffsil::random::SplitMix64;

/// Draws on top of 64 random bits. The names differ from `SplitMix64`'s own f32 `uniform` and
/// `range`, which would otherwise win method resolution.
pub trait Draws {
    /// The next 64 random bits.
    fn bits(&mut self) -> u64;

    /// Uniform in `[0, 1)`, 53 bits.
    fn unit(&mut self) -> f64 {
        (self.bits() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[lo, hi)`.
    fn range_f64(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform in `0..n` (up to modulo bias).
    fn below(&mut self, n: usize) -> usize {
        (self.bits() % n as u64) as usize
    }

    /// Uniform in `[-1, 1)`, 24 bits, as f32.
    fn signed_f32(&mut self) -> f32 {
        ((self.bits() >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    }

    /// A random unit vector: a cube sample of length in `(0.1, 1]`, normalised.
    fn unit_dvec3(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.range_f64(-1.0, 1.0), self.range_f64(-1.0, 1.0), self.range_f64(-1.0, 1.0));
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

impl Draws for SplitMix64 {
    fn bits(&mut self) -> u64 {
        self.next_u64()
    }
}

/// A tiny seeded PRNG (xorshift64*), so tests need no extra dependency.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed (any value, zero included).
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03 | 1)
    }

    /// A generator whose state is `state` (not zero), unscrambled.
    pub fn from_state(state: u64) -> Rng {
        Rng(state)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in `[0, 1)`.
    pub fn uniform(&mut self) -> f64 {
        self.unit()
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        self.range_f64(lo, hi)
    }

    /// `n` loss weights uniform in `[-1, 1]` (as f32, so `∂L/∂I` is exactly representable).
    pub fn weights(&mut self, n: usize) -> Vec<f32> {
        (0..n).map(|_| self.range(-1.0, 1.0) as f32).collect()
    }

    /// A random unit vector of dimension `n` (normalised uniform cube sample).
    pub fn direction(&mut self, n: usize) -> Vec<f64> {
        let v: Vec<f64> = (0..n).map(|_| self.range(-1.0, 1.0)).collect();
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.into_iter().map(|x| x / norm).collect()
    }
}

impl Draws for Rng {
    fn bits(&mut self) -> u64 {
        self.next_u64()
    }
}
