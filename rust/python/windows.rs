//! Bindings for `windows`: making windows from packed events, frames, and noise.
//!
//! Windows cross the boundary as their CSR columns (`t0`, `offsets`, `t`, `x`, `y`,
//! `n_preceding`); the Python `uavsnn.windows.Windows` holds them.

use numpy::{IntoPyArray, PyArray1, PyArray3, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;

use super::errors::detach;
use crate::error::{Error, Result};
use crate::events::{PackedEvents, SensorSize};
use crate::windows::{self, WindowConfig, Windows, WindowsView};

/// The CSR columns of windows, as NumPy arrays.
type WindowArrays<'py> = (
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray1<u16>>,
    Bound<'py, PyArray1<u16>>,
    Bound<'py, PyArray1<i64>>,
);

/// A non-negative integer parameter, or a typed error naming it.
fn non_negative(name: &'static str, value: i64) -> Result<u64> {
    u64::try_from(value).map_err(|_| Error::param(name, format!("must be >= 0, got {value}")))
}

fn to_i64(values: Vec<usize>) -> Vec<i64> {
    values.into_iter().map(|v| v as i64).collect()
}

fn into_arrays(py: Python<'_>, w: Windows) -> WindowArrays<'_> {
    (
        w.t0.into_pyarray(py),
        to_i64(w.offsets).into_pyarray(py),
        w.t.into_pyarray(py),
        w.x.into_pyarray(py),
        w.y.into_pyarray(py),
        w.n_preceding
            .into_iter()
            .map(|v| v as i64)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )
}

/// Borrowed CSR columns received from Python.
struct Columns<'a> {
    t0: &'a [u64],
    offsets: Vec<usize>,
    t: &'a [u64],
    x: &'a [u16],
    y: &'a [u16],
}

impl<'a> Columns<'a> {
    fn new(
        t0: &'a PyReadonlyArray1<'_, u64>,
        offsets: &PyReadonlyArray1<'_, i64>,
        t: &'a PyReadonlyArray1<'_, u64>,
        x: &'a PyReadonlyArray1<'_, u16>,
        y: &'a PyReadonlyArray1<'_, u16>,
    ) -> PyResult<Self> {
        Ok(Self {
            t0: t0.as_slice()?,
            offsets: offsets
                .as_slice()?
                .iter()
                .map(|&o| usize::try_from(o).unwrap_or(usize::MAX))
                .collect(),
            t: t.as_slice()?,
            x: x.as_slice()?,
            y: y.as_slice()?,
        })
    }

    /// A checked view (negative offsets became `usize::MAX` and fail the check).
    fn view(&self, width: u16, height: u16, length_us: i64) -> Result<WindowsView<'_>> {
        let sensor = SensorSize::new(width, height)?;
        WindowsView::new(
            sensor,
            non_negative("length_us", length_us)?,
            self.t0,
            &self.offsets,
            self.t,
            self.x,
            self.y,
        )
    }
}

/// The step between window starts in µs: `L·(1 − o)` rounded down, at least 1.
#[pyfunction]
fn window_step(py: Python<'_>, length_us: i64, overlap: f64) -> PyResult<u64> {
    detach(py, || {
        windows::window_step(non_negative("length_us", length_us)?, overlap)
    })
}

/// Cut packed canonical events into windows; returns the CSR columns.
#[pyfunction]
#[pyo3(signature = (events, width, height, length_us, overlap=0.0, median=false, start_us=None, end_us=None))]
fn make_windows<'py>(
    py: Python<'py>,
    events: PyReadonlyArray1<'py, u8>,
    width: u16,
    height: u16,
    length_us: i64,
    overlap: f64,
    median: bool,
    start_us: Option<i64>,
    end_us: Option<i64>,
) -> PyResult<WindowArrays<'py>> {
    let raw = events.as_slice()?;
    let w = detach(py, || {
        let sensor = SensorSize::new(width, height)?;
        let config = WindowConfig::new(non_negative("length_us", length_us)?, overlap)?
            .with_median(median)
            .with_range(
                start_us.map(|v| non_negative("start_us", v)).transpose()?,
                end_us.map(|v| non_negative("end_us", v)).transpose()?,
            );
        windows::make_windows(&PackedEvents::new(raw)?, sensor, &config)
    })?;
    Ok(into_arrays(py, w))
}

/// Check windows' CSR columns; raise `ShapeError`/`EventError`/`ParameterError` if invalid.
#[pyfunction]
fn check_windows(
    py: Python<'_>,
    width: u16,
    height: u16,
    length_us: i64,
    t0: PyReadonlyArray1<'_, u64>,
    offsets: PyReadonlyArray1<'_, i64>,
    t: PyReadonlyArray1<'_, u64>,
    x: PyReadonlyArray1<'_, u16>,
    y: PyReadonlyArray1<'_, u16>,
) -> PyResult<()> {
    let columns = Columns::new(&t0, &offsets, &t, &x, &y)?;
    detach(py, || columns.view(width, height, length_us).map(|_| ()))
}

/// Dense time-embedded frames `(k, height, width)` float32 of windows `indices`.
#[pyfunction]
fn window_frames<'py>(
    py: Python<'py>,
    width: u16,
    height: u16,
    length_us: i64,
    t0: PyReadonlyArray1<'py, u64>,
    offsets: PyReadonlyArray1<'py, i64>,
    t: PyReadonlyArray1<'py, u64>,
    x: PyReadonlyArray1<'py, u16>,
    y: PyReadonlyArray1<'py, u16>,
    indices: PyReadonlyArray1<'py, i64>,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let columns = Columns::new(&t0, &offsets, &t, &x, &y)?;
    let indices = indices.as_slice()?;
    let (view, indices) = detach(py, || {
        let view = columns.view(width, height, length_us)?;
        let indices = indices
            .iter()
            .enumerate()
            .map(|(pos, &i)| {
                usize::try_from(i).map_err(|_| {
                    Error::param(
                        "indices",
                        format!(
                            "indices[{pos}]={i} is out of range for {} windows",
                            view.len()
                        ),
                    )
                })
            })
            .collect::<Result<Vec<_>>>()?;
        windows::frames_len(&view, &indices)?;
        Ok((view, indices))
    })?;
    // NumPy's allocator: large arrays come zeroed on demand (and on huge pages where the
    // kernel allows), so each frame is touched once, when it is filled.
    let out = PyArray3::<f32>::zeros(py, [indices.len(), height as usize, width as usize], false);
    {
        let mut buffer = out.readwrite();
        let buffer = buffer.as_slice_mut()?;
        detach(py, || windows::frames_into(&view, &indices, buffer))?;
    }
    Ok(out)
}

/// Add uniform noise to windows (window `i` draws from `(seed, first + i)`); returns the noisy
/// CSR columns and the SNR (dB) per window.
#[pyfunction]
fn add_noise<'py>(
    py: Python<'py>,
    width: u16,
    height: u16,
    length_us: i64,
    t0: PyReadonlyArray1<'py, u64>,
    offsets: PyReadonlyArray1<'py, i64>,
    t: PyReadonlyArray1<'py, u64>,
    x: PyReadonlyArray1<'py, u16>,
    y: PyReadonlyArray1<'py, u16>,
    n_preceding: PyReadonlyArray1<'py, i64>,
    fraction: f64,
    seed: u64,
    first: u64,
) -> PyResult<(WindowArrays<'py>, Bound<'py, PyArray1<f64>>)> {
    let columns = Columns::new(&t0, &offsets, &t, &x, &y)?;
    let preceding = n_preceding.as_slice()?;
    let noisy = detach(py, || {
        let view = columns.view(width, height, length_us)?;
        let preceding = preceding
            .iter()
            .map(|&p| non_negative("n_preceding", p))
            .collect::<Result<Vec<_>>>()?;
        windows::add_noise(&view, &preceding, fraction, seed, first)
    })?;
    Ok((
        into_arrays(py, noisy.windows),
        noisy.snr_db.into_pyarray(py),
    ))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("MAX_WINDOWS", windows::MAX_WINDOWS)?;
    m.add_function(wrap_pyfunction!(window_step, m)?)?;
    m.add_function(wrap_pyfunction!(make_windows, m)?)?;
    m.add_function(wrap_pyfunction!(check_windows, m)?)?;
    m.add_function(wrap_pyfunction!(window_frames, m)?)?;
    m.add_function(wrap_pyfunction!(add_noise, m)?)?;
    Ok(())
}
