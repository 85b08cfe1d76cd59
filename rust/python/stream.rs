//! Bindings for `stream`: the UDP packet decoder (and, with the engine, the streaming detector).

use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;

use super::errors::{detach, map};
use crate::events::{Event, SensorSize, PACKED_EVENT_SIZE};
use crate::stream::{PacketDecoder, PacketFormat};

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
    m.add_class::<PyPacketDecoder>()?;
    m.add("PACKET_FORMATS", PacketFormat::NAMES.to_vec())?;
    Ok(())
}
