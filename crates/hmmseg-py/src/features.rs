//! Bindings of `hmmseg::features`: the Table I features and target-object labelling.

use hmmseg::features::{self as core, FeatureParams, Scene};
use nalgebra::DVector;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::errors::{guard, IntoPyResult};
use crate::ndconv::{indices, indices_to_numpy, matrix, matrix_stack, to_numpy, vector};

/// Parameters from JSON (`None` = defaults).
fn params(py: Python<'_>, json: Option<&str>) -> PyResult<FeatureParams> {
    json.map_or_else(|| Ok(FeatureParams::default()), FeatureParams::from_json)
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
    tcp: Bound<'py, PyAny>,
    opening: Bound<'py, PyAny>,
    object_position: Bound<'py, PyAny>,
    object_quaternion: Bound<'py, PyAny>,
    object_size: Bound<'py, PyAny>,
    dt: f64,
    target: Option<Bound<'py, PyAny>>,
    params_json: Option<&str>,
) -> PyResult<FeatureArrays<'py>> {
    guard(py, || {
        let p = params(py, params_json)?;
        let target = target.map(|t| indices(&t, "target")).transpose()?;
        let scene = Scene {
            tcp: matrix(&tcp, "tcp", "(n, 3)")?,
            opening: DVector::from_vec(vector(&opening, "opening", "(n,)")?),
            object_position: matrix_stack(&object_position, "object_position", "(k, n, 3)")?,
            object_quaternion: matrix_stack(&object_quaternion, "object_quaternion", "(k, n, 4)")?,
            object_size: matrix(&object_size, "object_size", "(k, 3)")?,
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
    })
}

/// Target object index of every sample.
#[pyfunction]
#[pyo3(signature = (tcp, object_position, object_size, dt, params_json=None))]
fn label_targets<'py>(
    py: Python<'py>,
    tcp: Bound<'py, PyAny>,
    object_position: Bound<'py, PyAny>,
    object_size: Bound<'py, PyAny>,
    dt: f64,
    params_json: Option<&str>,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    guard(py, || {
        let p = params(py, params_json)?;
        let tcp = matrix(&tcp, "tcp", "(n, 3)")?;
        let pos = matrix_stack(&object_position, "object_position", "(k, n, 3)")?;
        let size = matrix(&object_size, "object_size", "(k, 3)")?;
        let lab = py
            .detach(|| core::label_targets(&tcp, &pos, &size, dt, &p))
            .py_err(py)?;
        Ok(indices_to_numpy(py, &lab))
    })
}

/// The default feature parameters as JSON.
#[pyfunction]
fn default_feature_params(py: Python<'_>) -> PyResult<String> {
    guard(py, || FeatureParams::default().to_json().py_err(py))
}

/// Validate feature parameters given as JSON; returns them normalised (defaults filled in).
#[pyfunction]
fn check_feature_params(py: Python<'_>, params_json: &str) -> PyResult<String> {
    guard(py, || {
        FeatureParams::from_json(params_json)
            .py_err(py)?
            .to_json()
            .py_err(py)
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    // The feature columns and the eight Table I features, defined once in the engine.
    m.add("FEATURE_NAMES", PyTuple::new(py, core::FEATURE_NAMES)?)?;
    let groups = core::FEATURE_GROUPS
        .iter()
        .map(|(name, cols)| (*name, cols.start, cols.end).into_pyobject(py))
        .collect::<PyResult<Vec<_>>>()?;
    m.add("FEATURE_GROUPS", PyTuple::new(py, groups)?)?;
    m.add_function(wrap_pyfunction!(compute_features, m)?)?;
    m.add_function(wrap_pyfunction!(label_targets, m)?)?;
    m.add_function(wrap_pyfunction!(default_feature_params, m)?)?;
    m.add_function(wrap_pyfunction!(check_feature_params, m)?)?;
    Ok(())
}
