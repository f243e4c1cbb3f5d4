//! Criterion benchmarks of the HMM engine: the cases of `benches/engine_vs_hmmlearn.py`.
//!
//! Run with `cargo bench -p hmmseg --bench hmm`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use hmmseg::hmm::{CovarianceType, FitConfig, Hmm};
use nalgebra::{DMatrix, DVector};

/// Left-right model with `n` states, `m` components per state and `f` features.
fn left_right(n: usize, m: usize, f: usize) -> Hmm {
    let mut a = DMatrix::zeros(n, n);
    for i in 0..n {
        if i + 1 < n {
            a[(i, i)] = 0.95;
            a[(i, i + 1)] = 0.05;
        } else {
            a[(i, i)] = 1.0;
        }
    }
    let mut pi = DVector::zeros(n);
    pi[0] = 1.0;
    let weights = DMatrix::from_element(n, m, 1.0 / m as f64);
    let means = (0..n)
        .map(|j| DMatrix::from_fn(m, f, |k, d| j as f64 + 0.3 * k as f64 - 0.1 * d as f64))
        .collect();
    let covars = (0..n)
        .map(|j| {
            (0..m)
                .map(|_| DMatrix::identity(f, f) * (0.2 + 0.05 * j as f64))
                .collect()
        })
        .collect();
    Hmm::from_params(pi, a, weights, means, covars, CovarianceType::Diag).expect("valid model")
}

fn bench(c: &mut Criterion) {
    let model = left_right(5, 1, 1);
    let x = model.sample(200, 1).expect("sample").0;
    c.bench_function("score T=200 N=5 1-D diag", |b| {
        b.iter(|| model.log_likelihood(black_box(&x)).expect("score"));
    });
    c.bench_function("prefix scores T=200 N=5 1-D diag", |b| {
        b.iter(|| model.prefix_log_likelihoods(black_box(&x)).expect("prefix"));
    });
    c.bench_function("viterbi T=200 N=5 1-D diag", |b| {
        b.iter(|| model.viterbi(black_box(&x)).expect("viterbi"));
    });

    let gmm = left_right(5, 3, 2);
    let xg = gmm.sample(200, 2).expect("sample").0;
    c.bench_function("score T=200 N=5 GMM M=3 2-D diag", |b| {
        b.iter(|| gmm.log_likelihood(black_box(&xg)).expect("score"));
    });

    let xs: Vec<DMatrix<f64>> = (0..9)
        .map(|i| model.sample(200, 10 + i).expect("sample").0)
        .collect();
    let ten = FitConfig {
        max_iter: 10,
        tol: f64::NEG_INFINITY,
        ..FitConfig::default()
    };
    c.bench_function("refit 9x200 N=5 1-D diag, 10 iterations", |b| {
        b.iter(|| model.refit(black_box(&xs), &ten).expect("refit"));
    });
    let fit = FitConfig {
        n_states: 5,
        max_iter: 10,
        tol: f64::NEG_INFINITY,
        ..FitConfig::default()
    };
    c.bench_function("fit (init + 10 iterations) 9x200 N=5 1-D diag", |b| {
        b.iter(|| Hmm::fit(black_box(&xs), &fit).expect("fit"));
    });
    let many: Vec<DMatrix<f64>> = (0..100)
        .map(|i| model.sample(60, 100 + i).expect("sample").0)
        .collect();
    c.bench_function("score_many 100x60 N=5 1-D diag", |b| {
        b.iter(|| model.log_likelihood_many(black_box(&many)).expect("many"));
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(30);
    targets = bench
}
criterion_main!(benches);
