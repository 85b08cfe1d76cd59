//! Bindings for events: validation of packed event records.

use numpy::PyReadonlyArray1;
use pyo3::prelude::*;

use super::errors::detach;
use crate::events::{decode_packed, Event, SensorSize};

/// Decode and validate packed event records (canonical dtype viewed as `uint8`).
pub fn events_from_bytes(
    py: Python<'_>,
    bytes: &PyReadonlyArray1<'_, u8>,
    width: u16,
    height: u16,
    previous_t: Option<u64>,
) -> PyResult<Vec<Event>> {
    let raw = bytes.as_slice()?;
    detach(py, || {
        let sensor = SensorSize::new(width, height)?;
        decode_packed(raw, sensor, previous_t, 0)
    })
}

/// Validate events given as packed bytes; raise `EventError` naming the first bad event.
#[pyfunction]
#[pyo3(signature = (events, width, height, previous_t=None))]
fn validate_events(
    py: Python<'_>,
    events: PyReadonlyArray1<'_, u8>,
    width: u16,
    height: u16,
    previous_t: Option<u64>,
) -> PyResult<usize> {
    events_from_bytes(py, &events, width, height, previous_t).map(|v| v.len())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(validate_events, m)?)
}
