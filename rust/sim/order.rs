//! Putting one frame interval's events in time order.
//!
//! The events of the interval `[t0, t1]` are generated row by row (or chunk by chunk), each
//! buffer in pixel order. A stable counting sort on `t - t0` gathers them straight from those
//! buffers into the output in two linear passes; ties keep buffer order, which makes the
//! output deterministic. Very long intervals with few events fall back to a stable comparison
//! sort.

use crate::events::Event;

/// [`gather_sorted`] over the event buffers of `items` (`events` of each: rows, bands), which
/// keep their buffers (emptied, their capacity kept) for the next interval.
pub fn gather_from<T, F>(
    items: &mut [T],
    events: F,
    t0: u64,
    t1: u64,
    out: &mut Vec<Event>,
    scratch: &mut Vec<u32>,
) where
    F: Fn(&mut T) -> &mut Vec<Event>,
{
    let mut parts: Vec<Vec<Event>> = items
        .iter_mut()
        .map(|item| std::mem::take(events(item)))
        .collect();
    gather_sorted(&mut parts, t0, t1, out, scratch);
    for (item, part) in items.iter_mut().zip(parts) {
        *events(item) = part;
    }
}

/// Interleaved histograms of the counting sort.
const LANES: usize = 4;

/// Append the events of `parts` (all with `t0 <= t <= t1`) to `out`, sorted by time, stably
/// (ties in the order of `parts`, then of each part). The parts are left empty.
pub fn gather_sorted(
    parts: &mut [Vec<Event>],
    t0: u64,
    t1: u64,
    out: &mut Vec<Event>,
    scratch: &mut Vec<u32>,
) {
    let n: usize = parts.iter().map(Vec::len).sum();
    let start = out.len();
    let span = t1 - t0;
    if n < 2 || span > 8 * n as u64 + (1 << 16) || u32::try_from(n).is_err() {
        for p in parts.iter_mut() {
            out.append(p);
        }
        out[start..].sort_by_key(|e| e.t);
        return;
    }
    // Four interleaved histograms: consecutive events often share a time, and one counter
    // would serialise on its own increments.

    let bins = span as usize + 2;
    scratch.clear();
    scratch.resize(LANES * bins, 0);
    for (i, e) in parts.iter().flatten().enumerate() {
        scratch[(i % LANES) * bins + (e.t - t0) as usize + 1] += 1;
    }
    let (offsets, lanes) = scratch.split_at_mut(bins);
    let mut total = 0u32;
    for (b, slot) in offsets.iter_mut().enumerate() {
        let here = *slot + lanes.chunks_exact(bins).map(|l| l[b]).sum::<u32>();
        total += here;
        *slot = total;
    }
    out.resize(start + n, Event::default());
    let dest = &mut out[start..];
    for p in parts.iter_mut() {
        for e in p.iter() {
            let slot = &mut scratch[(e.t - t0) as usize];
            dest[*slot as usize] = *e;
            *slot += 1;
        }
        p.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(t: u64, x: u16) -> Event {
        Event {
            t,
            x,
            y: 0,
            p: true,
        }
    }

    #[test]
    fn stable_counting_sort_across_parts() {
        let mut parts = vec![
            vec![ev(15, 0), ev(10, 1)],
            vec![ev(15, 2), ev(12, 3), ev(10, 4)],
        ];
        let mut out = vec![ev(3, 99)];
        let mut s = Vec::new();
        gather_sorted(&mut parts, 10, 20, &mut out, &mut s);
        let order: Vec<u16> = out.iter().map(|e| e.x).collect();
        assert_eq!(order, vec![99, 1, 4, 3, 0, 2]);
        assert!(parts.iter().all(Vec::is_empty));
        // A long interval takes the comparison-sort path, with the same result.
        let mut parts = vec![
            vec![ev(1_000_000_000, 0), ev(5, 1)],
            vec![ev(1_000_000_000, 2)],
        ];
        let mut out = Vec::new();
        gather_sorted(&mut parts, 0, 1_000_000_000, &mut out, &mut s);
        assert_eq!(out.iter().map(|e| e.x).collect::<Vec<_>>(), vec![1, 0, 2]);
    }
}
