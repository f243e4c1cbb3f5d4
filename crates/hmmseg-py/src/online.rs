//! Binding of the online segmenter (`hmmseg::segment::online`): stage 1 and the stage-2 score
//! rows fed one sample at a time, and the online DP fed one section at a time.

use hmmseg::segment::online::{OnlineDp, OnlineScorer, SectionRows, Settled};
use hmmseg::segment::scorer::EndState;
use hmmseg::segment::{Grammar, GrammarMode, GrammarSpec, RiseParams};
use hmmseg::stage1::{Criterion, Stage1Params};
use hmmseg::EngineError;
use numpy::{PyArray1, PyArrayDyn};
use pyo3::prelude::*;

use crate::errors::{guard, IntoPyResult};
use crate::ndconv::{self, count, counts, int_arg, int_list_arg, opt_int_arg, shaped, vector};
use crate::segment::PyTemplateSet;

/// `(skill, start section, end section, start, end, score, margin, confidence, forced)`.
type SettledTuple = (usize, usize, usize, usize, usize, f64, f64, f64, bool);

/// `(boundary index, boundary sample, first start section, scores (R, O, S), rising (R,))`.
type RowsTuple<'py> = (
    usize,
    usize,
    usize,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArray1<bool>>,
);

/// `(start sections (R,), scores (R, O, S))`.
type RunningTuple<'py> = (Bound<'py, PyArray1<i64>>, Bound<'py, PyArrayDyn<f64>>);

fn settled(v: Vec<Settled>) -> Vec<SettledTuple> {
    v.into_iter()
        .map(|x| {
            let s = x.segment;
            (
                s.skill,
                s.start_section,
                s.end_section,
                s.start,
                s.end,
                s.score,
                s.margin,
                s.confidence,
                x.forced,
            )
        })
        .collect()
}

fn rows_tuple(py: Python<'_>, r: SectionRows) -> PyResult<RowsTuple<'_>> {
    let n = r.rising.len();
    let scores = shaped(py, &[n, r.n_objects, r.n_skills], r.scores)?;
    let rising = ndconv::bools_to_numpy(py, r.rising);
    Ok((r.index, r.bound, r.first_start, scores, rising))
}

/// The online segmenter: `push_sample` per sample gives the score rows of each new final
/// section boundary; the caller adds its evidence (co-motion, maximum over objects) and passes
/// the rows to `add_section`, which returns the segments settled.
#[pyclass(name = "OnlineSegmenter", module = "lfd._hmmseg")]
pub struct PyOnlineSegmenter {
    scorer: OnlineScorer,
    dp: OnlineDp,
    n_objects: usize,
    n_stage1: usize,
    n_columns: usize,
    beam: f64,
    stable: Option<usize>,
}

#[pymethods]
impl PyOnlineSegmenter {
    #[new]
    #[pyo3(signature = (templates, grammar_json, shared, n_objects, n_stage1, columns, hysteresis,
        min_section, max_len, end="final", mode="enforce", penalty=0.0, min_rise=0.02,
        dominance=0.0, lag=0, beam=f64::INFINITY, stable=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        templates: &PyTemplateSet,
        grammar_json: &str,
        shared: Vec<bool>,
        #[pyo3(from_py_with = int_arg)] n_objects: i128,
        #[pyo3(from_py_with = int_arg)] n_stage1: i128,
        #[pyo3(from_py_with = int_list_arg)] columns: Vec<i128>,
        hysteresis: Vec<f64>,
        #[pyo3(from_py_with = int_arg)] min_section: i128,
        #[pyo3(from_py_with = int_arg)] max_len: i128,
        end: &str,
        mode: &str,
        penalty: f64,
        min_rise: f64,
        dominance: f64,
        #[pyo3(from_py_with = int_arg)] lag: i128,
        beam: f64,
        #[pyo3(from_py_with = opt_int_arg)] stable: Option<i128>,
    ) -> PyResult<Self> {
        guard(py, || {
            let end: EndState = end.parse().py_err(py)?;
            let mode: GrammarMode = mode.parse().py_err(py)?;
            let columns = counts(py, &columns, "columns", 0)?;
            if columns.len() != hysteresis.len() {
                return Err(EngineError::ShapeMismatch(format!(
                    "{} columns but {} hysteresis values",
                    columns.len(),
                    hysteresis.len()
                )))
                .py_err(py);
            }
            let stage1 = Stage1Params {
                criteria: columns
                    .iter()
                    .zip(&hysteresis)
                    .map(|(&column, &hysteresis)| Criterion { column, hysteresis })
                    .collect(),
                min_section: count(py, min_section, "min_section", 0)?,
            };
            let n_objects = count(py, n_objects, "n_objects", 1)?;
            let n_stage1 = count(py, n_stage1, "n_stage1", 0)?;
            let max_len = count(py, max_len, "max_len", 0)?;
            let lag = count(py, lag, "lag", 0)?;
            let set = templates.set();
            let spec = GrammarSpec::from_json(grammar_json).py_err(py)?;
            let grammar = Grammar::for_skills(&spec, &set.skills).py_err(py)?;
            let scorer = OnlineScorer::new(
                set,
                shared,
                n_objects,
                n_stage1,
                stage1,
                max_len,
                end,
                RiseParams {
                    min_rise,
                    dominance,
                },
            )
            .py_err(py)?;
            let dp = OnlineDp::new(grammar, mode, penalty, max_len, lag).py_err(py)?;
            Ok(Self {
                scorer,
                dp,
                n_objects,
                n_stage1,
                n_columns: set.ranges.len(),
                beam,
                stable: match stable {
                    Some(v) => Some(count(py, v, "stable", 0)?),
                    None => None,
                },
            })
        })
    }

    /// Consume one sample: the stage-1 row and thresholds `(n_stage1,)`, the raw feature rows
    /// with each object as the target `(n_objects, n_columns)` (finite), the TCP height. Returns
    /// the rows of a boundary that became final (or None) and the segments settled by the
    /// hypotheses within `beam` nats agreeing (unless the beam is NaN: off).
    /// Returns the rows of a boundary that became final, or None.
    fn push_sample<'py>(
        &mut self,
        py: Python<'py>,
        stage1_values: Bound<'py, PyAny>,
        stage1_thresholds: Bound<'py, PyAny>,
        obs: Bound<'py, PyAny>,
        z: f64,
    ) -> PyResult<Option<RowsTuple<'py>>> {
        guard(py, || {
            let what = format!("({},)", self.n_stage1);
            let v = vector(&stage1_values, "stage1_values", &what)?;
            let t = vector(&stage1_thresholds, "stage1_thresholds", &what)?;
            let (o, rows, cols) = ndconv::row_major(
                &obs,
                "obs",
                &format!("({}, {})", self.n_objects, self.n_columns),
            )?;
            if rows != self.n_objects || cols != self.n_columns {
                return Err(EngineError::ShapeMismatch(format!(
                    "obs must have shape ({}, {}), got ({rows}, {cols})",
                    self.n_objects, self.n_columns
                )))
                .py_err(py);
            }
            match self.scorer.push(&v, &t, &o, z).py_err(py)? {
                Some(r) => Ok(Some(rows_tuple(py, r)?)),
                None => Ok(None),
            }
        })
    }

    /// End of the samples: the rows of the last section (a tentative boundary is dropped).
    fn finish_samples<'py>(&mut self, py: Python<'py>) -> PyResult<RowsTuple<'py>> {
        guard(py, || {
            let r = self.scorer.finish().py_err(py)?;
            rows_tuple(py, r)
        })
    }

    /// Add the rows of the runs ending at the next boundary `bound` (`scores` `(R, S)`,
    /// `rising` `(R,)`, from section `first_start`); `now`: samples seen. Returns the segments
    /// settled.
    fn add_section(
        &mut self,
        py: Python<'_>,
        #[pyo3(from_py_with = int_arg)] bound: i128,
        #[pyo3(from_py_with = int_arg)] first_start: i128,
        scores: Bound<'_, PyAny>,
        rising: Bound<'_, PyAny>,
        #[pyo3(from_py_with = int_arg)] now: i128,
    ) -> PyResult<Vec<SettledTuple>> {
        guard(py, || {
            let bound = count(py, bound, "bound", 1)?;
            let first_start = count(py, first_start, "first_start", 0)?;
            let now = count(py, now, "now", 0)?;
            let (totals, r, _c) = ndconv::row_major(&scores, "scores", "(n_runs, n_skills)")?;
            let rising = ndconv::bool_vector(&rising, "rising", r)?;
            let out = self
                .dp
                .add_section(bound, first_start, totals, rising, now)
                .py_err(py)?;
            Ok(settled(out))
        })
    }

    /// The segments still going on: for every start section the DP has reached, the summed
    /// log-likelihood of its samples so far per object and skill (any end state): `(start
    /// sections (R,), scores (R, O, S))`.
    fn running<'py>(&self, py: Python<'py>) -> PyResult<RunningTuple<'py>> {
        guard(py, || {
            let (sections, scores) = self.scorer.running(self.dp.n_sections());
            let shape = [sections.len(), self.n_objects, self.dp.n_skills()];
            Ok((
                ndconv::indices_to_numpy(py, &sections),
                shaped(py, &shape, scores)?,
            ))
        })
    }

    /// Settle what every hypothesis within the beam agrees on: `sections` `(R,)` and `scores`
    /// `(R, S)` the running segments (from `running`, with the caller's evidence and object
    /// choice).
    fn converge(
        &mut self,
        py: Python<'_>,
        sections: Bound<'_, PyAny>,
        scores: Bound<'_, PyAny>,
    ) -> PyResult<Vec<SettledTuple>> {
        guard(py, || {
            if self.beam.is_nan() {
                return Ok(Vec::new());
            }
            let sections = ndconv::indices(&sections, "sections")?;
            let (values, r, c) = ndconv::row_major(&scores, "scores", "(n_starts, n_skills)")?;
            if r != sections.len() || c != self.dp.n_skills() {
                return Err(EngineError::ShapeMismatch(format!(
                    "scores must have shape ({}, {}), got ({r}, {c})",
                    sections.len(),
                    self.dp.n_skills()
                )))
                .py_err(py);
            }
            Ok(settled(self.dp.converge_running(
                &sections,
                &values,
                self.beam,
                self.stable,
                self.scorer.n_samples(),
            )))
        })
    }

    /// The clock moved to `now` samples: force the segments older than the lag.
    fn tick(
        &mut self,
        py: Python<'_>,
        #[pyo3(from_py_with = int_arg)] now: i128,
    ) -> PyResult<Vec<SettledTuple>> {
        guard(py, || {
            let now = count(py, now, "now", 0)?;
            Ok(settled(self.dp.tick(now)))
        })
    }

    /// End of the stream (after the last section was added): settle the best complete path.
    fn finish(&mut self, py: Python<'_>) -> PyResult<Vec<SettledTuple>> {
        guard(py, || Ok(settled(self.dp.finish().py_err(py)?)))
    }

    /// The best current path's last segment `(skill, start, end)`, or None.
    fn provisional(&self, py: Python<'_>) -> PyResult<Option<(usize, usize, usize)>> {
        guard(py, || Ok(self.dp.provisional()))
    }

    /// The best current path's unsettled segments `(skill, start, end)`.
    fn best_path(&self, py: Python<'_>) -> PyResult<Vec<(usize, usize, usize)>> {
        guard(py, || Ok(self.dp.best_path()))
    }

    /// Warnings of the DP so far.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.dp.warnings().to_vec()
    }

    /// Samples consumed.
    #[getter]
    fn n_samples(&self) -> usize {
        self.scorer.n_samples()
    }

    /// Final section boundaries so far.
    #[getter]
    fn bounds<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        ndconv::indices_to_numpy(py, self.scorer.bounds())
    }

    /// Start sections whose forward states are kept.
    #[getter]
    fn n_active(&self) -> usize {
        self.scorer.n_active()
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyOnlineSegmenter>()
}
