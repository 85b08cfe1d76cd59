//! Events and their validation (SPEC §1).
//!
//! One event is `(t, x, y, p)`: `t` in microseconds, `x`/`y` pixel coordinates with the origin at
//! the top left, `p` the polarity. In NumPy the canonical layout is the packed record
//! `[("t","<u8"),("x","<u2"),("y","<u2"),("p","?")]` (13 bytes); [`decode_packed`] reads it
//! without an intermediate copy per column.

use crate::error::{Error, Result};

/// One DVS event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Event {
    /// Timestamp in microseconds.
    pub t: u64,
    /// Column, 0 at the left.
    pub x: u16,
    /// Row, 0 at the top.
    pub y: u16,
    /// Polarity: `true` for an increase of brightness (ON).
    pub p: bool,
}

/// Width and height of a sensor in pixels. Deserialised through [`SensorSize::new`] (a zero
/// side is refused there as by it).
///
/// The fields are public, so a size written as a struct literal may have a zero side. Every
/// function of the crate that takes a `SensorSize` checks it where it uses it
/// ([`SensorSize::validate`]) and refuses a zero side with the [`Error::InvalidParameter`]
/// (`sensor_size`) that [`SensorSize::new`] gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "RawSensorSize")]
pub struct SensorSize {
    /// Columns, at least 1.
    pub width: u16,
    /// Rows, at least 1.
    pub height: u16,
}

/// A [`SensorSize`] as written, before its check.
#[derive(serde::Deserialize)]
struct RawSensorSize {
    width: u16,
    height: u16,
}

impl TryFrom<RawSensorSize> for SensorSize {
    type Error = Error;

    fn try_from(raw: RawSensorSize) -> Result<Self> {
        Self::new(raw.width, raw.height)
    }
}

impl SensorSize {
    /// A sensor size, rejecting zero dimensions.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] (`sensor_size`) when `width` or `height` is 0.
    pub fn new(width: u16, height: u16) -> Result<Self> {
        Self { width, height }.validate_as("sensor_size")
    }

    /// This size checked as [`SensorSize::new`] checks one: the fields are public, so a size
    /// written as a struct literal may have a zero side.
    ///
    /// # Errors
    ///
    /// As [`SensorSize::new`].
    pub fn validate(self) -> Result<Self> {
        self.validate_as("sensor_size")
    }

    /// [`SensorSize::validate`] naming the parameter `name` in the error (`target` for the
    /// target of a downsampling).
    pub(crate) fn validate_as(self, name: &'static str) -> Result<Self> {
        if self.width == 0 || self.height == 0 {
            return Err(Error::param(
                name,
                format!(
                    "width and height must be positive, got {}x{}",
                    self.width, self.height
                ),
            ));
        }
        Ok(self)
    }

    /// Number of pixels (0 for a size with a zero side, which [`SensorSize::validate`]
    /// refuses).
    pub fn area(self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Row-major index of a pixel, which must lie on the sensor ([`SensorSize::contains`]):
    /// callers check their coordinates first. Debug builds assert it, so that a pixel off the
    /// sensor (or any pixel of a size with a zero side) is not silently given the index of
    /// another pixel, or one past the sensor's last.
    #[inline]
    pub fn index(self, x: u16, y: u16) -> usize {
        debug_assert!(
            self.contains(x, y),
            "pixel ({x}, {y}) is off the {}x{} sensor",
            self.width,
            self.height
        );
        y as usize * self.width as usize + x as usize
    }

    /// Whether a coordinate lies on the sensor (never, for a size with a zero side).
    #[inline]
    pub fn contains(self, x: u16, y: u16) -> bool {
        x < self.width && y < self.height
    }
}

/// Size in bytes of one packed NumPy event record.
pub const PACKED_EVENT_SIZE: usize = 13;

/// Read access to a sequence of events, whatever its memory layout: a slice of [`Event`], or
/// packed NumPy records read in place ([`PackedEvents`]), so that windowing and filters need no
/// copy of a recording.
pub trait EventSource: Sync {
    /// Number of events.
    fn len(&self) -> usize;

    /// Event `i` (`i < len()`; panics otherwise, like slice indexing).
    fn get(&self, i: usize) -> Event;

    /// Whether there are no events.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of leading events with `t < time` (events sorted by time).
    fn count_before(&self, time: u64) -> usize {
        let (mut lo, mut hi) = (0, self.len());
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if self.get(mid).t < time {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        lo
    }
}

impl EventSource for [Event] {
    #[inline]
    fn len(&self) -> usize {
        <[Event]>::len(self)
    }

    #[inline]
    fn get(&self, i: usize) -> Event {
        self[i]
    }
}

impl<const N: usize> EventSource for [Event; N] {
    #[inline]
    fn len(&self) -> usize {
        N
    }

    #[inline]
    fn get(&self, i: usize) -> Event {
        self[i]
    }
}

impl EventSource for Vec<Event> {
    #[inline]
    fn len(&self) -> usize {
        Vec::len(self)
    }

    #[inline]
    fn get(&self, i: usize) -> Event {
        self[i]
    }
}

/// Canonical NumPy event records (13 bytes each, little-endian), read in place.
#[derive(Debug, Clone, Copy)]
pub struct PackedEvents<'a> {
    bytes: &'a [u8],
}

impl<'a> PackedEvents<'a> {
    /// Wrap packed records, checking only that the length is a whole number of records.
    pub fn new(bytes: &'a [u8]) -> Result<Self> {
        if !bytes.len().is_multiple_of(PACKED_EVENT_SIZE) {
            return Err(Error::Shape {
                name: "events",
                expected: format!("a multiple of {PACKED_EVENT_SIZE} bytes"),
                got: format!("{} bytes", bytes.len()),
            });
        }
        Ok(Self { bytes })
    }
}

impl EventSource for PackedEvents<'_> {
    #[inline]
    fn len(&self) -> usize {
        self.bytes.len() / PACKED_EVENT_SIZE
    }

    #[inline]
    fn get(&self, i: usize) -> Event {
        packed_event(&self.bytes[i * PACKED_EVENT_SIZE..(i + 1) * PACKED_EVENT_SIZE])
    }
}

/// One packed 13-byte record (`t u64, x u16, y u16, p u8`, little endian: the canonical
/// dtype's bytes), unchecked (the first 13 bytes of `record`).
///
/// # Panics
///
/// If `record` holds fewer than [`PACKED_EVENT_SIZE`] bytes.
#[inline]
pub fn packed_event(record: &[u8]) -> Event {
    let r = record;
    Event {
        t: u64::from_le_bytes([r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7]]),
        x: u16::from_le_bytes([r[8], r[9]]),
        y: u16::from_le_bytes([r[10], r[11]]),
        p: r[12] != 0,
    }
}

/// Check that events are sorted by time and inside the sensor.
///
/// `previous_t` is the time of the last event already accepted (for streams fed in chunks);
/// `index_offset` is added to the index reported in errors.
///
/// # Errors
///
/// [`Error::InvalidParameter`] (`sensor_size`) for a sensor with a zero side
/// ([`SensorSize::validate`]), then [`Error::InvalidEvent`] naming the first bad event.
pub fn validate(
    events: &[Event],
    sensor: SensorSize,
    previous_t: Option<u64>,
    index_offset: usize,
) -> Result<()> {
    validate_source(events, sensor, previous_t, index_offset)
}

/// [`validate`] for any [`EventSource`].
///
/// # Errors
///
/// As [`validate`].
pub fn validate_source<E: EventSource + ?Sized>(
    events: &E,
    sensor: SensorSize,
    previous_t: Option<u64>,
    index_offset: usize,
) -> Result<()> {
    sensor.validate()?;
    // A pass without a branch per event (cheaper than checking each event in turn, which
    // branches three times per event);
    // the exact scan below runs only to name the first bad event.
    let mut prev = previous_t.unwrap_or(0);
    let mut bad = 0u8;
    for i in 0..events.len() {
        let e = events.get(i);
        bad |=
            u8::from(e.x >= sensor.width) | u8::from(e.y >= sensor.height) | u8::from(e.t < prev);
        prev = e.t;
    }
    if bad == 0 {
        return Ok(());
    }
    let mut last = previous_t;
    for i in 0..events.len() {
        let e = events.get(i);
        check_one(&e, sensor, last, index_offset.saturating_add(i))?;
        last = Some(e.t);
    }
    Ok(())
}

#[inline]
fn check_one(e: &Event, sensor: SensorSize, last: Option<u64>, index: usize) -> Result<()> {
    if !sensor.contains(e.x, e.y) {
        return Err(Error::InvalidEvent {
            index,
            reason: format!(
                "(x={}, y={}) is outside the {}x{} sensor",
                e.x, e.y, sensor.width, sensor.height
            ),
        });
    }
    if let Some(prev) = last {
        if e.t < prev {
            return Err(Error::InvalidEvent {
                index,
                reason: format!("t={} goes backwards (previous event at t={prev})", e.t),
            });
        }
    }
    Ok(())
}

/// Decode packed 13-byte records (the canonical NumPy dtype viewed as bytes) into events,
/// validating them in the same pass.
///
/// # Errors
///
/// [`Error::InvalidParameter`] (`sensor_size`) for a sensor with a zero side, [`Error::Shape`]
/// for a length that is not a whole number of records, [`Error::InvalidEvent`] for the first
/// bad event.
pub fn decode_packed(
    bytes: &[u8],
    sensor: SensorSize,
    previous_t: Option<u64>,
    index_offset: usize,
) -> Result<Vec<Event>> {
    sensor.validate()?;
    if !bytes.len().is_multiple_of(PACKED_EVENT_SIZE) {
        return Err(Error::Shape {
            name: "events",
            expected: format!("a multiple of {PACKED_EVENT_SIZE} bytes"),
            got: format!("{} bytes", bytes.len()),
        });
    }
    let mut out = Vec::with_capacity(bytes.len() / PACKED_EVENT_SIZE);
    let mut last = previous_t;
    for (i, r) in bytes.chunks_exact(PACKED_EVENT_SIZE).enumerate() {
        let e = Event {
            t: u64::from_le_bytes([r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7]]),
            x: u16::from_le_bytes([r[8], r[9]]),
            y: u16::from_le_bytes([r[10], r[11]]),
            p: r[12] != 0,
        };
        check_one(&e, sensor, last, index_offset.saturating_add(i))?;
        last = Some(e.t);
        out.push(e);
    }
    Ok(out)
}

/// Test support: `err` is the error [`SensorSize::new`] gives for a zero side.
#[cfg(test)]
#[track_caller]
pub(crate) fn assert_zero_sensor(err: &Error) {
    assert!(
        matches!(
            err,
            Error::InvalidParameter {
                name: "sensor_size",
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("must be positive"), "{err}");
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(t: u64, x: u16, y: u16) -> Event {
        Event { t, x, y, p: true }
    }

    #[test]
    fn a_sensor_size_is_deserialised_through_its_check() {
        let size: SensorSize = serde_json::from_str(r#"{"width": 240, "height": 180}"#).unwrap();
        assert_eq!(size, SensorSize::new(240, 180).unwrap());
        let err = serde_json::from_str::<SensorSize>(r#"{"width": 0, "height": 0}"#).unwrap_err();
        assert!(err.to_string().contains("must be positive"), "{err}");
        assert_eq!(
            serde_json::to_string(&size).unwrap(),
            r#"{"width":240,"height":180}"#
        );
    }

    #[test]
    fn rejects_out_of_sensor_and_backwards_time() {
        let s = SensorSize::new(4, 3).unwrap();
        assert!(validate(&[ev(0, 0, 0), ev(1, 3, 2)], s, None, 0).is_ok());
        let err = validate(&[ev(0, 0, 0), ev(1, 4, 0)], s, None, 0).unwrap_err();
        assert!(matches!(err, Error::InvalidEvent { index: 1, .. }), "{err}");
        let err = validate(&[ev(5, 0, 0), ev(4, 0, 0)], s, None, 10).unwrap_err();
        assert!(
            matches!(err, Error::InvalidEvent { index: 11, .. }),
            "{err}"
        );
        let err = validate(&[ev(5, 0, 0)], s, Some(6), 0).unwrap_err();
        assert!(err.to_string().contains("goes backwards"), "{err}");
    }

    #[test]
    fn decodes_packed_records() {
        let s = SensorSize::new(640, 480).unwrap();
        let mut bytes = Vec::new();
        for (t, x, y, p) in [(7u64, 1u16, 2u16, true), (9, 639, 479, false)] {
            bytes.extend_from_slice(&t.to_le_bytes());
            bytes.extend_from_slice(&x.to_le_bytes());
            bytes.extend_from_slice(&y.to_le_bytes());
            bytes.push(u8::from(p));
        }
        let events = decode_packed(&bytes, s, None, 0).unwrap();
        assert_eq!(
            events,
            vec![
                ev(7, 1, 2),
                Event {
                    t: 9,
                    x: 639,
                    y: 479,
                    p: false
                }
            ]
        );
        assert!(decode_packed(&bytes[..12], s, None, 0).is_err());
        // An offset near the end of usize names the bad event without overflowing.
        let back = [&bytes[13..], &bytes[..13]].concat();
        for offset in [usize::MAX - 1, usize::MAX] {
            let err = decode_packed(&back, s, None, offset).unwrap_err();
            assert!(err.to_string().contains("goes backwards"), "{err}");
            let err = validate(&[ev(9, 0, 0), ev(7, 0, 0)], s, None, offset).unwrap_err();
            assert!(err.to_string().contains("goes backwards"), "{err}");
        }
    }

    #[test]
    fn packed_source_reads_records_in_place() {
        let s = SensorSize::new(640, 480).unwrap();
        let mut bytes = Vec::new();
        for (t, x, y, p) in [
            (7u64, 1u16, 2u16, true),
            (9, 639, 479, false),
            (9, 3, 3, true),
        ] {
            bytes.extend_from_slice(&t.to_le_bytes());
            bytes.extend_from_slice(&x.to_le_bytes());
            bytes.extend_from_slice(&y.to_le_bytes());
            bytes.push(u8::from(p));
        }
        let packed = PackedEvents::new(&bytes).unwrap();
        let decoded = decode_packed(&bytes, s, None, 0).unwrap();
        assert_eq!(packed.len(), 3);
        assert_eq!((0..3).map(|i| packed.get(i)).collect::<Vec<_>>(), decoded);
        assert_eq!(packed.count_before(9), 1);
        assert_eq!(packed.count_before(10), 3);
        assert_eq!(decoded[..].count_before(0), 0);
        assert!(validate_source(&packed, s, None, 0).is_ok());
        assert!(PackedEvents::new(&bytes[..20]).is_err());
    }

    #[test]
    fn zero_sensor_is_rejected() {
        assert!(SensorSize::new(0, 10).is_err());
    }

    #[test]
    fn a_sensor_size_literal_is_checked_where_it_is_used() {
        // The fields are public: a literal skips `new`. The checks of events accepted no
        // events on it (nothing lies on a 0x0 sensor) without a word.
        let ok = SensorSize::new(4, 3).unwrap();
        assert_eq!(ok.validate(), Ok(ok));
        for (width, height) in [(0, 0), (0, 3), (4, 0)] {
            let bad = SensorSize { width, height };
            assert_zero_sensor(&bad.validate().unwrap_err());
            assert_eq!(bad.validate(), SensorSize::new(width, height));
            assert_zero_sensor(&validate(&[], bad, None, 0).unwrap_err());
            assert_zero_sensor(&validate(&[ev(0, 0, 0)], bad, None, 0).unwrap_err());
            let packed = PackedEvents::new(&[]).unwrap();
            assert_zero_sensor(&validate_source(&packed, bad, None, 0).unwrap_err());
            assert_zero_sensor(&decode_packed(&[], bad, None, 0).unwrap_err());
        }
    }

    #[cfg(debug_assertions)]
    #[test]
    #[should_panic(expected = "off the 0x0 sensor")]
    fn the_index_of_a_pixel_off_the_sensor_is_a_bug_debug_builds_catch() {
        // Unchecked, a 0x0 sensor gave pixel (3, 0) the index 3 (of a state of 0 pixels).
        let _ = SensorSize {
            width: 0,
            height: 0,
        }
        .index(3, 0);
    }
}
