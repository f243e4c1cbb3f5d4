//! Continuous hidden Markov models: Gaussian / Gaussian-mixture emissions, Baum-Welch training,
//! forward (whole sequence, many sequences, every prefix), Viterbi and state posteriors.
//!
//! Observations are `DMatrix<f64>` of shape `(n_samples, n_features)`: one ROW per time step.
//!
//! Numerics: the forward-backward recursions run on probabilities scaled per time step, with
//! every emission row divided by its maximum first; when a step underflows anyway (an observation
//! far from every reachable state) the whole sequence is redone in log space (log-sum-exp), so
//! the result is always correct and the common case is fast.
//!
//! Files: [`model`] (the [`Hmm`] type, validation, JSON), `emission` (Gaussian mixtures and
//! their precomputed constants), `forward` (the recursions), `train` (Baum-Welch), `init`
//! (seeded k-means / uniform segmentation start), `kmeans`.

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
mod train;
mod validate;

pub use config::{CovarianceType, FitConfig, FitReport, Topology};
pub use model::{Hmm, HmmParams, FORMAT_VERSION};
