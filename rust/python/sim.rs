//! Bindings for `sim`: the PIX2NVS simulator and the DVS emulator as stateful kernels that take
//! batches of frames and return packed events (the canonical dtype viewed as bytes).

use ndarray::{ArrayView3, ArrayView4, Axis};
use numpy::{
    IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3, PyReadonlyArray4,
};
use pyo3::prelude::*;

use super::errors::{detach, map, read, write, InUse, SIGNAL_CHECK_SECONDS};
use crate::error::{Error, Result};
use crate::events::{Event, PACKED_EVENT_SIZE};
use crate::sim::{
    DvsEmulator, DvsParams, Frame, Pix2Nvs, Pix2NvsParams, Pooling, ReferenceUpdate, SubSamples,
};

/// Events as packed 13-byte records, the canonical NumPy dtype's memory layout.
fn pack(events: &[Event]) -> Vec<u8> {
    let mut out = Vec::with_capacity(events.len() * PACKED_EVENT_SIZE);
    for e in events {
        out.extend_from_slice(&e.t.to_le_bytes());
        out.extend_from_slice(&e.x.to_le_bytes());
        out.extend_from_slice(&e.y.to_le_bytes());
        out.push(u8::from(e.p));
    }
    out
}

/// Frames of one batch, borrowed from NumPy.
enum Batch<'a> {
    Gray(ArrayView3<'a, u8>),
    Bgr(ArrayView4<'a, u8>),
    Float(ArrayView3<'a, f32>),
}

impl Batch<'_> {
    fn len(&self) -> usize {
        match self {
            Batch::Gray(v) => v.len_of(Axis(0)),
            Batch::Bgr(v) => v.len_of(Axis(0)),
            Batch::Float(v) => v.len_of(Axis(0)),
        }
    }

    fn frame(&self, i: usize) -> Frame<'_> {
        match self {
            Batch::Gray(v) => Frame::Gray(v.index_axis(Axis(0), i)),
            Batch::Bgr(v) => Frame::Bgr(v.index_axis(Axis(0), i)),
            Batch::Float(v) => Frame::GrayF32(v.index_axis(Axis(0), i)),
        }
    }
}

/// Check a batch's timestamps before any frame changes a kernel's state.
fn check_times(n: usize, times: &[u64], last: Option<u64>) -> Result<()> {
    if times.len() != n {
        return Err(Error::Simulation(format!(
            "{} timestamps for {n} frames; give one per frame",
            times.len()
        )));
    }
    let mut prev = last;
    for (i, &t) in times.iter().enumerate() {
        if let Some(p) = prev {
            if t <= p {
                return Err(Error::Simulation(format!(
                    "timestamp {i} ({t} us) is not after the one before it ({p} us); frame times \
                     must increase strictly"
                )));
            }
        }
        prev = Some(t);
    }
    Ok(())
}

/// Anything that takes frames one at a time.
trait Kernel: Send {
    fn push(&mut self, frame: &Frame<'_>, t: u64, out: &mut Vec<Event>) -> Result<()>;
    fn last_time(&self) -> Option<u64>;
}

impl Kernel for Pix2Nvs {
    fn push(&mut self, frame: &Frame<'_>, t: u64, out: &mut Vec<Event>) -> Result<()> {
        Pix2Nvs::push(self, frame, t, out)
    }
    fn last_time(&self) -> Option<u64> {
        Pix2Nvs::last_time(self)
    }
}

impl Kernel for DvsEmulator {
    fn push(&mut self, frame: &Frame<'_>, t: u64, out: &mut Vec<Event>) -> Result<()> {
        DvsEmulator::push(self, frame, t, out)
    }
    fn last_time(&self) -> Option<u64> {
        DvsEmulator::last_time(self)
    }
}

/// Run a batch through a kernel with the GIL released, Python's signals checked about every
/// [`SIGNAL_CHECK_SECONDS`]; packed events out. An interruption (Ctrl-C) leaves the kernel past the
/// frames it ran, whose events are lost: `interrupted` is set, and every later batch refused.
fn run_batch<'py, K: Kernel>(
    py: Python<'py>,
    kernel: &mut K,
    interrupted: &mut bool,
    batch: &Batch<'_>,
    times: &PyReadonlyArray1<'_, u64>,
) -> PyResult<Bound<'py, PyArray1<u8>>> {
    refuse_interrupted(py, *interrupted)?;
    let times = times.as_slice()?;
    let last = kernel.last_time();
    detach(py, || check_times(batch.len(), times, last))?;
    let mut events = Vec::new();
    let mut next = 0;
    while next < times.len() {
        next = detach(py, || {
            let began = std::time::Instant::now();
            let mut i = next;
            while i < times.len() && began.elapsed().as_secs_f64() < SIGNAL_CHECK_SECONDS {
                kernel.push(&batch.frame(i), times[i], &mut events)?;
                i += 1;
            }
            Ok(i)
        })?;
        if let Err(err) = py.check_signals() {
            *interrupted = next < times.len();
            return Err(err);
        }
    }
    let bytes = detach(py, || Ok(pack(&events)))?;
    Ok(bytes.into_pyarray(py))
}

/// The error of a kernel whose earlier batch was interrupted part way (see [`run_batch`]).
fn refuse_interrupted(py: Python<'_>, interrupted: bool) -> PyResult<()> {
    if interrupted {
        return map(
            py,
            Err(Error::Simulation(
                "an earlier batch of frames was interrupted part way: this simulator is past \
                 frames whose events were lost; make a new one"
                    .into(),
            )),
        );
    }
    Ok(())
}

fn reference_mode(name: &str) -> Result<ReferenceUpdate> {
    match name {
        "frame" => Ok(ReferenceUpdate::Frame),
        "event_copy" => Ok(ReferenceUpdate::EventCopy),
        "event_increment" => Ok(ReferenceUpdate::EventIncrement),
        other => Err(Error::param(
            "reference",
            format!("must be 'frame', 'event_copy' or 'event_increment', got {other:?}"),
        )),
    }
}

fn pooling_mode(name: &str) -> Result<Pooling> {
    match name {
        "strongest" => Ok(Pooling::Strongest),
        "all" => Ok(Pooling::All),
        other => Err(Error::param(
            "pooling",
            format!("must be 'strongest' or 'all', got {other:?}"),
        )),
    }
}

/// Adds to a kernel's Python methods (`impl $kernel { ... }`, whose `inner` is a `Kernel`)
/// `push_gray`, `push_bgr` and `push_float`, the same for every kernel and written once here.
/// PyO3 takes one `#[pymethods]` block per class, so they join the kernel's own block.
macro_rules! frame_kernel_methods {
    (impl $kernel:ident { $($methods:tt)* }) => {
        #[pymethods]
        impl $kernel {
            $($methods)*

            /// Feed `(n, h, w)` uint8 gray frames; returns packed events.
            fn push_gray<'py>(
                slf: &Bound<'py, Self>,
                frames: PyReadonlyArray3<'_, u8>,
                timestamps_us: PyReadonlyArray1<'_, u64>,
            ) -> PyResult<Bound<'py, PyArray1<u8>>> {
                let batch = Batch::Gray(frames.as_array());
                let mut this = write(slf, Self::IN_USE)?;
                let this = &mut *this;
                run_batch(slf.py(), &mut this.inner, &mut this.interrupted, &batch, &timestamps_us)
            }

            /// Feed `(n, h, w, 3)` uint8 BGR frames; returns packed events.
            fn push_bgr<'py>(
                slf: &Bound<'py, Self>,
                frames: PyReadonlyArray4<'_, u8>,
                timestamps_us: PyReadonlyArray1<'_, u64>,
            ) -> PyResult<Bound<'py, PyArray1<u8>>> {
                let batch = Batch::Bgr(frames.as_array());
                let mut this = write(slf, Self::IN_USE)?;
                let this = &mut *this;
                run_batch(slf.py(), &mut this.inner, &mut this.interrupted, &batch, &timestamps_us)
            }

            /// Feed `(n, h, w)` float32 gray frames (0–255 scale); returns packed events.
            fn push_float<'py>(
                slf: &Bound<'py, Self>,
                frames: PyReadonlyArray3<'_, f32>,
                timestamps_us: PyReadonlyArray1<'_, u64>,
            ) -> PyResult<Bound<'py, PyArray1<u8>>> {
                let batch = Batch::Float(frames.as_array());
                let mut this = write(slf, Self::IN_USE)?;
                let this = &mut *this;
                run_batch(slf.py(), &mut this.inner, &mut this.interrupted, &batch, &timestamps_us)
            }
        }
    };
}

/// PIX2NVS fed batches of frames; keeps its state between calls.
#[pyclass(module = "uavsnn._core")]
pub struct Pix2NvsKernel {
    inner: Pix2Nvs,
    /// A batch was interrupted part way ([`run_batch`]).
    interrupted: bool,
}

/// Every call borrows the simulator by hand (see [`read`]): a batch of frames lets the GIL go
/// holding it.
impl Pix2NvsKernel {
    const IN_USE: InUse = ("the simulator", "give each video its own simulator");
}

frame_kernel_methods! {
impl Pix2NvsKernel {
    #[new]
    #[pyo3(signature = (width, height, *, threshold, n_max, reference, block_size, adaptive,
                        threshold_min, threshold_max, log_offset, output_size=None,
                        pooling="strongest", compat=false))]
    fn new(
        py: Python<'_>,
        width: usize,
        height: usize,
        threshold: f32,
        n_max: u32,
        reference: &str,
        block_size: usize,
        adaptive: f32,
        threshold_min: f32,
        threshold_max: f32,
        log_offset: f32,
        output_size: Option<(usize, usize)>,
        pooling: &str,
        compat: bool,
    ) -> PyResult<Self> {
        let build = || -> Result<Pix2Nvs> {
            let params = Pix2NvsParams {
                threshold,
                n_max,
                reference: reference_mode(reference)?,
                block_size,
                adaptive,
                threshold_min,
                threshold_max,
                log_offset,
                compat,
            };
            let pool = pooling_mode(pooling)?;
            Pix2Nvs::new(
                params,
                width,
                height,
                output_size.map(|(w, h)| (w, h, pool)),
            )
        };
        let inner = map(py, build())?;
        Ok(Self {
            inner,
            interrupted: false,
        })
    }

    /// `(width, height)` of the events written.
    #[getter]
    fn output_size(slf: &Bound<'_, Self>) -> PyResult<(usize, usize)> {
        Ok(read(slf, Self::IN_USE)?.inner.output_size())
    }

    /// Frames consumed so far.
    #[getter]
    fn frames_seen(slf: &Bound<'_, Self>) -> PyResult<usize> {
        Ok(read(slf, Self::IN_USE)?.inner.frames_seen())
    }
}
}

/// The DVS emulator fed batches of frames; keeps its state between calls.
#[pyclass(module = "uavsnn._core")]
pub struct DvsKernel {
    inner: DvsEmulator,
    /// A batch was interrupted part way ([`run_batch`]).
    interrupted: bool,
}

/// Every call borrows the emulator by hand (see [`read`]): a batch of frames lets the GIL go
/// holding it.
impl DvsKernel {
    const IN_USE: InUse = ("the emulator", "give each video its own emulator");
}

frame_kernel_methods! {
impl DvsKernel {
    #[new]
    #[pyo3(signature = (width, height, *, seed, threshold_on, threshold_off, threshold_sigma,
                        refractory_us, leak_rate_hz, leak_spread_decades, shot_noise_rate_hz,
                        shot_noise_bright_factor, hot_pixel_fraction, hot_pixel_rate_hz,
                        cutoff_hz, linlog_threshold, cutoff_dark_luma=20.0))]
    fn new(
        py: Python<'_>,
        width: usize,
        height: usize,
        seed: u64,
        threshold_on: f32,
        threshold_off: f32,
        threshold_sigma: f32,
        refractory_us: f64,
        leak_rate_hz: f64,
        leak_spread_decades: f64,
        shot_noise_rate_hz: f64,
        shot_noise_bright_factor: f64,
        hot_pixel_fraction: f64,
        hot_pixel_rate_hz: f64,
        cutoff_hz: f64,
        linlog_threshold: f32,
        cutoff_dark_luma: f32,
    ) -> PyResult<Self> {
        let params = DvsParams {
            threshold_on,
            threshold_off,
            threshold_sigma,
            refractory_us,
            leak_rate_hz,
            leak_spread_decades,
            shot_noise_rate_hz,
            shot_noise_bright_factor,
            hot_pixel_fraction,
            hot_pixel_rate_hz,
            cutoff_hz,
            cutoff_dark_luma,
            linlog_threshold,
        };
        let inner = detach(py, || DvsEmulator::new(params, width, height, seed))?;
        Ok(Self {
            inner,
            interrupted: false,
        })
    }

    /// `(width, height)` of the sensor.
    #[getter]
    fn size(slf: &Bound<'_, Self>) -> PyResult<(usize, usize)> {
        Ok(read(slf, Self::IN_USE)?.inner.size())
    }

    /// Frames consumed so far.
    #[getter]
    fn frames_seen(slf: &Bound<'_, Self>) -> PyResult<usize> {
        Ok(read(slf, Self::IN_USE)?.inner.frames_seen())
    }

    /// Row-major indices of the hot pixels.
    fn hot_pixels(slf: &Bound<'_, Self>) -> PyResult<Vec<usize>> {
        Ok(read(slf, Self::IN_USE)?.inner.hot_pixels())
    }

    /// Feed one `(h, w)` float32 gray frame at `t_us` with sub-frame samples: `patches` is a
    /// list of `(x0, y0, times_us, values)`, `values` `(len(times_us), ph, pw)` float32 luma
    /// of the patch at those times (strictly between the previous frame and this one).
    /// Returns packed events.
    fn push_float_samples<'py>(
        slf: &Bound<'py, Self>,
        frame: PyReadonlyArray2<'_, f32>,
        t_us: u64,
        patches: Vec<(
            usize,
            usize,
            PyReadonlyArray1<'_, u64>,
            PyReadonlyArray3<'_, f32>,
        )>,
    ) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let py = slf.py();
        let frame = frame.as_array();
        let mut subs = Vec::with_capacity(patches.len());
        for (x0, y0, times, values) in &patches {
            let (m, h, w) = values.as_array().dim();
            if m != times.len()? {
                return map(
                    py,
                    Err(Error::Simulation(format!(
                        "a sub-frame patch has {m} planes of values for {} times",
                        times.len()?
                    ))),
                );
            }
            subs.push(SubSamples {
                x0: *x0,
                y0: *y0,
                width: w,
                height: h,
                times: times.as_slice()?,
                values: values.as_slice()?,
            });
        }
        let mut this = write(slf, Self::IN_USE)?;
        refuse_interrupted(py, this.interrupted)?;
        let inner = &mut this.inner;
        let bytes = detach(py, || {
            let mut events = Vec::new();
            inner.push_with_samples(&Frame::GrayF32(frame), t_us, &subs, &mut events)?;
            Ok(pack(&events))
        })?;
        Ok(bytes.into_pyarray(py))
    }
}
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Pix2NvsKernel>()?;
    m.add_class::<DvsKernel>()?;
    Ok(())
}
