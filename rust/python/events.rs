//! Bindings for events: validation of packed event records, and the event filters.

use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;

use super::errors::detach;
use crate::error::Error;
use crate::events::{validate_source, EventSource, PackedEvents, SensorSize};
use crate::filters;

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
    let raw = events.as_slice()?;
    // Read in place: decoding them first took 16 bytes an event, and an abort where that
    // allocation failed.
    detach(py, || {
        let sensor = SensorSize::new(width, height)?;
        let packed = PackedEvents::new(raw)?;
        validate_source(&packed, sensor, previous_t, 0)?;
        Ok(packed.len())
    })
}

/// Which events the background-activity filter keeps (tonic's `denoise` semantics).
#[pyfunction]
fn denoise_mask<'py>(
    py: Python<'py>,
    events: PyReadonlyArray1<'py, u8>,
    width: u16,
    height: u16,
    dt_us: i64,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let raw = events.as_slice()?;
    let keep = detach(py, || {
        let sensor = SensorSize::new(width, height)?;
        let dt = u64::try_from(dt_us)
            .map_err(|_| Error::param("dt_us", format!("must be >= 1 µs, got {dt_us}")))?;
        filters::denoise_mask(&PackedEvents::new(raw)?, sensor, dt)
    })?;
    Ok(keep.into_pyarray(py))
}

/// Crop to the target's aspect (centred) and scale: returns the kept events, as packed
/// 13-byte records with their new `x`, `y`, in one pass after the source's validation.
#[pyfunction]
fn downsample_events<'py>(
    py: Python<'py>,
    events: PyReadonlyArray1<'py, u8>,
    width: u16,
    height: u16,
    target_width: u16,
    target_height: u16,
) -> PyResult<Bound<'py, PyArray1<u8>>> {
    let raw = events.as_slice()?;
    let out = detach(py, || {
        let source = SensorSize::new(width, height)?;
        let target = SensorSize::new(target_width, target_height)?;
        filters::downsample_packed(raw, source, target)
    })?;
    Ok(out.into_pyarray(py))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(validate_events, m)?)?;
    m.add_function(wrap_pyfunction!(denoise_mask, m)?)?;
    m.add_function(wrap_pyfunction!(downsample_events, m)?)?;
    Ok(())
}
