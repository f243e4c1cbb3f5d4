//! Extreme but finite inputs (observations up to 1e300, variances down to 1e-300): every
//! result is finite, posterior rows sum to 1, or the call returns `NonFinite` (the
//! log-likelihood is below the range of doubles). Never NaN, never a row summing to 0.
#![allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]

mod hmm_common;

use hmm_common::random_model;
use hmmseg::hmm::{CovarianceType, Hmm};
use hmmseg::EngineError;
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

/// The benchmark's left-right model: 5 states, 1-D, variances 0.2..0.4.
fn left_right() -> Hmm {
    let n = 5;
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
    Hmm::from_params(
        pi,
        a,
        DMatrix::from_element(n, 1, 1.0),
        (0..n)
            .map(|j| DMatrix::from_element(1, 1, j as f64))
            .collect(),
        (0..n)
            .map(|j| vec![DMatrix::from_element(1, 1, 0.2 + 0.05 * j as f64)])
            .collect(),
        CovarianceType::Diag,
    )
    .unwrap()
}

/// Everything the model says about `x`: each result is finite and consistent, or a
/// `NonFinite` error. Returns whether the log-likelihood was representable.
fn check_all(model: &Hmm, x: &DMatrix<f64>) -> Result<bool, TestCaseError> {
    let non_finite = |e: &EngineError| matches!(e, EngineError::NonFinite(_));
    let ll = model.log_likelihood(x);
    match &ll {
        Ok(v) => prop_assert!(v.is_finite()),
        Err(e) => prop_assert!(non_finite(e), "{e}"),
    }
    match model.posteriors(x) {
        Ok(p) => {
            prop_assert_eq!(p.shape(), (x.nrows(), model.n_states()));
            for r in p.row_iter() {
                prop_assert!(r.iter().all(|v| (0.0..=1.0).contains(v)), "{r}");
                prop_assert!((r.sum() - 1.0).abs() < 1e-9, "row sums to {}", r.sum());
            }
        }
        Err(e) => prop_assert!(non_finite(&e), "{e}"),
    }
    match model.viterbi(x) {
        Ok((score, path)) => {
            prop_assert!(score.is_finite());
            prop_assert_eq!(path.len(), x.nrows());
            prop_assert!(path.iter().all(|&s| s < model.n_states()));
            if let Ok(v) = &ll {
                prop_assert!(score <= v + 1e-9 * (1.0 + v.abs()), "{score} > {v}");
            }
        }
        Err(e) => prop_assert!(non_finite(&e), "{e}"),
    }
    match model.prefix_log_likelihoods(x) {
        Ok(p) => {
            prop_assert!(p.iter().all(|v| v.is_finite()));
            if let Ok(v) = &ll {
                let last = p[x.nrows() - 1];
                prop_assert!((last - v).abs() <= 1e-9 * (1.0 + v.abs()), "{last} vs {v}");
            }
        }
        Err(e) => prop_assert!(non_finite(&e), "{e}"),
    }
    Ok(ll.is_ok())
}

#[test]
fn issue_magnitudes() {
    let model = left_right();
    for (value, representable) in [(1e50, true), (1e150, true), (1e160, false), (-1e150, true)] {
        let x = DMatrix::from_element(200, 1, value);
        assert_eq!(check_all(&model, &x).unwrap(), representable, "{value}");
        if representable {
            // Far beyond every mean, the state with the widest variance wins at the end.
            let p = model.posteriors(&x).unwrap();
            assert!(p[(199, 4)] > 0.99, "{value}: {}", p.row(199));
            assert!(model.log_likelihood(&x).unwrap() < -1e90);
        } else {
            let e = model.posteriors(&x).unwrap_err();
            assert!(e.to_string().contains("rescale the features"), "{e}");
        }
    }
    // One extreme sample inside ordinary data.
    let mut x = DMatrix::from_fn(200, 1, |t, _| (t / 40) as f64);
    x[(100, 0)] = 1e150;
    assert!(check_all(&model, &x).unwrap());
}

#[test]
fn tiny_variances() {
    let n = 2;
    let model = Hmm::from_params(
        DVector::from_vec(vec![0.5, 0.5]),
        DMatrix::from_row_slice(n, n, &[0.9, 0.1, 0.1, 0.9]),
        DMatrix::from_element(n, 1, 1.0),
        vec![
            DMatrix::from_element(1, 1, 0.0),
            DMatrix::from_element(1, 1, 1.0),
        ],
        vec![
            vec![DMatrix::from_element(1, 1, 1e-300)],
            vec![DMatrix::from_element(1, 1, 1e-300)],
        ],
        CovarianceType::Diag,
    )
    .unwrap();
    let x = DMatrix::from_fn(50, 1, |t, _| if t % 7 == 0 { 1.0 } else { 1e-151 });
    assert!(check_all(&model, &x).unwrap());
    let p = model.posteriors(&x).unwrap();
    assert_eq!(p[(0, 1)], 1.0);
    // A variance whose inverse overflows is refused when the model is built.
    let err = Hmm::from_params(
        DVector::from_element(1, 1.0),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 1.0),
        vec![DMatrix::from_element(1, 1, 0.0)],
        vec![vec![DMatrix::from_element(1, 1, 1e-320)]],
        CovarianceType::Diag,
    )
    .unwrap_err();
    assert!(matches!(err, EngineError::NotPositiveDefinite(_)), "{err}");
}

fn cov_type() -> impl Strategy<Value = CovarianceType> {
    prop_oneof![Just(CovarianceType::Diag), Just(CovarianceType::Full)]
}

fn magnitude() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(1.0),
        Just(1e10),
        Just(1e50),
        Just(1e100),
        Just(1e150),
        Just(1e154),
        Just(1e160),
        Just(1e300),
    ]
}

/// `model` with every covariance multiplied by `scale` (`None` if that is not a valid model).
fn rescaled(model: &Hmm, scale: f64) -> Option<Hmm> {
    let covars = model
        .covars()
        .iter()
        .map(|s| s.iter().map(|c| c * scale).collect())
        .collect();
    Hmm::from_params(
        model.startprob().clone(),
        model.transmat().clone(),
        model.weights().clone(),
        model.means().to_vec(),
        covars,
        model.covariance(),
    )
    .ok()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn extreme_inputs_give_finite_results_or_non_finite_errors(
        n in 1usize..11, m in 1usize..3, f in 1usize..4, cov in cov_type(), lr: bool,
        seed in 0u64..10_000, len in 1usize..120, scale in magnitude(),
        offset in magnitude(), neg: bool, var_exp in prop_oneof![Just(0i32), Just(-50), Just(-150), Just(-300)],
        spikes in proptest::collection::vec((0usize..120, magnitude()), 0..4),
    ) {
        let base = random_model(n, m, f, cov, lr, seed);
        let Some(model) = rescaled(&base, 10f64.powi(var_exp)) else {
            return Ok(());
        };
        let mut x = base.sample(len, seed + 1).unwrap().0;
        let sign = if neg { -1.0 } else { 1.0 };
        x.iter_mut().for_each(|v| *v = *v * scale + sign * (offset - 1.0));
        for (t, v) in spikes {
            if t < len {
                x[(t, 0)] = v;
            }
        }
        if x.iter().all(|v| v.is_finite()) {
            check_all(&model, &x)?;
        }
    }
}
