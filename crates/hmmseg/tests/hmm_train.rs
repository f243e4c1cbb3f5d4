//! Baum-Welch: recovers known models, is deterministic, monotone, and keeps structural zeros.
#![allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]

mod hmm_common;

use hmm_common::{random_model, sample_many};
use hmmseg::hmm::{CovarianceType, FitConfig, Hmm, Topology};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn left_right_fit_recovers_means_and_keeps_zeros() {
    // Like demonstrations of one skill: three phases of 40-60 samples each, noisy levels.
    let levels = [(0.0, 0.3), (3.0, 0.5), (-2.0, 0.7)];
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let xs: Vec<DMatrix<f64>> = (0..9)
        .map(|_| {
            let mut v = Vec::new();
            for &(mu, var) in &levels {
                for _ in 0..rng.random_range(40..=60) {
                    let noise: f64 = (0..12).map(|_| rng.random::<f64>()).sum::<f64>() - 6.0;
                    v.push(mu + f64::sqrt(var) * noise);
                }
            }
            DMatrix::from_column_slice(v.len(), 1, &v)
        })
        .collect();
    let config = FitConfig {
        n_states: 3,
        ..FitConfig::default()
    };
    let (model, report) = Hmm::fit(&xs, &config).unwrap();
    assert!(report.n_iter >= 1 && report.n_iter <= config.max_iter);
    assert_eq!(report.log_likelihood_history.len(), report.n_iter);
    assert!(report.converged);
    for j in 0..3 {
        let (got, want) = (model.means()[j][(0, 0)], levels[j].0);
        assert!((got - want).abs() < 0.1, "state {j}: {got} vs {want}");
    }
    let a = model.transmat();
    for i in 0..3 {
        for j in 0..3 {
            if j != i && j != i + 1 {
                assert_eq!(a[(i, j)], 0.0, "transition {i}->{j} must stay exactly zero");
            }
        }
    }
    assert_eq!(model.startprob().as_slice(), &[1.0, 0.0, 0.0]);
    // The trained model explains its data better than a different random model.
    let other = random_model(3, 1, 1, CovarianceType::Diag, true, 99);
    let ours: f64 = model.log_likelihood_many(&xs).unwrap().iter().sum();
    let theirs: f64 = other.log_likelihood_many(&xs).unwrap().iter().sum();
    assert!(ours > theirs);
}

#[test]
fn fit_is_deterministic_for_a_seed_and_history_is_monotone() {
    for (cov, m, topology) in [
        (CovarianceType::Diag, 1, Topology::Ergodic),
        (CovarianceType::Full, 1, Topology::Ergodic),
        (CovarianceType::Diag, 2, Topology::LeftRight),
        (CovarianceType::Full, 2, Topology::Ergodic),
    ] {
        let truth = random_model(3, m, 2, cov, topology == Topology::LeftRight, 8);
        let xs = sample_many(&truth, 5, 30, 90, 4);
        let config = FitConfig {
            n_states: 3,
            n_mix: m,
            covariance: cov,
            topology,
            seed: 42,
            max_iter: 25,
            ..FitConfig::default()
        };
        let (a, ra) = Hmm::fit(&xs, &config).unwrap();
        let (b, rb) = Hmm::fit(&xs, &config).unwrap();
        assert_eq!(a.to_json().unwrap(), b.to_json().unwrap());
        assert_eq!(ra, rb);
        for w in ra.log_likelihood_history.windows(2) {
            assert!(
                w[1] >= w[0] - 1e-8 * w[0].abs(),
                "{cov:?} {m}: EM decreased: {w:?}"
            );
        }
        // The final model is at least as good as the last recorded iteration.
        let final_ll: f64 = a.log_likelihood_many(&xs).unwrap().iter().sum();
        assert!(final_ll >= ra.log_likelihood_history.last().unwrap() - 1e-8 * final_ll.abs());
    }
}

#[test]
fn result_does_not_depend_on_thread_count() {
    let truth = random_model(4, 1, 2, CovarianceType::Diag, false, 12);
    let xs = sample_many(&truth, 16, 200, 300, 6);
    let config = FitConfig {
        n_states: 4,
        topology: Topology::Ergodic,
        max_iter: 5,
        ..FitConfig::default()
    };
    let (par, _) = Hmm::fit(&xs, &config).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let (seq, _) = pool.install(|| Hmm::fit(&xs, &config)).unwrap();
    assert_eq!(par.to_json().unwrap(), seq.to_json().unwrap());
}

#[test]
fn refit_continues_from_the_given_parameters() {
    let truth = random_model(3, 1, 1, CovarianceType::Diag, false, 31);
    let xs = sample_many(&truth, 4, 40, 60, 1);
    let steps = FitConfig {
        max_iter: 3,
        tol: f64::NEG_INFINITY,
        ..FitConfig::default()
    };
    let (three, report) = truth.refit(&xs, &steps).unwrap();
    assert_eq!(report.n_iter, 3);
    assert!(!report.converged);
    let mut step = truth.clone();
    let mut lls = Vec::new();
    for _ in 0..3 {
        let (next, ll) = step.baum_welch_step(&xs, steps.covariance_floor).unwrap();
        lls.push(ll);
        step = next;
    }
    assert_eq!(step, three);
    assert_eq!(lls, report.log_likelihood_history);
    let zero = FitConfig {
        max_iter: 0,
        ..FitConfig::default()
    };
    let (same, r0) = truth.refit(&xs, &zero).unwrap();
    assert_eq!(same, truth);
    assert_eq!(r0.n_iter, 0);
}

#[test]
fn covariance_floor_is_respected() {
    // Constant data: every ML variance would be zero.
    let xs = vec![DMatrix::from_element(20, 2, 0.5); 3];
    for cov in [CovarianceType::Diag, CovarianceType::Full] {
        let config = FitConfig {
            n_states: 2,
            covariance: cov,
            covariance_floor: 0.01,
            ..FitConfig::default()
        };
        let (model, _) = Hmm::fit(&xs, &config).unwrap();
        for c in model.covars().iter().flatten() {
            let eig = c.clone().symmetric_eigen().eigenvalues;
            assert!(eig.min() >= 0.01 * (1.0 - 1e-9), "{cov:?}: {eig}");
        }
        assert!(model.log_likelihood(&xs[0]).unwrap().is_finite());
    }
}

#[test]
fn short_sequences_and_many_states_still_fit() {
    // Sequences shorter than the number of states (left-right) and an ergodic model.
    let xs: Vec<_> = (0..4)
        .map(|i| DMatrix::from_fn(3, 1, |t, _| (t + i) as f64))
        .collect();
    for topology in [Topology::LeftRight, Topology::Ergodic] {
        let config = FitConfig {
            n_states: 5,
            topology,
            max_iter: 10,
            ..FitConfig::default()
        };
        let (model, _) = Hmm::fit(&xs, &config).unwrap();
        assert_eq!(model.n_states(), 5);
        assert!(model.log_likelihood(&xs[0]).unwrap().is_finite());
    }
}
