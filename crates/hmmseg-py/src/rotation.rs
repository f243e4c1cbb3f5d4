//! Bindings of `hmmseg::rotation`: quaternions `(x, y, z, w)`, rotation matrices, extrinsic
//! x-y-z Euler angles and slerp (scipy-equivalent; `lfd.rotations` wraps them). A row with a
//! NaN gives a NaN row.

use hmmseg::rotation as core;
use numpy::PyArrayDyn;
use pyo3::prelude::*;

use crate::errors::{guard, IntoPyResult};
use crate::ndconv::{shaped, vector};
use crate::signal::fixed_rows;

/// One-argument row conversion: `f` of `x` `(n, *inp)` as `(n, *out)`.
fn convert<'py>(
    py: Python<'py>,
    x: &Bound<'py, PyAny>,
    name: &str,
    inp: &[usize],
    out: &[usize],
    f: fn(&[f64]) -> hmmseg::Result<Vec<f64>>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    guard(py, || {
        let x = fixed_rows(x, name, inp)?;
        let (v, n) = (x.values(), x.n);
        let r = py.detach(|| f(v)).py_err(py)?;
        let mut sh = vec![n];
        sh.extend_from_slice(out);
        shaped(py, &sh, r)
    })
}

/// Unit quaternions `(n, 4)` of quaternions `(n, 4)` (`Rotation.from_quat`).
#[pyfunction]
fn quat_normalize<'py>(
    py: Python<'py>,
    q: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    convert(py, &q, "q", &[4], &[4], core::normalize_many)
}

/// Rotation matrices `(n, 3, 3)` of quaternions `(n, 4)`.
#[pyfunction]
fn quat_to_matrix<'py>(
    py: Python<'py>,
    q: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    convert(py, &q, "q", &[4], &[3, 3], core::to_matrix_many)
}

/// Unit quaternions `(n, 4)` of rotation matrices `(n, 3, 3)` (`Rotation.from_matrix`).
#[pyfunction]
fn quat_from_matrix<'py>(
    py: Python<'py>,
    m: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    convert(py, &m, "m", &[3, 3], &[4], core::from_matrix_many)
}

/// Extrinsic x-y-z Euler angles `(n, 3)` of rotation matrices `(n, 3, 3)`.
#[pyfunction]
fn euler_xyz_from_matrix<'py>(
    py: Python<'py>,
    m: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    convert(py, &m, "m", &[3, 3], &[3], core::euler_xyz_from_matrix_many)
}

/// Rotation matrices `(n, 3, 3)` of extrinsic x-y-z Euler angles `(n, 3)`.
#[pyfunction]
fn matrix_from_euler_xyz<'py>(
    py: Python<'py>,
    e: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    convert(py, &e, "e", &[3], &[3, 3], core::matrix_from_euler_xyz_many)
}

/// Extrinsic x-y-z Euler angles `(n, 3)` of quaternions `(n, 4)`.
#[pyfunction]
fn euler_xyz_from_quat<'py>(
    py: Python<'py>,
    q: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    convert(py, &q, "q", &[4], &[3], core::euler_xyz_from_quat_many)
}

/// Quaternions `(n, 4)` of extrinsic x-y-z Euler angles `(n, 3)`.
#[pyfunction]
fn quat_from_euler_xyz<'py>(
    py: Python<'py>,
    e: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    convert(py, &e, "e", &[3], &[4], core::quat_from_euler_xyz_many)
}

/// Signs flipped so consecutive finite quaternions `(n, 4)` have non-negative dot products.
#[pyfunction]
fn quat_make_continuous<'py>(
    py: Python<'py>,
    q: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    convert(py, &q, "q", &[4], &[4], core::make_continuous)
}

/// `p * q` row by row (`(n, 4)` each, or one of them `(1, 4)`), normalised.
#[pyfunction]
fn quat_multiply<'py>(
    py: Python<'py>,
    p: Bound<'py, PyAny>,
    q: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    guard(py, || {
        let (p, q) = (fixed_rows(&p, "p", &[4])?, fixed_rows(&q, "q", &[4])?);
        let (pv, qv) = (p.values(), q.values());
        let r = py.detach(|| core::compose_many(pv, qv)).py_err(py)?;
        // the engine's pairing decides the rows (one row with none is none)
        shaped(py, &[r.len() / 4, 4], r)
    })
}

/// `R(q) v` (or `R(q)^T v` with `inverse`) row by row (`(n, 4)`, `(n, 3)`; either may be one row).
#[pyfunction]
#[pyo3(signature = (q, v, inverse=false))]
fn quat_apply<'py>(
    py: Python<'py>,
    q: Bound<'py, PyAny>,
    v: Bound<'py, PyAny>,
    inverse: bool,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    guard(py, || {
        let (q, v) = (fixed_rows(&q, "q", &[4])?, fixed_rows(&v, "v", &[3])?);
        let (qv, vv) = (q.values(), v.values());
        let r = py.detach(|| core::apply_many(qv, vv, inverse)).py_err(py)?;
        shaped(py, &[r.len() / 3, 3], r)
    })
}

/// `Slerp(times, Rotation.from_quat(q))(at).as_quat()`: `(len(at), 4)`.
#[pyfunction]
fn quat_slerp<'py>(
    py: Python<'py>,
    times: Bound<'py, PyAny>,
    q: Bound<'py, PyAny>,
    at: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    guard(py, || {
        let times = vector(&times, "times", "(m,)")?;
        let at = vector(&at, "at", "(n,)")?;
        let q = fixed_rows(&q, "q", &[4])?;
        let qv = q.values();
        let r = py.detach(|| core::slerp(&times, qv, &at)).py_err(py)?;
        shaped(py, &[at.len(), 4], r)
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(quat_normalize, m)?)?;
    m.add_function(wrap_pyfunction!(quat_to_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(quat_from_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(euler_xyz_from_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(matrix_from_euler_xyz, m)?)?;
    m.add_function(wrap_pyfunction!(euler_xyz_from_quat, m)?)?;
    m.add_function(wrap_pyfunction!(quat_from_euler_xyz, m)?)?;
    m.add_function(wrap_pyfunction!(quat_make_continuous, m)?)?;
    m.add_function(wrap_pyfunction!(quat_multiply, m)?)?;
    m.add_function(wrap_pyfunction!(quat_apply, m)?)?;
    m.add_function(wrap_pyfunction!(quat_slerp, m)?)?;
    Ok(())
}
