//! `lfd._hmmseg`: the thin PyO3 binding of the `hmmseg` engine.
//!
//! Nothing but conversion (numpy <-> nalgebra) and error mapping lives here; every algorithm is
//! in `crates/hmmseg`. Heavy work runs with the interpreter released (`py.detach`).

mod dtw;
mod errors;
mod features;
mod hmm;
mod ndconv;
mod segment;

use pyo3::prelude::*;

#[pymodule]
fn _hmmseg(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    dtw::register(m)?;
    features::register(m)?;
    hmm::register(m)?;
    segment::register(m)?;
    Ok(())
}
