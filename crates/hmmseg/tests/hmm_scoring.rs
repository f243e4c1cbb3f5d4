//! Scoring entry points agree with each other and with hand computations.
#![allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]

mod hmm_common;

use hmm_common::{random_model, sample_many};
use hmmseg::hmm::{CovarianceType, Hmm};
use nalgebra::{DMatrix, DVector};

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn many_prefix_and_single_agree_for_every_emission_kind() {
    for (cov, m, f) in [
        (CovarianceType::Diag, 1, 1),
        (CovarianceType::Full, 1, 3),
        (CovarianceType::Diag, 3, 2),
        (CovarianceType::Full, 2, 2),
    ] {
        let model = random_model(4, m, f, cov, false, 7);
        let xs = sample_many(&model, 6, 1, 60, 11);
        let many = model.log_likelihood_many(&xs).unwrap();
        for (x, &ll_many) in xs.iter().zip(&many) {
            let ll = model.log_likelihood(x).unwrap();
            assert_eq!(ll.to_bits(), ll_many.to_bits());
            let prefix = model.prefix_log_likelihoods(x).unwrap();
            assert_eq!(prefix.len(), x.nrows());
            assert!(close(prefix[x.nrows() - 1], ll, 1e-12));
            // Each prefix scored separately.
            for t in [0, x.nrows() / 2, x.nrows() - 1] {
                let sub = x.rows(0, t + 1).into_owned();
                assert!(close(prefix[t], model.log_likelihood(&sub).unwrap(), 1e-12));
            }
            // The joint probability of the best path never exceeds the total.
            let (vit, path) = model.viterbi(x).unwrap();
            assert_eq!(path.len(), x.nrows());
            assert!(vit <= ll + 1e-9);
        }
    }
}

#[test]
fn posterior_rows_sum_to_one() {
    let model = random_model(5, 2, 2, CovarianceType::Full, true, 3);
    for x in sample_many(&model, 3, 1, 80, 5) {
        let post = model.posteriors(&x).unwrap();
        assert_eq!(post.shape(), (x.nrows(), 5));
        for r in post.row_iter() {
            assert!((r.sum() - 1.0).abs() < 1e-12);
            assert!(r.iter().all(|&p| (0.0..=1.0 + 1e-12).contains(&p)));
        }
        // Left-right: the first sample is in state 0 with certainty.
        assert_eq!(post[(0, 0)], 1.0);
    }
}

#[test]
fn viterbi_recovers_states_of_a_well_separated_toy_model() {
    let model = Hmm::from_params(
        DVector::from_vec(vec![1.0, 0.0, 0.0]),
        DMatrix::from_row_slice(3, 3, &[0.8, 0.2, 0.0, 0.0, 0.8, 0.2, 0.0, 0.0, 1.0]),
        DMatrix::from_element(3, 1, 1.0),
        (0..3)
            .map(|j| DMatrix::from_element(1, 1, 10.0 * j as f64))
            .collect(),
        (0..3)
            .map(|_| vec![DMatrix::from_element(1, 1, 1.0)])
            .collect(),
        CovarianceType::Diag,
    )
    .unwrap();
    let x = DMatrix::from_column_slice(7, 1, &[0.3, -0.5, 9.0, 11.0, 10.2, 19.5, 21.0]);
    let (score, path) = model.viterbi(&x).unwrap();
    assert_eq!(path, vec![0, 0, 1, 1, 1, 2, 2]);
    // ln P(x, path) by hand.
    let ln_n =
        |v: f64, mu: f64| -0.5 * (2.0 * std::f64::consts::PI).ln() - 0.5 * (v - mu) * (v - mu);
    let mut want = 0.0;
    for (t, &s) in path.iter().enumerate() {
        want += ln_n(x[(t, 0)], 10.0 * s as f64);
        if t > 0 {
            want += model.transmat()[(path[t - 1], s)].ln();
        }
    }
    assert!((score - want).abs() < 1e-10);
}

#[test]
fn sampling_is_deterministic_and_respects_topology() {
    let model = random_model(4, 1, 2, CovarianceType::Diag, true, 1);
    let (a, sa) = model.sample(50, 9).unwrap();
    let (b, sb) = model.sample(50, 9).unwrap();
    assert_eq!(a, b);
    assert_eq!(sa, sb);
    assert_eq!(sa[0], 0);
    assert!(sa.windows(2).all(|w| w[1] == w[0] || w[1] == w[0] + 1));
}

#[test]
fn underflow_falls_back_to_log_space_through_the_public_api() {
    // Left-right, no way out of state 0; state 1 explains the middle sample far better, so
    // the scaled recursion underflows and the log-space recursion must take over.
    let model = Hmm::from_params(
        DVector::from_vec(vec![1.0, 0.0]),
        DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1.0]),
        DMatrix::from_element(2, 1, 1.0),
        vec![
            DMatrix::from_element(1, 1, 0.0),
            DMatrix::from_element(1, 1, 100.0),
        ],
        vec![
            vec![DMatrix::from_element(1, 1, 1.0)],
            vec![DMatrix::from_element(1, 1, 1.0)],
        ],
        CovarianceType::Diag,
    )
    .unwrap();
    let x = DMatrix::from_column_slice(3, 1, &[0.0, 100.0, 0.5]);
    let ln_n = |v: f64| -0.5 * (2.0 * std::f64::consts::PI).ln() - 0.5 * v * v;
    let want = ln_n(0.0) + ln_n(100.0) + ln_n(0.5);
    assert!(close(model.log_likelihood(&x).unwrap(), want, 1e-12));
    assert!(close(
        model.log_likelihood_many(std::slice::from_ref(&x)).unwrap()[0],
        want,
        1e-12
    ));
    assert!(close(
        model.prefix_log_likelihoods(&x).unwrap()[2],
        want,
        1e-12
    ));
    assert_eq!(model.viterbi(&x).unwrap().1, vec![0, 0, 0]);
    // Nine states take the general (non-fixed-size) path; it must agree with a small model.
    let big = hmm_common::random_model(9, 1, 2, CovarianceType::Diag, true, 5);
    let xb = big.sample(50, 3).unwrap().0;
    let prefix = big.prefix_log_likelihoods(&xb).unwrap();
    assert!(close(big.log_likelihood(&xb).unwrap(), prefix[49], 1e-12));
}
