//! Every documented error path returns the right `EngineError` variant (and never panics).
#![allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]

mod hmm_common;

use hmm_common::random_model;
use hmmseg::hmm::{CovarianceType, FitConfig, Hmm};
use hmmseg::EngineError;
use nalgebra::{DMatrix, DVector};

type Params = (
    DVector<f64>,
    DMatrix<f64>,
    DMatrix<f64>,
    Vec<DMatrix<f64>>,
    Vec<Vec<DMatrix<f64>>>,
);

fn one_state(f: usize) -> Params {
    (
        DVector::from_element(1, 1.0),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::from_element(1, 1, 1.0),
        vec![DMatrix::zeros(1, f)],
        vec![vec![DMatrix::identity(f, f)]],
    )
}

#[test]
fn scoring_input_errors() {
    let model = random_model(3, 1, 2, CovarianceType::Diag, false, 1);
    let empty = DMatrix::<f64>::zeros(0, 2);
    let wrong = DMatrix::<f64>::zeros(4, 3);
    let mut nan = DMatrix::<f64>::zeros(4, 2);
    nan[(2, 1)] = f64::NAN;
    let mut inf = DMatrix::<f64>::zeros(4, 2);
    inf[(0, 0)] = f64::NEG_INFINITY;
    for (x, check) in [
        (
            &empty,
            (|e: &EngineError| matches!(e, EngineError::EmptySequence(_)))
                as fn(&EngineError) -> bool,
        ),
        (&wrong, |e| matches!(e, EngineError::ShapeMismatch(_))),
        (&nan, |e| matches!(e, EngineError::NonFinite(_))),
        (&inf, |e| matches!(e, EngineError::NonFinite(_))),
    ] {
        assert!(check(&model.log_likelihood(x).unwrap_err()));
        assert!(check(&model.prefix_log_likelihoods(x).unwrap_err()));
        assert!(check(&model.viterbi(x).unwrap_err()));
        assert!(check(&model.posteriors(x).unwrap_err()));
        let good = DMatrix::zeros(3, 2);
        assert!(check(
            &model
                .log_likelihood_many(&[good.clone(), x.clone()])
                .unwrap_err()
        ));
        assert!(check(
            &model
                .refit(&[good, x.clone()], &FitConfig::default())
                .unwrap_err()
        ));
        if x.ncols() == 2 {
            // Alone, a 3-feature sequence is valid training data.
            let config = FitConfig {
                n_states: 1,
                ..FitConfig::default()
            };
            assert!(check(
                &Hmm::fit(std::slice::from_ref(x), &config).unwrap_err()
            ));
        }
    }
    assert_eq!(model.log_likelihood_many(&[]).unwrap(), Vec::<f64>::new());
}

#[test]
fn fit_errors() {
    let x = DMatrix::from_fn(4, 1, |t, _| t as f64);
    let cfg = |n_states| FitConfig {
        n_states,
        ..FitConfig::default()
    };
    assert!(matches!(
        Hmm::fit(&[], &cfg(2)),
        Err(EngineError::EmptySequence(_))
    ));
    assert!(
        matches!(Hmm::fit(std::slice::from_ref(&x), &cfg(5)), Err(EngineError::InvalidParameter(m)) if m.contains("more states"))
    );
    assert!(matches!(
        Hmm::fit(std::slice::from_ref(&x), &cfg(0)),
        Err(EngineError::InvalidParameter(_))
    ));
    let y = DMatrix::zeros(4, 2);
    assert!(matches!(
        Hmm::fit(&[x.clone(), y], &cfg(2)),
        Err(EngineError::ShapeMismatch(_))
    ));
    let zero_f = DMatrix::<f64>::zeros(4, 0);
    assert!(matches!(
        Hmm::fit(&[zero_f], &cfg(2)),
        Err(EngineError::ShapeMismatch(_))
    ));
    for bad in [
        FitConfig { n_mix: 0, ..cfg(2) },
        FitConfig {
            tol: f64::NAN,
            ..cfg(2)
        },
        FitConfig {
            covariance_floor: -1.0,
            ..cfg(2)
        },
    ] {
        assert!(matches!(
            Hmm::fit(std::slice::from_ref(&x), &bad),
            Err(EngineError::InvalidParameter(_))
        ));
    }
    let model = random_model(2, 1, 1, CovarianceType::Diag, false, 1);
    assert!(matches!(
        model.refit(
            &[x],
            &FitConfig {
                covariance_floor: 0.0,
                ..cfg(2)
            }
        ),
        Err(EngineError::InvalidParameter(_))
    ));
    assert!(matches!(
        model.sample(0, 0),
        Err(EngineError::EmptySequence(_))
    ));
}

#[test]
fn from_params_errors() {
    let ok = one_state(2);
    assert!(Hmm::from_params(
        ok.0.clone(),
        ok.1.clone(),
        ok.2.clone(),
        ok.3.clone(),
        ok.4.clone(),
        CovarianceType::Full
    )
    .is_ok());
    let err =
        |p: Params| Hmm::from_params(p.0, p.1, p.2, p.3, p.4, CovarianceType::Full).unwrap_err();
    // No states.
    let mut p = one_state(2);
    p.0 = DVector::zeros(0);
    assert!(matches!(err(p), EngineError::InvalidParameter(_)));
    // Shapes.
    let mut p = one_state(2);
    p.1 = DMatrix::from_element(2, 2, 0.5);
    assert!(matches!(err(p), EngineError::ShapeMismatch(_)));
    let mut p = one_state(2);
    p.2 = DMatrix::zeros(1, 0);
    assert!(matches!(err(p), EngineError::ShapeMismatch(_)));
    let mut p = one_state(2);
    p.3 = vec![DMatrix::zeros(1, 3)];
    assert!(matches!(err(p), EngineError::ShapeMismatch(_)));
    let mut p = one_state(2);
    p.3 = vec![DMatrix::zeros(1, 0)];
    p.4 = vec![vec![DMatrix::zeros(0, 0)]];
    assert!(matches!(err(p), EngineError::ShapeMismatch(_)));
    let mut p = one_state(2);
    p.4 = vec![vec![DMatrix::identity(3, 3)]];
    assert!(matches!(err(p), EngineError::ShapeMismatch(_)));
    // Not stochastic.
    let mut p = one_state(2);
    p.0 = DVector::from_element(1, 0.9);
    assert!(matches!(err(p), EngineError::NotStochastic(_)));
    let mut p = one_state(2);
    p.1 = DMatrix::from_element(1, 1, 1.1);
    assert!(matches!(err(p), EngineError::NotStochastic(_)));
    let mut p = one_state(2);
    p.2 = DMatrix::from_element(1, 1, 0.5);
    assert!(matches!(err(p), EngineError::NotStochastic(_)));
    // Non-finite.
    let mut p = one_state(2);
    p.3 = vec![DMatrix::from_element(1, 2, f64::NAN)];
    assert!(matches!(err(p), EngineError::NonFinite(_)));
    let mut p = one_state(2);
    p.0 = DVector::from_element(1, f64::INFINITY);
    assert!(matches!(err(p), EngineError::NonFinite(_)));
    // Not SPD.
    let mut p = one_state(2);
    p.4 = vec![vec![DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0])]];
    assert!(matches!(err(p), EngineError::NotPositiveDefinite(_)));
    let mut p = one_state(2);
    p.4 = vec![vec![DMatrix::zeros(2, 2)]];
    let e = Hmm::from_params(p.0, p.1, p.2, p.3, p.4, CovarianceType::Diag).unwrap_err();
    assert!(matches!(e, EngineError::NotPositiveDefinite(_)));
}

#[test]
fn extreme_observations_do_not_break_scoring() {
    let model = random_model(3, 2, 2, CovarianceType::Full, true, 4);
    let x = DMatrix::from_row_slice(3, 2, &[0.0, 0.0, 1e6, -1e6, 0.0, 0.0]);
    let ll = model.log_likelihood(&x).unwrap();
    assert!(ll.is_finite() && ll < -1e9);
    let prefix = model.prefix_log_likelihoods(&x).unwrap();
    assert!((prefix[2] - ll).abs() <= 1e-9 * ll.abs());
    let post = model.posteriors(&x).unwrap();
    assert!(post.row_iter().all(|r| (r.sum() - 1.0).abs() < 1e-9));
}
