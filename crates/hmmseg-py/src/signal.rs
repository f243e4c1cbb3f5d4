//! Bindings of `hmmseg::signal`: Butterworth design, zero-phase filtering, tridiagonal solves
//! and cubic splines of the preprocessing (scipy-equivalent; `lfd.preprocessing` wraps them).

use hmmseg::signal as core;
use numpy::{
    ndarray::IxDyn, PyArray1, PyArray2, PyArrayDyn, PyArrayMethods, PyReadonlyArray2,
    PyReadonlyArrayDyn, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors::{guard, invalid, shape, IntoPyResult};
use crate::limits::check_table;
use crate::ndconv::{bool_matrix, count, int_arg, py_shape, readonly, shaped, vector};

/// A float64 array `(n, ...)` read as row-major values: in place when it is C-contiguous, else
/// copied once.
pub struct Rows<'py> {
    view: PyReadonlyArrayDyn<'py, f64>,
    copy: Option<Vec<f64>>,
    /// Number of rows.
    pub n: usize,
    /// The shape after the first axis.
    pub trailing: Vec<usize>,
}

impl Rows<'_> {
    /// The values, row-major.
    pub fn values(&self) -> &[f64] {
        match (&self.copy, self.view.as_slice()) {
            (Some(v), _) => v,
            (None, Ok(s)) => s,
            (None, Err(_)) => &[], // never: `rows` copies an array it cannot read in place
        }
    }
}

/// A float64 array `(n, ...)` as row-major values, `n` and the trailing shape.
pub fn rows<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Rows<'py>> {
    let view = readonly::<f64, IxDyn>(obj, name, "(n, ...)")?;
    let sh = view.shape().to_vec();
    if sh.is_empty() {
        return Err(shape(
            obj.py(),
            format!("{name} must have at least 1 dimension"),
        ));
    }
    let copy = match view.as_slice() {
        Ok(_) => None,
        Err(_) => Some(view.as_array().iter().copied().collect()),
    };
    Ok(Rows {
        view,
        copy,
        n: sh[0],
        trailing: sh[1..].to_vec(),
    })
}

/// A float64 array `(n, *trailing)` with a fixed trailing shape (see [`rows`]).
pub fn fixed_rows<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    trailing: &[usize],
) -> PyResult<Rows<'py>> {
    let r = rows(obj, name)?;
    if r.trailing != trailing {
        let n = r.n;
        let mut want = vec![n];
        want.extend_from_slice(trailing);
        let mut got = vec![n];
        got.extend_from_slice(&r.trailing);
        return Err(shape(
            obj.py(),
            format!(
                "{name} must have shape {}, got {}",
                py_shape(&want).replacen(&n.to_string(), "n", 1),
                py_shape(&got)
            ),
        ));
    }
    Ok(r)
}

type Coefficients<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>);

/// `(b, a)` of a Butterworth low-pass: `scipy.signal.butter(order, cutoff, fs=fs)`.
#[pyfunction]
fn butter_lowpass(
    py: Python<'_>,
    #[pyo3(from_py_with = int_arg)] order: i128,
    cutoff: f64,
    fs: f64,
) -> PyResult<Coefficients<'_>> {
    guard(py, || {
        let order = count(py, order, "order", 1)?;
        let (b, a) = core::butter_lowpass(order, cutoff, fs).py_err(py)?;
        Ok((
            crate::ndconv::vector_to_numpy(py, b),
            crate::ndconv::vector_to_numpy(py, a),
        ))
    })
}

/// `scipy.signal.lfilter_zi(b, a)`.
#[pyfunction]
fn lfilter_zi<'py>(
    py: Python<'py>,
    b: Bound<'py, PyAny>,
    a: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    guard(py, || {
        let (b, a) = (vector(&b, "b", "(nb,)")?, vector(&a, "a", "(na,)")?);
        let zi = core::lfilter_zi(&b, &a).py_err(py)?;
        Ok(crate::ndconv::vector_to_numpy(py, zi))
    })
}

/// `scipy.signal.filtfilt(b, a, x, axis=0, padlen=padlen)` of `x` `(n, ...)`.
#[pyfunction]
fn filtfilt<'py>(
    py: Python<'py>,
    b: Bound<'py, PyAny>,
    a: Bound<'py, PyAny>,
    x: Bound<'py, PyAny>,
    #[pyo3(from_py_with = int_arg)] padlen: i128,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    guard(py, || {
        let (b, a) = (vector(&b, "b", "(nb,)")?, vector(&a, "a", "(na,)")?);
        let padlen = count(py, padlen, "padlen", 0)?;
        let x = rows(&x, "x")?;
        let (v, n, t) = (x.values(), x.n, x.trailing.clone());
        let c = t.iter().product();
        let y = py
            .detach(|| core::filtfilt(&b, &a, v, n, c, padlen))
            .py_err(py)?;
        let mut sh = vec![n];
        sh.extend(t);
        shaped(py, &sh, y)
    })
}

type RunsResult<'py> = (Bound<'py, PyArrayDyn<f64>>, Vec<(usize, usize)>);

/// `filtfilt` of `x` `(n, c)` run by run of `ok` `(n, c)`: the filtered signal (NaN where not
/// `ok`) and the `(start, stop)` of the runs of at most `padlen` samples left unfiltered.
#[pyfunction]
fn filtfilt_runs<'py>(
    py: Python<'py>,
    b: Bound<'py, PyAny>,
    a: Bound<'py, PyAny>,
    x: Bound<'py, PyAny>,
    ok: Bound<'py, PyAny>,
    #[pyo3(from_py_with = int_arg)] padlen: i128,
) -> PyResult<RunsResult<'py>> {
    guard(py, || {
        let (b, a) = (vector(&b, "b", "(nb,)")?, vector(&a, "a", "(na,)")?);
        let padlen = count(py, padlen, "padlen", 0)?;
        let x = rows(&x, "x")?;
        let (v, n, t) = (x.values(), x.n, &x.trailing);
        if t.len() != 1 {
            return Err(shape(
                py,
                format!(
                    "x must be a 2-D array (n, c), got {} dimensions",
                    t.len() + 1
                ),
            ));
        }
        let c = t[0];
        let ok = bool_matrix(&ok, "ok", n, c)?;
        let (y, short) = py
            .detach(|| core::filtfilt_runs(&b, &a, v, &ok, n, c, padlen))
            .py_err(py)?;
        Ok((shaped(py, &[n, c], y)?, short))
    })
}

/// Solve the tridiagonal system `(dl, d, du)` for `rhs` `(m, ...)` (LAPACK `dgtsv`).
#[pyfunction]
fn solve_tridiagonal<'py>(
    py: Python<'py>,
    dl: Bound<'py, PyAny>,
    d: Bound<'py, PyAny>,
    du: Bound<'py, PyAny>,
    rhs: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    guard(py, || {
        let dl = vector(&dl, "dl", "(m - 1,)")?;
        let d = vector(&d, "d", "(m,)")?;
        let du = vector(&du, "du", "(m - 1,)")?;
        let rhs = rows(&rhs, "rhs")?;
        let (v, m, t) = (rhs.values(), rhs.n, rhs.trailing.clone());
        let c = t.iter().product();
        if m != d.len() {
            return Err(shape(
                py,
                format!("rhs has {m} rows for a system of {} rows", d.len()),
            ));
        }
        let x = py
            .detach(|| core::solve_tridiagonal(&dl, &d, &du, v, c))
            .py_err(py)?;
        let mut sh = vec![m];
        sh.extend(t);
        shaped(py, &sh, x)
    })
}

/// `scipy.interpolate.CubicSpline(t, y, axis=0)(at)` for `y` `(m, ...)`.
#[pyfunction]
fn cubic_spline<'py>(
    py: Python<'py>,
    t: Bound<'py, PyAny>,
    y: Bound<'py, PyAny>,
    at: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    guard(py, || {
        let t = vector(&t, "t", "(m,)")?;
        let at = vector(&at, "at", "(n,)")?;
        let y = rows(&y, "y")?;
        let (v, m, trailing) = (y.values(), y.n, y.trailing.clone());
        if m != t.len() {
            return Err(shape(py, format!("y has {m} rows for {} knots", t.len())));
        }
        let c = trailing.iter().product();
        check_table(
            py,
            "len(at) x columns of y (spline values)",
            &[at.len(), c],
            8,
        )?;
        let out = py
            .detach(|| core::CubicSpline::new(&t, v, c).map(|s| s.eval(&at)))
            .py_err(py)?;
        let mut sh = vec![at.len()];
        sh.extend(trailing);
        shaped(py, &sh, out)
    })
}

type Resampled<'py> = (Bound<'py, PyArrayDyn<f64>>, Bound<'py, PyArrayDyn<bool>>);

/// Cubic-spline resampling of the columns of `x` `(m, c)` (NaN where not observed) from `ts`
/// to `td`, through confidence-weighted nodes when `weights` `(m, c)` are given: values and
/// valid flags `(len(td), c)` (`lfd.preprocessing.resample.resample_positions`). `x` and
/// `weights` `(m, cw)`, `cw` dividing `c`, are C-contiguous float64 arrays read in place.
#[pyfunction]
#[pyo3(signature = (ts, x, weights, td, max_gap))]
fn resample_columns<'py>(
    py: Python<'py>,
    ts: Bound<'py, PyAny>,
    x: Bound<'py, PyAny>,
    weights: Option<Bound<'py, PyAny>>,
    td: Bound<'py, PyAny>,
    max_gap: f64,
) -> PyResult<Resampled<'py>> {
    guard(py, || {
        let ts = vector(&ts, "ts", "(m,)")?;
        let td = vector(&td, "td", "(n,)")?;
        let (xa, m, c) = contiguous(&x, "x")?;
        if m != ts.len() {
            return Err(shape(py, format!("x has {m} rows for {} times", ts.len())));
        }
        let wa = weights.map(|w| contiguous(&w, "weights")).transpose()?;
        if let Some((_, mw, cw)) = &wa {
            if *mw != m || *cw == 0 || c % cw != 0 {
                return Err(shape(
                    py,
                    format!("weights of shape ({mw}, {cw}) do not fit values of shape ({m}, {c})"),
                ));
            }
        }
        check_table(
            py,
            "len(td) x columns of x (resampled values)",
            &[td.len(), c],
            8,
        )?;
        let xs = xa.as_slice().map_err(|e| shape(py, format!("x: {e}")))?;
        let ws = match &wa {
            Some((w, _, _)) => Some(
                w.as_slice()
                    .map_err(|e| shape(py, format!("weights: {e}")))?,
            ),
            None => None,
        };
        let (values, valid) = py
            .detach(|| core::resample_columns(&ts, xs, c, ws, &td, max_gap))
            .py_err(py)?;
        Ok((
            shaped(py, &[td.len(), c], values)?,
            shaped(py, &[td.len(), c], valid)?,
        ))
    })
}

/// A C-contiguous 2-D float64 array, read in place: `(view, rows, columns)`.
fn contiguous<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<(PyReadonlyArray2<'py, f64>, usize, usize)> {
    let py = obj.py();
    let arr = obj.cast::<PyArray2<f64>>().map_err(|_| {
        invalid(
            py,
            format!("{name} must be a 2-D C-contiguous numpy array of float64"),
        )
    })?;
    if !arr.is_c_contiguous() {
        return Err(invalid(py, format!("{name} must be C-contiguous")));
    }
    let (r, c) = (arr.shape()[0], arr.shape()[1]);
    let view = arr
        .try_readonly()
        .map_err(|e| invalid(py, format!("{name} cannot be read: {e}")))?;
    Ok((view, r, c))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(butter_lowpass, m)?)?;
    m.add_function(wrap_pyfunction!(lfilter_zi, m)?)?;
    m.add_function(wrap_pyfunction!(filtfilt, m)?)?;
    m.add_function(wrap_pyfunction!(filtfilt_runs, m)?)?;
    m.add_function(wrap_pyfunction!(solve_tridiagonal, m)?)?;
    m.add_function(wrap_pyfunction!(cubic_spline, m)?)?;
    m.add_function(wrap_pyfunction!(resample_columns, m)?)?;
    Ok(())
}
