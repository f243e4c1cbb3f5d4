//! Bindings of `hmmseg::dtw` and `hmmseg::normalize`.

use hmmseg::{dtw as core, normalize, EngineError};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

use crate::errors::IntoPyResult;
use crate::ndconv::{matrix, row_major, to_numpy};

/// Checked row-major copies of two sequences with equal column counts: `(a, b, dim)`.
fn pair(
    py: Python<'_>,
    a: &PyReadonlyArray2<'_, f64>,
    b: &PyReadonlyArray2<'_, f64>,
) -> PyResult<(Vec<f64>, Vec<f64>, usize)> {
    let (da, db) = (a.as_array().ncols(), b.as_array().ncols());
    if da != db {
        return Err(EngineError::ShapeMismatch(format!(
            "a has {da} columns but b has {db}"
        )))
        .py_err(py);
    }
    Ok((row_major(a), row_major(b), da))
}

/// DTW distance and path of two (n, d) and (m, d) sequences.
#[pyfunction]
#[pyo3(signature = (a, b, band=None))]
fn dtw<'py>(
    py: Python<'py>,
    a: PyReadonlyArray2<'py, f64>,
    b: PyReadonlyArray2<'py, f64>,
    band: Option<usize>,
) -> PyResult<(f64, Bound<'py, PyArray2<i64>>)> {
    let (ra, rb, d) = pair(py, &a, &b)?;
    let res = py
        .detach(|| core::dtw_slices(&ra, &rb, d, band))
        .py_err(py)?;
    let path = Array2::from_shape_fn((res.path.len(), 2), |(k, c)| {
        let (i, j) = res.path[k];
        (if c == 0 { i } else { j }) as i64
    });
    Ok((res.distance, path.into_pyarray(py)))
}

/// DTW distance of two (n, d) and (m, d) sequences, without the path.
#[pyfunction]
#[pyo3(signature = (a, b, band=None))]
fn dtw_distance(
    py: Python<'_>,
    a: PyReadonlyArray2<'_, f64>,
    b: PyReadonlyArray2<'_, f64>,
    band: Option<usize>,
) -> PyResult<f64> {
    let (ra, rb, d) = pair(py, &a, &b)?;
    py.detach(|| core::dtw_distance_slices(&ra, &rb, d, band))
        .py_err(py)
}

/// Warp each (m_s, d) sequence onto the time axis of the (n, d) reference.
#[pyfunction]
#[pyo3(signature = (reference, seqs, band=None))]
fn align_to_reference<'py>(
    py: Python<'py>,
    reference: PyReadonlyArray2<'py, f64>,
    seqs: Vec<PyReadonlyArray2<'py, f64>>,
    band: Option<usize>,
) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
    let r = matrix(&reference);
    let s: Vec<_> = seqs.iter().map(matrix).collect();
    let out = py
        .detach(|| core::align_to_reference(&r, &s, band))
        .py_err(py)?;
    Ok(out.iter().map(|m| to_numpy(py, m)).collect())
}

/// Per-column min-max normalisation of an (n, d) array to [0, 1].
#[pyfunction]
fn minmax<'py>(
    py: Python<'py>,
    x: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m = matrix(&x);
    let out = normalize::minmax(&m).py_err(py)?;
    Ok(to_numpy(py, &out))
}

/// Per-column normalisation of an (n, d) array with fixed bounds lo, hi of length d.
#[pyfunction]
fn minmax_with<'py>(
    py: Python<'py>,
    x: PyReadonlyArray2<'py, f64>,
    lo: PyReadonlyArray1<'py, f64>,
    hi: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m = matrix(&x);
    let lo: Vec<f64> = lo.as_array().to_vec();
    let hi: Vec<f64> = hi.as_array().to_vec();
    let out = normalize::minmax_with(&m, &lo, &hi).py_err(py)?;
    Ok(to_numpy(py, &out))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(dtw, m)?)?;
    m.add_function(wrap_pyfunction!(dtw_distance, m)?)?;
    m.add_function(wrap_pyfunction!(align_to_reference, m)?)?;
    m.add_function(wrap_pyfunction!(minmax, m)?)?;
    m.add_function(wrap_pyfunction!(minmax_with, m)?)?;
    Ok(())
}
