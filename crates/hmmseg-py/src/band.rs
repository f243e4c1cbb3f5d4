//! Binding of [`hmmseg::segment::Band`], the runs of sections a segment may span: the one
//! definition of the band and its run order (`lfd.segmentation.band.Band` is a numpy view of it).

use hmmseg::segment::Band;
use numpy::PyArray1;
use pyo3::prelude::*;

use crate::errors::{guard, IntoPyResult};
use crate::limits::check_table;
use crate::ndconv::{self, count, indices, int_arg};
use crate::segment::n_sections;

/// The start and end sections of every run.
type Runs<'py> = (Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>);

/// The runs of sections of at most `max_len` samples (0: no bound; a single section always)
/// over `boundaries`, stored start section by start section (immutable).
#[pyclass(name = "Band", module = "lfd._hmmseg", frozen)]
pub struct PyBand {
    inner: Band,
}

#[pymethods]
impl PyBand {
    #[new]
    fn new(
        py: Python<'_>,
        boundaries: Bound<'_, PyAny>,
        #[pyo3(from_py_with = int_arg)] max_len: i128,
    ) -> PyResult<Self> {
        guard(py, || {
            let b = indices(&boundaries, "boundaries")?;
            n_sections(py, &b)?;
            let max_len = count(py, max_len, "max_len", 0)?;
            Ok(Self {
                inner: Band::new(b, max_len).py_err(py)?,
            })
        })
    }

    /// Section boundaries `(K + 1,)` (sample indices).
    #[getter]
    fn boundaries<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        ndconv::indices_to_numpy(py, self.inner.boundaries())
    }

    /// The bound on a run's length in samples (0: none).
    #[getter]
    fn max_len(&self) -> usize {
        self.inner.max_len()
    }

    /// Number of sections `K`.
    #[getter]
    fn n_sections(&self) -> usize {
        self.inner.n_sections()
    }

    /// Number of runs `N`.
    #[getter]
    fn n_runs(&self) -> usize {
        self.inner.n_runs()
    }

    /// `(K + 1,)`: the runs starting at section `i` are rows `offsets[i]..offsets[i + 1]`.
    #[getter]
    fn offsets<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        ndconv::indices_to_numpy(py, self.inner.offsets())
    }

    /// `(K,)`: the last end section of the runs starting at each section.
    #[getter]
    fn last_ends<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let last: Vec<usize> = (0..self.inner.n_sections())
            .map(|i| self.inner.last_end(i))
            .collect();
        ndconv::indices_to_numpy(py, &last)
    }

    /// The start and end section `(N,)` of every run, in row order.
    fn runs<'py>(&self, py: Python<'py>) -> PyResult<Runs<'py>> {
        guard(py, || {
            check_table(
                py,
                "n_runs x 2 (run starts and ends)",
                &[self.inner.n_runs(), 2],
                8,
            )?;
            let (starts, ends): (Vec<usize>, Vec<usize>) = self.inner.runs().unzip();
            Ok((
                ndconv::indices_to_numpy(py, &starts),
                ndconv::indices_to_numpy(py, &ends),
            ))
        })
    }

    /// Row of run `i..j`; None outside the band.
    fn index(
        &self,
        #[pyo3(from_py_with = int_arg)] i: i128,
        #[pyo3(from_py_with = int_arg)] j: i128,
    ) -> Option<usize> {
        let i = usize::try_from(i).ok()?;
        let j = usize::try_from(j).ok()?;
        self.inner.index(i, j)
    }

    fn __repr__(&self) -> String {
        format!(
            "Band(n_sections={}, max_len={}, n_runs={})",
            self.inner.n_sections(),
            self.inner.max_len(),
            self.inner.n_runs()
        )
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Self>()
            .is_ok_and(|o| o.get().inner == self.inner)
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyBand>()
}
