//! The binding's only numpy <-> Rust conversions (arrays and integer arguments).
//!
//! Arrays in: any numpy memory layout (C- or Fortran-ordered, strided views, negative strides)
//! is read by logical `(row, column, ...)` index into an owned copy, so the engine can run
//! with the interpreter released. An argument that is not a numpy array, has the wrong number
//! of dimensions or the wrong dtype is refused with a one-line `lfd.errors` exception naming
//! the argument (`ShapeMismatchError` for the dimensions, `InvalidParameterError` otherwise);
//! nothing is converted silently. Arrays out are new C-ordered arrays.
//!
//! Integers in: sizes and indices arrive as Python ints of any size (`int_arg` and friends, via
//! `#[pyo3(from_py_with = ...)]`) and are range-checked by name with [`count`], so `-1` or
//! `2**70` is an `InvalidParameterError`, not an `OverflowError` or a panic.

use nalgebra::DMatrix;
use numpy::ndarray::{Array1, Array2, ArrayD, ArrayView2, Dimension, Ix1, Ix2, Ix3, IxDyn};
use numpy::{
    Element, IntoPyArray, PyArray, PyArray1, PyArray2, PyArrayDescrMethods, PyArrayDyn,
    PyArrayMethods, PyReadonlyArray, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors::{internal, invalid, shape};

/// A shape as Python writes it: `(3,)`, `(2, 4)`.
pub fn py_shape(shape: &[usize]) -> String {
    if let [n] = shape {
        format!("({n},)")
    } else {
        let dims: Vec<String> = shape.iter().map(ToString::to_string).collect();
        format!("({})", dims.join(", "))
    }
}

/// Read-only view of `obj` as an `ndim`-dimensional array of `T` (`D::NDIM`; any for `IxDyn`).
/// `what` describes the expected shape for the message, e.g. `"(n_samples, n_features)"`.
pub fn readonly<'py, T: Element, D: Dimension>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    what: &str,
) -> PyResult<PyReadonlyArray<'py, T, D>> {
    let py = obj.py();
    let want = numpy::dtype::<T>(py);
    let Ok(untyped) = obj.cast::<PyUntypedArray>() else {
        let ty = obj
            .get_type()
            .name()
            .map_or_else(|_| "?".into(), |n| n.to_string());
        return Err(invalid(
            py,
            format!("{name} must be a numpy array of {want} {what}, got {ty}"),
        ));
    };
    if let Some(nd) = D::NDIM {
        if untyped.ndim() != nd {
            return Err(shape(
                py,
                format!(
                    "{name} must be a {nd}-D array {what}, got shape {}",
                    py_shape(untyped.shape())
                ),
            ));
        }
    }
    let dtype = untyped.dtype();
    if !dtype.is_equiv_to(&want) {
        return Err(invalid(
            py,
            format!("{name} must have dtype {want}, got {dtype}"),
        ));
    }
    let array = untyped
        .cast::<PyArray<T, D>>()
        .map_err(|e| internal(py, &format!("{name}: {e}")))?;
    array
        .try_readonly()
        .map_err(|e| invalid(py, format!("{name} cannot be read: {e}")))
}

/// A 2-D view as a column-major matrix (one `memcpy` for C- or Fortran-contiguous data).
fn view_to_matrix(v: &ArrayView2<'_, f64>) -> DMatrix<f64> {
    let (r, c) = v.dim();
    if let Some(s) = v.as_slice() {
        DMatrix::from_row_slice(r, c, s)
    } else if let Some(s) = v.t().as_slice() {
        DMatrix::from_column_slice(r, c, s)
    } else {
        DMatrix::from_fn(r, c, |i, j| v[[i, j]])
    }
}

/// A 2-D float64 array `(rows, columns)` as a matrix.
pub fn matrix(obj: &Bound<'_, PyAny>, name: &str, what: &str) -> PyResult<DMatrix<f64>> {
    let a = readonly::<f64, Ix2>(obj, name, what)?;
    Ok(view_to_matrix(&a.as_array()))
}

/// A list of 2-D float64 arrays as matrices (named `name[i]` in messages).
pub fn matrix_list(
    objs: &[Bound<'_, PyAny>],
    name: &str,
    what: &str,
) -> PyResult<Vec<DMatrix<f64>>> {
    objs.iter()
        .enumerate()
        .map(|(i, o)| matrix(o, &format!("{name}[{i}]"), what))
        .collect()
}

/// A 3-D float64 array `(k, n, c)` as `k` matrices `n x c`.
pub fn matrix_stack(obj: &Bound<'_, PyAny>, name: &str, what: &str) -> PyResult<Vec<DMatrix<f64>>> {
    let a = readonly::<f64, Ix3>(obj, name, what)?;
    let v = a.as_array();
    Ok(v.outer_iter().map(|m| view_to_matrix(&m)).collect())
}

/// A 2-D float64 array as row-major values: `(values, rows, columns)`.
pub fn row_major(
    obj: &Bound<'_, PyAny>,
    name: &str,
    what: &str,
) -> PyResult<(Vec<f64>, usize, usize)> {
    let a = readonly::<f64, Ix2>(obj, name, what)?;
    let v = a.as_array();
    let (r, c) = v.dim();
    let values = match v.as_slice() {
        Some(s) => s.to_vec(),
        None => v.iter().copied().collect(),
    };
    Ok((values, r, c))
}

/// A 1-D float64 array as a vector.
pub fn vector(obj: &Bound<'_, PyAny>, name: &str, what: &str) -> PyResult<Vec<f64>> {
    let a = readonly::<f64, Ix1>(obj, name, what)?;
    Ok(a.as_array().iter().copied().collect())
}

/// A float64 array of `ndim` dimensions as an owned array in logical (C) order.
pub fn array_nd(
    obj: &Bound<'_, PyAny>,
    name: &str,
    ndim: usize,
    what: &str,
) -> PyResult<ArrayD<f64>> {
    let a = readonly::<f64, IxDyn>(obj, name, what)?;
    let v = a.as_array();
    if v.ndim() != ndim {
        return Err(shape(
            obj.py(),
            format!(
                "{name} must be a {ndim}-D array {what}, got shape {}",
                py_shape(v.shape())
            ),
        ));
    }
    Ok(v.to_owned())
}

/// A 1-D bool array of `len` values.
pub fn bool_vector(obj: &Bound<'_, PyAny>, name: &str, len: usize) -> PyResult<Vec<bool>> {
    let what = format!("({len},)");
    let a = readonly::<bool, Ix1>(obj, name, &what)?;
    let v = a.as_array();
    if v.len() != len {
        return Err(shape(
            obj.py(),
            format!("{name} must have shape {what}, got {}", py_shape(v.shape())),
        ));
    }
    Ok(v.iter().copied().collect())
}

/// A 1-D int64 array of non-negative indices.
pub fn indices(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<usize>> {
    let a = readonly::<i64, Ix1>(obj, name, "of indices")?;
    a.as_array()
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            usize::try_from(v)
                .map_err(|_| invalid(obj.py(), format!("{name}[{i}] = {v} is negative")))
        })
        .collect()
}

/// A 2-D bool array of shape `(rows, cols)`, row-major.
pub fn bool_matrix(
    obj: &Bound<'_, PyAny>,
    name: &str,
    rows: usize,
    cols: usize,
) -> PyResult<Vec<bool>> {
    let what = format!("({rows}, {cols})");
    let a = readonly::<bool, Ix2>(obj, name, &what)?;
    let v = a.as_array();
    if v.dim() != (rows, cols) {
        return Err(shape(
            obj.py(),
            format!("{name} must have shape {what}, got {}", py_shape(v.shape())),
        ));
    }
    Ok(v.iter().copied().collect())
}

// --- integers --------------------------------------------------------------------------------

/// A Python int of any size (for `#[pyo3(from_py_with = int_arg)]`): beyond `i128` it is an
/// `InvalidParameterError`, not an `OverflowError`; a non-int stays a `TypeError`.
pub fn int_arg(obj: &Bound<'_, PyAny>) -> PyResult<i128> {
    match obj.extract::<i128>() {
        Ok(v) => Ok(v),
        Err(e) if e.is_instance_of::<pyo3::exceptions::PyOverflowError>(obj.py()) => {
            Err(invalid(obj.py(), format!("integer {obj} is out of range")))
        }
        Err(e) => Err(e),
    }
}

/// An optional int (`None` stays `None`).
pub fn opt_int_arg(obj: &Bound<'_, PyAny>) -> PyResult<Option<i128>> {
    if obj.is_none() {
        Ok(None)
    } else {
        int_arg(obj).map(Some)
    }
}

/// A sequence of ints.
pub fn int_list_arg(obj: &Bound<'_, PyAny>) -> PyResult<Vec<i128>> {
    if obj.is_instance_of::<pyo3::types::PyString>() {
        return Err(pyo3::exceptions::PyTypeError::new_err(
            "expected a sequence of ints, got str",
        ));
    }
    obj.try_iter()?.map(|item| int_arg(&item?)).collect()
}

/// An optional sequence of ints.
pub fn opt_int_list_arg(obj: &Bound<'_, PyAny>) -> PyResult<Option<Vec<i128>>> {
    if obj.is_none() {
        Ok(None)
    } else {
        int_list_arg(obj).map(Some)
    }
}

/// `value` as a `usize` of at least `min` (an `InvalidParameterError` naming `name` otherwise).
pub fn count(py: Python<'_>, value: i128, name: &str, min: usize) -> PyResult<usize> {
    match usize::try_from(value) {
        Ok(v) if v >= min => Ok(v),
        _ => Err(invalid(
            py,
            format!("{name} must be an integer >= {min}, got {value}"),
        )),
    }
}

/// `value` as a `u64` seed.
pub fn seed(py: Python<'_>, value: i128) -> PyResult<u64> {
    u64::try_from(value).map_err(|_| {
        invalid(
            py,
            format!("seed must be an integer in [0, 2**64), got {value}"),
        )
    })
}

/// Every value of a list as a `usize` of at least `min` (`name[i]` in messages).
pub fn counts(py: Python<'_>, values: &[i128], name: &str, min: usize) -> PyResult<Vec<usize>> {
    values
        .iter()
        .enumerate()
        .map(|(i, &v)| count(py, v, &format!("{name}[{i}]"), min))
        .collect()
}

// --- out ---------------------------------------------------------------------------------------

/// A matrix as a new 2-D numpy array.
pub fn to_numpy<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// A vector as a new 1-D float64 array.
pub fn vector_to_numpy(py: Python<'_>, v: Vec<f64>) -> Bound<'_, PyArray1<f64>> {
    Array1::from_vec(v).into_pyarray(py)
}

/// Indices as a new 1-D int64 array.
pub fn indices_to_numpy<'py>(py: Python<'py>, v: &[usize]) -> Bound<'py, PyArray1<i64>> {
    Array1::from_iter(v.iter().map(|&i| i as i64)).into_pyarray(py)
}

/// Row-major values as a new array of `shape` (an `InternalError` if the sizes disagree).
pub fn shaped<'py, T: Element>(
    py: Python<'py>,
    shape_: &[usize],
    values: Vec<T>,
) -> PyResult<Bound<'py, PyArrayDyn<T>>> {
    ArrayD::from_shape_vec(IxDyn(shape_), values)
        .map(|a| a.into_pyarray(py))
        .map_err(|e| internal(py, &format!("result of shape {shape_:?}: {e}")))
}
