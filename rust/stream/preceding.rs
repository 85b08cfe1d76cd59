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

/// "Never seen, or seen too long ago to count."
const NEVER: u64 = u64::MAX;

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
}

impl PrecedingCounter {
    /// A counter for a sensor of `area` pixels and a span of `length` microseconds.
    pub fn new(area: usize, length: u64) -> Self {
        Self {
            length,
            latest: vec![NEVER; area],
            queue: VecDeque::new(),
            active: 0,
            compact_at: 2 * area + 64,
        }
    }

    /// Record an event of `pixel` at `t` (times must not decrease between calls). Returns the
    /// time of the pixel's previous event if it is still within the counter's memory.
    #[inline]
    pub fn push(&mut self, t: u64, pixel: usize) -> Option<u64> {
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
    /// than `t0`, and `t0` must not decrease between calls.
    pub fn count_before(&mut self, t0: u64) -> usize {
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
        let mut c = PrecedingCounter::new(4, 10);
        assert_eq!(c.count_before(0), 0);
        assert_eq!(c.push(1, 0), None);
        assert_eq!(c.push(2, 0), Some(1));
        c.push(5, 1);
        assert_eq!(c.count_before(6), 2);
        // At t0 = 12 the span is [2, 12): pixel 0's latest event (t=2) still counts.
        assert_eq!(c.count_before(12), 2);
        // At t0 = 13 it is [3, 13): pixel 0 has left.
        assert_eq!(c.count_before(13), 1);
        assert_eq!(c.push(14, 0), None);
    }

    #[test]
    fn memory_stays_bounded_under_a_flood() {
        let area = 16;
        let mut c = PrecedingCounter::new(area, u64::MAX / 2);
        for t in 0..100_000u64 {
            c.push(t, (t % area as u64) as usize);
            assert!(c.queued() <= 2 * area + 64 + 1);
        }
        assert_eq!(c.count_before(100_000), area);
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
            let mut c = PrecedingCounter::new(6, length);
            c.compact_at = 8; // exercise compaction often
            let mut next = 0;
            let mut t0 = 0;
            while next < events.len() || t0 <= t {
                while next < events.len() && events[next].0 < t0 {
                    c.push(events[next].0, events[next].1);
                    next += 1;
                }
                prop_assert_eq!(c.count_before(t0), brute(&events, t0, length));
                t0 += step;
            }
        }
    }
}
