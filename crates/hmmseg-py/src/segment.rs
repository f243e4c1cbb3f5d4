//! Bindings of stage 1 (`hmmseg::stage1`) and stage 2 (`hmmseg::segment`): section boundaries,
//! the TCP rise decision, score tables, the greedy loop, the segmental DP and skill templates.

use hmmseg::segment::greedy::greedy;
use hmmseg::segment::{dp::dp, Grammar, GrammarMode, GrammarSpec, RiseParams, ScoreTable, Segmentation};
use hmmseg::stage1::{section_boundaries, Criterion, Stage1Params};
use hmmseg::EngineError;
use nalgebra::DMatrix;
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3};
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
            usize::try_from(v)
                .map_err(|_| EngineError::InvalidParameter(format!("{what}[{i}] = {v} is negative")))
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

/// A `(K, K + 1, S)` array of summed log-likelihoods -> [`ScoreTable`].
fn table(
    py: Python<'_>,
    scores: &PyReadonlyArray3<'_, f64>,
    boundaries: Vec<usize>,
) -> PyResult<ScoreTable> {
    let a = scores.as_array();
    let k = boundaries.len().saturating_sub(1);
    let (d0, d1, ns) = a.dim();
    if d0 != k || d1 != k + 1 {
        return Err(EngineError::ShapeMismatch(format!(
            "scores must have shape ({k}, {}, n_skills) for {} boundaries, got ({d0}, {d1}, {ns})",
            k + 1,
            k + 1
        )))
        .py_err(py);
    }
    if a.iter().any(|v| v.is_nan()) {
        return Err(EngineError::NonFinite("scores contain NaN (use -inf to exclude)".into())).py_err(py);
    }
    ScoreTable::from_fn(boundaries, ns, |i, j, s| a[(i, j, s)]).py_err(py)
}

fn table_to_numpy<'py>(py: Python<'py>, t: &ScoreTable) -> Bound<'py, PyArray3<f64>> {
    let k = t.n_sections();
    let arr = Array3::from_shape_vec((k, k + 1, t.n_skills()), t.as_slice().to_vec())
        .unwrap_or_else(|_| Array3::zeros((k, k + 1, t.n_skills())));
    arr.into_pyarray(py)
}

type SegmentTuple = (usize, usize, usize, usize, usize, f64, f64);

fn result(r: Segmentation) -> (Vec<SegmentTuple>, Vec<String>) {
    let segs = r
        .segments
        .iter()
        .map(|s| (s.skill, s.start_section, s.end_section, s.start, s.end, s.score, s.confidence))
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
    let b = py.detach(|| section_boundaries(&v, &t, &params)).py_err(py)?;
    Ok(b.iter().map(|&x| x as i64).collect::<Vec<_>>().into_pyarray(py))
}

/// Is the TCP rising over each run of sections? `(K, K + 1)` bool.
#[pyfunction]
#[pyo3(signature = (z, boundaries, min_rise=0.03, dominance=1.0))]
fn rising_table<'py>(
    py: Python<'py>,
    z: PyReadonlyArray1<'py, f64>,
    boundaries: PyReadonlyArray1<'py, i64>,
    min_rise: f64,
    dominance: f64,
) -> PyResult<Bound<'py, PyArray2<bool>>> {
    let b = to_indices(py, &boundaries, "boundaries")?;
    let z: Vec<f64> = z.as_array().iter().copied().collect();
    let r = hmmseg::segment::rising_table(&z, &b, RiseParams { min_rise, dominance }).py_err(py)?;
    let k = b.len() - 1;
    let arr = Array2::from_shape_vec((k, k + 1), r).unwrap_or_else(|_| Array2::from_elem((k, k + 1), false));
    Ok(arr.into_pyarray(py))
}

fn rising_vec(rising: Option<PyReadonlyArray2<'_, bool>>) -> Option<Vec<bool>> {
    rising.map(|r| r.as_array().iter().copied().collect())
}

/// The paper's greedy loop on a score table; returns `(segments, warnings)`, a segment being
/// `(skill, start_section, end_section, start, end, score, confidence)`.
#[pyfunction]
#[pyo3(signature = (scores, boundaries, skills, grammar_json, rising=None, mode="warn"))]
fn segment_greedy<'py>(
    py: Python<'py>,
    scores: PyReadonlyArray3<'py, f64>,
    boundaries: PyReadonlyArray1<'py, i64>,
    skills: Vec<String>,
    grammar_json: &str,
    rising: Option<PyReadonlyArray2<'py, bool>>,
    mode: &str,
) -> PyResult<(Vec<SegmentTuple>, Vec<String>)> {
    let mode = parse_mode(py, mode)?;
    let t = table(py, &scores, to_indices(py, &boundaries, "boundaries")?)?;
    let g = grammar(py, grammar_json, &skills)?;
    let r = rising_vec(rising);
    let out = py.detach(|| greedy(&t, &g, r.as_deref(), mode)).py_err(py)?;
    Ok(result(out))
}

/// The segmental DP on a score table (see `segment_greedy` for the result).
#[pyfunction]
#[pyo3(signature = (scores, boundaries, skills, grammar_json, rising=None, mode="warn", penalty=0.0))]
fn segment_dp<'py>(
    py: Python<'py>,
    scores: PyReadonlyArray3<'py, f64>,
    boundaries: PyReadonlyArray1<'py, i64>,
    skills: Vec<String>,
    grammar_json: &str,
    rising: Option<PyReadonlyArray2<'py, bool>>,
    mode: &str,
    penalty: f64,
) -> PyResult<(Vec<SegmentTuple>, Vec<String>)> {
    let mode = parse_mode(py, mode)?;
    let t = table(py, &scores, to_indices(py, &boundaries, "boundaries")?)?;
    let g = grammar(py, grammar_json, &skills)?;
    let r = rising_vec(rising);
    let out = py.detach(|| dp(&t, &g, r.as_deref(), mode, penalty)).py_err(py)?;
    Ok(result(out))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(stage1_boundaries, m)?)?;
    m.add_function(wrap_pyfunction!(rising_table, m)?)?;
    m.add_function(wrap_pyfunction!(segment_greedy, m)?)?;
    m.add_function(wrap_pyfunction!(segment_dp, m)?)?;
    let _ = table_to_numpy;
    Ok(())
}
