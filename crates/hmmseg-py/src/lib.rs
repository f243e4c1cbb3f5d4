//! `lfd._hmmseg`: the thin PyO3 binding of the `hmmseg` engine (and of the `lfd-mcap`
//! recording reader, [`mcap`]).
//!
//! Nothing but conversion ([`ndconv`]: numpy <-> nalgebra, Python ints -> sizes), size checks
//! before allocating ([`limits`]) and error mapping ([`errors`]) lives here; every algorithm
//! is in `crates/hmmseg`. Every entry point runs inside [`errors::guard`] (a panic becomes
//! `lfd.errors.InternalError`) and heavy work runs with the interpreter released
//! (`py.detach`), so the engine may be called from several Python threads at once.

mod band;
mod dtw;
mod errors;
mod features;
mod hmm;
mod limits;
mod mcap;
mod ndconv;
mod rotation;
mod search;
mod segment;
mod signal;

use hmmseg::features::SizeMeasure;
use hmmseg::hmm::{CovarianceType, Topology};
use hmmseg::segment::scorer::EndState;
use hmmseg::segment::GrammarMode;
use hmmseg::OptionEnum;
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// Add `typing.Literal[...]` of an option enum's names as the module attribute `alias`, so the
/// values Python may pass are the engine's own (`python/lfd/_hmmseg.pyi` repeats them for type
/// checkers; a test compares the two).
fn add_literal<T: OptionEnum>(m: &Bound<'_, PyModule>, alias: &str) -> PyResult<()> {
    let py = m.py();
    let literal = py.import("typing")?.getattr("Literal")?;
    let names = PyTuple::new(py, T::NAMES)?;
    m.add(alias, literal.get_item(names)?)
}

/// Load numpy's C API now, with the module. rust-numpy loads it on first use and panics if
/// that import fails, as it does when a Ctrl+C arrives just then (the import raises
/// `KeyboardInterrupt`): a first engine call during an interrupt would fail with an engine
/// error instead of stopping the run.
fn load_numpy_api(py: Python<'_>) -> PyResult<()> {
    py.import("numpy")?;
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        numpy::dtype::<f64>(py);
    }))
    .map_err(|_| pyo3::exceptions::PyImportError::new_err("lfd._hmmseg cannot load numpy's C API"))
}

#[pymodule]
fn _hmmseg(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::init(m.py())?;
    load_numpy_api(m.py())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    add_literal::<CovarianceType>(m, "CovarianceType")?;
    add_literal::<Topology>(m, "Topology")?;
    add_literal::<GrammarMode>(m, "GrammarMode")?;
    add_literal::<EndState>(m, "EndState")?;
    add_literal::<SizeMeasure>(m, "SizeMeasure")?;
    dtw::register(m)?;
    features::register(m)?;
    hmm::register(m)?;
    segment::register(m)?;
    band::register(m)?;
    search::register(m)?;
    mcap::register(m)?;
    signal::register(m)?;
    rotation::register(m)?;
    m.add_function(wrap_pyfunction!(errors::hooks::raise_engine_error, m)?)?;
    m.add_function(wrap_pyfunction!(errors::hooks::panic, m)?)?;
    Ok(())
}
