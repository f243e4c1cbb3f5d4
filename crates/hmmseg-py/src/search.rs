//! Bindings of the stage-2 search (`hmmseg::segment::{greedy, dp}`): the grammar compiled once
//! for a skill order ([`PyGrammar`]), the search over a score table, and its result, one
//! [`PyCut`] per segment.

use hmmseg::segment::greedy::greedy;
use hmmseg::segment::{
    dp::dp, Band, Grammar, GrammarMode, GrammarSpec, ScoreTable, Segment, Segmentation,
};
use hmmseg::EngineError;
use std::borrow::Cow;

use numpy::ndarray::IxDyn;
use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;

use crate::errors::{guard, IntoPyResult};
use crate::ndconv::{self, bool_matrix, count, indices, int_arg};
use crate::segment::n_sections;

/// The skill grammar bound to a skill order: parsed, checked and turned into indices once, then
/// passed to every search (immutable).
#[pyclass(name = "Grammar", module = "lfd._hmmseg", frozen)]
pub struct PyGrammar {
    inner: Grammar,
}

#[pymethods]
impl PyGrammar {
    /// Compile the grammar JSON `rules` (the format of `lfd/data/grammar.json`) for `skills`
    /// (the template order). A malformed grammar, an unsupported `format_version` or a name
    /// that is no skill is an `lfd.errors.ModelFormatError`; no skill an `EmptySequenceError`.
    #[new]
    fn new(py: Python<'_>, rules: &str, skills: Vec<String>) -> PyResult<Self> {
        guard(py, || {
            let spec = GrammarSpec::from_json(rules).py_err(py)?;
            Ok(Self {
                inner: Grammar::for_skills(&spec, &skills).py_err(py)?,
            })
        })
    }

    /// Skill names, in index order.
    #[getter]
    fn skills(&self) -> Vec<String> {
        self.inner.skills().to_vec()
    }

    fn __repr__(&self) -> String {
        format!("Grammar(skills={:?})", self.inner.skills())
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Self>()
            .is_ok_and(|o| o.get().inner == self.inner)
    }
}

/// One segment chosen by the search: sections `start_section..end_section`, samples
/// `start..end`, skill index `skill`; `score` (mean log-likelihood per sample), `margin` (nats
/// per sample over the best rival skill, `inf` without one) and `confidence` (posterior
/// probability among the candidate skills) as in `hmmseg::segment::Segment` (immutable).
#[pyclass(name = "Cut", module = "lfd._hmmseg", frozen)]
#[derive(PartialEq)]
pub struct PyCut {
    #[pyo3(get)]
    skill: usize,
    #[pyo3(get)]
    start_section: usize,
    #[pyo3(get)]
    end_section: usize,
    #[pyo3(get)]
    start: usize,
    #[pyo3(get)]
    end: usize,
    #[pyo3(get)]
    score: f64,
    #[pyo3(get)]
    margin: f64,
    #[pyo3(get)]
    confidence: f64,
}

impl From<&Segment> for PyCut {
    fn from(s: &Segment) -> Self {
        Self {
            skill: s.skill,
            start_section: s.start_section,
            end_section: s.end_section,
            start: s.start,
            end: s.end,
            score: s.score,
            margin: s.margin,
            confidence: s.confidence,
        }
    }
}

#[pymethods]
impl PyCut {
    fn __repr__(&self) -> String {
        format!(
            "Cut(skill={}, start_section={}, end_section={}, start={}, end={}, score={:?}, \
             margin={:?}, confidence={:?})",
            self.skill,
            self.start_section,
            self.end_section,
            self.start,
            self.end,
            self.score,
            self.margin,
            self.confidence
        )
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.cast::<Self>().is_ok_and(|o| o.get() == self)
    }
}

/// The segments of a search and its warnings.
type Found = (Vec<PyCut>, Vec<String>);

/// A score table as the searches read it: borrowed from the caller's array where it can be.
type Table<'a> = ScoreTable<Cow<'a, [f64]>>;

/// Scores and rise decisions from numpy -> a [`ScoreTable`] and its rise decisions in band order.
///
/// Either banded, `scores` `(N, S)` over the runs of `Band(boundaries, max_len)` with `rising`
/// `(N,)`, or dense, `scores` `(K, K + 1, S)` over every run with `rising` `(K, K + 1)` (no
/// `max_len` then: a dense table holds every run).
/// A C-contiguous banded table is borrowed, not copied (`view` is the caller's).
fn inputs<'a>(
    py: Python<'_>,
    view: &'a PyReadonlyArrayDyn<'_, f64>,
    boundaries: Vec<usize>,
    rising: Option<&Bound<'_, PyAny>>,
    max_len: usize,
) -> PyResult<(Table<'a>, Option<Vec<bool>>)> {
    let k = n_sections(py, &boundaries)?;
    let a = view.as_array();
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
            let band = t.band().clone();
            let t = ScoreTable::from_entries(band, ns, Cow::Owned(t.into_values()));
            (t.py_err(py)?, true)
        }
        [_, ns] => {
            let band = Band::new(boundaries, max_len).py_err(py)?;
            // read in place from a C-contiguous array, else one copy
            let values = view
                .as_slice()
                .map_or_else(|_| Cow::Owned(a.iter().copied().collect()), Cow::Borrowed);
            let t = ScoreTable::from_entries(band, ns, values).py_err(py)?;
            (t, false)
        }
        _ => {
            return Err(EngineError::ShapeMismatch(format!(
                "scores must be banded (N, n_skills) or dense (K, K + 1, n_skills), got shape \
                 {}",
                ndconv::py_shape(&shape)
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
            let band = table.band();
            let flat = if dense {
                let flat = bool_matrix(r, "rising", k, k + 1)?;
                band.runs().map(|(i, j)| flat[i * (k + 1) + j]).collect()
            } else {
                ndconv::bool_vector(r, "rising", band.n_runs())?
            };
            Some(flat)
        }
    };
    Ok((table, rising))
}

/// The body shared by the searches: read the options and the table, run `search` on them with
/// the interpreter released, return its segments as [`PyCut`]s.
fn run_search(
    py: Python<'_>,
    scores: &Bound<'_, PyAny>,
    boundaries: &Bound<'_, PyAny>,
    rising: Option<&Bound<'_, PyAny>>,
    mode: &str,
    max_len: i128,
    search: impl FnOnce(&Table<'_>, Option<&[bool]>, GrammarMode) -> hmmseg::Result<Segmentation> + Send,
) -> PyResult<Found> {
    guard(py, || {
        let mode: GrammarMode = mode.parse().py_err(py)?;
        let max_len = count(py, max_len, "max_len", 0)?;
        let view = ndconv::readonly::<f64, IxDyn>(
            scores,
            "scores",
            "(n_runs, n_skills) or (n_sections, n_sections + 1, n_skills)",
        )?;
        let (t, r) = inputs(
            py,
            &view,
            indices(boundaries, "boundaries")?,
            rising,
            max_len,
        )?;
        let out = py.detach(|| search(&t, r.as_deref(), mode)).py_err(py)?;
        Ok((out.segments.iter().map(PyCut::from).collect(), out.warnings))
    })
}

/// The paper's greedy loop on a score table; returns `(cuts, warnings)`. `lookahead` values each
/// cut together with its best successor segment (see `hmmseg::segment::greedy`). `scores` is
/// banded, `(N, S)` over the runs of `Band(boundaries, max_len)` (with `rising` `(N,)`), or
/// dense, `(K, K + 1, S)` (with `rising` `(K, K + 1)`, no `max_len`); `S` is the number of the
/// grammar's skills.
#[pyfunction]
#[pyo3(signature = (scores, boundaries, grammar, rising=None, mode="warn", lookahead=false, max_len=0))]
fn segment_greedy(
    py: Python<'_>,
    scores: Bound<'_, PyAny>,
    boundaries: Bound<'_, PyAny>,
    grammar: &PyGrammar,
    rising: Option<Bound<'_, PyAny>>,
    mode: &str,
    lookahead: bool,
    #[pyo3(from_py_with = int_arg)] max_len: i128,
) -> PyResult<Found> {
    let g = &grammar.inner;
    run_search(
        py,
        &scores,
        &boundaries,
        rising.as_ref(),
        mode,
        max_len,
        |t, r, mode| greedy(t, g, r, mode, lookahead),
    )
}

/// The segmental DP on a score table (see `segment_greedy` for the inputs and the result).
#[pyfunction]
#[pyo3(signature = (scores, boundaries, grammar, rising=None, mode="warn", penalty=0.0, max_len=0))]
fn segment_dp(
    py: Python<'_>,
    scores: Bound<'_, PyAny>,
    boundaries: Bound<'_, PyAny>,
    grammar: &PyGrammar,
    rising: Option<Bound<'_, PyAny>>,
    mode: &str,
    penalty: f64,
    #[pyo3(from_py_with = int_arg)] max_len: i128,
) -> PyResult<Found> {
    let g = &grammar.inner;
    run_search(
        py,
        &scores,
        &boundaries,
        rising.as_ref(),
        mode,
        max_len,
        |t, r, mode| dp(t, g, r, mode, penalty),
    )
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyGrammar>()?;
    m.add_class::<PyCut>()?;
    m.add_function(wrap_pyfunction!(segment_greedy, m)?)?;
    m.add_function(wrap_pyfunction!(segment_dp, m)?)?;
    Ok(())
}
