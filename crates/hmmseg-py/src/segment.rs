//! Bindings of stage 1 (`hmmseg::stage1`) and stage 2 (`hmmseg::segment`): section boundaries,
//! the TCP rise decision, score tables, the greedy loop, the segmental DP and skill templates.

use hmmseg::segment::greedy::greedy;
use hmmseg::segment::scorer::EndState;
use hmmseg::segment::templates::{FeatureGroup, TemplateParams, TemplateSet};
use hmmseg::segment::{
    dp::dp, Band, Grammar, GrammarMode, GrammarSpec, RiseParams, ScoreTable, Segmentation,
};
use hmmseg::stage1::{section_boundaries, Criterion, Stage1Params};
use hmmseg::EngineError;
use nalgebra::DMatrix;
use numpy::ndarray::{Array2, Array3};
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2,
    PyReadonlyArrayDyn,
};
use pyo3::prelude::*;

use crate::errors::IntoPyResult;

/// numpy (row-major) -> nalgebra.
fn to_matrix(x: &PyReadonlyArray2<'_, f64>) -> DMatrix<f64> {
    let a = x.as_array();
    DMatrix::from_fn(a.nrows(), a.ncols(), |r, c| a[(r, c)])
}

/// int64 sample indices -> usize, rejecting negative values.
fn to_indices(py: Python<'_>, x: &PyReadonlyArray1<'_, i64>, what: &str) -> PyResult<Vec<usize>> {
    x.as_array()
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            usize::try_from(v).map_err(|_| {
                EngineError::InvalidParameter(format!("{what}[{i}] = {v} is negative"))
            })
        })
        .collect::<hmmseg::Result<Vec<usize>>>()
        .py_err(py)
}

fn parse_mode(py: Python<'_>, mode: &str) -> PyResult<GrammarMode> {
    match mode {
        "off" => Ok(GrammarMode::Off),
        "warn" => Ok(GrammarMode::Warn),
        "enforce" => Ok(GrammarMode::Enforce),
        other => Err(EngineError::InvalidParameter(format!(
            "grammar mode must be 'off', 'warn' or 'enforce', got {other:?}"
        )))
        .py_err(py),
    }
}

fn grammar(py: Python<'_>, grammar_json: &str, skills: &[String]) -> PyResult<Grammar> {
    let spec = GrammarSpec::from_json(grammar_json).py_err(py)?;
    Grammar::for_skills(&spec, skills).py_err(py)
}

/// Scores and rise decisions from numpy -> a [`ScoreTable`] and its rise decisions in band order.
///
/// Either banded, `scores` `(N, S)` over the runs of `Band(boundaries, max_len)` with `rising`
/// `(N,)`, or dense, `scores` `(K, K + 1, S)` over every run with `rising` `(K, K + 1)` (no
/// `max_len` then: a dense table holds every run).
fn inputs(
    py: Python<'_>,
    scores: &PyReadonlyArrayDyn<'_, f64>,
    boundaries: Vec<usize>,
    rising: Option<&PyReadonlyArrayDyn<'_, bool>>,
    max_len: usize,
) -> PyResult<(ScoreTable, Option<Vec<bool>>)> {
    let a = scores.as_array();
    let k = boundaries.len().saturating_sub(1);
    let shape = a.shape().to_vec();
    let (table, dense) = match shape[..] {
        [d0, d1, ns] => {
            if d0 != k || d1 != k + 1 {
                return Err(EngineError::ShapeMismatch(format!(
                    "scores must have shape ({k}, {}, n_skills) for {} boundaries, got \
                     ({d0}, {d1}, {ns})",
                    k + 1,
                    k + 1
                )))
                .py_err(py);
            }
            if max_len != 0 {
                return Err(EngineError::InvalidParameter(
                    "max_len applies to banded (N, n_skills) scores; a (K, K + 1, n_skills) \
                     table holds every run"
                        .into(),
                ))
                .py_err(py);
            }
            let band = Band::new(boundaries, 0).py_err(py)?;
            let t = ScoreTable::from_band_fn(band, ns, |i, j, s| a[[i, j, s]]).py_err(py)?;
            (t, true)
        }
        [_, ns] => {
            let band = Band::new(boundaries, max_len).py_err(py)?;
            let t = ScoreTable::from_values(band, ns, a.iter().copied().collect()).py_err(py)?;
            (t, false)
        }
        _ => {
            return Err(EngineError::ShapeMismatch(format!(
                "scores must be banded (N, n_skills) or dense (K, K + 1, n_skills), got shape \
                 {shape:?}"
            )))
            .py_err(py)
        }
    };
    if a.iter().any(|v| v.is_nan()) {
        return Err(EngineError::NonFinite(
            "scores contain NaN (use -inf to exclude)".into(),
        ))
        .py_err(py);
    }
    let rising = match rising {
        None => None,
        Some(r) => {
            let r = r.as_array();
            let band = table.band();
            let want = if dense { k * (k + 1) } else { band.n_runs() };
            let ndim = if dense { 2 } else { 1 };
            if r.ndim() != ndim || r.len() != want {
                return Err(EngineError::ShapeMismatch(format!(
                    "rising must have shape {} for these scores, got {:?}",
                    if dense {
                        format!("({k}, {})", k + 1)
                    } else {
                        format!("({want},)")
                    },
                    r.shape()
                )))
                .py_err(py);
            }
            let flat: Vec<bool> = r.iter().copied().collect();
            Some(if dense {
                band.runs().map(|(i, j)| flat[i * (k + 1) + j]).collect()
            } else {
                flat
            })
        }
    };
    Ok((table, rising))
}

fn dense_to_numpy<'py>(py: Python<'py>, t: &ScoreTable) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let k = t.n_sections();
    Array3::from_shape_vec((k, k + 1, t.n_skills()), t.to_dense())
        .map(|a| a.into_pyarray(py))
        .map_err(|e| EngineError::ShapeMismatch(format!("score table: {e}")))
        .py_err(py)
}

fn band_to_numpy<'py>(py: Python<'py>, t: &ScoreTable) -> PyResult<Bound<'py, PyArray2<f64>>> {
    Array2::from_shape_vec((t.band().n_runs(), t.n_skills()), t.as_slice().to_vec())
        .map(|a| a.into_pyarray(py))
        .map_err(|e| EngineError::ShapeMismatch(format!("score table: {e}")))
        .py_err(py)
}

type SegmentTuple = (usize, usize, usize, usize, usize, f64, f64, f64);

fn result(r: Segmentation) -> (Vec<SegmentTuple>, Vec<String>) {
    let segs = r
        .segments
        .iter()
        .map(|s| {
            (
                s.skill,
                s.start_section,
                s.end_section,
                s.start,
                s.end,
                s.score,
                s.margin,
                s.confidence,
            )
        })
        .collect();
    (segs, r.warnings)
}

/// Stage-1 section boundaries `[0, ..., n]` from threshold crossings.
#[pyfunction]
#[pyo3(signature = (values, thresholds, columns, hysteresis, min_section))]
fn stage1_boundaries<'py>(
    py: Python<'py>,
    values: PyReadonlyArray2<'py, f64>,
    thresholds: PyReadonlyArray2<'py, f64>,
    columns: Vec<usize>,
    hysteresis: Vec<f64>,
    min_section: usize,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    if columns.len() != hysteresis.len() {
        return Err(EngineError::ShapeMismatch(format!(
            "{} columns but {} hysteresis values",
            columns.len(),
            hysteresis.len()
        )))
        .py_err(py);
    }
    let params = Stage1Params {
        criteria: columns
            .iter()
            .zip(&hysteresis)
            .map(|(&column, &hysteresis)| Criterion { column, hysteresis })
            .collect(),
        min_section,
    };
    let (v, t) = (to_matrix(&values), to_matrix(&thresholds));
    let b = py
        .detach(|| section_boundaries(&v, &t, &params))
        .py_err(py)?;
    Ok(b.iter()
        .map(|&x| x as i64)
        .collect::<Vec<_>>()
        .into_pyarray(py))
}

/// Is the TCP rising over each run of sections? `(K, K + 1)` bool (every run: for small inputs;
/// see `rising_band`).
#[pyfunction]
#[pyo3(signature = (z, boundaries, min_rise=0.02, dominance=0.0))]
fn rising_table<'py>(
    py: Python<'py>,
    z: PyReadonlyArray1<'py, f64>,
    boundaries: PyReadonlyArray1<'py, i64>,
    min_rise: f64,
    dominance: f64,
) -> PyResult<Bound<'py, PyArray2<bool>>> {
    let b = to_indices(py, &boundaries, "boundaries")?;
    let z: Vec<f64> = z.as_array().iter().copied().collect();
    let r = hmmseg::segment::rising_table(
        &z,
        &b,
        RiseParams {
            min_rise,
            dominance,
        },
    )
    .py_err(py)?;
    let k = b.len() - 1;
    Array2::from_shape_vec((k, k + 1), r)
        .map(|a| a.into_pyarray(py))
        .map_err(|e| EngineError::ShapeMismatch(format!("rise table: {e}")))
        .py_err(py)
}

/// Is the TCP rising over each run of the band of `max_len` samples? `(N,)` bool, in the band's
/// run order (see `band_ends`).
#[pyfunction]
#[pyo3(signature = (z, boundaries, max_len, min_rise=0.02, dominance=0.0))]
fn rising_band<'py>(
    py: Python<'py>,
    z: PyReadonlyArray1<'py, f64>,
    boundaries: PyReadonlyArray1<'py, i64>,
    max_len: usize,
    min_rise: f64,
    dominance: f64,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let b = to_indices(py, &boundaries, "boundaries")?;
    let z: Vec<f64> = z.as_array().iter().copied().collect();
    let params = RiseParams {
        min_rise,
        dominance,
    };
    let r = py
        .detach(|| {
            let band = Band::new(b, max_len)?;
            hmmseg::segment::rising_band(&z, &band, params)
        })
        .py_err(py)?;
    Ok(r.into_pyarray(py))
}

/// The band of runs of at most `max_len` samples (0: no bound) over `boundaries`: the last
/// admissible end section of the runs starting at each section, `(K,)` int64. The runs of start
/// section `i` are `i..i + 1`, ..., `i..last[i]`, stored start by start.
#[pyfunction]
fn band_ends<'py>(
    py: Python<'py>,
    boundaries: PyReadonlyArray1<'py, i64>,
    max_len: usize,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let band = Band::new(to_indices(py, &boundaries, "boundaries")?, max_len).py_err(py)?;
    Ok((0..band.n_sections())
        .map(|i| band.last_end(i) as i64)
        .collect::<Vec<_>>()
        .into_pyarray(py))
}

/// The paper's greedy loop on a score table; returns `(segments, warnings)`, a segment being
/// `(skill, start_section, end_section, start, end, score, margin, confidence)`. `lookahead` values each
/// cut together with its best successor segment (see `hmmseg::segment::greedy`). `scores` is
/// banded, `(N, S)` over the runs of the band of `max_len` samples (with `rising` `(N,)`), or
/// dense, `(K, K + 1, S)` (with `rising` `(K, K + 1)`, no `max_len`).
#[pyfunction]
#[pyo3(signature = (scores, boundaries, skills, grammar_json, rising=None, mode="warn", lookahead=false, max_len=0))]
#[allow(clippy::too_many_arguments)]
fn segment_greedy<'py>(
    py: Python<'py>,
    scores: PyReadonlyArrayDyn<'py, f64>,
    boundaries: PyReadonlyArray1<'py, i64>,
    skills: Vec<String>,
    grammar_json: &str,
    rising: Option<PyReadonlyArrayDyn<'py, bool>>,
    mode: &str,
    lookahead: bool,
    max_len: usize,
) -> PyResult<(Vec<SegmentTuple>, Vec<String>)> {
    let mode = parse_mode(py, mode)?;
    let b = to_indices(py, &boundaries, "boundaries")?;
    let (t, r) = inputs(py, &scores, b, rising.as_ref(), max_len)?;
    let g = grammar(py, grammar_json, &skills)?;
    let out = py
        .detach(|| greedy(&t, &g, r.as_deref(), mode, lookahead))
        .py_err(py)?;
    Ok(result(out))
}

/// The segmental DP on a score table (see `segment_greedy` for the inputs and the result).
#[pyfunction]
#[pyo3(signature = (scores, boundaries, skills, grammar_json, rising=None, mode="warn", penalty=0.0, max_len=0))]
#[allow(clippy::too_many_arguments)]
fn segment_dp<'py>(
    py: Python<'py>,
    scores: PyReadonlyArrayDyn<'py, f64>,
    boundaries: PyReadonlyArray1<'py, i64>,
    skills: Vec<String>,
    grammar_json: &str,
    rising: Option<PyReadonlyArrayDyn<'py, bool>>,
    mode: &str,
    penalty: f64,
    max_len: usize,
) -> PyResult<(Vec<SegmentTuple>, Vec<String>)> {
    let mode = parse_mode(py, mode)?;
    let b = to_indices(py, &boundaries, "boundaries")?;
    let (t, r) = inputs(py, &scores, b, rising.as_ref(), max_len)?;
    let g = grammar(py, grammar_json, &skills)?;
    let out = py
        .detach(|| dp(&t, &g, r.as_deref(), mode, penalty))
        .py_err(py)?;
    Ok(result(out))
}

/// Trained skill templates: one HMM per skill x feature plus the normalisation ranges.
#[pyclass(name = "TemplateSet", module = "lfd._hmmseg", frozen)]
struct PyTemplateSet {
    inner: TemplateSet,
}

#[pymethods]
impl PyTemplateSet {
    /// Train from labelled examples `(skill index, raw observations (n, C))`.
    #[staticmethod]
    #[pyo3(signature = (skills, features, examples, params_json=None))]
    fn train(
        py: Python<'_>,
        skills: Vec<String>,
        features: Vec<(String, usize, usize)>,
        examples: Vec<(usize, PyReadonlyArray2<'_, f64>)>,
        params_json: Option<&str>,
    ) -> PyResult<Self> {
        let params = match params_json {
            Some(t) => TemplateParams::with_overrides(t).py_err(py)?,
            None => TemplateParams::default(),
        };
        let features: Vec<FeatureGroup> = features
            .into_iter()
            .map(|(name, start, end)| FeatureGroup { name, start, end })
            .collect();
        let examples: Vec<(usize, DMatrix<f64>)> =
            examples.iter().map(|(s, x)| (*s, to_matrix(x))).collect();
        let inner = py
            .detach(|| TemplateSet::train(&skills, &features, &examples, &params))
            .py_err(py)?;
        Ok(Self { inner })
    }

    /// Read templates from JSON text (checks version, skills and shapes).
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str) -> PyResult<Self> {
        Ok(Self {
            inner: TemplateSet::from_json(text).py_err(py)?,
        })
    }

    /// The templates as JSON text.
    fn to_json(&self, py: Python<'_>) -> PyResult<String> {
        self.inner.to_json().py_err(py)
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
    fn params_json(&self) -> String {
        serde_json::to_string(&self.inner.params).unwrap_or_default()
    }

    /// Map raw observations `(n, C)` to `[0, 1]` with the template ranges.
    fn normalise<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let y = self.inner.normalise(&to_matrix(&x)).py_err(py)?;
        Ok(Array2::from_shape_fn(y.shape(), |(r, c)| y[(r, c)]).into_pyarray(py))
    }

    /// Summed log-likelihoods `(K, K + 1, S)` of every run of sections of raw observations,
    /// `-inf` for runs longer than `max_len` samples (quadratic in the number of sections: for
    /// small inputs; see `score_band`); `end` = "final" (a segment must end in the last HMM
    /// state) or "any"; `features` = the feature indices to sum (all if None).
    #[pyo3(signature = (raw, boundaries, max_len=0, end="final", features=None))]
    fn score_table<'py>(
        &self,
        py: Python<'py>,
        raw: PyReadonlyArray2<'py, f64>,
        boundaries: PyReadonlyArray1<'py, i64>,
        max_len: usize,
        end: &str,
        features: Option<Vec<usize>>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let t = self.scores(py, &raw, &boundaries, max_len, end, features)?;
        dense_to_numpy(py, &t)
    }

    /// Summed log-likelihoods `(N, S)` of the runs of sections of at most `max_len` samples
    /// (the band of `band_ends(boundaries, max_len)`, in its run order); see `score_table`.
    #[pyo3(signature = (raw, boundaries, max_len=0, end="final", features=None))]
    fn score_band<'py>(
        &self,
        py: Python<'py>,
        raw: PyReadonlyArray2<'py, f64>,
        boundaries: PyReadonlyArray1<'py, i64>,
        max_len: usize,
        end: &str,
        features: Option<Vec<usize>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let t = self.scores(py, &raw, &boundaries, max_len, end, features)?;
        band_to_numpy(py, &t)
    }
}

impl PyTemplateSet {
    fn scores(
        &self,
        py: Python<'_>,
        raw: &PyReadonlyArray2<'_, f64>,
        boundaries: &PyReadonlyArray1<'_, i64>,
        max_len: usize,
        end: &str,
        features: Option<Vec<usize>>,
    ) -> PyResult<ScoreTable> {
        let end = match end {
            "final" => EndState::Final,
            "any" => EndState::Any,
            other => {
                return Err(EngineError::InvalidParameter(format!(
                    "end must be 'final' or 'any', got {other:?}"
                )))
                .py_err(py)
            }
        };
        let b = to_indices(py, boundaries, "boundaries")?;
        let x = to_matrix(raw);
        py.detach(|| {
            self.inner
                .score_table(&x, &b, max_len, end, features.as_deref())
        })
        .py_err(py)
    }
}

/// The default template training parameters as JSON.
#[pyfunction]
fn default_template_params() -> String {
    serde_json::to_string(&TemplateParams::default()).unwrap_or_default()
}

/// The default template parameters with the overrides in `overrides_json` (a JSON object)
/// applied and checked, as JSON; unknown keys and bad values raise `InvalidParameterError`.
#[pyfunction]
fn template_params(py: Python<'_>, overrides_json: &str) -> PyResult<String> {
    let params = TemplateParams::with_overrides(overrides_json).py_err(py)?;
    serde_json::to_string(&params)
        .map_err(|e| EngineError::Format(format!("template parameters: {e}")))
        .py_err(py)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyTemplateSet>()?;
    m.add_function(wrap_pyfunction!(default_template_params, m)?)?;
    m.add_function(wrap_pyfunction!(template_params, m)?)?;
    m.add_function(wrap_pyfunction!(stage1_boundaries, m)?)?;
    m.add_function(wrap_pyfunction!(rising_table, m)?)?;
    m.add_function(wrap_pyfunction!(rising_band, m)?)?;
    m.add_function(wrap_pyfunction!(band_ends, m)?)?;
    m.add_function(wrap_pyfunction!(segment_greedy, m)?)?;
    m.add_function(wrap_pyfunction!(segment_dp, m)?)?;
    Ok(())
}
