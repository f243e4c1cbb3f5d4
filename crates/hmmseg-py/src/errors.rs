//! The error contract of the binding: every [`hmmseg::EngineError`] variant becomes its
//! `lfd.errors` class, and a Rust panic becomes `lfd.errors.InternalError`.
//!
//! The classes are imported once, when the module is initialised ([`init`]); if `lfd.errors`
//! cannot be imported (or lacks a class) the import of `lfd._hmmseg` fails. Raising an error
//! is then an exhaustive `match` over the variants and a call of the stored class: no lookup
//! by name, no fallback class.

use std::any::Any;
use std::panic::{catch_unwind, AssertUnwindSafe};

use hmmseg::EngineError;
use pyo3::exceptions::{PyImportError, PyKeyboardInterrupt};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyType;

/// The `lfd.errors` classes the binding raises.
struct Classes {
    empty_sequence: Py<PyType>,
    shape_mismatch: Py<PyType>,
    non_finite: Py<PyType>,
    invalid_parameter: Py<PyType>,
    not_stochastic: Py<PyType>,
    not_positive_definite: Py<PyType>,
    not_converged: Py<PyType>,
    model_format: Py<PyType>,
    internal: Py<PyType>,
    /// `RecordingFormatError` (an `LfdError, ValueError`, not an engine error).
    recording_format: Py<PyType>,
}

static CLASSES: PyOnceLock<Classes> = PyOnceLock::new();

/// Import the `lfd.errors` classes (called once from the module initialiser); any problem is
/// an `ImportError` of `lfd._hmmseg`.
pub fn init(py: Python<'_>) -> PyResult<()> {
    let classes = load(py).map_err(|e| {
        PyImportError::new_err(format!(
            "lfd._hmmseg cannot load its exception classes from lfd.errors: {e}"
        ))
    })?;
    // A second initialisation (a sub-interpreter re-importing the module) keeps the first set.
    let _ = CLASSES.set(py, classes);
    Ok(())
}

fn load(py: Python<'_>) -> PyResult<Classes> {
    let module = py.import("lfd.errors")?;
    let base = module.getattr("EngineError")?.cast_into::<PyType>()?;
    let class = |name: &str| -> PyResult<Py<PyType>> {
        let cls = module.getattr(name)?.cast_into::<PyType>()?;
        if !cls.is_subclass(base.as_any())? {
            return Err(PyImportError::new_err(format!(
                "lfd.errors.{name} is not a subclass of lfd.errors.EngineError"
            )));
        }
        Ok(cls.unbind())
    };
    Ok(Classes {
        empty_sequence: class("EmptySequenceError")?,
        shape_mismatch: class("ShapeMismatchError")?,
        non_finite: class("NonFiniteError")?,
        invalid_parameter: class("InvalidParameterError")?,
        not_stochastic: class("NotStochasticError")?,
        not_positive_definite: class("NotPositiveDefiniteError")?,
        not_converged: class("NotConvergedError")?,
        model_format: class("ModelFormatError")?,
        internal: class("InternalError")?,
        recording_format: {
            let lfd_error = module.getattr("LfdError")?.cast_into::<PyType>()?;
            let cls = module
                .getattr("RecordingFormatError")?
                .cast_into::<PyType>()?;
            if !cls.is_subclass(lfd_error.as_any())? {
                return Err(PyImportError::new_err(
                    "lfd.errors.RecordingFormatError is not a subclass of lfd.errors.LfdError",
                ));
            }
            cls.unbind()
        },
    })
}

fn classes(py: Python<'_>) -> PyResult<&'static Classes> {
    CLASSES
        .get(py)
        .ok_or_else(|| PyImportError::new_err("lfd._hmmseg was used before its initialisation"))
}

/// The class of an engine error variant (exhaustive: a new variant must be mapped here).
fn class_of<'c>(c: &'c Classes, err: &EngineError) -> &'c Py<PyType> {
    match err {
        EngineError::EmptySequence(_) => &c.empty_sequence,
        EngineError::ShapeMismatch(_) => &c.shape_mismatch,
        EngineError::NonFinite(_) => &c.non_finite,
        EngineError::InvalidParameter(_) => &c.invalid_parameter,
        EngineError::NotStochastic(_) => &c.not_stochastic,
        EngineError::NotPositiveDefinite(_) => &c.not_positive_definite,
        EngineError::NotConverged(_) => &c.not_converged,
        EngineError::Format(_) => &c.model_format,
    }
}

fn raise(py: Python<'_>, class: &Py<PyType>, msg: String) -> PyErr {
    match class.bind(py).call1((msg,)) {
        Ok(value) => PyErr::from_value(value),
        Err(e) => e,
    }
}

/// Convert an engine error into the matching `lfd.errors` exception.
pub fn to_py(py: Python<'_>, err: &EngineError) -> PyErr {
    match classes(py) {
        Ok(c) => raise(py, class_of(c, err), err.to_string()),
        Err(e) => e,
    }
}

/// `lfd.errors.InternalError`: a bug in the engine or the binding (a panic, an impossible
/// shape), never the caller's fault.
pub fn internal(py: Python<'_>, msg: &str) -> PyErr {
    match classes(py) {
        Ok(c) => raise(
            py,
            &c.internal,
            format!("internal error in the lfd engine (please report it): {msg}"),
        ),
        Err(e) => e,
    }
}

/// `lfd.errors.RecordingFormatError`: a recording that cannot be read.
pub fn recording_format(py: Python<'_>, msg: String) -> PyErr {
    match classes(py) {
        Ok(c) => raise(py, &c.recording_format, msg),
        Err(e) => e,
    }
}

/// Shorthand: an [`EngineError::InvalidParameter`] as a Python exception.
pub fn invalid(py: Python<'_>, msg: String) -> PyErr {
    to_py(py, &EngineError::InvalidParameter(msg))
}

/// Shorthand: an [`EngineError::ShapeMismatch`] as a Python exception.
pub fn shape(py: Python<'_>, msg: String) -> PyErr {
    to_py(py, &EngineError::ShapeMismatch(msg))
}

fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a Rust panic".to_string()
    }
}

/// Run the body of a Python entry point; a Rust panic inside it becomes
/// `lfd.errors.InternalError` instead of pyo3's `PanicException` (a `BaseException` that
/// `except Exception` does not catch). Every `#[pyfunction]` and `#[pymethods]` body runs
/// through this. Unwinding is safe to stop here: the binding's classes are frozen (nothing
/// is left half-updated) and the engine works on copies of the caller's arrays.
///
/// A panic that carries a `KeyboardInterrupt` (a Python call inside the binding, such as a lazy
/// import, interrupted by Ctrl+C) is that interrupt: it is raised as `KeyboardInterrupt`, so
/// the run stops instead of going on as if one input had failed.
pub fn guard<T>(py: Python<'_>, body: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(body)).unwrap_or_else(|payload| {
        let msg = panic_message(&*payload);
        if msg.contains("KeyboardInterrupt") {
            return Err(PyKeyboardInterrupt::new_err(msg));
        }
        Err(internal(py, &format!("panic: {msg}")))
    })
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

/// Test hooks (`lfd._hmmseg._raise_engine_error`, `lfd._hmmseg._panic`): they exist only so the
/// Python tests can check the error mapping for variants no input reaches and the panic
/// boundary. Not part of the API.
pub mod hooks {
    use super::{guard, EngineError, IntoPyResult};
    use pyo3::prelude::*;

    /// Raise the `lfd.errors` class of the engine error variant named `variant`
    /// (e.g. `"NotConverged"`). Test hook.
    #[pyfunction]
    #[pyo3(name = "_raise_engine_error")]
    pub fn raise_engine_error(py: Python<'_>, variant: &str) -> PyResult<()> {
        guard(py, || {
            let msg = format!("raised by the test hook for {variant}");
            let err = match variant {
                "EmptySequence" => EngineError::EmptySequence(msg),
                "ShapeMismatch" => EngineError::ShapeMismatch(msg),
                "NonFinite" => EngineError::NonFinite(msg),
                "InvalidParameter" => EngineError::InvalidParameter(msg),
                "NotStochastic" => EngineError::NotStochastic(msg),
                "NotPositiveDefinite" => EngineError::NotPositiveDefinite(msg),
                "NotConverged" => EngineError::NotConverged(msg),
                "Format" => EngineError::Format(msg),
                other => {
                    EngineError::InvalidParameter(format!("no engine error variant {other:?}"))
                }
            };
            Err(err).py_err(py)
        })
    }

    /// Panic inside the engine boundary (with the interpreter released, as real work runs).
    /// Test hook.
    #[pyfunction]
    #[pyo3(name = "_panic")]
    pub fn panic(py: Python<'_>, message: &str) -> PyResult<()> {
        guard(py, || {
            py.detach(|| std::panic::panic_any(message.to_string()))
        })
    }
}
