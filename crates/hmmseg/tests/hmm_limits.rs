//! Absurd sizes are refused with `InvalidParameter` before anything is allocated (no abort,
//! no panic, no hang).
#![allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]

mod hmm_common;

use std::time::Instant;

use hmm_common::random_model;
use hmmseg::hmm::{CovarianceType, FitConfig, Hmm, MAX_ELEMENTS};
use hmmseg::EngineError;
use nalgebra::{DMatrix, DVector};

fn invalid(e: EngineError, needle: &str) {
    assert!(
        matches!(&e, EngineError::InvalidParameter(m) if m.contains(needle)),
        "expected InvalidParameter mentioning {needle:?}, got {e}"
    );
}

#[test]
fn sample_refuses_huge_counts() {
    let model = random_model(3, 1, 2, CovarianceType::Diag, true, 1);
    invalid(model.sample(1_000_000_000_000, 0).unwrap_err(), "n_samples");
    invalid(model.sample(usize::MAX, 0).unwrap_err(), "n_samples");
    // The limit itself: MAX_ELEMENTS / 2 samples of 2 features is allowed (not drawn here),
    // one more sample is not.
    invalid(model.sample(MAX_ELEMENTS / 2 + 1, 0).unwrap_err(), "limit");
    assert_eq!(model.sample(5, 0).unwrap().0.shape(), (5, 2));
}

#[test]
fn fit_refuses_huge_models() {
    let x = DMatrix::from_fn(50, 1, |t, _| (t as f64 * 0.3).sin());
    let fit = |n_states, n_mix| {
        let config = FitConfig {
            n_states,
            n_mix,
            max_iter: 2,
            ..FitConfig::default()
        };
        Hmm::fit(std::slice::from_ref(&x), &config)
    };
    // n_states^2 transitions, whatever the data.
    invalid(fit(100_000, 1).unwrap_err(), "transition matrix");
    invalid(fit(1 << 33, 1).unwrap_err(), "transition matrix");
    // Components: overflow, above the limit, more than the samples (n_mix = 10^6 used to hang
    // in k-means).
    invalid(fit(2, 1 << 63).unwrap_err(), "mixture weights");
    invalid(fit(3, 1 << 40).unwrap_err(), "mixture weights");
    let start = Instant::now();
    invalid(fit(2, 1_000_000).unwrap_err(), "more mixture components");
    invalid(fit(5, 11).unwrap_err(), "more mixture components");
    assert!(start.elapsed().as_secs_f64() < 1.0);
    invalid(fit(51, 1).unwrap_err(), "more states");
    assert!(fit(5, 10).is_ok());
    // Many samples do not make 100000 states acceptable (10^10 transitions).
    let long = DMatrix::from_fn(100_001, 1, |t, _| t as f64);
    let config = FitConfig {
        n_states: 100_000,
        ..FitConfig::default()
    };
    invalid(
        Hmm::fit(std::slice::from_ref(&long), &config).unwrap_err(),
        "100000 x 100000",
    );
}

#[test]
fn full_covariances_of_many_features_are_refused() {
    // 2 samples of 20000 features: 20000^2 x 2 covariance entries (3.2 GB).
    let x = DMatrix::from_fn(2, 20_000, |t, d| (t + d) as f64);
    let config = FitConfig {
        n_states: 2,
        covariance: CovarianceType::Full,
        ..FitConfig::default()
    };
    invalid(
        Hmm::fit(std::slice::from_ref(&x), &config).unwrap_err(),
        "covariance",
    );
}

#[test]
fn scoring_refuses_huge_work_buffers() {
    // One state with 1024 components: a sequence of 2^18 + 1 samples needs more than 2^28
    // emission values.
    let m = 1024;
    let model = Hmm::from_params(
        DVector::from_element(1, 1.0),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, m, 1.0 / m as f64),
        vec![DMatrix::from_fn(m, 1, |k, _| k as f64)],
        vec![vec![DMatrix::from_element(1, 1, 1.0); m]],
        CovarianceType::Diag,
    )
    .unwrap();
    let x = DMatrix::from_element((1 << 18) + 1, 1, 0.5);
    invalid(
        model.log_likelihood(&x).unwrap_err(),
        "samples x n_states x n_mix",
    );
    invalid(model.viterbi(&x).unwrap_err(), "limit");
    invalid(model.posteriors(&x).unwrap_err(), "limit");
    invalid(model.prefix_log_likelihoods(&x).unwrap_err(), "limit");
    invalid(
        model
            .log_likelihood_many(std::slice::from_ref(&x))
            .unwrap_err(),
        "limit",
    );
    let config = FitConfig {
        max_iter: 1,
        ..FitConfig::default()
    };
    invalid(
        model.refit(std::slice::from_ref(&x), &config).unwrap_err(),
        "limit",
    );
    let short = DMatrix::from_element(10, 1, 0.5);
    assert!(model.log_likelihood(&short).unwrap().is_finite());
}
