//! numpy <-> nalgebra conversions shared by the DTW and feature bindings.
//!
//! numpy arrays are row-major, nalgebra matrices column-major: every copy goes element by
//! element through logical `(row, column)` indices, so any numpy memory layout is accepted.

use nalgebra::DMatrix;
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;

/// Copy a 2-D numpy array into a matrix of the same shape.
pub fn matrix(x: &PyReadonlyArray2<'_, f64>) -> DMatrix<f64> {
    let a = x.as_array();
    DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[[i, j]])
}

/// Split a `(k, n, c)` array into `k` matrices of `n x c`.
pub fn matrices(x: &PyReadonlyArray3<'_, f64>) -> Vec<DMatrix<f64>> {
    let a = x.as_array();
    let (k, n, c) = a.dim();
    (0..k)
        .map(|o| DMatrix::from_fn(n, c, |i, j| a[[o, i, j]]))
        .collect()
}

/// Row-major copy of a 2-D array (a copy, so the interpreter can be released safely while the
/// engine reads it).
pub fn row_major(x: &PyReadonlyArray2<'_, f64>) -> Vec<f64> {
    match x.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => x.as_array().iter().copied().collect(),
    }
}

/// A matrix as a new 2-D numpy array.
pub fn to_numpy<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// Object indices as a new 1-D int64 numpy array.
pub fn indices_to_numpy<'py>(py: Python<'py>, v: &[usize]) -> Bound<'py, PyArray1<i64>> {
    Array1::from_iter(v.iter().map(|&i| i as i64)).into_pyarray(py)
}
