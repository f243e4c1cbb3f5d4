//! Property tests over random models and sequences.
#![allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]

mod hmm_common;

use hmm_common::{random_model, sample_many};
use hmmseg::hmm::{CovarianceType, FitConfig, Hmm};
use proptest::prelude::*;

fn cov_type() -> impl Strategy<Value = CovarianceType> {
    prop_oneof![Just(CovarianceType::Diag), Just(CovarianceType::Full)]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn prefix_last_equals_log_likelihood(
        n in 1usize..6, m in 1usize..3, f in 1usize..4, cov in cov_type(), lr: bool, seed in 0u64..1000, len in 1usize..80,
    ) {
        let model = random_model(n, m, f, cov, lr, seed);
        let x = model.sample(len, seed + 1).unwrap().0;
        let ll = model.log_likelihood(&x).unwrap();
        let prefix = model.prefix_log_likelihoods(&x).unwrap();
        prop_assert!((prefix[len - 1] - ll).abs() <= 1e-10 * (1.0 + ll.abs()));
        // Prefix log-likelihoods of continuous data need not be monotone, but are finite.
        prop_assert!(prefix.iter().all(|v| v.is_finite()));
        let post = model.posteriors(&x).unwrap();
        for r in post.row_iter() {
            prop_assert!((r.sum() - 1.0).abs() < 1e-10);
        }
        let (vit, _) = model.viterbi(&x).unwrap();
        prop_assert!(vit <= ll + 1e-9 * (1.0 + ll.abs()));
    }

    #[test]
    fn em_never_decreases_and_keeps_zeros(
        n in 1usize..5, m in 1usize..3, f in 1usize..3, cov in cov_type(), lr: bool, seed in 0u64..1000,
    ) {
        let truth = random_model(n, m, f, cov, lr, seed);
        let start = random_model(n, m, f, cov, lr, seed + 17);
        let xs = sample_many(&truth, 3, 5, 40, seed);
        let config = FitConfig { max_iter: 8, tol: f64::NEG_INFINITY, covariance_floor: 1e-6, ..FitConfig::default() };
        let (model, report) = start.refit(&xs, &config).unwrap();
        let h = &report.log_likelihood_history;
        for w in h.windows(2) {
            prop_assert!(w[1] >= w[0] - 1e-7 * (1.0 + w[0].abs()), "EM decreased: {:?}", w);
        }
        for i in 0..n {
            for j in 0..n {
                if start.transmat()[(i, j)] == 0.0 {
                    prop_assert_eq!(model.transmat()[(i, j)], 0.0);
                }
            }
            if start.startprob()[i] == 0.0 {
                prop_assert_eq!(model.startprob()[i], 0.0);
            }
        }
        let json = model.to_json().unwrap();
        prop_assert_eq!(Hmm::from_json(&json).unwrap(), model);
    }
}
