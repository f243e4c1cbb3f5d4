//! Bindings of stage 1 (`hmmseg::stage1`) and of the stage-2 scores (`hmmseg::segment`): section
//! boundaries, the TCP rise decision, skill templates and their score tables (the search over
//! them is in [`crate::search`], the band of runs in [`crate::band`]).

use hmmseg::segment::scorer::EndState;
use hmmseg::segment::templates::{FeatureGroup, TemplateParams, TemplateSet};
use hmmseg::segment::{Band, RiseParams, ScoreTable};
use hmmseg::stage1::{section_boundaries, Criterion, Stage1Params};
use hmmseg::EngineError;
use nalgebra::DMatrix;
use numpy::{PyArray1, PyArray2, PyArrayDyn};
use pyo3::prelude::*;

use crate::errors::{guard, IntoPyResult};
use crate::limits::{check_hmm, check_table};
use crate::ndconv::{
    self, count, counts, indices, int_arg, int_list_arg, matrix, opt_int_list_arg, shaped,
    to_numpy, vector,
};

const OBS: &str = "(n_samples, n_columns)";

/// Number of sections `K` of `K + 1` boundaries (at least one section).
pub(crate) fn n_sections(py: Python<'_>, boundaries: &[usize]) -> PyResult<usize> {
    match boundaries.len() {
        0 | 1 => Err(EngineError::ShapeMismatch(format!(
            "boundaries must hold at least 2 values (one section), got {}",
            boundaries.len()
        )))
        .py_err(py),
        n => Ok(n - 1),
    }
}

fn dense_to_numpy<'py>(py: Python<'py>, t: &ScoreTable) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let k = t.n_sections();
    shaped(py, &[k, k + 1, t.n_skills()], t.to_dense())
}

/// The banded table as a numpy array `(N, S)` (its entries moved, not copied).
fn band_to_numpy(py: Python<'_>, t: ScoreTable) -> PyResult<Bound<'_, PyArrayDyn<f64>>> {
    let shape = [t.band().n_runs(), t.n_skills()];
    shaped(py, &shape, t.into_values())
}

/// Stage-1 parameters from the Python arguments: a hysteresis per criterion column, the
/// shortest section in samples.
pub(crate) fn stage1_params(
    py: Python<'_>,
    columns: &[i128],
    hysteresis: &[f64],
    min_section: i128,
) -> PyResult<Stage1Params> {
    let columns = counts(py, columns, "columns", 0)?;
    if columns.len() != hysteresis.len() {
        return Err(EngineError::ShapeMismatch(format!(
            "{} columns but {} hysteresis values",
            columns.len(),
            hysteresis.len()
        )))
        .py_err(py);
    }
    Ok(Stage1Params {
        criteria: columns
            .iter()
            .zip(hysteresis)
            .map(|(&column, &hysteresis)| Criterion { column, hysteresis })
            .collect(),
        min_section: count(py, min_section, "min_section", 0)?,
    })
}

/// Stage-1 section boundaries `[0, ..., n]` from threshold crossings.
#[pyfunction]
#[pyo3(signature = (values, thresholds, columns, hysteresis, min_section))]
fn stage1_boundaries<'py>(
    py: Python<'py>,
    values: Bound<'py, PyAny>,
    thresholds: Bound<'py, PyAny>,
    #[pyo3(from_py_with = int_list_arg)] columns: Vec<i128>,
    hysteresis: Vec<f64>,
    #[pyo3(from_py_with = int_arg)] min_section: i128,
) -> PyResult<Bound<'py, numpy::PyArray1<i64>>> {
    guard(py, || {
        let params = stage1_params(py, &columns, &hysteresis, min_section)?;
        let v = matrix(&values, "values", "(n_samples, n_features)")?;
        let t = matrix(&thresholds, "thresholds", "(n_samples, n_features)")?;
        let b = py
            .detach(|| section_boundaries(&v, &t, &params))
            .py_err(py)?;
        Ok(ndconv::indices_to_numpy(py, &b))
    })
}

/// Is the TCP rising over each run of sections? `(K, K + 1)` bool (every run: for small inputs;
/// see `rising_band`).
#[pyfunction]
#[pyo3(signature = (z, boundaries, min_rise=0.02, dominance=0.0))]
fn rising_table<'py>(
    py: Python<'py>,
    z: Bound<'py, PyAny>,
    boundaries: Bound<'py, PyAny>,
    min_rise: f64,
    dominance: f64,
) -> PyResult<Bound<'py, PyArrayDyn<bool>>> {
    guard(py, || {
        let b = indices(&boundaries, "boundaries")?;
        let z = vector(&z, "z", "(n_samples,)")?;
        let k = n_sections(py, &b)?;
        check_table(
            py,
            "n_sections x (n_sections + 1) (rise table)",
            &[k, k + 1],
            1,
        )?;
        let params = RiseParams {
            min_rise,
            dominance,
        };
        let r = py
            .detach(|| hmmseg::segment::rising_table(&z, &b, params))
            .py_err(py)?;
        shaped(py, &[k, k + 1], r)
    })
}

/// Is the TCP rising over each run of the band of `max_len` samples? `(N,)` bool, in the band's
/// run order (see `Band`).
#[pyfunction]
#[pyo3(signature = (z, boundaries, max_len, min_rise=0.02, dominance=0.0))]
fn rising_band<'py>(
    py: Python<'py>,
    z: Bound<'py, PyAny>,
    boundaries: Bound<'py, PyAny>,
    #[pyo3(from_py_with = int_arg)] max_len: i128,
    min_rise: f64,
    dominance: f64,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    guard(py, || {
        let b = indices(&boundaries, "boundaries")?;
        n_sections(py, &b)?;
        let max_len = count(py, max_len, "max_len", 0)?;
        let z = vector(&z, "z", "(n_samples,)")?;
        let params = RiseParams {
            min_rise,
            dominance,
        };
        let band = Band::new(b, max_len).py_err(py)?;
        check_table(py, "n_runs (rise decisions)", &[band.n_runs()], 1)?;
        let r = py
            .detach(|| hmmseg::segment::rising_band(&z, &band, params))
            .py_err(py)?;
        Ok(PyArray1::from_vec(py, r))
    })
}

/// Trained skill templates: one HMM per skill x feature plus the normalisation ranges.
#[pyclass(name = "TemplateSet", module = "lfd._hmmseg", frozen)]
pub struct PyTemplateSet {
    inner: TemplateSet,
}

impl PyTemplateSet {
    /// The engine's template set.
    pub fn set(&self) -> &TemplateSet {
        &self.inner
    }
}

/// A serialisation result (an `lfd.errors.ModelFormatError` if it could not be written).
fn to_json_text(py: Python<'_>, what: &str, text: serde_json::Result<String>) -> PyResult<String> {
    text.map_err(|e| EngineError::Format(format!("{what}: {e}")))
        .py_err(py)
}

#[pymethods]
impl PyTemplateSet {
    /// Train from labelled examples `(skill index, raw observations (n, C))`.
    #[staticmethod]
    #[pyo3(signature = (skills, features, examples, params_json=None))]
    fn train(
        py: Python<'_>,
        skills: Vec<String>,
        features: Vec<(String, Bound<'_, PyAny>, Bound<'_, PyAny>)>,
        examples: Vec<(Bound<'_, PyAny>, Bound<'_, PyAny>)>,
        params_json: Option<&str>,
    ) -> PyResult<Self> {
        guard(py, || {
            let params = match params_json {
                Some(t) => TemplateParams::with_overrides(t).py_err(py)?,
                None => TemplateParams::default(),
            };
            let features: Vec<FeatureGroup> = features
                .into_iter()
                .enumerate()
                .map(|(i, (name, start, end))| {
                    Ok(FeatureGroup {
                        name,
                        start: count(py, int_arg(&start)?, &format!("features[{i}] start"), 0)?,
                        end: count(py, int_arg(&end)?, &format!("features[{i}] end"), 0)?,
                    })
                })
                .collect::<PyResult<_>>()?;
            let examples: Vec<(usize, DMatrix<f64>)> = examples
                .iter()
                .enumerate()
                .map(|(i, (s, x))| {
                    Ok((
                        count(py, int_arg(s)?, &format!("examples[{i}] skill"), 0)?,
                        matrix(x, &format!("examples[{i}] observations"), OBS)?,
                    ))
                })
                .collect::<PyResult<_>>()?;
            let longest = examples.iter().map(|(_, x)| x.nrows()).max().unwrap_or(0);
            let widest = features
                .iter()
                .map(|f| f.end.saturating_sub(f.start))
                .max()
                .unwrap_or(0);
            let fit = &params.fit;
            check_hmm(
                py,
                fit.n_states,
                fit.n_mix,
                widest,
                fit.covariance == hmmseg::hmm::CovarianceType::Full,
                longest,
            )?;
            let inner = py
                .detach(|| TemplateSet::train(&skills, &features, &examples, &params))
                .py_err(py)?;
            Ok(Self { inner })
        })
    }

    /// Read templates from JSON text (checks version, skills and shapes).
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str) -> PyResult<Self> {
        guard(py, || {
            Ok(Self {
                inner: TemplateSet::from_json(text).py_err(py)?,
            })
        })
    }

    /// The templates as JSON text.
    fn to_json(&self, py: Python<'_>) -> PyResult<String> {
        guard(py, || self.inner.to_json().py_err(py))
    }

    /// Skill names, in model order.
    #[getter]
    fn skills(&self) -> Vec<String> {
        self.inner.skills.clone()
    }

    /// Features as `(name, first column, end column)`.
    #[getter]
    fn features(&self) -> Vec<(String, usize, usize)> {
        self.inner
            .features
            .iter()
            .map(|f| (f.name.clone(), f.start, f.end))
            .collect()
    }

    /// `(lo, hi)` normalisation range of every observation column.
    #[getter]
    fn ranges(&self) -> Vec<(f64, f64)> {
        self.inner.ranges.iter().map(|r| (r[0], r[1])).collect()
    }

    /// Training segments per skill.
    #[getter]
    fn n_examples(&self) -> Vec<usize> {
        self.inner.n_examples.clone()
    }

    /// Training parameters as JSON.
    #[getter]
    fn params_json(&self, py: Python<'_>) -> PyResult<String> {
        guard(py, || {
            to_json_text(
                py,
                "template parameters",
                serde_json::to_string(&self.inner.params),
            )
        })
    }

    /// Map raw observations `(n, C)` to `[0, 1]` with the template ranges.
    fn normalise<'py>(
        &self,
        py: Python<'py>,
        x: Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(py, || {
            let x = matrix(&x, "x", OBS)?;
            let y = py.detach(|| self.inner.normalise(&x)).py_err(py)?;
            Ok(to_numpy(py, &y))
        })
    }

    /// Summed log-likelihoods `(K, K + 1, S)` of every run of sections of raw observations,
    /// `-inf` for runs longer than `max_len` samples (quadratic in the number of sections: for
    /// small inputs; see `score_band`); `end` = "final" (a segment must end in the last HMM
    /// state) or "any"; `features` = the feature indices to sum (all if None).
    #[pyo3(signature = (raw, boundaries, max_len=0, end="final", features=None))]
    fn score_table<'py>(
        &self,
        py: Python<'py>,
        raw: Bound<'py, PyAny>,
        boundaries: Bound<'py, PyAny>,
        #[pyo3(from_py_with = int_arg)] max_len: i128,
        end: &str,
        #[pyo3(from_py_with = opt_int_list_arg)] features: Option<Vec<i128>>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        guard(py, || {
            let t = self.scores(py, &raw, &boundaries, max_len, end, features, true)?;
            dense_to_numpy(py, &t)
        })
    }

    /// Summed log-likelihoods `(N, S)` of the runs of sections of at most `max_len` samples
    /// (the runs of `Band(boundaries, max_len)`, in its row order); see `score_table`.
    #[pyo3(signature = (raw, boundaries, max_len=0, end="final", features=None))]
    fn score_band<'py>(
        &self,
        py: Python<'py>,
        raw: Bound<'py, PyAny>,
        boundaries: Bound<'py, PyAny>,
        #[pyo3(from_py_with = int_arg)] max_len: i128,
        end: &str,
        #[pyo3(from_py_with = opt_int_list_arg)] features: Option<Vec<i128>>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        guard(py, || {
            let t = self.scores(py, &raw, &boundaries, max_len, end, features, false)?;
            band_to_numpy(py, t)
        })
    }
}

impl PyTemplateSet {
    /// The score table of `raw` over `boundaries` (`dense`: checked against the size budget as
    /// a `(K, K + 1, S)` table, else as its band).
    #[allow(clippy::too_many_arguments)]
    fn scores(
        &self,
        py: Python<'_>,
        raw: &Bound<'_, PyAny>,
        boundaries: &Bound<'_, PyAny>,
        max_len: i128,
        end: &str,
        features: Option<Vec<i128>>,
        dense: bool,
    ) -> PyResult<ScoreTable> {
        let end: EndState = end.parse().py_err(py)?;
        let max_len = count(py, max_len, "max_len", 0)?;
        let features = features
            .map(|f| counts(py, &f, "features", 0))
            .transpose()?;
        let b = indices(boundaries, "boundaries")?;
        let k = n_sections(py, &b)?;
        let n_skills = self.inner.skills.len();
        if dense {
            check_table(
                py,
                "n_sections x (n_sections + 1) x n_skills (score table)",
                &[k, k + 1, n_skills],
                8,
            )?;
        } else {
            let band = Band::new(b.clone(), max_len).py_err(py)?;
            check_table(
                py,
                "n_runs x n_skills (banded score table)",
                &[band.n_runs(), n_skills],
                8,
            )?;
        }
        let x = matrix(raw, "raw", OBS)?;
        py.detach(|| {
            self.inner
                .score_table(&x, &b, max_len, end, features.as_deref())
        })
        .py_err(py)
    }
}

/// The default template training parameters as JSON.
#[pyfunction]
fn default_template_params(py: Python<'_>) -> PyResult<String> {
    guard(py, || {
        to_json_text(
            py,
            "template parameters",
            serde_json::to_string(&TemplateParams::default()),
        )
    })
}

/// The default template parameters with the overrides in `overrides_json` (a JSON object)
/// applied and checked, as JSON; unknown keys and bad values raise `InvalidParameterError`.
#[pyfunction]
fn template_params(py: Python<'_>, overrides_json: &str) -> PyResult<String> {
    guard(py, || {
        let params = TemplateParams::with_overrides(overrides_json).py_err(py)?;
        to_json_text(py, "template parameters", serde_json::to_string(&params))
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyTemplateSet>()?;
    m.add_function(wrap_pyfunction!(default_template_params, m)?)?;
    m.add_function(wrap_pyfunction!(template_params, m)?)?;
    m.add_function(wrap_pyfunction!(stage1_boundaries, m)?)?;
    m.add_function(wrap_pyfunction!(rising_table, m)?)?;
    m.add_function(wrap_pyfunction!(rising_band, m)?)?;
    Ok(())
}
