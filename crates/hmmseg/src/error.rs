//! The one error type of the engine. Every fallible public function returns [`Result`].

use thiserror::Error;

/// Everything that can go wrong in the engine. Invalid input is reported, never a panic.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum EngineError {
    /// A sequence (or a set of sequences) had no samples.
    #[error("empty input: {0}")]
    EmptySequence(String),
    /// Array shapes or dimensions do not agree.
    #[error("shape mismatch: {0}")]
    ShapeMismatch(String),
    /// NaN or infinity where finite numbers are required.
    #[error("non-finite value: {0}")]
    NonFinite(String),
    /// A parameter is outside its valid range (e.g. more states than samples, negative variance).
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    /// A probability vector or matrix does not sum to one or has negative entries.
    #[error("not stochastic: {0}")]
    NotStochastic(String),
    /// A covariance matrix is not symmetric positive definite.
    #[error("covariance not positive definite: {0}")]
    NotPositiveDefinite(String),
    /// An iterative procedure did not converge or degenerated.
    #[error("not converged: {0}")]
    NotConverged(String),
    /// A serialised model could not be read (bad JSON, wrong format version, unknown skill).
    #[error("format error: {0}")]
    Format(String),
}

/// Result alias used throughout the engine.
pub type Result<T> = std::result::Result<T, EngineError>;
