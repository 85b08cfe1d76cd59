//! Decoders for the UDP packet formats the field's streaming tools send ([`PacketDecoder`]).

use std::fmt;
use std::str::FromStr;

use crate::error::{Error, Result};
use crate::events::{packed_event, Event, SensorSize, PACKED_EVENT_SIZE};

/// A UDP event packet format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PacketFormat {
    /// faery `t64_x16_y16_on8`: 13 bytes per event.
    T64X16Y16On8,
    /// faery `t32_x16_y15_on1`: 8 bytes per event.
    T32X16Y15On1,
    /// aestream / spif: one 32-bit word per event, plus one time word when bit 31 is clear.
    Spif,
}

impl PacketFormat {
    /// Every format, in the order of their names in [`PacketFormat::NAMES`].
    pub const ALL: [PacketFormat; 3] = [Self::T64X16Y16On8, Self::T32X16Y15On1, Self::Spif];
    /// The names accepted by [`FromStr`].
    pub const NAMES: [&'static str; 3] = ["t64_x16_y16_on8", "t32_x16_y15_on1", "spif"];

    /// The format's name, as faery and aestream spell it.
    pub fn name(self) -> &'static str {
        match self {
            Self::T64X16Y16On8 => Self::NAMES[0],
            Self::T32X16Y15On1 => Self::NAMES[1],
            Self::Spif => Self::NAMES[2],
        }
    }
}

impl fmt::Display for PacketFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for PacketFormat {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| {
                Error::param(
                    "format",
                    format!(
                        "unknown packet format {s:?}; expected one of {:?}",
                        Self::NAMES
                    ),
                )
            })
    }
}

const WRAP: u64 = 1 << 32;

/// Packets in a row refused only for going back in time after which the next one, if good in
/// itself, starts a new time base (a restarted sensor; see [`PacketDecoder`]): a few reordered
/// or repeated datagrams never reach it. The refused packets are held and decoded on the new
/// base, so a restarted sensor loses none of them (up to [`MAX_HELD_BYTES`]).
pub const RESTART_AFTER: u32 = 8;

/// The most bytes of refused packets held for a possible restart: [`RESTART_AFTER`] UDP
/// datagrams of the largest size. A packet that would take more is not held, and is lost if
/// the restart comes.
pub const MAX_HELD_BYTES: usize = RESTART_AFTER as usize * 65_536;

/// Decodes packets of one format into validated events, keeping the time base across packets.
///
/// The formats ([`PacketFormat`]):
///
/// - `t64_x16_y16_on8` (faery's default `UdpFormat`): packed 13-byte little-endian records,
///   `t: u64, x: u16, y: u16, on: u8`, the same bytes as the canonical NumPy dtype.
/// - `t32_x16_y15_on1` (faery's compact `UdpFormat`): 8-byte little-endian records,
///   `t: u32, x: u16, y_on: u16` with `y = y_on >> 1` and `on = y_on & 1`. The 32-bit time wraps
///   every 71.6 minutes; like faery's receiver, a jump back by more than 2³¹ µs is read as a wrap.
/// - `spif` (aestream's UDP output, the event word of `SpiNNaker`'s spif, "spiffer"): little-endian
///   32-bit words, bit 31 = "no timestamp" flag, bits 30..16 = x, bit 15 = polarity,
///   bits 14..0 = y. When bit 31 is clear, the next word is the event's time (u32 µs, unwrapped
///   as above). aestream sends no time by default; such events are stamped with the packet's
///   arrival time, which the caller reads from a monotonic clock.
///
/// A packet is decoded whole or not at all: a length that is not a whole number of records,
/// an event outside the sensor, a time going backwards, or a `spif` packet mixing stamped and
/// unstamped events is an error, and the decoder's state (last time, wrap count) is unchanged,
/// so the caller can count the packet as dropped and go on with the next one.
///
/// A sensor that restarts sends times from zero again, and a packet stamped far ahead by a
/// glitch moves the last time there: every later packet would go backwards, and the stream
/// would be lost until the new times passed the old one (hours). So after [`RESTART_AFTER`]
/// packets in a row refused only because their times go back, the next such packet starts a
/// new time base if it is good in itself: the refused packets, held meanwhile (at most
/// [`MAX_HELD_BYTES`] of them), are decoded on the new base before it, and
/// [`PacketDecoder::restarts`] counts the restart, for the caller to end the windows of the old
/// stream before it. [`PacketDecoder::dropped`] counts the packets refused and not taken back.
#[derive(Debug, Clone)]
pub struct PacketDecoder {
    format: PacketFormat,
    sensor: SensorSize,
    last_t: Option<u64>,
    /// Sum of the 32-bit wraps seen so far (a multiple of 2³²).
    wrap_base: u64,
    /// Last 32-bit timestamp read, to detect wraps.
    last_raw: Option<u32>,
    /// Packets refused in a row only because their times go back.
    backwards: u32,
    /// Those of them held for a restart, with their arrival times, in order.
    held: Vec<(Vec<u8>, u64)>,
    /// New time bases started (sensor restarts).
    restarts: u64,
    /// Packets refused and not taken back by a restart.
    dropped: u64,
}

impl PacketDecoder {
    /// A decoder for `format` checking coordinates against `sensor`. The sensor is checked
    /// where it is used: with a zero side ([`SensorSize::validate`]), every
    /// [`decode`](Self::decode) refuses with [`Error::InvalidParameter`] (`sensor_size`).
    pub fn new(format: PacketFormat, sensor: SensorSize) -> Self {
        Self {
            format,
            sensor,
            last_t: None,
            wrap_base: 0,
            last_raw: None,
            backwards: 0,
            held: Vec::new(),
            restarts: 0,
            dropped: 0,
        }
    }

    /// The format decoded.
    pub fn format(&self) -> PacketFormat {
        self.format
    }

    /// Time of the last event decoded.
    pub fn last_t(&self) -> Option<u64> {
        self.last_t
    }

    /// New time bases started so far: each is a sensor restart (or the end of a glitch's time
    /// far ahead), after [`RESTART_AFTER`] packets refused for going back. The events decoded
    /// since the last restart are in time order; those before it are of another stream.
    pub fn restarts(&self) -> u64 {
        self.restarts
    }

    /// Packets refused so far (each call that returned an error), less those a restart took
    /// back: the packets of the stream lost.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Decode one packet, appending its events to `out`. `arrival_us` stamps events that carry
    /// no time (`spif` without timestamps). On error nothing is appended and no state changes
    /// but the packets refused in a row for going back, which are held (those good in
    /// themselves) and may make this packet start a new time base (see [`PacketDecoder`] and
    /// [`Self::restarts`]): then the held packets' events, decoded on the new base, come before
    /// its own, and the call succeeds (the packet itself is dropped if it goes back from them).
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] (`sensor_size`) when the decoder's sensor has a zero side
    /// ([`SensorSize::validate`]): the packet is not read, nor counted as
    /// [`dropped`](Self::dropped); else [`Error::Stream`] or [`Error::InvalidEvent`] for a
    /// packet refused as above.
    pub fn decode(&mut self, packet: &[u8], arrival_us: u64, out: &mut Vec<Event>) -> Result<()> {
        self.sensor.validate()?;
        let mut clock = Clock {
            last_t: self.last_t,
            wrap_base: self.wrap_base,
            last_raw: self.last_raw,
            went_back: false,
        };
        let before = out.len();
        let err = match self.decode_with(packet, arrival_us, &mut clock, out) {
            // A packet without events says nothing of the time: it ends no run of packets
            // going back (a sender's empty keep-alives would otherwise hold off a restart).
            Ok(()) if out.len() == before => return Ok(()),
            Ok(()) => {
                self.commit(&clock);
                return Ok(());
            }
            Err(err) => err,
        };
        if clock.went_back {
            self.backwards = self.backwards.saturating_add(1);
        }
        if !clock.went_back || !self.good_alone(packet, arrival_us, out) {
            self.dropped += 1;
            return Err(err);
        }
        if self.backwards <= RESTART_AFTER {
            let held: usize = self.held.iter().map(|(bytes, _)| bytes.len()).sum();
            if held + packet.len() <= MAX_HELD_BYTES {
                self.held.push((packet.to_vec(), arrival_us));
            }
            self.dropped += 1;
            return Err(err);
        }
        // A new time base: the held packets, each taken back if good on it (one that is not,
        // reordered within the restart, stays dropped), then this one. The new stream is this
        // packet's: the held packets it goes back from (the old stream's last, reordered
        // before the restart) are left out, from the first on.
        let held = std::mem::take(&mut self.held);
        for start in 0..=held.len() {
            let mark = out.len();
            let mut fresh = Clock::default();
            let mut taken = 0;
            for (bytes, arrival) in &held[start..] {
                let mut trial = fresh.clone();
                if self.decode_with(bytes, *arrival, &mut trial, out).is_ok() {
                    fresh = trial;
                    taken += 1;
                }
            }
            if self
                .decode_with(packet, arrival_us, &mut fresh, out)
                .is_ok()
            {
                self.commit(&fresh);
                self.dropped -= taken;
                self.restarts += 1;
                return Ok(());
            }
            out.truncate(mark);
        }
        // Not reached: the packet alone is good on a new base (the last start above).
        self.dropped += 1;
        Err(err)
    }

    /// Whether `packet` decodes on a new time base (nothing is appended to `out`).
    fn good_alone(&self, packet: &[u8], arrival_us: u64, out: &mut Vec<Event>) -> bool {
        let mark = out.len();
        let good = self
            .decode_with(packet, arrival_us, &mut Clock::default(), out)
            .is_ok();
        out.truncate(mark);
        good
    }

    /// Decode with `clock`; on error nothing is appended.
    fn decode_with(
        &self,
        packet: &[u8],
        arrival_us: u64,
        clock: &mut Clock,
        out: &mut Vec<Event>,
    ) -> Result<()> {
        let mark = out.len();
        let result = match self.format {
            PacketFormat::T64X16Y16On8 => self.decode_t64(packet, clock, out),
            PacketFormat::T32X16Y15On1 => self.decode_t32(packet, clock, out),
            PacketFormat::Spif => self.decode_spif(packet, arrival_us, clock, out),
        };
        if result.is_err() {
            out.truncate(mark);
        }
        result
    }

    fn commit(&mut self, clock: &Clock) {
        self.last_t = clock.last_t;
        self.wrap_base = clock.wrap_base;
        self.last_raw = clock.last_raw;
        self.backwards = 0;
        self.held.clear();
    }

    fn whole(&self, packet: &[u8], record: usize) -> Result<()> {
        if packet.len().is_multiple_of(record) {
            Ok(())
        } else {
            Err(Error::Stream(format!(
                "{} packet of {} bytes is not a whole number of {record}-byte records",
                self.format,
                packet.len()
            )))
        }
    }

    fn decode_t64(&self, packet: &[u8], clock: &mut Clock, out: &mut Vec<Event>) -> Result<()> {
        self.whole(packet, PACKED_EVENT_SIZE)?;
        for (i, r) in packet.chunks_exact(PACKED_EVENT_SIZE).enumerate() {
            let e = packed_event(r);
            clock.accept(&e, self.sensor, i)?;
            out.push(e);
        }
        Ok(())
    }

    fn decode_t32(&self, packet: &[u8], clock: &mut Clock, out: &mut Vec<Event>) -> Result<()> {
        self.whole(packet, 8)?;
        for (i, r) in packet.chunks_exact(8).enumerate() {
            let y_on = u16::from_le_bytes([r[6], r[7]]);
            let e = Event {
                t: clock.unwrap(u32::from_le_bytes([r[0], r[1], r[2], r[3]])),
                x: u16::from_le_bytes([r[4], r[5]]),
                y: y_on >> 1,
                p: y_on & 1 == 1,
            };
            clock.accept(&e, self.sensor, i)?;
            out.push(e);
        }
        Ok(())
    }

    fn decode_spif(
        &self,
        packet: &[u8],
        arrival_us: u64,
        clock: &mut Clock,
        out: &mut Vec<Event>,
    ) -> Result<()> {
        self.whole(packet, 4)?;
        let mut words = packet
            .chunks_exact(4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
        let mut stamped = None;
        let mut i = 0;
        while let Some(word) = words.next() {
            let has_time = word & 0x8000_0000 == 0;
            if *stamped.get_or_insert(has_time) != has_time {
                return Err(Error::Stream(format!(
                    "spif packet mixes events with and without timestamps (event {i})"
                )));
            }
            let t = if has_time {
                let raw = words.next().ok_or_else(|| {
                    Error::Stream(format!(
                        "spif packet ends after event {i}, whose timestamp word is missing"
                    ))
                })?;
                clock.unwrap(raw)
            } else {
                arrival_us
            };
            let e = Event {
                t,
                x: ((word >> 16) & 0x7FFF) as u16,
                y: (word & 0x7FFF) as u16,
                p: word & 0x8000 != 0,
            };
            clock.accept(&e, self.sensor, i)?;
            out.push(e);
            i += 1;
        }
        Ok(())
    }
}

/// The time base while a packet is decoded, committed only when the whole packet is good
/// (the default: a stream's first, or a new one's).
#[derive(Default, Clone)]
struct Clock {
    last_t: Option<u64>,
    wrap_base: u64,
    last_raw: Option<u32>,
    /// An event was refused for going back in time.
    went_back: bool,
}

impl Clock {
    fn unwrap(&mut self, raw: u32) -> u64 {
        if let Some(previous) = self.last_raw {
            if raw < previous && u64::from(previous - raw) > WRAP / 2 {
                self.wrap_base += WRAP;
            }
        }
        self.last_raw = Some(raw);
        self.wrap_base + u64::from(raw)
    }

    fn accept(&mut self, e: &Event, sensor: SensorSize, index: usize) -> Result<()> {
        if !sensor.contains(e.x, e.y) {
            return Err(Error::InvalidEvent {
                index,
                reason: format!(
                    "(x={}, y={}) is outside the {}x{} sensor",
                    e.x, e.y, sensor.width, sensor.height
                ),
            });
        }
        if let Some(previous) = self.last_t {
            if e.t < previous {
                self.went_back = true;
                return Err(Error::InvalidEvent {
                    index,
                    reason: format!("t={} goes backwards (previous event at t={previous})", e.t),
                });
            }
        }
        self.last_t = Some(e.t);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sensor() -> SensorSize {
        SensorSize::new(640, 480).unwrap()
    }

    fn ev(t: u64, x: u16, y: u16, p: bool) -> Event {
        Event { t, x, y, p }
    }

    fn t64(events: &[Event]) -> Vec<u8> {
        let mut b = Vec::new();
        for e in events {
            b.extend_from_slice(&e.t.to_le_bytes());
            b.extend_from_slice(&e.x.to_le_bytes());
            b.extend_from_slice(&e.y.to_le_bytes());
            b.push(u8::from(e.p));
        }
        b
    }

    /// As faery's encoder writes it: `t & 0xFFFFFFFF`, `x`, `((y << 1) & 0x7FFF) | on`.
    fn t32(events: &[Event]) -> Vec<u8> {
        let mut b = Vec::new();
        for e in events {
            b.extend_from_slice(&((e.t & 0xFFFF_FFFF) as u32).to_le_bytes());
            b.extend_from_slice(&e.x.to_le_bytes());
            b.extend_from_slice(&(((e.y << 1) & 0x7FFF) | u16::from(e.p)).to_le_bytes());
        }
        b
    }

    /// As aestream's `DVSToUDP` writes it, with or without the time word.
    fn spif(events: &[Event], with_time: bool) -> Vec<u8> {
        let mut b = Vec::new();
        for e in events {
            let flag = if with_time { 0 } else { 0x8000_0000u32 };
            let word = flag
                | (u32::from(e.x & 0x7FFF) << 16)
                | (u32::from(e.p) << 15)
                | u32::from(e.y & 0x7FFF);
            b.extend_from_slice(&word.to_le_bytes());
            if with_time {
                b.extend_from_slice(&((e.t & 0xFFFF_FFFF) as u32).to_le_bytes());
            }
        }
        b
    }

    fn sample() -> Vec<Event> {
        vec![
            ev(10, 0, 0, true),
            ev(10, 639, 479, false),
            ev(25, 320, 7, true),
        ]
    }

    #[test]
    fn formats_round_trip() {
        for (format, bytes) in [
            (PacketFormat::T64X16Y16On8, t64(&sample())),
            (PacketFormat::T32X16Y15On1, t32(&sample())),
            (PacketFormat::Spif, spif(&sample(), true)),
        ] {
            let mut d = PacketDecoder::new(format, sensor());
            let mut out = Vec::new();
            d.decode(&bytes, 0, &mut out).unwrap();
            assert_eq!(out, sample(), "{format}");
            assert_eq!(format.name().parse::<PacketFormat>().unwrap(), format);
        }
        assert!("t16".parse::<PacketFormat>().is_err());
    }

    #[test]
    fn a_zero_sensor_is_refused_at_every_packet_and_drops_none() {
        // A 0x0 SensorSize literal took empty packets and refused every event as off the
        // sensor, counting each packet as dropped: a stream lost without a word of why.
        let zero = SensorSize {
            width: 0,
            height: 0,
        };
        for (format, bytes) in [
            (PacketFormat::T64X16Y16On8, t64(&sample())),
            (PacketFormat::T32X16Y15On1, t32(&sample())),
            (PacketFormat::Spif, spif(&sample(), true)),
        ] {
            let mut d = PacketDecoder::new(format, zero);
            let mut out = Vec::new();
            for packet in [&bytes[..], &[]] {
                let err = d.decode(packet, 0, &mut out).unwrap_err();
                crate::events::assert_zero_sensor(&err);
            }
            assert!(out.is_empty());
            assert_eq!((d.dropped(), d.restarts(), d.last_t()), (0, 0, None));
        }
    }

    #[test]
    fn unstamped_spif_events_take_the_arrival_time() {
        let mut d = PacketDecoder::new(PacketFormat::Spif, sensor());
        let mut out = Vec::new();
        d.decode(&spif(&sample(), false), 777, &mut out).unwrap();
        assert!(out.iter().all(|e| e.t == 777));
        let xs: Vec<(u16, u16, bool)> = out.iter().map(|e| (e.x, e.y, e.p)).collect();
        let want: Vec<(u16, u16, bool)> = sample().iter().map(|e| (e.x, e.y, e.p)).collect();
        assert_eq!(xs, want);
    }

    #[test]
    fn thirty_two_bit_time_unwraps() {
        let mut d = PacketDecoder::new(PacketFormat::T32X16Y15On1, sensor());
        let mut out = Vec::new();
        let before = ev(WRAP - 5, 1, 1, true);
        let after = ev(WRAP + 3, 2, 2, false);
        d.decode(&t32(&[before]), 0, &mut out).unwrap();
        d.decode(&t32(&[after]), 0, &mut out).unwrap();
        assert_eq!(out, vec![before, after]);
    }

    #[test]
    fn malformed_packets_are_errors_and_leave_the_state_alone() {
        let good = sample();
        let later = vec![ev(30, 1, 1, true)];
        for format in PacketFormat::ALL {
            let encode = |e: &[Event]| match format {
                PacketFormat::T64X16Y16On8 => t64(e),
                PacketFormat::T32X16Y15On1 => t32(e),
                PacketFormat::Spif => spif(e, true),
            };
            let mut d = PacketDecoder::new(format, sensor());
            let mut out = Vec::new();
            d.decode(&encode(&good), 0, &mut out).unwrap();
            let n = out.len();

            let mut truncated = encode(&later);
            truncated.pop();
            let err = d.decode(&truncated, 0, &mut out).unwrap_err();
            assert!(matches!(err, Error::Stream(_)), "{format}: {err}");

            let outside = encode(&[ev(40, 1, 1, true), ev(41, 640, 2, true)]);
            let err = d.decode(&outside, 0, &mut out).unwrap_err();
            assert!(
                matches!(err, Error::InvalidEvent { index: 1, .. }),
                "{format}: {err}"
            );

            let backwards = encode(&[ev(5, 1, 1, true)]);
            let err = d.decode(&backwards, 0, &mut out).unwrap_err();
            assert!(err.to_string().contains("backwards"), "{format}: {err}");

            assert_eq!(out.len(), n, "{format}: a bad packet appended events");
            assert_eq!(d.last_t(), Some(25));
            d.decode(&encode(&later), 0, &mut out).unwrap();
            assert_eq!(&out[n..], &later[..], "{format}");
        }
    }

    fn encoder(format: PacketFormat) -> impl Fn(&[Event]) -> Vec<u8> {
        move |e: &[Event]| match format {
            PacketFormat::T64X16Y16On8 => t64(e),
            PacketFormat::T32X16Y15On1 => t32(e),
            PacketFormat::Spif => spif(e, true),
        }
    }

    /// A sensor that restarts (times from 0 again after an hour, or for the 32-bit formats
    /// after 30 minutes: less than half a wrap back, so no wrap) has `RESTART_AFTER` packets
    /// refused and held, then the next one starts a new time base with them: none is lost.
    #[test]
    fn a_restarted_sensor_is_followed_after_a_few_packets_and_loses_none() {
        for format in PacketFormat::ALL {
            let encode = encoder(format);
            let before = if format == PacketFormat::T64X16Y16On8 {
                3_600_000_000
            } else {
                1_800_000_000
            };
            let mut d = PacketDecoder::new(format, sensor());
            let mut out = Vec::new();
            d.decode(&encode(&[ev(before, 1, 1, true)]), 0, &mut out)
                .unwrap();
            let new: Vec<Event> = (0..=u64::from(RESTART_AFTER))
                .map(|k| ev(k * 10, 2, 2, k % 2 == 0))
                .collect();
            for (k, e) in new[..new.len() - 1].iter().enumerate() {
                let err = d.decode(&encode(&[*e]), 0, &mut out).unwrap_err();
                assert!(err.to_string().contains("backwards"), "{format}: {err}");
                assert_eq!(d.restarts(), 0, "{format}");
                assert_eq!(d.dropped(), k as u64 + 1, "{format}");
            }
            assert_eq!(out.len(), 1, "{format}: refused packets append nothing");
            d.decode(&encode(&new[new.len() - 1..]), 0, &mut out)
                .unwrap();
            assert_eq!((d.restarts(), d.dropped()), (1, 0), "{format}");
            let mut want = vec![ev(before, 1, 1, true)];
            want.extend(&new);
            assert_eq!(out, want, "{format}");
            // The new base goes on as any stream: later times accepted, earlier refused.
            d.decode(&encode(&[ev(500, 4, 4, true)]), 0, &mut out)
                .unwrap();
            assert!(d
                .decode(&encode(&[ev(400, 4, 4, true)]), 0, &mut out)
                .is_err());
            assert_eq!((d.restarts(), d.dropped()), (1, 1), "{format}");
        }
    }

    /// A `t64` decoder that has taken one event at t = 1 s.
    fn past_a_second() -> PacketDecoder {
        let mut d = PacketDecoder::new(PacketFormat::T64X16Y16On8, sensor());
        d.decode(&t64(&[ev(1_000_000, 1, 1, true)]), 0, &mut Vec::new())
            .unwrap();
        d
    }

    /// Empty packets between the refused ones (a sender's keep-alives) neither end the run
    /// nor are held: the restart comes as without them.
    #[test]
    fn empty_packets_do_not_hold_off_a_restart() {
        let encode = encoder(PacketFormat::T64X16Y16On8);
        let mut d = past_a_second();
        let mut out = Vec::new();
        let new: Vec<Event> = (0..=u64::from(RESTART_AFTER))
            .map(|k| ev(10 + k, 2, 2, true))
            .collect();
        for e in &new {
            d.decode(&[], 0, &mut out).unwrap();
            let _ = d.decode(&encode(&[*e]), 0, &mut out);
        }
        assert_eq!((d.restarts(), d.dropped()), (1, 0));
        assert_eq!(out, new);
    }

    /// A glitch far ahead is accepted; the stream it cut off comes back after a few packets,
    /// whole.
    #[test]
    fn a_packet_stamped_far_ahead_costs_no_packet_of_the_stream() {
        let encode = encoder(PacketFormat::T64X16Y16On8);
        let mut d = PacketDecoder::new(PacketFormat::T64X16Y16On8, sensor());
        let mut out = Vec::new();
        d.decode(&encode(&[ev(1_000, 1, 1, true)]), 0, &mut out)
            .unwrap();
        d.decode(&encode(&[ev(100_000_000_000, 1, 1, true)]), 0, &mut out)
            .unwrap();
        let stream: Vec<Event> = (0..20u64).map(|k| ev(2_000 + k, 1, 1, true)).collect();
        let accepted = stream
            .iter()
            .filter(|e| d.decode(&encode(&[**e]), 0, &mut out).is_ok())
            .count();
        assert_eq!(accepted, 20 - RESTART_AFTER as usize);
        assert_eq!((d.restarts(), d.dropped()), (1, 0));
        assert_eq!(&out[2..], &stream[..]);
    }

    /// Within a restart, a held packet that goes back from those before it (reordered), or a
    /// packet bad in itself, is not taken back; the rest are, in order; a held packet of the
    /// old stream (reordered just before the restart) is left out; the packets held are
    /// bounded by `MAX_HELD_BYTES`.
    #[test]
    fn a_restart_takes_back_the_held_packets_good_on_the_new_base() {
        let encode = encoder(PacketFormat::T64X16Y16On8);
        let mut d = past_a_second();
        let mut out = Vec::new();
        let mut sent = vec![ev(100, 1, 1, true), ev(50, 1, 1, true)]; // the second reordered
        sent.extend((2..u64::from(RESTART_AFTER)).map(|k| ev(100 + k, 1, 1, true)));
        for e in &sent {
            assert!(d.decode(&encode(&[*e]), 0, &mut out).is_err());
        }
        // Going back and outside the sensor: refused, not held, and no restart.
        assert!(d
            .decode(&encode(&[ev(0, 640, 1, true)]), 0, &mut out)
            .is_err());
        assert_eq!(d.restarts(), 0);
        d.decode(&encode(&[ev(200, 2, 2, true)]), 0, &mut out)
            .unwrap();
        let mut want = vec![sent[0]];
        want.extend(&sent[2..]);
        want.push(ev(200, 2, 2, true));
        assert_eq!(out, want);
        assert_eq!((d.restarts(), d.dropped()), (1, 2));

        // The old stream's last packet arrives late, just as the sensor restarts.
        let mut d = past_a_second();
        out.clear();
        let late = ev(999_000, 1, 1, true);
        let new: Vec<Event> = (0..=u64::from(RESTART_AFTER))
            .map(|k| ev(10 + k, 2, 2, true))
            .collect();
        assert!(d.decode(&encode(&[late]), 0, &mut out).is_err());
        for e in &new {
            let _ = d.decode(&encode(&[*e]), 0, &mut out);
        }
        assert_eq!(d.restarts(), 1);
        assert_eq!(out, new);
        assert_eq!(d.dropped(), 1); // the late packet alone
        d.decode(&encode(&[ev(100, 3, 3, true)]), 0, &mut out)
            .unwrap();

        // Packets too large to hold are refused and lost, and the restart still comes.
        let mut d = past_a_second();
        out.clear();
        let big = MAX_HELD_BYTES / PACKED_EVENT_SIZE / 2 + 1;
        for k in 0..u64::from(RESTART_AFTER) {
            let events: Vec<Event> = (0..big as u64)
                .map(|i| ev(k * 1_000 + i / 100, 1, 1, true))
                .collect();
            assert!(d.decode(&encode(&events), 0, &mut out).is_err());
        }
        assert!(d.held.iter().map(|(b, _)| b.len()).sum::<usize>() <= MAX_HELD_BYTES);
        assert_eq!(d.held.len(), 1);
        d.decode(&encode(&[ev(9_000, 2, 2, true)]), 0, &mut out)
            .unwrap();
        assert_eq!(
            (d.restarts(), d.dropped()),
            (1, u64::from(RESTART_AFTER) - 1)
        );
        assert_eq!(out.len(), big + 1);
    }

    /// Reordered, repeated or malformed packets between good ones never restart the stream,
    /// and a packet bad in itself never starts a new base.
    #[test]
    fn reordering_and_bad_packets_start_no_new_base() {
        let encode = encoder(PacketFormat::T64X16Y16On8);
        let mut d = PacketDecoder::new(PacketFormat::T64X16Y16On8, sensor());
        let mut out = Vec::new();
        for k in 0..100u64 {
            // Packet k arrives after k+1: one of every two refused, never two in a row.
            let (a, b) = (ev(100 * k + 50, 1, 1, true), ev(100 * k, 1, 1, true));
            d.decode(&encode(&[a]), 0, &mut out).unwrap();
            assert!(d.decode(&encode(&[b]), 0, &mut out).is_err());
            assert!(d.decode(&encode(&[a]), 0, &mut out).is_ok()); // repeated: equal times
        }
        assert_eq!((d.restarts(), d.dropped()), (0, 100));
        let last = d.last_t();
        for _ in 0..2 * RESTART_AFTER {
            // Going back and outside the sensor: refused whatever the time base.
            let bad = encode(&[ev(0, 1, 1, true), ev(1, 640, 1, true)]);
            assert!(d.decode(&bad, 0, &mut out).is_err());
        }
        assert_eq!((d.restarts(), d.last_t()), (0, last));
        assert!(d.held.is_empty());
    }

    #[test]
    fn spif_rejects_a_missing_time_word_and_mixed_stamps() {
        let mut d = PacketDecoder::new(PacketFormat::Spif, sensor());
        let mut out = Vec::new();
        let stamped = spif(&sample(), true);
        let err = d
            .decode(&stamped[..stamped.len() - 4], 0, &mut out)
            .unwrap_err();
        assert!(err.to_string().contains("missing"), "{err}");
        let mut mixed = spif(&sample()[..1], true);
        mixed.extend(spif(&sample()[1..2], false));
        let err = d.decode(&mixed, 0, &mut out).unwrap_err();
        assert!(err.to_string().contains("mixes"), "{err}");
        assert!(out.is_empty());
        assert_eq!(d.last_t(), None);
    }
}
