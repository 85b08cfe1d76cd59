//! Event filters of the paper's preprocessing: background-activity denoising, and crop and
//! downsample of coordinates to a target sensor.

use crate::error::{check_alloc, Error, Result};
use crate::events::{
    validate_source, Event, EventSource, PackedEvents, SensorSize, PACKED_EVENT_SIZE,
};

/// Which events the background-activity filter keeps, with the semantics of tonic's
/// `tonic.functional.denoise_numpy` (tonic 1.x), event for event.
///
/// Events are taken in order. Each pixel remembers the time `t'` of its latest event; an event
/// at `(x, y, t)` is kept iff one of its four neighbours `(x±1, y)`, `(x, y±1)` on the sensor
/// fired at `t' > t − dt_us` earlier in the stream (tonic remembers `t' + dt_us > t`; this
/// compares `t − t' < dt_us`, the same rule without the sum, which could overflow near
/// `u64::MAX`). The event then updates its own pixel (its own past is not a support). As in
/// tonic, a pixel that has not fired yet counts as having fired at `t = 0`, so events with
/// `t < dt_us` are kept wherever they have a neighbour on the sensor.
///
/// One difference from tonic, by design: tonic's grid is the events' bounding box
/// `(max x + 1, max y + 1)`, ours is the recording's sensor. The results differ only for events
/// with `t < dt_us` next to the bounding box's edge; they are equal whenever the sensor is that
/// box or every `t ≥ dt_us`.
///
/// # Errors
///
/// [`Error::InvalidParameter`]: `sensor_size` for a sensor with a zero side
/// ([`SensorSize::validate`]) or above the memory cap, `dt_us` for 0; [`Error::InvalidEvent`]
/// for an event off the sensor or out of order.
pub fn denoise_mask<E: EventSource + ?Sized>(
    events: &E,
    sensor: SensorSize,
    dt_us: u64,
) -> Result<Vec<bool>> {
    sensor.validate()?;
    if dt_us == 0 {
        return Err(Error::param(
            "dt_us",
            "the filter time must be at least 1 µs, got 0",
        ));
    }
    let (w, h) = (sensor.width as usize, sensor.height as usize);
    check_alloc(
        "sensor_size",
        || format!("denoising on a {w}x{h} sensor (8 bytes a pixel)"),
        sensor.area(),
        8,
    )?;
    validate_source(events, sensor, None, 0)?;
    // Each pixel's latest time; every neighbour's is at most `t` (the events are sorted), so
    // `t - last` never wraps.
    let mut last = vec![0u64; sensor.area()];
    Ok((0..events.len())
        .map(|i| {
            let e = events.get(i);
            let (x, y, t) = (e.x as usize, e.y as usize, e.t);
            let px = y * w + x;
            last[px] = t;
            let recent = |n: usize| t - last[n] < dt_us;
            (x > 0 && recent(px - 1))
                || (x + 1 < w && recent(px + 1))
                || (y > 0 && recent(px - w))
                || (y + 1 < h && recent(px + w))
        })
        .collect())
}

/// The events that [`denoise_mask`] keeps, in order.
pub fn denoise(events: &[Event], sensor: SensorSize, dt_us: u64) -> Result<Vec<Event>> {
    let keep = denoise_mask(events, sensor, dt_us)?;
    Ok(events
        .iter()
        .zip(keep)
        .filter_map(|(e, k)| k.then_some(*e))
        .collect())
}

/// The centred region of a source sensor with the aspect ratio of a target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Crop {
    /// Left column of the region.
    pub x0: u16,
    /// Top row of the region.
    pub y0: u16,
    /// Width of the region.
    pub width: u16,
    /// Height of the region.
    pub height: u16,
}

impl Crop {
    /// The largest region of `source` with `target`'s aspect ratio, centred (rounded down to
    /// whole pixels, offsets rounded down).
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] (`sensor_size` or `target`) when either has a zero width or
    /// height (possible through [`SensorSize`]'s public fields; [`SensorSize::validate`]).
    pub fn centred(source: SensorSize, target: SensorSize) -> Result<Self> {
        source.validate()?;
        target.validate_as("target")?;
        let (sw, sh) = (u64::from(source.width), u64::from(source.height));
        let (tw, th) = (u64::from(target.width), u64::from(target.height));
        // Compare sw/sh with tw/th without division.
        let (width, height) = if sw * th > tw * sh {
            ((sh * tw / th).max(1), sh)
        } else {
            (sw, (sw * th / tw).max(1))
        };
        Ok(Self {
            x0: ((sw - width) / 2) as u16,
            y0: ((sh - height) / 2) as u16,
            width: width as u16,
            height: height as u16,
        })
    }
}

/// Where each event goes under [`downsample`]: `None` outside the crop, else its new pixel.
///
/// Inside the crop, `x' = ⌊(x − x0)·W' / w⌋` and `y' = ⌊(y − y0)·H' / h⌋`, so each target pixel
/// covers a block of source pixels. Every event inside the crop is kept, with its time and
/// polarity, in its original order, even when several land on one target pixel at once (a
/// window then takes the first of them).
///
/// # Errors
///
/// As [`Crop::centred`] for the sizes (checked first), then [`Error::InvalidEvent`] for an
/// event off `source` or out of order.
pub fn downsample_map<E: EventSource + ?Sized>(
    events: &E,
    source: SensorSize,
    target: SensorSize,
) -> Result<Vec<Option<(u16, u16)>>> {
    let crop = Crop::centred(source, target)?;
    validate_source(events, source, None, 0)?;
    let (cx, cy) = (u64::from(crop.width), u64::from(crop.height));
    let (tw, th) = (u64::from(target.width), u64::from(target.height));
    Ok((0..events.len())
        .map(|i| {
            let e = events.get(i);
            let inside = e.x >= crop.x0
                && e.y >= crop.y0
                && e.x - crop.x0 < crop.width
                && e.y - crop.y0 < crop.height;
            inside.then(|| {
                let x = u64::from(e.x - crop.x0) * tw / cx;
                let y = u64::from(e.y - crop.y0) * th / cy;
                (x as u16, y as u16)
            })
        })
        .collect())
}

/// [`downsample`] of packed 13-byte records (the canonical NumPy dtype's bytes): the kept
/// records, with their new coordinates, packed the same way, in one pass after validation.
///
/// # Errors
///
/// As [`downsample_map`], and [`Error::Shape`] for a length that is not a whole number of
/// records.
pub fn downsample_packed(raw: &[u8], source: SensorSize, target: SensorSize) -> Result<Vec<u8>> {
    let crop = Crop::centred(source, target)?;
    validate_source(&PackedEvents::new(raw)?, source, None, 0)?;
    let (cx, cy) = (u64::from(crop.width), u64::from(crop.height));
    let (tw, th) = (u64::from(target.width), u64::from(target.height));
    let mut out = Vec::with_capacity(raw.len());
    for r in raw.chunks_exact(PACKED_EVENT_SIZE) {
        let x = u16::from_le_bytes([r[8], r[9]]).wrapping_sub(crop.x0);
        let y = u16::from_le_bytes([r[10], r[11]]).wrapping_sub(crop.y0);
        // Left of or above the crop wraps round to a large value: one test per axis.
        if x < crop.width && y < crop.height {
            let x = (u64::from(x) * tw / cx) as u16;
            let y = (u64::from(y) * th / cy) as u16;
            out.extend_from_slice(&r[..8]);
            out.extend_from_slice(&x.to_le_bytes());
            out.extend_from_slice(&y.to_le_bytes());
            out.push(r[12]);
        }
    }
    Ok(out)
}

/// Crop `events` to the centred region of `source` with `target`'s aspect ratio, then scale
/// their coordinates onto `target` (see [`downsample_map`]).
///
/// # Errors
///
/// As [`downsample_map`].
pub fn downsample(events: &[Event], source: SensorSize, target: SensorSize) -> Result<Vec<Event>> {
    let map = downsample_map(events, source, target)?;
    Ok(events
        .iter()
        .zip(map)
        .filter_map(|(e, m)| m.map(|(x, y)| Event { x, y, ..*e }))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(t: u64, x: u16, y: u16) -> Event {
        Event { t, x, y, p: false }
    }

    #[test]
    fn denoise_keeps_supported_events_only() {
        let s = SensorSize::new(5, 5).unwrap();
        let dt = 10;
        let events = [
            ev(100, 2, 2), // no neighbour yet: dropped
            ev(105, 2, 3), // (2,2) fired 5 µs ago: kept
            ev(200, 0, 0), // isolated: dropped
            ev(209, 1, 0), // (0,0) fired 9 µs ago: kept
            ev(220, 0, 0), // (1,0) fired 11 µs ago: dropped
        ];
        assert_eq!(
            denoise_mask(&events, s, dt).unwrap(),
            vec![false, true, false, true, false]
        );
        // tonic's convention: unfired neighbours count as fired at t = 0.
        assert_eq!(denoise_mask(&[ev(3, 4, 4)], s, dt).unwrap(), vec![true]);
        assert_eq!(denoise(&events, s, dt).unwrap().len(), 2);
        assert!(denoise_mask(&events, s, 0).is_err());
    }

    #[test]
    fn denoise_refuses_a_sensor_above_the_memory_cap() {
        let huge = SensorSize::new(u16::MAX, u16::MAX).unwrap();
        let err = denoise_mask(&[] as &[Event], huge, 1000).unwrap_err();
        crate::error::assert_over_cap(&err, "sensor_size");
    }

    /// The packed path keeps and moves exactly the events that `downsample` does, polarity
    /// and time included, and refuses what it refuses.
    #[test]
    fn packed_downsample_equals_the_event_one() {
        let source = SensorSize::new(37, 23).unwrap();
        let events: Vec<Event> = (0..2000u64)
            .map(|i| Event {
                t: i / 3,
                x: (i * 7919 % 37) as u16,
                y: (i * 104_729 % 23) as u16,
                p: i % 5 == 0,
            })
            .collect();
        let raw: Vec<u8> = events
            .iter()
            .flat_map(|e| {
                let mut r = e.t.to_le_bytes().to_vec();
                r.extend_from_slice(&e.x.to_le_bytes());
                r.extend_from_slice(&e.y.to_le_bytes());
                r.push(u8::from(e.p));
                r
            })
            .collect();
        for (tw, th) in [(10, 10), (37, 23), (12, 5), (1, 1), (30, 20)] {
            let target = SensorSize::new(tw, th).unwrap();
            let want = downsample(&events, source, target).unwrap();
            let got = downsample_packed(&raw, source, target).unwrap();
            let got: Vec<Event> = got
                .chunks_exact(PACKED_EVENT_SIZE)
                .map(crate::events::packed_event)
                .collect();
            assert_eq!(got, want, "{tw}x{th}");
        }
        assert!(downsample_packed(&raw[..20], source, source).is_err());
        let mut outside = raw.clone();
        outside[8] = 37; // x = 37 on a 37-wide sensor
        assert!(downsample_packed(&outside, source, source).is_err());
    }

    #[test]
    fn crop_is_centred_with_the_target_aspect() {
        let c = Crop::centred(
            SensorSize::new(640, 480).unwrap(),
            SensorSize::new(240, 180).unwrap(),
        )
        .unwrap();
        assert_eq!(
            c,
            Crop {
                x0: 0,
                y0: 0,
                width: 640,
                height: 480
            }
        );
        let c = Crop::centred(
            SensorSize::new(1280, 720).unwrap(),
            SensorSize::new(240, 180).unwrap(),
        )
        .unwrap();
        assert_eq!(
            c,
            Crop {
                x0: 160,
                y0: 0,
                width: 960,
                height: 720
            }
        );
        let c = Crop::centred(
            SensorSize::new(346, 260).unwrap(),
            SensorSize::new(240, 180).unwrap(),
        )
        .unwrap();
        assert_eq!((c.width, c.height, c.x0, c.y0), (346, 259, 0, 0));
    }

    #[test]
    fn downsample_scales_and_keeps_every_event_in_the_crop() {
        let source = SensorSize::new(1280, 720).unwrap();
        let target = SensorSize::new(240, 180).unwrap();
        let events = [
            ev(1, 0, 0),
            ev(2, 160, 0),
            ev(3, 163, 3),
            ev(4, 1119, 719),
            ev(5, 1120, 5),
        ];
        let out = downsample(&events, source, target).unwrap();
        assert_eq!(out, vec![ev(2, 0, 0), ev(3, 0, 0), ev(4, 239, 179)]);
        assert!(downsample(&[ev(1, 1280, 0)], source, target).is_err());
    }

    #[test]
    fn denoise_compares_times_without_overflow() {
        // The rule is the same at any time: a neighbour 1 µs earlier, within dt, supports.
        let s = SensorSize::new(4, 4).unwrap();
        for base in [999, 1 << 62, u64::MAX - 1] {
            let pair = [ev(base, 0, 0), ev(base + 1, 1, 0)];
            assert_eq!(denoise_mask(&pair, s, 10).unwrap(), [false, true], "{base}");
            // and one exactly dt earlier does not.
            let pair = [ev(base - 9, 0, 0), ev(base + 1, 1, 0)];
            assert_eq!(
                denoise_mask(&pair, s, 10).unwrap(),
                [false, false],
                "{base}"
            );
        }
        // The widest window: t' = 1 > u64::MAX - u64::MAX supports the event at u64::MAX.
        let far = [ev(1, 0, 0), ev(u64::MAX, 1, 0)];
        assert_eq!(denoise_mask(&far, s, u64::MAX).unwrap(), [true, true]);
        let far = [ev(0, 0, 0), ev(u64::MAX, 1, 0)];
        assert_eq!(denoise_mask(&far, s, u64::MAX).unwrap(), [true, false]);
    }

    #[test]
    fn zero_sized_sensors_are_refused() {
        // SensorSize's fields are public (and it deserialises): a zero size used to divide by
        // zero.
        let s = SensorSize::new(4, 4).unwrap();
        let zero = SensorSize {
            width: 0,
            height: 0,
        };
        let flat = SensorSize {
            width: 4,
            height: 0,
        };
        let err = downsample(&[Event::default()], s, zero).unwrap_err();
        assert!(
            matches!(err, Error::InvalidParameter { name: "target", .. }),
            "{err}"
        );
        crate::events::assert_zero_sensor(&downsample(&[], flat, s).unwrap_err());
        assert!(downsample_packed(&[], s, flat).is_err());
        assert!(downsample_map(&[] as &[Event], zero, s).is_err());
        // Denoising on a 0x0 sensor accepted no events without a word; with events the size
        // was blamed on the first of them (an event error).
        let events = [ev(1, 0, 0)];
        for err in [
            denoise_mask(&[] as &[Event], zero, 10).unwrap_err(),
            denoise(&events, zero, 10).unwrap_err(),
            downsample(&events, zero, s).unwrap_err(),
            downsample_packed(&[0; PACKED_EVENT_SIZE], zero, s).unwrap_err(),
        ] {
            crate::events::assert_zero_sensor(&err);
        }
        assert!(Crop::centred(s, zero).is_err());
        assert!(Crop::centred(zero, s).is_err());
    }
}
