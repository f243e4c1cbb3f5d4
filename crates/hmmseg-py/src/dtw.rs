//! Bindings of `hmmseg::dtw` and `hmmseg::normalize`.

use hmmseg::{dtw as core, normalize, EngineError};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2};
use pyo3::prelude::*;

use crate::errors::{guard, IntoPyResult};
use crate::ndconv::{count, matrix, matrix_list, opt_int_arg, row_major, to_numpy, vector};

const SEQ: &str = "(n_samples, n_features)";

/// Checked row-major copies of two sequences with equal column counts: `(a, b, dim)`.
fn pair(
    py: Python<'_>,
    a: &Bound<'_, PyAny>,
    b: &Bound<'_, PyAny>,
) -> PyResult<(Vec<f64>, Vec<f64>, usize)> {
    let (ra, _, da) = row_major(a, "a", SEQ)?;
    let (rb, _, db) = row_major(b, "b", SEQ)?;
    if da != db {
        return Err(EngineError::ShapeMismatch(format!(
            "a has {da} columns but b has {db}"
        )))
        .py_err(py);
    }
    Ok((ra, rb, da))
}

/// The Sakoe-Chiba band radius (`None` = unbounded; the engine checks its range).
fn band_arg(py: Python<'_>, band: Option<i128>) -> PyResult<Option<usize>> {
    band.map(|b| count(py, b, "band", 0)).transpose()
}

/// DTW distance and path of two (n, d) and (m, d) sequences.
#[pyfunction]
#[pyo3(signature = (a, b, band=None))]
fn dtw<'py>(
    py: Python<'py>,
    a: Bound<'py, PyAny>,
    b: Bound<'py, PyAny>,
    #[pyo3(from_py_with = opt_int_arg)] band: Option<i128>,
) -> PyResult<(f64, Bound<'py, PyArray2<i64>>)> {
    guard(py, || {
        let band = band_arg(py, band)?;
        let (ra, rb, d) = pair(py, &a, &b)?;
        let res = py
            .detach(|| core::dtw_slices(&ra, &rb, d, band))
            .py_err(py)?;
        let path = Array2::from_shape_fn((res.path.len(), 2), |(k, c)| {
            let (i, j) = res.path[k];
            (if c == 0 { i } else { j }) as i64
        });
        Ok((res.distance, path.into_pyarray(py)))
    })
}

/// DTW distance of two (n, d) and (m, d) sequences, without the path.
#[pyfunction]
#[pyo3(signature = (a, b, band=None))]
fn dtw_distance(
    py: Python<'_>,
    a: Bound<'_, PyAny>,
    b: Bound<'_, PyAny>,
    #[pyo3(from_py_with = opt_int_arg)] band: Option<i128>,
) -> PyResult<f64> {
    guard(py, || {
        let band = band_arg(py, band)?;
        let (ra, rb, d) = pair(py, &a, &b)?;
        py.detach(|| core::dtw_distance_slices(&ra, &rb, d, band))
            .py_err(py)
    })
}

/// Warp each (m_s, d) sequence onto the time axis of the (n, d) reference.
#[pyfunction]
#[pyo3(signature = (reference, seqs, band=None))]
fn align_to_reference<'py>(
    py: Python<'py>,
    reference: Bound<'py, PyAny>,
    seqs: Vec<Bound<'py, PyAny>>,
    #[pyo3(from_py_with = opt_int_arg)] band: Option<i128>,
) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
    guard(py, || {
        let band = band_arg(py, band)?;
        let r = matrix(&reference, "reference", SEQ)?;
        let s = matrix_list(&seqs, "seqs", SEQ)?;
        let out = py
            .detach(|| core::align_to_reference(&r, &s, band))
            .py_err(py)?;
        Ok(out.iter().map(|m| to_numpy(py, m)).collect())
    })
}

/// Per-column min-max normalisation of an (n, d) array to [0, 1].
#[pyfunction]
fn minmax<'py>(py: Python<'py>, x: Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(py, || {
        let m = matrix(&x, "x", SEQ)?;
        let out = py.detach(|| normalize::minmax(&m)).py_err(py)?;
        Ok(to_numpy(py, &out))
    })
}

/// Per-column normalisation of an (n, d) array with fixed bounds lo, hi of length d.
#[pyfunction]
fn minmax_with<'py>(
    py: Python<'py>,
    x: Bound<'py, PyAny>,
    lo: Bound<'py, PyAny>,
    hi: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(py, || {
        let m = matrix(&x, "x", SEQ)?;
        let lo = vector(&lo, "lo", "(n_features,)")?;
        let hi = vector(&hi, "hi", "(n_features,)")?;
        let out = py
            .detach(|| normalize::minmax_with(&m, &lo, &hi))
            .py_err(py)?;
        Ok(to_numpy(py, &out))
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(dtw, m)?)?;
    m.add_function(wrap_pyfunction!(dtw_distance, m)?)?;
    m.add_function(wrap_pyfunction!(align_to_reference, m)?)?;
    m.add_function(wrap_pyfunction!(minmax, m)?)?;
    m.add_function(wrap_pyfunction!(minmax_with, m)?)?;
    Ok(())
}
