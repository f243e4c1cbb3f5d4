//! `lfd._hmmseg.Hmm`: the continuous HMM of `hmmseg::hmm`, wrapped for Python.
//!
//! Arrays in are float64 numpy arrays (the Python face `lfd.engine` converts and checks them);
//! observations are `(n_samples, n_features)`. Work runs with the interpreter released.

use hmmseg::hmm::{CovarianceType, FitConfig, FitReport, Hmm, Topology};
use hmmseg::EngineError;
use nalgebra::{DMatrix, DVector};
use numpy::ndarray::{Array1, Array2, Array3, Array4};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyArray4, PyReadonlyArray1, PyReadonlyArray2,
    PyReadonlyArray3, PyReadonlyArrayDyn, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors::IntoPyResult;

/// Copy a 2-D numpy array (any strides) into a column-major matrix.
fn matrix(a: &PyReadonlyArray2<'_, f64>) -> DMatrix<f64> {
    let (r, c) = (a.shape()[0], a.shape()[1]);
    if let Ok(s) = a.as_slice() {
        DMatrix::from_row_slice(r, c, s)
    } else {
        let v = a.as_array();
        DMatrix::from_fn(r, c, |i, j| v[[i, j]])
    }
}

fn matrices(xs: &[PyReadonlyArray2<'_, f64>]) -> Vec<DMatrix<f64>> {
    xs.iter().map(matrix).collect()
}

fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
    m.transpose().as_slice().to_vec()
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
        sequences: Vec<PyReadonlyArray2<'_, f64>>,
        n_states: usize,
        n_mix: usize,
        covariance: &str,
        topology: &str,
        seed: u64,
        max_iter: usize,
        tol: f64,
        covariance_floor: f64,
    ) -> PyResult<FitResult> {
        let config = FitConfig {
            n_states,
            n_mix,
            covariance: CovarianceType::parse(covariance).py_err(py)?,
            topology: Topology::parse(topology).py_err(py)?,
            seed,
            max_iter,
            tol,
            covariance_floor,
        };
        let xs = matrices(&sequences);
        py.detach(|| Hmm::fit(&xs, &config))
            .map(fit_result)
            .py_err(py)
    }

    /// Baum-Welch from this model's parameters (no re-initialisation).
    /// Returns `(model, log_likelihood_history, n_iter, converged)`.
    #[pyo3(signature = (sequences, *, max_iter, tol = f64::NEG_INFINITY, covariance_floor = 1e-3))]
    fn refit(
        &self,
        py: Python<'_>,
        sequences: Vec<PyReadonlyArray2<'_, f64>>,
        max_iter: usize,
        tol: f64,
        covariance_floor: f64,
    ) -> PyResult<FitResult> {
        let config = FitConfig {
            max_iter,
            tol,
            covariance_floor,
            ..FitConfig::default()
        };
        let xs = matrices(&sequences);
        py.detach(|| self.inner.refit(&xs, &config))
            .map(fit_result)
            .py_err(py)
    }

    /// Build from parameters: `startprob (n,)`, `transmat (n, n)`, `weights (n, m)`,
    /// `means (n, m, f)`, `covars (n, m, f)` for diag or `(n, m, f, f)` for full.
    #[staticmethod]
    #[pyo3(signature = (startprob, transmat, weights, means, covars, covariance = "diag"))]
    fn from_params(
        py: Python<'_>,
        startprob: PyReadonlyArray1<'_, f64>,
        transmat: PyReadonlyArray2<'_, f64>,
        weights: PyReadonlyArray2<'_, f64>,
        means: PyReadonlyArray3<'_, f64>,
        covars: PyReadonlyArrayDyn<'_, f64>,
        covariance: &str,
    ) -> PyResult<Self> {
        let cov = CovarianceType::parse(covariance).py_err(py)?;
        let mu = means.as_array();
        let (n, m, f) = mu.dim();
        let c = covars.as_array();
        let want: Vec<usize> = match cov {
            CovarianceType::Diag => vec![n, m, f],
            CovarianceType::Full => vec![n, m, f, f],
        };
        if c.shape() != want.as_slice() {
            return Err(EngineError::ShapeMismatch(format!(
                "covars has shape {:?}, expected {want:?} for {covariance} covariances",
                c.shape()
            )))
            .py_err(py);
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
        let start = DVector::from_iterator(startprob.len(), startprob.as_array().iter().copied());
        let inner = Hmm::from_params(
            start,
            matrix(&transmat),
            matrix(&weights),
            means_v,
            covars_v,
            cov,
        )
        .py_err(py)?;
        Ok(Self { inner })
    }

    /// Read a model written by `to_json`.
    #[staticmethod]
    fn from_json(py: Python<'_>, s: &str) -> PyResult<Self> {
        Hmm::from_json(s).map(|inner| Self { inner }).py_err(py)
    }

    /// Serialise to JSON (with a format version); `from_json` restores it bit for bit.
    fn to_json(&self, py: Python<'_>) -> PyResult<String> {
        self.inner.to_json().py_err(py)
    }

    /// `ln P(x)` by the forward algorithm; `x` is `(n_samples, n_features)`.
    fn log_likelihood(&self, py: Python<'_>, x: PyReadonlyArray2<'_, f64>) -> PyResult<f64> {
        let x = matrix(&x);
        py.detach(|| self.inner.log_likelihood(&x)).py_err(py)
    }

    /// `ln P(x)` of every sequence (in parallel), as a float64 array.
    fn log_likelihood_many<'py>(
        &self,
        py: Python<'py>,
        sequences: Vec<PyReadonlyArray2<'py, f64>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let xs = matrices(&sequences);
        let out = py
            .detach(|| self.inner.log_likelihood_many(&xs))
            .py_err(py)?;
        Ok(Array1::from_vec(out).into_pyarray(py))
    }

    /// `out[t] = ln P(x[0..=t])` for every `t`, in one forward pass.
    fn prefix_log_likelihoods<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let x = matrix(&x);
        let out = py
            .detach(|| self.inner.prefix_log_likelihoods(&x))
            .py_err(py)?;
        Ok(Array1::from_vec(out.as_slice().to_vec()).into_pyarray(py))
    }

    /// Most likely state path: `(ln P(x, path), path)` with `path` an int64 array.
    fn viterbi<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(f64, Bound<'py, PyArray1<i64>>)> {
        let x = matrix(&x);
        let (score, path) = py.detach(|| self.inner.viterbi(&x)).py_err(py)?;
        let path: Vec<i64> = path.into_iter().map(|s| s as i64).collect();
        Ok((score, Array1::from_vec(path).into_pyarray(py)))
    }

    /// State posteriors, `(n_samples, n_states)`, rows sum to 1.
    fn posteriors<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let x = matrix(&x);
        let p = py.detach(|| self.inner.posteriors(&x)).py_err(py)?;
        let a = Array2::from_shape_vec(p.shape(), row_major(&p)).map_err(|e| {
            pyo3::exceptions::PyRuntimeError::new_err(format!("internal shape error: {e}"))
        })?;
        Ok(a.into_pyarray(py))
    }

    /// Draw `n_samples` observations and their states: `(x (n_samples, n_features), states)`.
    #[pyo3(signature = (n_samples, *, seed = 0))]
    fn sample<'py>(&self, py: Python<'py>, n_samples: usize, seed: u64) -> PyResult<Sampled<'py>> {
        let (x, states) = self.inner.sample(n_samples, seed).py_err(py)?;
        let f = self.inner.n_features();
        let x = Array2::from_shape_vec((n_samples, f), row_major(&x)).map_err(|e| {
            pyo3::exceptions::PyRuntimeError::new_err(format!("internal shape error: {e}"))
        })?;
        let states: Vec<i64> = states.into_iter().map(|s| s as i64).collect();
        Ok((
            x.into_pyarray(py),
            Array1::from_vec(states).into_pyarray(py),
        ))
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
    fn startprob<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_vec(self.inner.startprob().as_slice().to_vec()).into_pyarray(py)
    }

    /// Transition matrix, `(n_states, n_states)`.
    #[getter]
    fn transmat<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let a = self.inner.transmat();
        Array2::from_shape_fn(a.shape(), |(i, j)| a[(i, j)]).into_pyarray(py)
    }

    /// Mixture weights, `(n_states, n_mix)`.
    #[getter]
    fn weights<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let w = self.inner.weights();
        Array2::from_shape_fn(w.shape(), |(i, j)| w[(i, j)]).into_pyarray(py)
    }

    /// Component means, `(n_states, n_mix, n_features)`.
    #[getter]
    fn means<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        let h = &self.inner;
        let shape = (h.n_states(), h.n_mix(), h.n_features());
        Array3::from_shape_fn(shape, |(j, k, d)| h.means()[j][(k, d)]).into_pyarray(py)
    }

    /// Component covariances as full matrices, `(n_states, n_mix, n_features, n_features)`.
    #[getter]
    fn covars<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray4<f64>> {
        let h = &self.inner;
        let (n, m, f) = (h.n_states(), h.n_mix(), h.n_features());
        Array4::from_shape_fn((n, m, f, f), |(j, k, r, s)| h.covars()[j][k][(r, s)])
            .into_pyarray(py)
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

/// Add the HMM class to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyHmm>()?;
    Ok(())
}
