//! The [`Hmm`] type: parameters, validation, scoring entry points and JSON.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::config::CovarianceType;
use super::emission::Emission;
use super::forward::{self, Chain, Workspace};
use super::score;
use super::validate::{check_sequence, check_stochastic};
use crate::error::{EngineError, Result};
use crate::limits::checked_elements;

/// Version written into every serialised model; [`Hmm::from_json`] rejects any other.
pub const FORMAT_VERSION: u32 = 1;

/// A continuous HMM with Gaussian-mixture emissions (`n_mix = 1`: plain Gaussians).
///
/// Immutable once built: [`Hmm::from_params`] validates and precomputes everything the
/// recursions need; training returns a new model. Serialises through [`HmmParams`].
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(into = "HmmParams", try_from = "HmmParams")]
pub struct Hmm {
    startprob: DVector<f64>,
    transmat: DMatrix<f64>,
    weights: DMatrix<f64>,
    means: Vec<DMatrix<f64>>,
    covars: Vec<Vec<DMatrix<f64>>>,
    covariance: CovarianceType,
    pub(crate) chain: Chain,
    pub(crate) emission: Emission,
}

/// The serialised form of an [`Hmm`]: plain nested row-major lists, with a format version.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct HmmParams {
    /// Must equal [`FORMAT_VERSION`].
    pub format_version: u32,
    /// `"diag"` or `"full"`.
    pub covariance: CovarianceType,
    /// `n_states`.
    pub startprob: Vec<f64>,
    /// `n_states x n_states`, rows sum to 1.
    pub transmat: Vec<Vec<f64>>,
    /// `n_states x n_mix`, rows sum to 1.
    pub weights: Vec<Vec<f64>>,
    /// `n_states x n_mix x n_features`.
    pub means: Vec<Vec<Vec<f64>>>,
    /// `n_states x n_mix x n_features x n_features` (diag models store diagonal matrices).
    pub covars: Vec<Vec<Vec<Vec<f64>>>>,
}

fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    m.row_iter().map(|r| r.iter().copied().collect()).collect()
}

fn matrix(rows: &[Vec<f64>], n_cols: usize, what: &str) -> Result<DMatrix<f64>> {
    if let Some(r) = rows.iter().position(|r| r.len() != n_cols) {
        return Err(EngineError::ShapeMismatch(format!(
            "{what}: row {r} has {} entries, expected {n_cols}",
            rows[r].len()
        )));
    }
    Ok(DMatrix::from_fn(rows.len(), n_cols, |r, c| rows[r][c]))
}

/// `v` if finite, else the error for a log-probability below the range of doubles.
fn finite(v: f64, what: &str) -> Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(EngineError::NonFinite(format!(
            "{what}: the log-likelihood is {v}, outside the range of double precision \
             (observations astronomically far from every state; rescale the features)"
        )))
    }
}

impl From<Hmm> for HmmParams {
    fn from(h: Hmm) -> Self {
        Self {
            format_version: FORMAT_VERSION,
            covariance: h.covariance,
            startprob: h.startprob.iter().copied().collect(),
            transmat: rows(&h.transmat),
            weights: rows(&h.weights),
            means: h.means.iter().map(rows).collect(),
            covars: h
                .covars
                .iter()
                .map(|s| s.iter().map(rows).collect())
                .collect(),
        }
    }
}

impl TryFrom<HmmParams> for Hmm {
    type Error = EngineError;

    fn try_from(p: HmmParams) -> Result<Self> {
        if p.format_version != FORMAT_VERSION {
            return Err(EngineError::Format(format!(
                "model format_version {} is not supported (expected {FORMAT_VERSION})",
                p.format_version
            )));
        }
        let n = p.startprob.len();
        let m = p.weights.first().map_or(0, Vec::len);
        let f = p.means.first().and_then(|s| s.first()).map_or(0, Vec::len);
        let transmat = matrix(&p.transmat, n, "transmat")?;
        let weights = matrix(&p.weights, m, "weights")?;
        let means = p
            .means
            .iter()
            .enumerate()
            .map(|(j, s)| matrix(s, f, &format!("means of state {j}")))
            .collect::<Result<Vec<_>>>()?;
        let covars = p
            .covars
            .iter()
            .enumerate()
            .map(|(j, s)| {
                s.iter()
                    .enumerate()
                    .map(|(k, c)| matrix(c, f, &format!("covariance of state {j}, component {k}")))
                    .collect::<Result<Vec<_>>>()
            })
            .collect::<Result<Vec<_>>>()?;
        Hmm::from_params(
            DVector::from_vec(p.startprob),
            transmat,
            weights,
            means,
            covars,
            p.covariance,
        )
    }
}

impl Hmm {
    /// Build a model from its parameters, validating everything.
    ///
    /// * `startprob`: `n_states`, a probability vector.
    /// * `transmat`: `n_states x n_states`, every row a probability vector.
    /// * `weights`: `n_states x n_mix`, every row a probability vector.
    /// * `means`: per state an `n_mix x n_features` matrix.
    /// * `covars`: per state, per component an `n_features x n_features` SPD matrix
    ///   (a diag model requires diagonal matrices).
    pub fn from_params(
        startprob: DVector<f64>,
        transmat: DMatrix<f64>,
        weights: DMatrix<f64>,
        means: Vec<DMatrix<f64>>,
        covars: Vec<Vec<DMatrix<f64>>>,
        covariance: CovarianceType,
    ) -> Result<Self> {
        let n = startprob.len();
        if n == 0 {
            return Err(EngineError::InvalidParameter(
                "a model needs at least one state".into(),
            ));
        }
        let shape_err = |what: &str, got: String, want: String| {
            Err(EngineError::ShapeMismatch(format!(
                "{what} has shape {got}, expected {want}"
            )))
        };
        if transmat.shape() != (n, n) {
            return shape_err(
                "transmat",
                format!("{:?}", transmat.shape()),
                format!("({n}, {n})"),
            );
        }
        let m = weights.ncols();
        if weights.nrows() != n || m == 0 {
            return shape_err(
                "weights",
                format!("{:?}", weights.shape()),
                format!("({n}, n_mix >= 1)"),
            );
        }
        let f = means.first().map_or(0, DMatrix::ncols);
        if means.len() != n || f == 0 || means.iter().any(|mu| mu.shape() != (m, f)) {
            let got: Vec<_> = means.iter().map(DMatrix::shape).collect();
            return shape_err(
                "means",
                format!("{got:?}"),
                format!("{n} x ({m}, n_features >= 1)"),
            );
        }
        if covars.len() != n
            || covars
                .iter()
                .any(|s| s.len() != m || s.iter().any(|c| c.shape() != (f, f)))
        {
            let got: Vec<Vec<_>> = covars
                .iter()
                .map(|s| s.iter().map(DMatrix::shape).collect())
                .collect();
            return shape_err(
                "covars",
                format!("{got:?}"),
                format!("{n} x {m} x ({f}, {f})"),
            );
        }
        check_stochastic(startprob.iter().copied(), "startprob")?;
        for i in 0..n {
            check_stochastic(
                transmat.row(i).iter().copied(),
                &format!("transmat row {i}"),
            )?;
            check_stochastic(weights.row(i).iter().copied(), &format!("weights row {i}"))?;
        }
        for (j, mu) in means.iter().enumerate() {
            if let Some(v) = mu.iter().find(|v| !v.is_finite()) {
                return Err(EngineError::NonFinite(format!(
                    "means of state {j} contain {v}"
                )));
            }
        }
        let emission = Emission::new(&weights, &means, &covars, covariance)?;
        let trans_rm: Vec<f64> = (0..n)
            .flat_map(|i| transmat.row(i).iter().copied().collect::<Vec<_>>())
            .collect();
        let chain = Chain::new(startprob.iter().copied().collect(), trans_rm);
        Ok(Self {
            startprob,
            transmat,
            weights,
            means,
            covars,
            covariance,
            chain,
            emission,
        })
    }

    /// Number of hidden states.
    pub fn n_states(&self) -> usize {
        self.startprob.len()
    }

    /// Dimension of one observation.
    pub fn n_features(&self) -> usize {
        self.emission.n_features
    }

    /// Gaussian components per state.
    pub fn n_mix(&self) -> usize {
        self.weights.ncols()
    }

    /// Start probabilities, length `n_states`.
    pub fn startprob(&self) -> &DVector<f64> {
        &self.startprob
    }

    /// Transition matrix, `n_states x n_states` (`[i, j] = P(j | i)`).
    pub fn transmat(&self) -> &DMatrix<f64> {
        &self.transmat
    }

    /// Mixture weights, `n_states x n_mix`.
    pub fn weights(&self) -> &DMatrix<f64> {
        &self.weights
    }

    /// Per state: component means, `n_mix x n_features`.
    pub fn means(&self) -> &[DMatrix<f64>] {
        &self.means
    }

    /// Per state, per component: covariance, `n_features x n_features`.
    pub fn covars(&self) -> &[Vec<DMatrix<f64>>] {
        &self.covars
    }

    /// Diagonal or full covariances.
    pub fn covariance(&self) -> CovarianceType {
        self.covariance
    }

    /// Refuse a sequence of `t_len` samples whose work buffers (`t_len x n_states x n_mix`
    /// values) would exceed [`super::MAX_ELEMENTS`].
    pub(crate) fn check_work(&self, t_len: usize) -> Result<()> {
        checked_elements(
            &[t_len, self.emission.n_components()],
            "scoring this sequence (samples x n_states x n_mix)",
        )
        .map(|_| ())
    }

    /// Validate `x` and fill `ws.logb` (and `ws.comp`) with its emission log-probabilities.
    pub(crate) fn emissions_into(
        &self,
        x: &DMatrix<f64>,
        ws: &mut Workspace,
        what: &str,
    ) -> Result<()> {
        check_sequence(x, self.n_features(), what)?;
        self.check_work(x.nrows())?;
        self.emission.log_emissions(x, &mut ws.comp, &mut ws.logb);
        Ok(())
    }

    /// `ln P(x | model)` by the forward algorithm. `x`: `(n_samples, n_features)`.
    ///
    /// A likelihood below the range of doubles (observations astronomically far from every
    /// state, e.g. 1e160 against unit-scale means) is an [`EngineError::NonFinite`] error.
    pub fn log_likelihood(&self, x: &DMatrix<f64>) -> Result<f64> {
        let mut ws = Workspace::default();
        self.score_into(x, &mut ws, "sequence")
    }

    /// Validate and score one sequence: the small-model fast path, else the general one.
    fn score_into(&self, x: &DMatrix<f64>, ws: &mut Workspace, what: &str) -> Result<f64> {
        check_sequence(x, self.n_features(), what)?;
        self.check_work(x.nrows())?;
        if let Some(ll) = score::log_likelihood_small(&self.chain, &self.emission, x) {
            return Ok(ll);
        }
        self.emission.log_emissions(x, &mut ws.comp, &mut ws.logb);
        finite(forward::log_likelihood(&self.chain, ws), what)
    }

    /// [`Self::log_likelihood`] of every sequence, in parallel (rayon), in input order.
    pub fn log_likelihood_many(&self, xs: &[DMatrix<f64>]) -> Result<Vec<f64>> {
        let out: Vec<Result<f64>> = xs
            .par_iter()
            .enumerate()
            .map_init(Workspace::default, |ws, (i, x)| {
                self.score_into(x, ws, &format!("sequence {i}"))
            })
            .collect();
        out.into_iter().collect()
    }

    /// `out[t] = ln P(x[0..=t] | model)` for every `t`, in one forward pass
    /// (the last entry equals [`Self::log_likelihood`]).
    pub fn prefix_log_likelihoods(&self, x: &DMatrix<f64>) -> Result<DVector<f64>> {
        let mut ws = Workspace::default();
        self.emissions_into(x, &mut ws, "sequence")?;
        let out = forward::prefix_log_likelihoods(&self.chain, &mut ws);
        for v in &out {
            finite(*v, "sequence")?;
        }
        Ok(DVector::from_vec(out))
    }

    /// Most likely state path (Viterbi) and its joint log-probability `ln P(x, path)`.
    pub fn viterbi(&self, x: &DMatrix<f64>) -> Result<(f64, Vec<usize>)> {
        let mut ws = Workspace::default();
        self.emissions_into(x, &mut ws, "sequence")?;
        let (score, path) = forward::viterbi(&self.chain, &ws.logb);
        Ok((finite(score, "sequence")?, path))
    }

    /// State posteriors `P(s_t = j | x)`, shape `(n_samples, n_states)`; rows sum to 1.
    pub fn posteriors(&self, x: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        let mut ws = Workspace::default();
        self.emissions_into(x, &mut ws, "sequence")?;
        let ll = forward::forward_backward(&self.chain, &mut ws, None);
        finite(ll, "sequence")?;
        if ws.gamma.iter().any(|v| !v.is_finite()) {
            return Err(EngineError::NonFinite(
                "sequence: the state posteriors are not representable in double precision".into(),
            ));
        }
        Ok(DMatrix::from_row_slice(
            x.nrows(),
            self.n_states(),
            &ws.gamma,
        ))
    }

    /// Serialise to JSON (with `"format_version"`); [`Self::from_json`] restores it bit for bit.
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string(&HmmParams::from(self.clone()))
            .map_err(|e| EngineError::Format(format!("cannot serialise model: {e}")))
    }

    /// Read a model written by [`Self::to_json`]; bad JSON or another format version is a
    /// [`EngineError::Format`], bad parameters the matching validation error.
    pub fn from_json(s: &str) -> Result<Self> {
        let bad = |e: serde_json::Error| {
            EngineError::Format(format!("not a valid HMM JSON document: {e}"))
        };
        let value: serde_json::Value = serde_json::from_str(s).map_err(bad)?;
        match value
            .get("format_version")
            .and_then(serde_json::Value::as_u64)
        {
            Some(v) if v == u64::from(FORMAT_VERSION) => {}
            Some(v) => {
                return Err(EngineError::Format(format!(
                    "model format_version {v} is not supported (expected {FORMAT_VERSION})"
                )))
            }
            None => {
                return Err(EngineError::Format(
                    "model JSON has no integer \"format_version\"".into(),
                ))
            }
        }
        let params: HmmParams = serde_json::from_value(value).map_err(bad)?;
        Self::try_from(params)
    }
}
