//! Continuous hidden Markov models: Gaussian / Gaussian-mixture emissions, Baum-Welch training,
//! forward (whole sequence, many sequences, every prefix), Viterbi and state posteriors.
//!
//! Observations are `DMatrix<f64>` of shape `(n_samples, n_features)`: one ROW per time step.
//!
//! Numerics: the forward-backward recursions run on probabilities scaled per time step, with
//! every emission row divided by its maximum first; when a step underflows anyway (an observation
//! far from every reachable state) the whole sequence is redone in log space (log-sum-exp,
//! normalised per step so posteriors stay exact for astronomically large log-densities), so
//! the result is always correct and the common case is fast. A log-likelihood below the range
//! of doubles is an [`crate::EngineError::NonFinite`] error, never `-inf` or NaN in a result.
//!
//! Files: `model` (the [`Hmm`] type, validation, JSON), `config` ([`FitConfig`] and friends),
//! `emission` (Gaussian mixtures and their precomputed constants), `forward` (the recursions),
//! `score` (fixed-size fast path of the forward log-likelihood for up to 8 states), `fastexp`
//! (a vectorisable `exp`), `simd` (runtime AVX2/FMA dispatch, the engine's only `unsafe`),
//! `train` (Baum-Welch), `init` (seeded k-means / uniform
//! segmentation start), `kmeans`, `moments` (means, covariances, the covariance floor),
//! `sample` (drawing sequences), `validate` (input checks); the size and iteration limits
//! ([`MAX_ELEMENTS`], [`MAX_ITER`]) are [`crate::limits`].
//!
//! ```
//! use hmmseg::hmm::{FitConfig, Hmm};
//! use nalgebra::DMatrix;
//!
//! // Two demonstrations of a two-phase motion (one feature).
//! let demo = |k: f64| DMatrix::from_fn(40, 1, |t, _| if t < 20 { 0.0 } else { 1.0 } + 0.01 * k * (t as f64).sin());
//! let config = FitConfig { n_states: 2, ..FitConfig::default() };
//! let (model, report) = Hmm::fit(&[demo(1.0), demo(2.0)], &config).unwrap();
//! assert!(report.n_iter >= 1);
//! let (_, path) = model.viterbi(&demo(3.0)).unwrap();
//! assert_eq!((path[0], path[39]), (0, 1));
//! assert!(model.log_likelihood(&demo(3.0)).unwrap() > model.log_likelihood(&demo(30.0)).unwrap());
//! ```

mod config;
mod emission;
mod fastexp;
mod forward;
mod init;
mod kmeans;
mod model;
mod moments;
mod sample;
mod score;
pub(crate) mod simd;
mod train;
mod validate;

pub use crate::limits::{MAX_ELEMENTS, MAX_ITER};
pub use config::{CovarianceType, FitConfig, FitReport, Topology};
pub(crate) use emission::Emission;
pub use model::{Hmm, HmmParams, FORMAT_VERSION};
