//! PENT's "preceding" estimate of a window's input count, kept up to date as events arrive
//! (docs/model.md §4): the number of distinct pixels with at least one event in `[t0 − L, t0)`.
//!
//! A pixel counts when its latest event before `t0` is not older than `t0 − L`, so only each
//! pixel's latest event matters. The counter keeps that time per pixel and a queue of
//! `(time, pixel)` entries in time order; entries that a later event of the same pixel made stale
//! are skipped when they reach the front, and the queue is compacted down to one entry per pixel
//! whenever it grows past twice the sensor area. Each event is pushed once and popped or dropped
//! once, so the cost is O(1) amortised per event and the memory is bounded by the sensor area,
//! whatever the event rate.

use std::collections::VecDeque;

use crate::error::{check_alloc, Error, Result};
use crate::windows::MAX_TIME_US;

/// "Never seen, or seen too long ago to count." Above [`MAX_TIME_US`], so no event's time.
const NEVER: u64 = u64::MAX;

/// Bytes the counter may hold per pixel: its latest time, and up to two queued 16-byte entries.
const BYTES_PER_PIXEL: usize = 8 + 2 * 16;

/// Distinct active pixels over a sliding span of `length` microseconds.
#[derive(Debug, Clone)]
pub struct PrecedingCounter {
    length: u64,
    /// Latest event time of each pixel, `NEVER` once it has left the span.
    latest: Vec<u64>,
    /// `(t, pixel)` in non-decreasing `t`; an entry is current when `latest[pixel] == t`.
    queue: VecDeque<(u64, u32)>,
    /// Pixels whose latest event has not been evicted yet.
    active: usize,
    compact_at: usize,
    /// The latest `t0` given to [`count_before`](Self::count_before).
    last_t0: u64,
}

impl PrecedingCounter {
    /// A counter for a sensor of `area` pixels and a span of `length` microseconds.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] (`area`) when the counter's memory, up to 40 bytes a pixel,
    /// is above [`MAX_ALLOC_BYTES`](crate::error::MAX_ALLOC_BYTES).
    pub fn new(area: usize, length: u64) -> Result<Self> {
        check_alloc(
            "area",
            || format!("a preceding-pixel counter of {area} pixels"),
            area,
            BYTES_PER_PIXEL,
        )?;
        Ok(Self {
            length,
            latest: vec![NEVER; area],
            queue: VecDeque::new(),
            active: 0,
            compact_at: 2 * area + 64,
            last_t0: 0,
        })
    }

    /// Record an event of `pixel` at `t`. Returns the time of the pixel's previous event if it
    /// is still within the counter's memory.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] when `pixel` is not below the counter's area, or `t` is above
    /// [`MAX_TIME_US`]; [`Error::Stream`] when `t` is before the latest event still counted
    /// (times must not decrease between calls). Nothing is recorded then.
    pub fn push(&mut self, t: u64, pixel: usize) -> Result<Option<u64>> {
        if pixel >= self.latest.len() {
            return Err(Error::param(
                "pixel",
                format!(
                    "must be below the counter's area, {}, got {pixel}",
                    self.latest.len()
                ),
            ));
        }
        if t > MAX_TIME_US {
            return Err(Error::param(
                "t",
                format!("must be at most 2^62 µs (MAX_TIME_US), got {t}"),
            ));
        }
        if let Some(&(last, _)) = self.queue.back() {
            if t < last {
                return Err(Error::Stream(format!(
                    "event at t={t} comes before the previous one (t={last})"
                )));
            }
        }
        Ok(self.push_valid(t, pixel))
    }

    /// [`push`](Self::push) for callers that checked its conditions (the stream detector, which
    /// validates each chunk): `pixel` below the area, `t` at most [`MAX_TIME_US`] and not before
    /// the previous push's. The hot path: no check beyond the pixel's bounds.
    #[inline]
    pub(crate) fn push_valid(&mut self, t: u64, pixel: usize) -> Option<u64> {
        let previous = self.latest[pixel];
        if previous == t {
            return Some(t);
        }
        if previous == NEVER {
            self.active += 1;
        }
        self.latest[pixel] = t;
        self.queue.push_back((t, pixel as u32));
        if self.queue.len() > self.compact_at {
            self.compact();
        }
        (previous != NEVER).then_some(previous)
    }

    /// Distinct pixels with an event in `[t0 − L, t0)`. Every event pushed so far must be earlier
    /// than `t0`, and `t0` must not decrease between calls (since construction or
    /// [`clear`](Self::clear)): the count forgets the events that an earlier `t0` left behind.
    ///
    /// # Errors
    ///
    /// [`Error::Stream`] when an event pushed so far is at or after `t0`, or `t0` is before an
    /// earlier call's; nothing changes then.
    pub fn count_before(&mut self, t0: u64) -> Result<usize> {
        if t0 < self.last_t0 {
            return Err(Error::Stream(format!(
                "count_before({t0}) comes after count_before({}); window starts must not \
                 decrease",
                self.last_t0
            )));
        }
        if let Some(&(last, _)) = self.queue.back() {
            if last >= t0 {
                return Err(Error::Stream(format!(
                    "count_before({t0}) after an event at t={last}; every event counted must \
                     be earlier than the window start"
                )));
            }
        }
        self.last_t0 = t0;
        Ok(self.count_valid(t0))
    }

    /// [`count_before`](Self::count_before) for callers that keep its conditions (the stream
    /// detector).
    pub(crate) fn count_valid(&mut self, t0: u64) -> usize {
        let oldest = t0.saturating_sub(self.length);
        while let Some(&(t, pixel)) = self.queue.front() {
            if t >= oldest {
                break;
            }
            self.queue.pop_front();
            let pixel = pixel as usize;
            if self.latest[pixel] == t {
                self.latest[pixel] = NEVER;
                self.active -= 1;
            }
        }
        self.active
    }

    /// Number of queued entries (bounded by about twice the sensor area).
    pub fn queued(&self) -> usize {
        self.queue.len()
    }

    /// Forget everything.
    pub fn clear(&mut self) {
        self.latest.fill(NEVER);
        self.queue.clear();
        self.active = 0;
        self.last_t0 = 0;
    }

    fn compact(&mut self) {
        let latest = &self.latest;
        self.queue.retain(|&(t, pixel)| latest[pixel as usize] == t);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn brute(events: &[(u64, usize)], t0: u64, length: u64) -> usize {
        let oldest = t0.saturating_sub(length);
        let mut pixels: Vec<usize> = events
            .iter()
            .filter(|&&(t, _)| t >= oldest && t < t0)
            .map(|&(_, p)| p)
            .collect();
        pixels.sort_unstable();
        pixels.dedup();
        pixels.len()
    }

    #[test]
    fn counts_distinct_pixels_in_the_span() {
        let mut c = PrecedingCounter::new(4, 10).unwrap();
        assert_eq!(c.count_before(0).unwrap(), 0);
        assert_eq!(c.push(1, 0).unwrap(), None);
        assert_eq!(c.push(2, 0).unwrap(), Some(1));
        c.push(5, 1).unwrap();
        assert_eq!(c.count_before(6).unwrap(), 2);
        // At t0 = 12 the span is [2, 12): pixel 0's latest event (t=2) still counts.
        assert_eq!(c.count_before(12).unwrap(), 2);
        // At t0 = 13 it is [3, 13): pixel 0 has left.
        assert_eq!(c.count_before(13).unwrap(), 1);
        assert_eq!(c.push(14, 0).unwrap(), None);
    }

    #[test]
    fn memory_stays_bounded_under_a_flood() {
        let area = 16;
        let mut c = PrecedingCounter::new(area, u64::MAX / 2).unwrap();
        for t in 0..100_000u64 {
            c.push(t, (t % area as u64) as usize).unwrap();
            assert!(c.queued() <= 2 * area + 64 + 1);
        }
        assert_eq!(c.count_before(100_000).unwrap(), area);
    }

    proptest! {
        #[test]
        fn equals_brute_force(
            deltas in prop::collection::vec((0u64..4, 0usize..6), 0..200),
            length in 1u64..20,
            step in 1u64..8,
        ) {
            let mut events = Vec::new();
            let mut t = 0;
            for (d, p) in deltas {
                t += d;
                events.push((t, p));
            }
            let mut c = PrecedingCounter::new(6, length).unwrap();
            c.compact_at = 8; // exercise compaction often
            let mut next = 0;
            let mut t0 = 0;
            while next < events.len() || t0 <= t {
                while next < events.len() && events[next].0 < t0 {
                    c.push(events[next].0, events[next].1).unwrap();
                    next += 1;
                }
                prop_assert_eq!(c.count_before(t0).unwrap(), brute(&events, t0, length));
                t0 += step;
            }
        }
    }

    #[test]
    fn bad_input_is_refused_and_changes_nothing() {
        // An area whose table overflows or passes the cap used to panic or abort.
        for area in [usize::MAX / 8, 1 << 40] {
            let err = PrecedingCounter::new(area, 10).unwrap_err();
            crate::error::assert_over_cap(&err, "area");
        }
        let mut c = PrecedingCounter::new(4, 10).unwrap();
        // A pixel off the counter used to index out of bounds.
        let err = c.push(5, 4).unwrap_err();
        assert!(
            matches!(err, Error::InvalidParameter { name: "pixel", .. }),
            "{err}"
        );
        // u64::MAX is the "never" mark: such an event was recorded but never counted.
        for t in [u64::MAX, MAX_TIME_US + 1] {
            let err = c.push(t, 0).unwrap_err();
            assert!(
                matches!(err, Error::InvalidParameter { name: "t", .. }),
                "{err}"
            );
        }
        assert_eq!(c.push(MAX_TIME_US - 5, 0).unwrap(), None);
        assert!(matches!(c.push(3, 1), Err(Error::Stream(_))));
        assert_eq!(c.queued(), 1);
        // Window starts: after every event, and never going back.
        assert!(matches!(
            c.count_before(MAX_TIME_US - 5),
            Err(Error::Stream(_))
        ));
        assert_eq!(c.count_before(MAX_TIME_US).unwrap(), 1);
        assert!(matches!(
            c.count_before(MAX_TIME_US - 1),
            Err(Error::Stream(_))
        ));
        assert_eq!(c.count_before(MAX_TIME_US).unwrap(), 1);
        c.clear();
        assert_eq!(c.push(7, 3).unwrap(), None);
        assert_eq!(c.count_before(8).unwrap(), 1);
    }
}
