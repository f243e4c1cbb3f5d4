//! Bindings of `hmmseg::features`: the Table I features and target-object labelling.

use hmmseg::features::{self as core, FeatureParams, Scene};
use hmmseg::EngineError;
use nalgebra::{DMatrix, DVector};
use numpy::{PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;

use crate::errors::IntoPyResult;
use crate::ndconv::{indices_to_numpy, matrices, matrix, to_numpy};

/// Parameters from JSON (`None` = defaults).
fn params(py: Python<'_>, json: Option<&str>) -> PyResult<FeatureParams> {
    json.map_or_else(|| Ok(FeatureParams::default()), FeatureParams::from_json)
        .py_err(py)
}

/// Object sizes `(k, 3)`; an array of `k == 0` rows arrives with any column count.
fn sizes(x: &PyReadonlyArray2<'_, f64>) -> DMatrix<f64> {
    matrix(x)
}

/// Non-negative int64 indices as `usize`.
fn indices(py: Python<'_>, x: &PyReadonlyArray1<'_, i64>) -> PyResult<Vec<usize>> {
    x.as_array()
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            usize::try_from(v).map_err(|_| {
                EngineError::InvalidParameter(format!("target[{i}] = {v} is negative"))
            })
        })
        .collect::<hmmseg::Result<Vec<usize>>>()
        .py_err(py)
}

type FeatureArrays<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<i64>>,
);

/// Table I features: returns `(values (n, 10), thresholds (n, 10), target (n,))`.
#[pyfunction]
#[pyo3(signature = (tcp, opening, object_position, object_quaternion, object_size, dt, target=None, params_json=None))]
fn compute_features<'py>(
    py: Python<'py>,
    tcp: PyReadonlyArray2<'py, f64>,
    opening: PyReadonlyArray1<'py, f64>,
    object_position: PyReadonlyArray3<'py, f64>,
    object_quaternion: PyReadonlyArray3<'py, f64>,
    object_size: PyReadonlyArray2<'py, f64>,
    dt: f64,
    target: Option<PyReadonlyArray1<'py, i64>>,
    params_json: Option<&str>,
) -> PyResult<FeatureArrays<'py>> {
    let p = params(py, params_json)?;
    let target = target.map(|t| indices(py, &t)).transpose()?;
    let scene = Scene {
        tcp: matrix(&tcp),
        opening: DVector::from_iterator(
            opening.as_array().len(),
            opening.as_array().iter().copied(),
        ),
        object_position: matrices(&object_position),
        object_quaternion: matrices(&object_quaternion),
        object_size: sizes(&object_size),
        dt,
    };
    let f = py
        .detach(|| core::compute_features(&scene, target.as_deref(), &p))
        .py_err(py)?;
    Ok((
        to_numpy(py, &f.values),
        to_numpy(py, &f.thresholds),
        indices_to_numpy(py, &f.target),
    ))
}

/// Target object index of every sample.
#[pyfunction]
#[pyo3(signature = (tcp, object_position, object_size, dt, params_json=None))]
fn label_targets<'py>(
    py: Python<'py>,
    tcp: PyReadonlyArray2<'py, f64>,
    object_position: PyReadonlyArray3<'py, f64>,
    object_size: PyReadonlyArray2<'py, f64>,
    dt: f64,
    params_json: Option<&str>,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let p = params(py, params_json)?;
    let tcp = matrix(&tcp);
    let pos = matrices(&object_position);
    let size = sizes(&object_size);
    let lab = py
        .detach(|| core::label_targets(&tcp, &pos, &size, dt, &p))
        .py_err(py)?;
    Ok(indices_to_numpy(py, &lab))
}

/// Column names of the feature matrix, in order.
#[pyfunction]
fn feature_names() -> Vec<&'static str> {
    core::FEATURE_NAMES.to_vec()
}

/// The default feature parameters as JSON.
#[pyfunction]
fn default_feature_params() -> String {
    FeatureParams::default().to_json()
}

/// Validate feature parameters given as JSON; returns them normalised (defaults filled in).
#[pyfunction]
fn check_feature_params(py: Python<'_>, params_json: &str) -> PyResult<String> {
    Ok(FeatureParams::from_json(params_json).py_err(py)?.to_json())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(compute_features, m)?)?;
    m.add_function(wrap_pyfunction!(label_targets, m)?)?;
    m.add_function(wrap_pyfunction!(feature_names, m)?)?;
    m.add_function(wrap_pyfunction!(default_feature_params, m)?)?;
    m.add_function(wrap_pyfunction!(check_feature_params, m)?)?;
    Ok(())
}
