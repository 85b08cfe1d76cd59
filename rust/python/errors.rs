//! Error mapping and the GIL-free, panic-safe call wrapper.

use std::panic::{catch_unwind, AssertUnwindSafe};

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::PyClass;

use crate::error::Error;

/// Turn an engine error into an instance of the matching class of `uavsnn.errors`.
///
/// The hierarchy is defined once, in Python (`uavsnn/errors.py`), so that classes can also
/// subclass `ValueError` where callers expect it; the class is looked up when the error is
/// raised. If the package is not importable (the raw extension used on its own) a builtin
/// exception carries the same message.
pub fn to_pyerr(py: Python<'_>, err: &Error) -> PyErr {
    let message = err.to_string();
    let class = py
        .import("uavsnn.errors")
        .and_then(|m| m.getattr(err.python_class()));
    match class.and_then(|c| c.call1((message.clone(),))) {
        Ok(instance) => PyErr::from_value(instance),
        Err(_) => match err {
            Error::Internal(_) => PyRuntimeError::new_err(message),
            _ => PyValueError::new_err(message),
        },
    }
}

/// The wall time a long call runs between checks of Python's signals (the parts of `infer`,
/// the frames of a simulator's batch): Ctrl-C waits about this long at most.
pub const SIGNAL_CHECK_SECONDS: f64 = 0.1;

/// Run `f` with the GIL released, its parallel work on threads this process has (in a forked
/// child too: [`crate::threads::in_live_pool`]); map its error, and any panic, to a `uavsnn`
/// exception.
pub fn detach<T, F>(py: Python<'_>, f: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> crate::Result<T> + Send,
{
    let run = || crate::threads::in_live_pool(f).and_then(|result| result);
    let outcome = py.detach(|| catch_unwind(AssertUnwindSafe(run)));
    match outcome {
        Ok(Ok(value)) => Ok(value),
        Ok(Err(err)) => Err(to_pyerr(py, &err)),
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| (*s).to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            Err(to_pyerr(py, &Error::Internal(what)))
        }
    }
}

/// Map an engine result without releasing the GIL (for cheap calls).
#[allow(dead_code)] // used by the area wrappers as they land
pub fn map<T>(py: Python<'_>, r: crate::Result<T>) -> PyResult<T> {
    r.map_err(|e| to_pyerr(py, &e))
}

/// The error of a call on an object whose other call, on another thread, holds it (such calls
/// let the GIL go while they run): a `StreamError` naming the object (`what`: "the network")
/// and what to do (`instead`), not pyo3's untyped `RuntimeError("Already borrowed")`.
fn in_use(py: Python<'_>, (what, instead): InUse) -> PyErr {
    to_pyerr(
        py,
        &Error::Stream(format!(
            "{what} is in use by another thread (one of its calls is running); wait for it to \
             return, or {instead}"
        )),
    )
}

/// How a class names itself and its remedy in [`in_use`]'s error.
pub type InUse = (&'static str, &'static str);

/// `slf` borrowed to read, or a `StreamError` when another thread's call is changing it.
pub fn read<'py, T: PyClass>(slf: &Bound<'py, T>, names: InUse) -> PyResult<PyRef<'py, T>> {
    slf.try_borrow().map_err(|_| in_use(slf.py(), names))
}

/// `slf` borrowed to change, or a `StreamError` when another thread's call holds it.
pub fn write<'py, T>(slf: &Bound<'py, T>, names: InUse) -> PyResult<PyRefMut<'py, T>>
where
    T: PyClass<Frozen = pyo3::pyclass::boolean_struct::False>,
{
    slf.try_borrow_mut().map_err(|_| in_use(slf.py(), names))
}
