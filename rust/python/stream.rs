//! Bindings for `stream`: the streaming detector and the UDP packet decoder.
//!
//! The detector is built from the network's config (JSON) and weights, the documented face of
//! `uavsnn.network.Network`, so it holds its own copy of the weights. Events cross as the packed
//! bytes of the canonical dtype; detections come back as packed records that Python views with
//! `uavsnn.detector.DETECTION_DTYPE`.

use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;

use super::errors::{detach, map};
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
    fn push<'py>(&mut self, py: Python<'py>, raw: &[u8]) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let Self { inner, found } = self;
        let bytes = detach(py, || {
            // Read in place: decoding the chunk first took 16 bytes an event.
            let events = PackedEvents::new(raw)?;
            found.clear();
            inner.push(&events, found)?;
            Ok(pack_detections(found))
        })?;
        Ok(bytes.into_pyarray(py))
    }

    /// End the stream; return the packed detections still pending.
    fn flush<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let Self { inner, found, .. } = self;
        let bytes = detach(py, || {
            found.clear();
            inner.flush(found)?;
            Ok(pack_detections(found))
        })?;
        Ok(bytes.into_pyarray(py))
    }

    /// Forget the stream.
    fn reset(&mut self) {
        self.inner.reset();
    }

    #[getter]
    fn sensor_size(&self) -> (u16, u16) {
        let s = self.inner.sensor();
        (s.width, s.height)
    }

    #[getter]
    fn window_us(&self) -> u64 {
        self.inner.config().window_us
    }

    #[getter]
    fn overlap(&self) -> f64 {
        self.inner.config().overlap
    }

    #[getter]
    fn step_us(&self) -> u64 {
        self.inner.step_us()
    }

    #[getter]
    fn events_seen(&self) -> u64 {
        self.inner.stats().events
    }

    #[getter]
    fn windows_opened(&self) -> u64 {
        self.inner.stats().windows_opened
    }

    #[getter]
    fn detections_emitted(&self) -> u64 {
        self.inner.stats().detections
    }

    #[getter]
    fn live_windows(&self) -> usize {
        self.inner.live_windows()
    }

    #[getter]
    fn states_allocated(&self) -> usize {
        self.inner.states_allocated()
    }

    #[getter]
    fn last_t(&self) -> Option<u64> {
        self.inner.last_t()
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
        &mut self,
        py: Python<'py>,
        packet: &[u8],
        arrival_us: u64,
    ) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let Self { inner, scratch } = self;
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
    fn format(&self) -> &'static str {
        self.inner.format().name()
    }

    /// Time of the last event decoded, or `None`.
    #[getter]
    fn last_t(&self) -> Option<u64> {
        self.inner.last_t()
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyStreamDetector>()?;
    m.add_class::<PyPacketDecoder>()?;
    m.add("DETECTION_RECORD_SIZE", DETECTION_RECORD)?;
    m.add("PACKET_FORMATS", PacketFormat::NAMES.to_vec())?;
    Ok(())
}
