//! Shared helpers of the `hmm_*` integration tests: random valid models and data.
#![allow(dead_code)]

use hmmseg::hmm::{CovarianceType, Hmm};
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A random probability vector of length `n` (entries >= 0.05 before normalisation).
pub fn prob_vec(n: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let v: Vec<f64> = (0..n).map(|_| 0.05 + rng.random::<f64>()).collect();
    let s: f64 = v.iter().sum();
    v.into_iter().map(|x| x / s).collect()
}

/// A random SPD matrix (`f x f`), diagonal for diag models.
pub fn spd(f: usize, cov: CovarianceType, rng: &mut ChaCha8Rng) -> DMatrix<f64> {
    match cov {
        CovarianceType::Diag => {
            DMatrix::from_diagonal(&DVector::from_fn(f, |_, _| 0.2 + rng.random::<f64>()))
        }
        CovarianceType::Full => {
            let a = DMatrix::from_fn(f, f, |_, _| rng.random::<f64>() - 0.5);
            &a * a.transpose() + DMatrix::identity(f, f) * 0.3
        }
    }
}

/// A random valid model. `left_right`: start in 0, only `i -> i` and `i -> i + 1`.
pub fn random_model(
    n: usize,
    m: usize,
    f: usize,
    cov: CovarianceType,
    left_right: bool,
    seed: u64,
) -> Hmm {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (startprob, transmat) = if left_right {
        let mut a = DMatrix::zeros(n, n);
        for i in 0..n {
            if i + 1 < n {
                let stay = 0.5 + 0.45 * rng.random::<f64>();
                a[(i, i)] = stay;
                a[(i, i + 1)] = 1.0 - stay;
            } else {
                a[(i, i)] = 1.0;
            }
        }
        let mut pi = DVector::zeros(n);
        pi[0] = 1.0;
        (pi, a)
    } else {
        let pi = DVector::from_vec(prob_vec(n, &mut rng));
        let rows: Vec<f64> = (0..n).flat_map(|_| prob_vec(n, &mut rng)).collect();
        (pi, DMatrix::from_row_slice(n, n, &rows))
    };
    let w: Vec<f64> = (0..n).flat_map(|_| prob_vec(m, &mut rng)).collect();
    let weights = DMatrix::from_row_slice(n, m, &w);
    let means = (0..n)
        .map(|j| {
            DMatrix::from_fn(m, f, |_, _| {
                2.0 * j as f64 + 1.5 * (rng.random::<f64>() - 0.5)
            })
        })
        .collect();
    let covars = (0..n)
        .map(|_| (0..m).map(|_| spd(f, cov, &mut rng)).collect())
        .collect();
    Hmm::from_params(startprob, transmat, weights, means, covars, cov).expect("valid random model")
}

/// Draw `count` sequences of lengths `min_len..=max_len` from `model`.
pub fn sample_many(
    model: &Hmm,
    count: usize,
    min_len: usize,
    max_len: usize,
    seed: u64,
) -> Vec<DMatrix<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|i| {
            let len = rng.random_range(min_len..=max_len);
            model.sample(len, seed * 1000 + i as u64).expect("sample").0
        })
        .collect()
}
