//! The engine called from several threads at once gives the same results, bit for bit, as
//! the same calls made one after another.
#![allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]

mod hmm_common;

use hmm_common::{random_model, sample_many};
use hmmseg::hmm::{CovarianceType, FitConfig, Hmm};
use nalgebra::DMatrix;

type Outcome = (Vec<f64>, Vec<(f64, Vec<usize>)>, Vec<DMatrix<f64>>, Hmm);

fn work(models: &[Hmm], xs: &[DMatrix<f64>]) -> Outcome {
    let mut scores = Vec::new();
    let mut paths = Vec::new();
    let mut posts = Vec::new();
    for m in models {
        for x in xs {
            if x.ncols() == m.n_features() {
                scores.push(m.log_likelihood(x).unwrap());
                scores.extend(m.prefix_log_likelihoods(x).unwrap().iter());
                paths.push(m.viterbi(x).unwrap());
                posts.push(m.posteriors(x).unwrap());
            }
        }
    }
    let config = FitConfig {
        n_states: 3,
        n_mix: 2,
        max_iter: 5,
        ..FitConfig::default()
    };
    let one_d: Vec<DMatrix<f64>> = xs.iter().filter(|x| x.ncols() == 1).cloned().collect();
    let (fitted, _) = Hmm::fit(&one_d, &config).unwrap();
    (scores, paths, posts, fitted)
}

#[test]
fn concurrent_calls_match_sequential_ones() {
    let models = vec![
        random_model(5, 1, 1, CovarianceType::Diag, true, 3),
        random_model(3, 2, 2, CovarianceType::Full, false, 4),
        random_model(12, 1, 1, CovarianceType::Diag, false, 5),
    ];
    let mut xs = sample_many(&models[0], 4, 20, 300, 7);
    xs.extend(sample_many(&models[1], 3, 10, 200, 8));
    let want = work(&models, &xs);
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..6)
            .map(|_| s.spawn(|| (0..3).map(|_| work(&models, &xs)).collect::<Vec<_>>()))
            .collect();
        for h in handles {
            for got in h.join().unwrap() {
                assert_eq!(got.0, want.0);
                assert_eq!(got.1, want.1);
                assert_eq!(got.2, want.2);
                assert_eq!(got.3, want.3);
            }
        }
    });
}
