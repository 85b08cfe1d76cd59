//! Putting one frame interval's events in time order.
//!
//! Every event of the interval `[t0, t1]` is generated pixel by pixel, so they come out in
//! pixel order; a stable counting sort on `t - t0` orders them in two linear passes (ties keep
//! the pixel order, which makes the output deterministic). Very long intervals with few events
//! fall back to a stable comparison sort.

use crate::events::Event;

/// Sort `events` (all with `t0 <= t <= t1`) by time, stably. `scratch` is reused between calls.
pub fn sort_interval(events: &mut Vec<Event>, t0: u64, t1: u64, scratch: &mut Sorter) {
    let n = events.len();
    if n < 2 {
        return;
    }
    let span = (t1 - t0) as usize + 1;
    if span > 8 * n + (1 << 16) {
        events.sort_by_key(|e| e.t);
        return;
    }
    let counts = &mut scratch.counts;
    counts.clear();
    counts.resize(span + 1, 0);
    for e in events.iter() {
        counts[(e.t - t0) as usize + 1] += 1;
    }
    for i in 1..counts.len() {
        counts[i] += counts[i - 1];
    }
    let out = &mut scratch.buffer;
    out.clear();
    out.resize(n, Event::default());
    for e in events.iter() {
        let slot = &mut counts[(e.t - t0) as usize];
        out[*slot as usize] = *e;
        *slot += 1;
    }
    std::mem::swap(events, out);
}

/// Reusable buffers of [`sort_interval`].
#[derive(Debug, Default, Clone)]
pub struct Sorter {
    counts: Vec<u32>,
    buffer: Vec<Event>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stable_counting_sort() {
        let ev = |t, x| Event {
            t,
            x,
            y: 0,
            p: true,
        };
        let mut v = vec![ev(15, 0), ev(10, 1), ev(15, 2), ev(12, 3), ev(10, 4)];
        let mut s = Sorter::default();
        sort_interval(&mut v, 10, 20, &mut s);
        let order: Vec<u16> = v.iter().map(|e| e.x).collect();
        assert_eq!(order, vec![1, 4, 3, 0, 2]);
        // long interval, comparison sort path
        let mut w = vec![ev(1_000_000_000, 0), ev(5, 1), ev(1_000_000_000, 2)];
        sort_interval(&mut w, 0, 1_000_000_000, &mut s);
        assert_eq!(w.iter().map(|e| e.x).collect::<Vec<_>>(), vec![1, 0, 2]);
    }
}
