//! Bindings for `signature`: the rotor-signature estimator over a box.
//!
//! Events cross as the packed bytes of the canonical dtype (read in place); the estimate comes
//! back as a tuple that `uavsnn.signature.RotorEstimate` names.

use numpy::PyReadonlyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::errors::{detach, read, write, InUse};
use crate::error::{Error, Result};
use crate::events::PackedEvents;
use crate::signature::spectrum::{RotorSpectrum, SpectrumConfig};
use crate::signature::{Region, RotorConfig, RotorSignature};

/// `(frequency_hz, strength, pixels, peak_votes, votes, intervals, detected)`.
type EstimateTuple = (f64, f64, u32, u64, u64, u64, bool);

/// `value` as a `T`, or an error naming `name` and the accepted `range`.
fn convert<T: TryFrom<i64>>(name: &'static str, value: i64, range: &str) -> Result<T> {
    T::try_from(value).map_err(|_| Error::param(name, format!("must be in {range}, got {value}")))
}

/// The box `x0, y0, width, height` as a [`Region`].
fn box_region(x0: i64, y0: i64, width: i64, height: i64) -> Result<Region> {
    let coordinate = |value| convert::<u16>("box", value, "0..=65535");
    Region::new(
        coordinate(x0)?,
        coordinate(y0)?,
        coordinate(width)?,
        coordinate(height)?,
    )
}

/// The `#[pymethods]` of an estimator class: its own methods, then those both classes share
/// (`update`, `clear`, `box`, `state_bytes`; the inner estimator has the same methods).
macro_rules! estimator_methods {
    ($class:ty { $($own:tt)* }) => {
        #[pymethods]
        impl $class {
            $($own)*

            /// Feed packed canonical event records (a `uint8` view of the canonical dtype).
            fn update(slf: &Bound<'_, Self>, events: PyReadonlyArray1<'_, u8>) -> PyResult<()> {
                let py = slf.py();
                let mut this = write(slf, Self::IN_USE)?;
                let raw = events.as_slice()?;
                let inner = &mut this.inner;
                detach(py, || {
                    let packed = PackedEvents::new(raw)?;
                    inner.extend(&packed);
                    Ok(())
                })
            }

            /// Forget every event.
            fn clear(slf: &Bound<'_, Self>) -> PyResult<()> {
                let py = slf.py();
                let mut this = write(slf, Self::IN_USE)?;
                let inner = &mut this.inner;
                detach(py, || {
                    inner.clear();
                    Ok(())
                })
            }

            /// `(x0, y0, width, height)`.
            #[getter]
            fn r#box(slf: &Bound<'_, Self>) -> PyResult<(u16, u16, u16, u16)> {
                let this = read(slf, Self::IN_USE)?;
                let r = this.inner.region();
                Ok((r.x0, r.y0, r.width, r.height))
            }

            #[getter]
            fn state_bytes(slf: &Bound<'_, Self>) -> PyResult<usize> {
                let this = read(slf, Self::IN_USE)?;
                Ok(this.inner.state_bytes())
            }
        }
    };
}

/// The estimator's defaults, as a dict (the single source of the Python defaults).
#[pyfunction]
fn rotor_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let c = RotorConfig::default();
    let d = PyDict::new(py);
    d.set_item("f_min_hz", c.f_min_hz)?;
    d.set_item("f_max_hz", c.f_max_hz)?;
    d.set_item("bins", c.bins)?;
    d.set_item("consistency", c.consistency)?;
    d.set_item("agree", c.agree)?;
    d.set_item("threshold", c.threshold)?;
    d.set_item("min_pixels", c.min_pixels)?;
    d.set_item("max_pixels", crate::signature::MAX_PIXELS)?;
    Ok(d)
}

/// How strongly a rate of `counts` events per bin swings beyond shot noise.
#[pyfunction]
fn rate_swing(counts: Vec<u32>) -> f64 {
    crate::signature::rate_swing(&counts)
}

/// A rotor-signature estimator over the box `x0, y0, width, height`.
#[pyclass(name = "RotorSignature", module = "uavsnn._core")]
struct PyRotorSignature {
    inner: RotorSignature,
}

/// Every call borrows the estimator by hand (see [`read`]): `update` lets the GIL go holding it.
impl PyRotorSignature {
    const IN_USE: InUse = ("the estimator", "give each thread its own estimator");
}

estimator_methods!(PyRotorSignature {
    #[new]
    #[pyo3(signature = (x0, y0, width, height, f_min_hz, f_max_hz, bins, consistency, agree, threshold, min_pixels))]
    fn new(
        py: Python<'_>,
        x0: i64,
        y0: i64,
        width: i64,
        height: i64,
        f_min_hz: f64,
        f_max_hz: f64,
        bins: i64,
        consistency: f64,
        agree: f64,
        threshold: f64,
        min_pixels: i64,
    ) -> PyResult<Self> {
        let inner = detach(py, || {
            let region = box_region(x0, y0, width, height)?;
            let config = RotorConfig {
                f_min_hz,
                f_max_hz,
                bins: convert("bins", bins, "3..=4096")?,
                consistency,
                agree,
                threshold,
                min_pixels: convert("min_pixels", min_pixels, "0..=2**32-1")?,
            };
            RotorSignature::new(config, region)
        })?;
        Ok(Self { inner })
    }

    /// The estimate from everything fed so far.
    fn estimate(slf: &Bound<'_, Self>) -> PyResult<EstimateTuple> {
        let py = slf.py();
        let this = read(slf, Self::IN_USE)?;
        let inner = &this.inner;
        detach(py, || {
            let s = inner.estimate();
            Ok((
                s.frequency_hz,
                s.strength,
                s.pixels,
                s.peak_votes,
                s.votes,
                s.intervals,
                s.detected,
            ))
        })
    }

    /// `(events, outside, late, on)` since construction or the last clear.
    #[getter]
    fn stats(slf: &Bound<'_, Self>) -> PyResult<(u64, u64, u64, u64)> {
        let this = read(slf, Self::IN_USE)?;
        let s = this.inner.stats();
        Ok((s.events, s.outside, s.late, s.on))
    }

    /// Count the box's events in `bins` bins of `bin_us` from `start_us` from now on.
    fn count_rate(slf: &Bound<'_, Self>, start_us: i64, bin_us: i64, bins: i64) -> PyResult<()> {
        let py = slf.py();
        let mut this = write(slf, Self::IN_USE)?;
        let inner = &mut this.inner;
        detach(py, || {
            let start_us = convert::<u64>("start_us", start_us, "0..=2**63-1")?;
            let bin_us = convert::<u64>("bin_us", bin_us, "1..=2**63-1")?;
            let bins = convert::<usize>("bins", bins, "1..=4096")?;
            inner.count_rate(start_us, bin_us, bins)
        })
    }

    /// The box's events per rate bin (empty when the rate is not counted).
    #[getter]
    fn rate(slf: &Bound<'_, Self>) -> PyResult<Vec<u32>> {
        let this = read(slf, Self::IN_USE)?;
        Ok(this.inner.rate())
    }

    /// The swing of those bins (`rate_swing`).
    #[getter]
    fn rate_swing(slf: &Bound<'_, Self>) -> PyResult<f64> {
        let this = read(slf, Self::IN_USE)?;
        Ok(this.inner.rate_swing())
    }
});

/// `(frequency_hz, prominence, pixels, channels, events, detected)`.
type SpectrumTuple = (f64, f64, u32, u32, u64, bool);

/// The spectrum estimator's defaults, as a dict (the single source of the Python defaults).
#[pyfunction]
fn spectrum_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let c = SpectrumConfig::default();
    let d = PyDict::new(py);
    d.set_item("bin_us", c.bin_us)?;
    d.set_item("span_us", c.span_us)?;
    d.set_item("f_min_hz", c.f_min_hz)?;
    d.set_item("f_max_hz", c.f_max_hz)?;
    d.set_item("freqs", c.freqs)?;
    d.set_item("min_events", c.min_events)?;
    d.set_item("agree", c.agree)?;
    d.set_item("threshold", c.threshold)?;
    d.set_item("min_pixels", c.min_pixels)?;
    d.set_item(
        "max_state_bytes",
        crate::signature::spectrum::MAX_STATE_BYTES,
    )?;
    Ok(d)
}

/// The event-rate spectrum estimator over the box `x0, y0, width, height`.
#[pyclass(name = "RotorSpectrum", module = "uavsnn._core")]
struct PyRotorSpectrum {
    inner: RotorSpectrum,
}

/// Every call borrows the estimator by hand (see [`read`]): `update` lets the GIL go holding it.
impl PyRotorSpectrum {
    const IN_USE: InUse = ("the estimator", "give each thread its own estimator");
}

estimator_methods!(PyRotorSpectrum {
    #[new]
    #[pyo3(signature = (x0, y0, width, height, bin_us, span_us, f_min_hz, f_max_hz, freqs, min_events, agree, threshold, min_pixels))]
    fn new(
        py: Python<'_>,
        x0: i64,
        y0: i64,
        width: i64,
        height: i64,
        bin_us: i64,
        span_us: i64,
        f_min_hz: f64,
        f_max_hz: f64,
        freqs: i64,
        min_events: i64,
        agree: f64,
        threshold: f64,
        min_pixels: i64,
    ) -> PyResult<Self> {
        let inner = detach(py, || {
            let region = box_region(x0, y0, width, height)?;
            let config = SpectrumConfig {
                bin_us: convert("bin_us", bin_us, "0..=2**32-1")?,
                span_us: convert("span_us", span_us, "0..=2**64-1")?,
                f_min_hz,
                f_max_hz,
                freqs: convert("freqs", freqs, "0..=4096")?,
                min_events: convert("min_events", min_events, "0..=2**32-1")?,
                agree,
                threshold,
                min_pixels: convert("min_pixels", min_pixels, "0..=2**32-1")?,
            };
            RotorSpectrum::new(config, region)
        })?;
        Ok(Self { inner })
    }

    /// The estimate from everything fed so far.
    fn estimate(slf: &Bound<'_, Self>) -> PyResult<SpectrumTuple> {
        let py = slf.py();
        let this = read(slf, Self::IN_USE)?;
        let inner = &this.inner;
        detach(py, || {
            let s = inner.estimate();
            Ok((
                s.frequency_hz,
                s.prominence,
                s.pixels,
                s.channels,
                s.events,
                s.detected,
            ))
        })
    }

    /// `(grid_hz, power)`: the summed power spectrum.
    fn power(slf: &Bound<'_, Self>) -> PyResult<(Vec<f64>, Vec<f64>)> {
        let py = slf.py();
        let this = read(slf, Self::IN_USE)?;
        let inner = &this.inner;
        detach(py, || Ok((inner.grid().to_vec(), inner.power())))
    }

    /// `(events, outside, late, beyond)` since construction or the last clear.
    #[getter]
    fn stats(slf: &Bound<'_, Self>) -> PyResult<(u64, u64, u64, u64)> {
        let this = read(slf, Self::IN_USE)?;
        let s = this.inner.stats();
        Ok((s.events, s.outside, s.late, s.beyond))
    }
});

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyRotorSignature>()?;
    m.add_class::<PyRotorSpectrum>()?;
    m.add_function(wrap_pyfunction!(spectrum_defaults, m)?)?;
    m.add_function(wrap_pyfunction!(rotor_defaults, m)?)?;
    m.add_function(wrap_pyfunction!(rate_swing, m)?)?;
    Ok(())
}
