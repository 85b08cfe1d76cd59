//! Bindings for `stream`: the streaming detector and the UDP packet decoder.
//!
//! The detector is built from the network's config (JSON) and weights, the documented face of
//! `uavsnn.network.Network`, so it holds its own copy of the weights. Events cross as the packed
//! bytes of the canonical dtype; detections come back as packed records that Python views with
//! `uavsnn.detector.DETECTION_DTYPE`.

use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;

use super::errors::{detach, map, read, write, InUse};
use super::network::pack_detection;
use crate::events::{Event, PackedEvents, SensorSize, PACKED_EVENT_SIZE};
use crate::network::{Network, NetworkConfig};
use crate::stream::{NetworkDetector, PacketDecoder, PacketFormat, StreamConfig, StreamDetection};

/// Size of one packed detection record: `window i8, t u8, map row col u2, x y f4, box 4×u2`.
const DETECTION_RECORD: usize = 8 + 8 + 3 * 2 + 2 * 4 + 4 * 2;

fn pack_detections(found: &[StreamDetection]) -> Vec<u8> {
    let mut out = Vec::with_capacity(found.len() * DETECTION_RECORD);
    for f in found {
        // Window indices stay far below 2^63 (times are at most 2^62 µs).
        out.extend_from_slice(&(f.window as i64).to_le_bytes());
        pack_detection(&mut out, &f.detection);
    }
    out
}

/// The streaming detector over a copy of a network.
#[pyclass(name = "StreamDetector", module = "uavsnn._core")]
struct PyStreamDetector {
    inner: NetworkDetector,
    found: Vec<StreamDetection>,
}

/// Every call borrows the detector by hand (see [`read`]): `push` and `flush` let the GIL go
/// holding it.
impl PyStreamDetector {
    const IN_USE: InUse = ("the detector", "give each stream its own Detector");
}

#[pymethods]
impl PyStreamDetector {
    #[new]
    #[pyo3(signature = (config_json, conv1, conv2, conv3, window_us, overlap, start_us=None))]
    fn new(
        py: Python<'_>,
        config_json: &str,
        conv1: PyReadonlyArray1<'_, f32>,
        conv2: PyReadonlyArray1<'_, f32>,
        conv3: PyReadonlyArray1<'_, f32>,
        window_us: u64,
        overlap: f64,
        start_us: Option<u64>,
    ) -> PyResult<Self> {
        let weights = [
            conv1.as_slice()?.to_vec(),
            conv2.as_slice()?.to_vec(),
            conv3.as_slice()?.to_vec(),
        ];
        let inner = detach(py, || {
            let config = NetworkConfig::from_json(config_json)?;
            let net = Network::from_weights(config, weights)?;
            NetworkDetector::new(
                net,
                StreamConfig {
                    window_us,
                    overlap,
                    start_us,
                },
            )
        })?;
        Ok(Self {
            inner,
            found: Vec::new(),
        })
    }

    /// Push packed event records (`bytes`); return the packed detections they decided.
    fn push<'py>(slf: &Bound<'py, Self>, raw: &[u8]) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let py = slf.py();
        let mut this = write(slf, Self::IN_USE)?;
        let Self { inner, found } = &mut *this;
        let mut signal = None;
        let bytes = detach(py, || {
            // Read in place: decoding the chunk first took 16 bytes an event.
            let events = PackedEvents::new(raw)?;
            found.clear();
            // Between slices, Python's signals (Ctrl-C), the GIL taken for the moment it takes.
            inner.push_while(&events, found, || {
                // A closure, not `Python::check_signals`: that names one lifetime.
                #[allow(clippy::redundant_closure_for_method_calls)]
                let checked = Python::attach(|py| py.check_signals());
                signal = checked.err();
                signal.is_none()
            })?;
            Ok(pack_detections(found))
        })?;
        match signal {
            // Interrupted part way: the detections of the slices read go with it
            // (`uavsnn.Detector` then refuses the stream until `reset`).
            Some(err) => Err(err),
            None => Ok(bytes.into_pyarray(py)),
        }
    }

    /// The stream has reached `t_us` without more events; return the packed detections that
    /// decides (those a later event would decide).
    fn advance<'py>(slf: &Bound<'py, Self>, t_us: u64) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let py = slf.py();
        let mut this = write(slf, Self::IN_USE)?;
        let Self { inner, found } = &mut *this;
        let bytes = detach(py, || {
            found.clear();
            inner.advance(t_us, found)?;
            Ok(pack_detections(found))
        })?;
        Ok(bytes.into_pyarray(py))
    }

    /// End the stream; return the packed detections still pending.
    fn flush<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let py = slf.py();
        let mut this = write(slf, Self::IN_USE)?;
        let Self { inner, found } = &mut *this;
        let bytes = detach(py, || {
            found.clear();
            inner.flush(found)?;
            Ok(pack_detections(found))
        })?;
        Ok(bytes.into_pyarray(py))
    }

    /// Forget the stream.
    fn reset(slf: &Bound<'_, Self>) -> PyResult<()> {
        write(slf, Self::IN_USE)?.inner.reset();
        Ok(())
    }

    #[getter]
    fn sensor_size(slf: &Bound<'_, Self>) -> PyResult<(u16, u16)> {
        let this = read(slf, Self::IN_USE)?;
        let s = this.inner.sensor();
        Ok((s.width, s.height))
    }

    #[getter]
    fn window_us(slf: &Bound<'_, Self>) -> PyResult<u64> {
        let this = read(slf, Self::IN_USE)?;
        Ok(this.inner.config().window_us)
    }

    #[getter]
    fn overlap(slf: &Bound<'_, Self>) -> PyResult<f64> {
        let this = read(slf, Self::IN_USE)?;
        Ok(this.inner.config().overlap)
    }

    #[getter]
    fn step_us(slf: &Bound<'_, Self>) -> PyResult<u64> {
        let this = read(slf, Self::IN_USE)?;
        Ok(this.inner.step_us())
    }

    #[getter]
    fn events_seen(slf: &Bound<'_, Self>) -> PyResult<u64> {
        let this = read(slf, Self::IN_USE)?;
        Ok(this.inner.stats().events)
    }

    #[getter]
    fn windows_opened(slf: &Bound<'_, Self>) -> PyResult<u64> {
        let this = read(slf, Self::IN_USE)?;
        Ok(this.inner.stats().windows_opened)
    }

    #[getter]
    fn detections_emitted(slf: &Bound<'_, Self>) -> PyResult<u64> {
        let this = read(slf, Self::IN_USE)?;
        Ok(this.inner.stats().detections)
    }

    #[getter]
    fn live_windows(slf: &Bound<'_, Self>) -> PyResult<usize> {
        let this = read(slf, Self::IN_USE)?;
        Ok(this.inner.live_windows())
    }

    #[getter]
    fn states_allocated(slf: &Bound<'_, Self>) -> PyResult<usize> {
        let this = read(slf, Self::IN_USE)?;
        Ok(this.inner.states_allocated())
    }

    #[getter]
    fn last_t(slf: &Bound<'_, Self>) -> PyResult<Option<u64>> {
        let this = read(slf, Self::IN_USE)?;
        Ok(this.inner.last_t())
    }
}

/// Append events as packed 13-byte records (the canonical dtype's bytes).
fn pack_events(events: &[Event], out: &mut Vec<u8>) {
    out.reserve(events.len() * PACKED_EVENT_SIZE);
    for e in events {
        out.extend_from_slice(&e.t.to_le_bytes());
        out.extend_from_slice(&e.x.to_le_bytes());
        out.extend_from_slice(&e.y.to_le_bytes());
        out.push(u8::from(e.p));
    }
}

/// Decoder of one UDP packet format (`t64_x16_y16_on8`, `t32_x16_y15_on1` or `spif`).
#[pyclass(name = "PacketDecoder", module = "uavsnn._core")]
struct PyPacketDecoder {
    inner: PacketDecoder,
    scratch: Vec<Event>,
}

/// Every call that reads or changes the decoder's state borrows it by hand (see [`read`]).
impl PyPacketDecoder {
    const IN_USE: InUse = ("the packet decoder", "give each stream its own decoder");
}

#[pymethods]
impl PyPacketDecoder {
    #[new]
    fn new(py: Python<'_>, format: &str, width: u16, height: u16) -> PyResult<Self> {
        let format: PacketFormat = map(py, format.parse())?;
        let sensor = map(py, SensorSize::new(width, height))?;
        Ok(Self {
            inner: PacketDecoder::new(format, sensor),
            scratch: Vec::new(),
        })
    }

    /// Decode one packet into packed event records (view them with `EVENT_DTYPE`). A malformed
    /// packet raises and leaves the decoder as it was.
    fn decode<'py>(
        slf: &Bound<'py, Self>,
        packet: &[u8],
        arrival_us: u64,
    ) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let py = slf.py();
        let mut this = write(slf, Self::IN_USE)?;
        let Self { inner, scratch } = &mut *this;
        let bytes = detach(py, || {
            scratch.clear();
            inner.decode(packet, arrival_us, scratch)?;
            let mut bytes = Vec::new();
            pack_events(scratch, &mut bytes);
            Ok(bytes)
        })?;
        Ok(bytes.into_pyarray(py))
    }

    /// The packet format's name.
    #[getter]
    fn format(slf: &Bound<'_, Self>) -> PyResult<&'static str> {
        Ok(read(slf, Self::IN_USE)?.inner.format().name())
    }

    /// Time of the last event decoded, or `None`.
    #[getter]
    fn last_t(slf: &Bound<'_, Self>) -> PyResult<Option<u64>> {
        Ok(read(slf, Self::IN_USE)?.inner.last_t())
    }

    /// New time bases started (sensor restarts), each after `RESTART_AFTER` packets in a row
    /// refused for going back in time (held, and decoded on the new base).
    #[getter]
    fn restarts(slf: &Bound<'_, Self>) -> PyResult<u64> {
        Ok(read(slf, Self::IN_USE)?.inner.restarts())
    }

    /// Packets refused (each `decode` that raised), less those a restart took back.
    #[getter]
    fn dropped(slf: &Bound<'_, Self>) -> PyResult<u64> {
        Ok(read(slf, Self::IN_USE)?.inner.dropped())
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyStreamDetector>()?;
    m.add_class::<PyPacketDecoder>()?;
    m.add("DETECTION_RECORD_SIZE", DETECTION_RECORD)?;
    m.add("PACKET_FORMATS", PacketFormat::NAMES.to_vec())?;
    m.add("RESTART_AFTER", crate::stream::RESTART_AFTER)?;
    m.add("PUSH_SLICE", crate::stream::PUSH_SLICE)?;
    m.add("MAX_HELD_BYTES", crate::stream::MAX_HELD_BYTES)?;
    Ok(())
}
