//! Fuzzing the engine's public API with proptest: every call returns `Ok` with sane numbers or an
//! `EngineError`; no panic, no abort, no hang.
//!
//! `cargo test -p hmmseg --test fuzz` runs a short smoke (CI). A long run sets the number of cases
//! per target: `HMMSEG_FUZZ_CASES=2000000 cargo test --release -p hmmseg --test fuzz -- --nocapture`
//! (each target prints its executions). Inputs mix ordinary values with what breaks numerics:
//! empty and one-sample sequences, NaN / inf, magnitudes from 1e-300 to 1e300, absurd sizes.

use hmmseg::dtw::dtw_distance;
use hmmseg::hmm::{CovarianceType, FitConfig, Hmm, Topology};
use hmmseg::normalize::minmax;
use hmmseg::stage1::{section_boundaries, Criterion, Stage1Params};
use nalgebra::DMatrix;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::OnceLock;

const SMOKE_CASES: u32 = 300;
const MAGNITUDES: [f64; 10] = [0.0, 1e-300, 1e-12, 1e-3, 1.0, 10.0, 1e6, 1e50, 1e160, 1e300];
const SPECIALS: [f64; 4] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -0.0];
const SIZES: [usize; 8] = [0, 1, 2, 3, 7, 1 << 31, 1 << 40, usize::MAX];

fn cases() -> u32 {
    std::env::var("HMMSEG_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(SMOKE_CASES)
}

fn runner() -> TestRunner {
    TestRunner::new(Config {
        cases: cases(),
        failure_persistence: None,
        max_shrink_iters: 200,
        ..Config::default()
    })
}

/// A matrix from a seed: `rows x cols` normals times a magnitude, sometimes one special value.
fn matrix(
    seed: u64,
    rows: usize,
    cols: usize,
    magnitude: f64,
    special: Option<f64>,
) -> DMatrix<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut m = DMatrix::from_fn(rows, cols, |_, _| {
        (rng.random::<f64>() * 2.0 - 1.0) * magnitude
    });
    if let Some(v) = special {
        if rows * cols > 0 {
            let k = rng.random_range(0..rows * cols);
            m[k] = v;
        }
    }
    m
}

fn arb_matrix(max_rows: usize, max_cols: usize) -> impl Strategy<Value = DMatrix<f64>> {
    (
        any::<u64>(),
        0..=max_rows,
        0..=max_cols,
        prop::sample::select(MAGNITUDES.to_vec()),
        prop::option::weighted(0.1, prop::sample::select(SPECIALS.to_vec())),
    )
        .prop_map(|(seed, r, c, mag, sp)| matrix(seed, r, c, mag, sp))
}

fn model() -> &'static Hmm {
    static MODEL: OnceLock<Hmm> = OnceLock::new();
    MODEL.get_or_init(|| {
        let x = matrix(1, 80, 2, 1.0, None);
        let config = FitConfig {
            n_states: 3,
            max_iter: 5,
            ..FitConfig::default()
        };
        Hmm::fit(&[x], &config).expect("a plain fit works").0
    })
}

fn report(target: &str, n: u32) {
    eprintln!("fuzz {target}: {n} cases passed");
}

#[test]
fn fuzz_scoring() {
    let m = model();
    runner()
        .run(&arb_matrix(60, 3), |x| {
            if let Ok(v) = m.log_likelihood(&x) {
                prop_assert!(!v.is_nan(), "log_likelihood NaN");
            }
            let _ = m.prefix_log_likelihoods(&x);
            if let Ok((v, path)) = m.viterbi(&x) {
                prop_assert!(!v.is_nan());
                prop_assert_eq!(path.len(), x.nrows());
            }
            if let Ok(p) = m.posteriors(&x) {
                for r in 0..p.nrows() {
                    let row = p.row(r);
                    prop_assert!(row.iter().all(|v| v.is_finite()), "posterior not finite");
                    prop_assert!(
                        (row.sum() - 1.0).abs() < 1e-6,
                        "posterior row sums to {}",
                        row.sum()
                    );
                }
            }
            Ok(())
        })
        .unwrap();
    report("scoring", cases());
}

#[test]
fn fuzz_fit() {
    let configs = (
        prop::sample::select(vec![1usize, 2, 3, 5, 1 << 20, 1 << 40, usize::MAX]),
        prop::sample::select(vec![1usize, 2, 3, 1 << 20, 1 << 40, usize::MAX]),
        prop::bool::ANY,
        prop::bool::ANY,
        any::<u64>(),
        prop::sample::select(vec![0usize, 1, 3]),
        prop::sample::select(vec![1e-4, 0.0, -1.0, f64::NAN]),
        prop::sample::select(vec![1e-3, 0.0, f64::INFINITY, 1e300]),
    );
    runner()
        .run(
            &(prop::collection::vec(arb_matrix(30, 3), 0..3), configs),
            |(seqs, (n_states, n_mix, full, ergodic, seed, max_iter, tol, floor))| {
                let config = FitConfig {
                    n_states,
                    n_mix,
                    covariance: if full {
                        CovarianceType::Full
                    } else {
                        CovarianceType::Diag
                    },
                    topology: if ergodic {
                        Topology::Ergodic
                    } else {
                        Topology::LeftRight
                    },
                    seed,
                    max_iter,
                    tol,
                    covariance_floor: floor,
                };
                if let Ok((m, _)) = Hmm::fit(&seqs, &config) {
                    prop_assert!(m.startprob().iter().all(|v| v.is_finite()));
                }
                Ok(())
            },
        )
        .unwrap();
    report("fit", cases());
}

#[test]
fn fuzz_sample_and_json() {
    let m = model();
    let text = m.to_json().unwrap();
    runner()
        .run(
            &(
                prop::sample::select(SIZES.to_vec()),
                any::<u64>(),
                0..text.len(),
                any::<u8>(),
            ),
            |(n, seed, pos, byte)| {
                if n <= 100_000 {
                    if let Ok((x, states)) = m.sample(n, seed) {
                        prop_assert_eq!(x.nrows(), n);
                        prop_assert_eq!(states.len(), n);
                    }
                } else {
                    // absurd sizes must be refused, not attempted
                    prop_assert!(m.sample(n, seed).is_err(), "sample({}) accepted", n);
                }
                let mut bytes = text.clone().into_bytes();
                bytes[pos] = byte;
                if let Ok(s) = String::from_utf8(bytes) {
                    let _ = Hmm::from_json(&s);
                }
                let _ = Hmm::from_json(&text[..pos]);
                Ok(())
            },
        )
        .unwrap();
    report("sample + from_json", cases());
}

#[test]
fn fuzz_dtw_normalize_stage1() {
    runner()
        .run(
            &(
                arb_matrix(40, 3),
                arb_matrix(40, 3),
                prop::option::of(prop::sample::select(vec![0usize, 1, 5, 1 << 40])),
                prop::sample::select(vec![0usize, 1, 3, usize::MAX]),
            ),
            |(a, b, band, min_section)| {
                if let Ok(d) = dtw_distance(&a, &b, band) {
                    prop_assert!(!d.is_nan(), "dtw NaN");
                }
                if let Ok(n) = minmax(&a) {
                    prop_assert_eq!(n.shape(), a.shape());
                }
                let params = Stage1Params {
                    criteria: (0..a.ncols())
                        .map(|column| Criterion {
                            column,
                            hysteresis: 0.01,
                        })
                        .collect(),
                    min_section,
                };
                let thresholds = DMatrix::from_element(a.nrows(), a.ncols(), 0.0);
                if let Ok(cuts) = section_boundaries(&a, &thresholds, &params) {
                    prop_assert!(cuts.windows(2).all(|w| w[0] < w[1]));
                }
                Ok(())
            },
        )
        .unwrap();
    report("dtw + normalize + stage1", cases());
}
