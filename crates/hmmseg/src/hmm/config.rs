//! Training options ([`FitConfig`]), the training report ([`FitReport`]) and the two enums that
//! name a model's structure.

use serde::{Deserialize, Serialize};

use crate::error::{EngineError, Result};
use crate::limits::{at_most, checked_elements, MAX_ITER};

/// Shape of every covariance matrix of the emission Gaussians.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum CovarianceType {
    /// Diagonal covariances (independent features).
    #[default]
    Diag,
    /// Full symmetric positive definite covariances.
    Full,
}

crate::option_enum!(CovarianceType, "covariance", [Diag => "diag", Full => "full"]);

/// Allowed state transitions of a model trained with [`crate::hmm::Hmm::fit`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
pub enum Topology {
    /// Every state may follow every state.
    #[serde(rename = "ergodic")]
    Ergodic,
    /// Start in state 0; from state `i` only `i -> i` and `i -> i + 1`. The forbidden
    /// transitions are exact zeros and stay exact zeros through training.
    #[default]
    #[serde(rename = "left-right")]
    LeftRight,
}

crate::option_enum!(Topology, "topology", [Ergodic => "ergodic", LeftRight => "left-right"]);

/// Options of [`crate::hmm::Hmm::fit`] and [`crate::hmm::Hmm::refit`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitConfig {
    /// Number of hidden states (>= 1).
    pub n_states: usize,
    /// Gaussian components per state (>= 1; 1 = plain Gaussian emissions).
    pub n_mix: usize,
    /// Diagonal or full covariances.
    pub covariance: CovarianceType,
    /// Ergodic or left-right transitions.
    pub topology: Topology,
    /// Seed of the k-means initialisation (same seed, same data -> same model, bit for bit).
    pub seed: u64,
    /// Maximum number of EM iterations (M-steps), at most [`MAX_ITER`]. 0 returns the initial
    /// model.
    pub max_iter: usize,
    /// Stop when the total log-likelihood improves by less than this between two iterations
    /// (`>= 0`); `-inf` runs exactly `max_iter` iterations. Any other negative value, NaN and
    /// `+inf` are refused.
    pub tol: f64,
    /// Lower bound on every eigenvalue of every covariance (diag: on every variance).
    pub covariance_floor: f64,
}

impl Default for FitConfig {
    fn default() -> Self {
        Self {
            n_states: 5,
            n_mix: 1,
            covariance: CovarianceType::Diag,
            topology: Topology::LeftRight,
            seed: 0,
            max_iter: 100,
            tol: 1e-4,
            covariance_floor: 1e-3,
        }
    }
}

impl FitConfig {
    /// Check the numeric options (`n_states`, `n_mix`, `tol`, `covariance_floor`).
    pub fn validate(&self) -> Result<()> {
        if self.n_states == 0 {
            return Err(EngineError::InvalidParameter(
                "n_states must be >= 1".into(),
            ));
        }
        if self.n_mix == 0 {
            return Err(EngineError::InvalidParameter("n_mix must be >= 1".into()));
        }
        checked_elements(
            &[self.n_states, self.n_states],
            "the transition matrix (n_states x n_states)",
        )?;
        checked_elements(
            &[self.n_states, self.n_mix],
            "the mixture weights (n_states x n_mix)",
        )?;
        self.validate_em()
    }

    /// Check the model size against the training data: at least one sample per state and per
    /// mixture component, and parameter / work buffers within [`super::MAX_ELEMENTS`].
    /// `total`: samples over all sequences, `longest`: the longest sequence, `f`: features.
    pub(crate) fn validate_sizes(&self, total: usize, longest: usize, f: usize) -> Result<()> {
        let (n, m) = (self.n_states, self.n_mix);
        if n > total {
            return Err(EngineError::InvalidParameter(format!(
                "more states ({n}) than training samples ({total})"
            )));
        }
        let k = checked_elements(&[n, m], "the mixture weights (n_states x n_mix)")?;
        if k > total {
            return Err(EngineError::InvalidParameter(format!(
                "more mixture components (n_states x n_mix = {n} x {m}) than training samples ({total})"
            )));
        }
        let f2 = match self.covariance {
            CovarianceType::Diag => f,
            CovarianceType::Full => checked_elements(&[f, f], "one full covariance")?,
        };
        checked_elements(&[k, f2], "the covariances (components x features)")?;
        checked_elements(
            &[longest, k],
            "the emission table (samples x n_states x n_mix)",
        )?;
        Ok(())
    }

    /// Check the options EM itself uses (`max_iter`, `tol`, `covariance_floor`).
    pub(crate) fn validate_em(&self) -> Result<()> {
        at_most(self.max_iter, MAX_ITER, "max_iter")?;
        if !((self.tol >= 0.0 && self.tol.is_finite()) || self.tol == f64::NEG_INFINITY) {
            return Err(EngineError::InvalidParameter(format!(
                "tol must be a finite number >= 0 (or -inf: exactly max_iter iterations), got {}",
                self.tol
            )));
        }
        if !(self.covariance_floor.is_finite() && self.covariance_floor > 0.0) {
            return Err(EngineError::InvalidParameter(format!(
                "covariance_floor must be finite and > 0, got {}",
                self.covariance_floor
            )));
        }
        Ok(())
    }
}

/// What happened during training.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitReport {
    /// Total log-likelihood of all training sequences before each M-step (one entry per
    /// iteration; the parameters returned have had one more M-step than the last entry saw).
    pub log_likelihood_history: Vec<f64>,
    /// Number of EM iterations (M-steps) performed.
    pub n_iter: usize,
    /// `true` if the improvement fell below `tol` before `max_iter` iterations.
    pub converged: bool,
}

#[cfg(test)]
#[allow(clippy::float_cmp, clippy::needless_range_loop, clippy::cast_lossless)]
mod tests {
    use super::*;

    #[test]
    fn enums_use_documented_names() {
        assert_eq!(
            serde_json::to_string(&CovarianceType::Full).unwrap(),
            "\"full\""
        );
        assert_eq!(
            serde_json::to_string(&Topology::LeftRight).unwrap(),
            "\"left-right\""
        );
        assert_eq!("ergodic".parse::<Topology>().unwrap(), Topology::Ergodic);
        assert_eq!(
            "diag".parse::<CovarianceType>().unwrap(),
            CovarianceType::Diag
        );
        assert!(matches!(
            "ring".parse::<Topology>(),
            Err(EngineError::InvalidParameter(_))
        ));
        assert!(matches!(
            "tied".parse::<CovarianceType>(),
            Err(EngineError::InvalidParameter(_))
        ));
    }

    #[test]
    fn config_validation() {
        assert!(FitConfig::default().validate().is_ok());
        let bad = [
            FitConfig {
                n_states: 0,
                ..FitConfig::default()
            },
            FitConfig {
                n_mix: 0,
                ..FitConfig::default()
            },
            FitConfig {
                tol: f64::NAN,
                ..FitConfig::default()
            },
            FitConfig {
                tol: -1.0,
                ..FitConfig::default()
            },
            FitConfig {
                tol: f64::INFINITY,
                ..FitConfig::default()
            },
            FitConfig {
                max_iter: MAX_ITER + 1,
                ..FitConfig::default()
            },
            FitConfig {
                max_iter: 1 << 40,
                tol: -1.0,
                ..FitConfig::default()
            },
            FitConfig {
                covariance_floor: 0.0,
                ..FitConfig::default()
            },
            FitConfig {
                covariance_floor: f64::INFINITY,
                ..FitConfig::default()
            },
        ];
        for c in bad {
            assert!(
                matches!(c.validate(), Err(EngineError::InvalidParameter(_))),
                "{c:?}"
            );
        }
        let neg = FitConfig {
            tol: f64::NEG_INFINITY,
            max_iter: MAX_ITER,
            ..FitConfig::default()
        };
        assert!(neg.validate().is_ok());
        let zero = FitConfig {
            tol: 0.0,
            ..FitConfig::default()
        };
        assert!(zero.validate().is_ok());
    }
}
