//! Drawing sequences from a model (for tests, benchmarks and synthetic data).

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::model::Hmm;
use crate::error::{EngineError, Result};
use crate::limits::checked_elements;

/// Index drawn from the probability vector `p` (the last index absorbs rounding).
fn categorical(p: impl Iterator<Item = f64>, rng: &mut ChaCha8Rng) -> usize {
    let mut u = rng.random::<f64>();
    let mut last = 0;
    for (i, v) in p.enumerate() {
        if v > 0.0 {
            last = i;
            if u < v {
                return i;
            }
            u -= v;
        }
    }
    last
}

/// A standard normal number (Box-Muller).
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

impl Hmm {
    /// Draw `n_samples` observations (`(n_samples, n_features)`) and their hidden states.
    /// Deterministic for a given `seed`.
    pub fn sample(&self, n_samples: usize, seed: u64) -> Result<(DMatrix<f64>, Vec<usize>)> {
        if n_samples == 0 {
            return Err(EngineError::EmptySequence(
                "cannot sample 0 observations".into(),
            ));
        }
        let f = self.n_features();
        checked_elements(&[n_samples, f], "sampling (n_samples x n_features)")?;
        let factors = self
            .covars()
            .iter()
            .map(|s| {
                s.iter()
                    .map(|c| {
                        c.clone().cholesky().map(|ch| ch.l()).ok_or_else(|| {
                            EngineError::NotPositiveDefinite(
                                "covariance has no Cholesky factor".into(),
                            )
                        })
                    })
                    .collect::<Result<Vec<_>>>()
            })
            .collect::<Result<Vec<_>>>()?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut x = DMatrix::zeros(n_samples, f);
        let mut states = Vec::with_capacity(n_samples);
        let mut state = categorical(self.startprob().iter().copied(), &mut rng);
        for t in 0..n_samples {
            if t > 0 {
                state = categorical(self.transmat().row(state).iter().copied(), &mut rng);
            }
            states.push(state);
            let m = categorical(self.weights().row(state).iter().copied(), &mut rng);
            let z = DVector::from_fn(f, |_, _| normal(&mut rng));
            let v = self.means()[state].row(m).transpose() + &factors[state][m] * z;
            x.row_mut(t).copy_from(&v.transpose());
        }
        Ok((x, states))
    }
}
