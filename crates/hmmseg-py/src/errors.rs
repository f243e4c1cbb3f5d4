//! Map every [`hmmseg::EngineError`] variant to its Python exception class in `lfd.errors`.

use hmmseg::EngineError;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// The name of the `lfd.errors` class that stands for an engine error variant.
fn class_name(err: &EngineError) -> &'static str {
    match err {
        EngineError::EmptySequence(_) => "EmptySequenceError",
        EngineError::ShapeMismatch(_) => "ShapeMismatchError",
        EngineError::NonFinite(_) => "NonFiniteError",
        EngineError::InvalidParameter(_) => "InvalidParameterError",
        EngineError::NotStochastic(_) => "NotStochasticError",
        EngineError::NotPositiveDefinite(_) => "NotPositiveDefiniteError",
        EngineError::NotConverged(_) => "NotConvergedError",
        EngineError::Format(_) => "ModelFormatError",
    }
}

/// Convert an engine error into the matching `lfd.errors` exception.
pub fn to_py(py: Python<'_>, err: &EngineError) -> PyErr {
    let msg = err.to_string();
    let lookup = || -> PyResult<PyErr> {
        let cls = py.import("lfd.errors")?.getattr(class_name(err))?;
        Ok(PyErr::from_value(cls.call1((msg.clone(),))?))
    };
    lookup().unwrap_or_else(|_| PyRuntimeError::new_err(msg.clone()))
}

/// Extension trait: `result.py_err(py)?` turns an engine result into a Python result.
pub trait IntoPyResult<T> {
    fn py_err(self, py: Python<'_>) -> PyResult<T>;
}

impl<T> IntoPyResult<T> for hmmseg::Result<T> {
    fn py_err(self, py: Python<'_>) -> PyResult<T> {
        self.map_err(|e| to_py(py, &e))
    }
}
