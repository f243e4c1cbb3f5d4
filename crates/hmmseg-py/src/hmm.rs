//! `lfd._hmmseg.Hmm`: the continuous HMM of `hmmseg::hmm`, wrapped for Python.
//!
//! Arrays in are float64 numpy arrays (the Python face `lfd.engine` converts and checks them);
//! observations are `(n_samples, n_features)`. Work runs with the interpreter released.

use hmmseg::hmm::{CovarianceType, FitConfig, FitReport, Hmm, Topology};
use nalgebra::{DMatrix, DVector};
use numpy::ndarray::{Array3, Array4};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyArray4};
use pyo3::prelude::*;

use crate::errors::{guard, IntoPyResult};
use crate::limits::{check_hmm, check_table};
use crate::ndconv::{self, count, int_arg, matrix, matrix_list};

const OBS: &str = "(n_samples, n_features)";

/// Parse an option name with the engine's `FromStr` (`InvalidParameterError` if unknown).
fn option<T: std::str::FromStr<Err = hmmseg::EngineError>>(py: Python<'_>, s: &str) -> PyResult<T> {
    s.parse::<T>().py_err(py)
}

/// The longest sequence and the feature count of the first one (0 for none).
fn extent(xs: &[DMatrix<f64>]) -> (usize, usize) {
    let longest = xs.iter().map(DMatrix::nrows).max().unwrap_or(0);
    (longest, xs.first().map_or(0, DMatrix::ncols))
}

/// `(model, history, n_iter, converged)` as returned to Python.
type FitResult = (PyHmm, Vec<f64>, usize, bool);

fn fit_result((inner, report): (Hmm, FitReport)) -> FitResult {
    (
        PyHmm { inner },
        report.log_likelihood_history,
        report.n_iter,
        report.converged,
    )
}

/// `(observations, states)` drawn from a model.
type Sampled<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<i64>>);

/// A continuous HMM with Gaussian-mixture emissions (immutable; training returns a new one).
#[pyclass(name = "Hmm", module = "lfd._hmmseg", frozen)]
pub struct PyHmm {
    inner: Hmm,
}

#[pymethods]
impl PyHmm {
    /// Train a new model: seeded initialisation, then Baum-Welch.
    /// Returns `(model, log_likelihood_history, n_iter, converged)`.
    #[staticmethod]
    #[pyo3(signature = (sequences, *, n_states, n_mix = 1, covariance = "diag", topology = "left-right", seed = 0, max_iter = 100, tol = 1e-4, covariance_floor = 1e-3))]
    fn fit(
        py: Python<'_>,
        sequences: Vec<Bound<'_, PyAny>>,
        #[pyo3(from_py_with = int_arg)] n_states: i128,
        #[pyo3(from_py_with = int_arg)] n_mix: i128,
        covariance: &str,
        topology: &str,
        #[pyo3(from_py_with = int_arg)] seed: i128,
        #[pyo3(from_py_with = int_arg)] max_iter: i128,
        tol: f64,
        covariance_floor: f64,
    ) -> PyResult<FitResult> {
        guard(py, || {
            let config = FitConfig {
                n_states: count(py, n_states, "n_states", 1)?,
                n_mix: count(py, n_mix, "n_mix", 1)?,
                covariance: option(py, covariance)?,
                topology: option::<Topology>(py, topology)?,
                seed: ndconv::seed(py, seed)?,
                max_iter: count(py, max_iter, "max_iter", 0)?,
                tol,
                covariance_floor,
            };
            let xs = matrix_list(&sequences, "sequences", OBS)?;
            let (longest, f) = extent(&xs);
            check_hmm(
                py,
                config.n_states,
                config.n_mix,
                f,
                config.covariance == CovarianceType::Full,
                longest,
            )?;
            py.detach(|| Hmm::fit(&xs, &config))
                .map(fit_result)
                .py_err(py)
        })
    }

    /// Baum-Welch from this model's parameters (no re-initialisation).
    /// Returns `(model, log_likelihood_history, n_iter, converged)`.
    #[pyo3(signature = (sequences, *, max_iter, tol = f64::NEG_INFINITY, covariance_floor = 1e-3))]
    fn refit(
        &self,
        py: Python<'_>,
        sequences: Vec<Bound<'_, PyAny>>,
        #[pyo3(from_py_with = int_arg)] max_iter: i128,
        tol: f64,
        covariance_floor: f64,
    ) -> PyResult<FitResult> {
        guard(py, || {
            let config = FitConfig {
                max_iter: count(py, max_iter, "max_iter", 0)?,
                tol,
                covariance_floor,
                ..FitConfig::default()
            };
            let xs = matrix_list(&sequences, "sequences", OBS)?;
            let h = &self.inner;
            check_hmm(
                py,
                h.n_states(),
                h.n_mix(),
                h.n_features(),
                h.covariance() == CovarianceType::Full,
                extent(&xs).0,
            )?;
            py.detach(|| h.refit(&xs, &config))
                .map(fit_result)
                .py_err(py)
        })
    }

    /// Build from parameters: `startprob (n,)`, `transmat (n, n)`, `weights (n, m)`,
    /// `means (n, m, f)`, `covars (n, m, f)` for diag or `(n, m, f, f)` for full.
    #[staticmethod]
    #[pyo3(signature = (startprob, transmat, weights, means, covars, covariance = "diag"))]
    fn from_params(
        py: Python<'_>,
        startprob: Bound<'_, PyAny>,
        transmat: Bound<'_, PyAny>,
        weights: Bound<'_, PyAny>,
        means: Bound<'_, PyAny>,
        covars: Bound<'_, PyAny>,
        covariance: &str,
    ) -> PyResult<Self> {
        guard(py, || {
            let cov: CovarianceType = option(py, covariance)?;
            let mu = ndconv::array_nd(&means, "means", 3, "(n_states, n_mix, n_features)")?;
            let (n, m, f) = (mu.shape()[0], mu.shape()[1], mu.shape()[2]);
            let (ndim, want) = match cov {
                CovarianceType::Diag => (3, vec![n, m, f]),
                CovarianceType::Full => (4, vec![n, m, f, f]),
            };
            let want_text = ndconv::py_shape(&want);
            let c = ndconv::array_nd(&covars, "covars", ndim, &want_text)?;
            if c.shape() != want.as_slice() {
                return Err(crate::errors::shape(
                    py,
                    format!(
                        "covars has shape {}, expected {want_text} for {covariance} covariances",
                        ndconv::py_shape(c.shape())
                    ),
                ));
            }
            let means_v = (0..n)
                .map(|j| DMatrix::from_fn(m, f, |k, d| mu[[j, k, d]]))
                .collect();
            let covars_v = (0..n)
                .map(|j| {
                    (0..m)
                        .map(|k| match cov {
                            CovarianceType::Diag => {
                                DMatrix::from_diagonal(&DVector::from_fn(f, |d, _| c[[j, k, d]]))
                            }
                            CovarianceType::Full => DMatrix::from_fn(f, f, |r, s| c[[j, k, r, s]]),
                        })
                        .collect()
                })
                .collect();
            let start = DVector::from_vec(ndconv::vector(&startprob, "startprob", "(n_states,)")?);
            let inner = Hmm::from_params(
                start,
                matrix(&transmat, "transmat", "(n_states, n_states)")?,
                matrix(&weights, "weights", "(n_states, n_mix)")?,
                means_v,
                covars_v,
                cov,
            )
            .py_err(py)?;
            Ok(Self { inner })
        })
    }

    /// Read a model written by `to_json`.
    #[staticmethod]
    fn from_json(py: Python<'_>, s: &str) -> PyResult<Self> {
        guard(py, || {
            Hmm::from_json(s).map(|inner| Self { inner }).py_err(py)
        })
    }

    /// Serialise to JSON (with a format version); `from_json` restores it bit for bit.
    fn to_json(&self, py: Python<'_>) -> PyResult<String> {
        guard(py, || self.inner.to_json().py_err(py))
    }

    /// `ln P(x)` by the forward algorithm; `x` is `(n_samples, n_features)`.
    fn log_likelihood(&self, py: Python<'_>, x: Bound<'_, PyAny>) -> PyResult<f64> {
        guard(py, || {
            let x = self.observations(py, &x, "x")?;
            py.detach(|| self.inner.log_likelihood(&x)).py_err(py)
        })
    }

    /// `ln P(x)` of every sequence (in parallel), as a float64 array.
    fn log_likelihood_many<'py>(
        &self,
        py: Python<'py>,
        sequences: Vec<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(py, || {
            let xs = matrix_list(&sequences, "sequences", OBS)?;
            self.check_len(py, extent(&xs).0)?;
            let out = py
                .detach(|| self.inner.log_likelihood_many(&xs))
                .py_err(py)?;
            Ok(ndconv::vector_to_numpy(py, out))
        })
    }

    /// `out[t] = ln P(x[0..=t])` for every `t`, in one forward pass.
    fn prefix_log_likelihoods<'py>(
        &self,
        py: Python<'py>,
        x: Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(py, || {
            let x = self.observations(py, &x, "x")?;
            let out = py
                .detach(|| self.inner.prefix_log_likelihoods(&x))
                .py_err(py)?;
            Ok(ndconv::vector_to_numpy(py, out.as_slice().to_vec()))
        })
    }

    /// Most likely state path: `(ln P(x, path), path)` with `path` an int64 array.
    fn viterbi<'py>(
        &self,
        py: Python<'py>,
        x: Bound<'py, PyAny>,
    ) -> PyResult<(f64, Bound<'py, PyArray1<i64>>)> {
        guard(py, || {
            let x = self.observations(py, &x, "x")?;
            let (score, path) = py.detach(|| self.inner.viterbi(&x)).py_err(py)?;
            Ok((score, ndconv::indices_to_numpy(py, &path)))
        })
    }

    /// State posteriors, `(n_samples, n_states)`, rows sum to 1.
    fn posteriors<'py>(
        &self,
        py: Python<'py>,
        x: Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(py, || {
            let x = self.observations(py, &x, "x")?;
            let p = py.detach(|| self.inner.posteriors(&x)).py_err(py)?;
            Ok(ndconv::to_numpy(py, &p))
        })
    }

    /// Draw `n_samples` observations and their states: `(x (n_samples, n_features), states)`.
    #[pyo3(signature = (n_samples, *, seed = 0))]
    fn sample<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = int_arg)] n_samples: i128,
        #[pyo3(from_py_with = int_arg)] seed: i128,
    ) -> PyResult<Sampled<'py>> {
        guard(py, || {
            let n = count(py, n_samples, "n_samples", 1)?;
            let seed = ndconv::seed(py, seed)?;
            check_table(
                py,
                "n_samples x n_features (samples)",
                &[n, self.inner.n_features()],
                8,
            )?;
            let (x, states) = py.detach(|| self.inner.sample(n, seed)).py_err(py)?;
            Ok((
                ndconv::to_numpy(py, &x),
                ndconv::indices_to_numpy(py, &states),
            ))
        })
    }

    /// Number of hidden states.
    #[getter]
    fn n_states(&self) -> usize {
        self.inner.n_states()
    }

    /// Dimension of one observation.
    #[getter]
    fn n_features(&self) -> usize {
        self.inner.n_features()
    }

    /// Gaussian components per state.
    #[getter]
    fn n_mix(&self) -> usize {
        self.inner.n_mix()
    }

    /// `"diag"` or `"full"`.
    #[getter]
    fn covariance(&self) -> &'static str {
        self.inner.covariance().as_str()
    }

    /// Start probabilities, `(n_states,)`.
    #[getter]
    fn startprob<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(py, || {
            Ok(ndconv::vector_to_numpy(
                py,
                self.inner.startprob().as_slice().to_vec(),
            ))
        })
    }

    /// Transition matrix, `(n_states, n_states)`.
    #[getter]
    fn transmat<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(py, || Ok(ndconv::to_numpy(py, self.inner.transmat())))
    }

    /// Mixture weights, `(n_states, n_mix)`.
    #[getter]
    fn weights<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(py, || Ok(ndconv::to_numpy(py, self.inner.weights())))
    }

    /// Component means, `(n_states, n_mix, n_features)`.
    #[getter]
    fn means<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        guard(py, || {
            let h = &self.inner;
            let shape = (h.n_states(), h.n_mix(), h.n_features());
            Ok(Array3::from_shape_fn(shape, |(j, k, d)| h.means()[j][(k, d)]).into_pyarray(py))
        })
    }

    /// Component covariances as full matrices, `(n_states, n_mix, n_features, n_features)`.
    #[getter]
    fn covars<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray4<f64>>> {
        guard(py, || {
            let h = &self.inner;
            let (n, m, f) = (h.n_states(), h.n_mix(), h.n_features());
            Ok(
                Array4::from_shape_fn((n, m, f, f), |(j, k, r, s)| h.covars()[j][k][(r, s)])
                    .into_pyarray(py),
            )
        })
    }

    fn __repr__(&self) -> String {
        let h = &self.inner;
        format!(
            "Hmm(n_states={}, n_mix={}, n_features={}, covariance={:?})",
            h.n_states(),
            h.n_mix(),
            h.n_features(),
            h.covariance().as_str()
        )
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Self>()
            .is_ok_and(|o| o.get().inner == self.inner)
    }
}

impl PyHmm {
    /// One observation sequence, with the forward tables it needs checked against the budget.
    fn observations(
        &self,
        py: Python<'_>,
        x: &Bound<'_, PyAny>,
        name: &str,
    ) -> PyResult<DMatrix<f64>> {
        let x = matrix(x, name, OBS)?;
        self.check_len(py, x.nrows())?;
        Ok(x)
    }

    /// Refuse sequences whose `n_samples x n_states` tables exceed the budget.
    fn check_len(&self, py: Python<'_>, longest: usize) -> PyResult<()> {
        check_table(
            py,
            "n_samples x n_states (forward table)",
            &[longest, self.inner.n_states()],
            8,
        )
    }
}

/// Add the HMM class to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyHmm>()?;
    Ok(())
}
