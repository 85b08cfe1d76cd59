//! Bindings for `stream`; filled in by its issue.

use pyo3::prelude::*;

#[allow(clippy::unnecessary_wraps)]
pub fn register(_m: &Bound<'_, PyModule>) -> PyResult<()> {
    Ok(())
}
