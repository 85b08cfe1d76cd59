//! The PyO3 binding: the only place where the engine meets Python. Compiled with the `python`
//! feature only. Each area of the engine has its own small wrapper module with a `register`
//! function; inputs are converted first, then the work runs with the GIL released through
//! [`errors::detach`], which also turns panics and engine errors into `uavsnn` exceptions.

// PyO3 functions receive their arguments by value; that is the calling convention, not a copy.
#![allow(clippy::needless_pass_by_value)]

mod errors;
mod events;
mod network;
mod portable;
mod signature;
mod sim;
mod stream;
mod windows;

use pyo3::prelude::*;

/// Panic inside the engine's call wrapper, on purpose: the test that no Rust panic crosses into
/// Python (it must arrive as `uavsnn.InternalError`, and the interpreter must carry on).
#[pyfunction]
fn _panic_for_test(py: Python<'_>) -> PyResult<()> {
    errors::detach(py, || -> crate::Result<()> {
        panic!("a deliberate panic for the test")
    })
}

#[pymodule]
#[pyo3(name = "_core")]
fn core_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // Before any work: the process whose rayon pool the engine may use, and that pool's size.
    crate::threads::note_process();
    crate::threads::cap_global_threads();
    events::register(m)?;
    windows::register(m)?;
    network::register(m)?;
    sim::register(m)?;
    portable::register(m)?;
    signature::register(m)?;
    stream::register(m)?;
    m.add_function(wrap_pyfunction!(_panic_for_test, m)?)?;
    Ok(())
}
